#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The README's CLI example as a new user runs it (issue 40: it failed as written from the repo
root): its server command, then its CLI block with bash from a copy of the repo root (links to
build/ and client/, ../shared beside it), so that the files it writes stay out of the source tree;
then its Node.js line against the same server, where node and the example's packages are there
(tools/install-deps.sh installs them; CI=true requires them).
Usage: readme_cli_test.py BUILD_DIR. Exits 77 (skipped) without ../shared/data or when port 50051,
the one the README names, is taken."""

import os
import pathlib
import re
import shlex
import shutil
import socket
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
PORT = 50051


def blocks() -> tuple[str, str, str]:
    """The server's command line, the CLI block after it and the Node.js block."""
    sh = re.findall(r"```sh\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    servers = [i for i, b in enumerate(sh) if b.startswith("build/server/scanprep-server")]
    assert servers and servers[0] + 1 < len(sh), "README: no server command and CLI block"
    node = [b for b in sh if b.startswith("node ")]
    assert node, "README: no Node.js block"
    return sh[servers[0]].split("#")[0].strip(), sh[servers[0] + 1], node[0]


def node_ready() -> bool:
    ready = shutil.which("node") is not None and (
        ROOT / "client/examples/node/node_modules/@grpc/grpc-js").is_dir()
    assert ready or os.environ.get("CI") != "true", "node or the example's packages are missing"
    return ready


def port_free() -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", PORT)) != 0


def main() -> int:
    build = pathlib.Path(sys.argv[1]).resolve()
    if not (SHARED / "data").is_dir():
        print(f"skipped: {SHARED / 'data'} not found")
        return 77
    if not port_free():
        print(f"skipped: port {PORT}, which the README names, is taken")
        return 77
    server_line, cli_block, node_block = blocks()
    assert f"127.0.0.1:{PORT}" in server_line, server_line
    with tempfile.TemporaryDirectory() as tmp:
        repo = pathlib.Path(tmp) / "scanprep"
        repo.mkdir()
        (repo / "build").symlink_to(build)
        (repo / "client").symlink_to(ROOT / "client")
        (pathlib.Path(tmp) / "shared").symlink_to(SHARED)
        server = subprocess.Popen(shlex.split(server_line) + ["--metrics_listen=127.0.0.1:0"],
                                  cwd=repo, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        try:
            for _ in range(100):
                if not port_free():
                    break
                time.sleep(0.1)
            run = subprocess.run(["bash", "-euo", "pipefail", "-c", cli_block], cwd=repo,
                                 capture_output=True, text=True, timeout=600)
            node = subprocess.run(["bash", "-euo", "pipefail", "-c", node_block], cwd=ROOT,
                                  capture_output=True, text=True,
                                  timeout=120) if node_ready() else None
        finally:
            server.terminate()
            server.wait(timeout=60)
        print(run.stdout, run.stderr)
        if run.returncode != 0:
            print(f"FAILED: the README's CLI block exited {run.returncode}")
            return 1
        for name in ("result.ply", "sim_frontal.ply", "sim.job.json"):
            if not (repo / name).is_file():
                print(f"FAILED: the README's CLI block wrote no {name}")
                return 1
        if "bun000" not in run.stdout:
            print("FAILED: health printed no table for bun000")
            return 1
        if node is not None:
            print(node.stdout, node.stderr)
            if node.returncode != 0 or "65 points sent, 64 returned" not in node.stdout:
                print("FAILED: the README's Node.js line did not remove the plate's spike")
                return 1
        else:
            print("the README's Node.js line not run: node or its packages are missing")
    print("the README's server command, CLI block and Node.js line ran as written")
    return 0


if __name__ == "__main__":
    sys.exit(main())
