#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""SPDX license headers of the project's own sources (LICENSE: Apache-2.0).

  tools/spdx.py --check   lists every source file without the header; exit 1 if any (ctest)
  tools/spdx.py --add     adds it where missing (after a shebang line)

Sources: C++ (.cc, .h), .proto, shell, Python, CMakeLists.txt, the Dockerfile and .ci/run; not
the verbatim copies of Google's protos (proto/google/), which carry Google's own notice."""
import pathlib
import subprocess
import sys

TAG = "SPDX-License-Identifier: Apache-2.0"
ROOT = pathlib.Path(__file__).resolve().parents[1]


def comment(path: pathlib.Path) -> str:
    return "//" if path.suffix in (".cc", ".h", ".proto") else "#"


def sources() -> list[pathlib.Path]:
    files = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"],
                           cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    keep = []
    for name in files:
        path = ROOT / name
        if name.startswith("proto/google/") or not path.is_file():
            continue
        if (path.suffix in (".cc", ".h", ".proto", ".sh", ".py")
                or path.name in ("CMakeLists.txt", "Dockerfile") or name == ".ci/run"):
            keep.append(path)
    return keep


def main() -> int:
    mode = sys.argv[1] if len(sys.argv) > 1 else "--check"
    missing = []
    for path in sources():
        lines = path.read_text().splitlines(keepends=True)
        head = lines[:3]
        if any(TAG in line for line in head):
            continue
        if mode == "--add":
            at = 1 if lines and lines[0].startswith("#!") else 0
            lines.insert(at, f"{comment(path)} {TAG}\n")
            path.write_text("".join(lines))
        missing.append(path.relative_to(ROOT))
    if mode == "--check" and missing:
        print(f"{len(missing)} source files lack '{TAG}' in their first lines "
              "(tools/spdx.py --add):")
        print("\n".join(f"  {m}" for m in missing))
        return 1
    print(f"{len(missing)} headers added" if mode == "--add" else "every source file has it")
    return 0


if __name__ == "__main__":
    sys.exit(main())
