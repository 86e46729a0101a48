# SPDX-License-Identifier: Apache-2.0
"""The README's Python example, as written there, run by the venv's python (the installed
package, not the sources) against a real scanprep-server, so that the README stays true. Run by
ctest after python_client_install (tests/CMakeLists.txt)."""

import pathlib
import re
import subprocess
import sys
import unittest

from local_server import LocalServer

README = pathlib.Path(__file__).resolve().parents[2] / "README.md"
EXAMPLE_TARGET = "localhost:50051"


class ReadmeExampleTest(unittest.TestCase):
    def test_the_readme_python_example_runs(self):
        blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
        self.assertTrue(blocks, f"{README}: no ```python block")
        example = blocks[0]
        self.assertIn(EXAMPLE_TARGET, example)
        with LocalServer() as server:
            run = subprocess.run([sys.executable, "-"], cwd=README.parent.parent,
                                 input=example.replace(EXAMPLE_TARGET, server.target),
                                 capture_output=True, text=True, timeout=120)
        self.assertEqual(run.returncode, 0, run.stderr)
        # The example's plane has 20 spikes; the outlier stage must remove every one.
        self.assertRegex(run.stdout, r"^20 of 20 spikes removed;")


if __name__ == "__main__":
    unittest.main()
