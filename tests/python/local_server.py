# SPDX-License-Identifier: Apache-2.0
"""scanprep-server ($SCANPREP_SERVER) for a test: plaintext on a free loopback port, stopped when
the `with` block (or unittest's enterClassContext) ends."""

import os
import re
import subprocess


class LocalServer:
    def __enter__(self) -> "LocalServer":
        self.process = subprocess.Popen(
            [os.environ["SCANPREP_SERVER"], "--listen=127.0.0.1:0", "--metrics_listen=127.0.0.1:0",
             "--plaintext", "--threads=2"], stdout=subprocess.PIPE, text=True)
        for line in self.process.stdout:
            match = re.search(r"listening on port (\d+)", line)
            if match:
                self.target = f"127.0.0.1:{match.group(1)}"
                return self
        self.process.wait(timeout=30)
        raise RuntimeError("scanprep-server did not start")

    def __exit__(self, *exc) -> None:
        self.process.terminate()
        self.process.wait(timeout=30)
        self.process.stdout.close()
