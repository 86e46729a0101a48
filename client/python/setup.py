# SPDX-License-Identifier: Apache-2.0
"""Generates the API's Python modules into the build from ../../proto with the system's protoc and
grpc_python_plugin (Debian's protobuf-compiler-grpc, the generator the C++ build uses), so that
building the wheel needs no registry and its modules match the proto it was built from.

The wheel holds scanprep.v1 (scanprep_pb2, scanprep_pb2_grpc) and the google.rpc error details as
scanprep_client._rpc, so it does not claim google.rpc, which googleapis-common-protos owns."""

import atexit
import pathlib
import shutil
import subprocess
import tempfile

from setuptools import setup
from setuptools.command.build_py import build_py

PROTO = pathlib.Path(__file__).resolve().parents[2] / "proto"


def _tool(name: str) -> str:
    path = shutil.which(name)
    if path is None:
        raise SystemExit(f"{name} not found: install Debian's protobuf-compiler-grpc")
    return path


class BuildPyWithApi(build_py):
    def run(self):
        super().run()
        if not (PROTO / "scanprep" / "v1" / "scanprep.proto").is_file():
            raise SystemExit(f"{PROTO}: the API's .proto files are not beside client/python (build "
                             "from the repository's client/python, not from a copy of it alone)")
        out = pathlib.Path(self.build_lib)
        protoc = _tool("protoc")
        subprocess.run([protoc, f"--proto_path={PROTO}", f"--python_out={out}",
                        f"--grpc_python_out={out}",
                        f"--plugin=protoc-gen-grpc_python={_tool('grpc_python_plugin')}",
                        str(PROTO / "scanprep" / "v1" / "scanprep.proto")], check=True)
        for package in (out / "scanprep", out / "scanprep" / "v1"):
            (package / "__init__.py").touch()
        rpc = out / "scanprep_client" / "_rpc"
        rpc.mkdir(exist_ok=True)
        (rpc / "__init__.py").touch()
        with tempfile.TemporaryDirectory() as tmp:
            subprocess.run([protoc, f"--proto_path={PROTO}", f"--python_out={tmp}",
                            str(PROTO / "google" / "rpc" / "status.proto"),
                            str(PROTO / "google" / "rpc" / "error_details.proto")], check=True)
            for module in pathlib.Path(tmp, "google", "rpc").glob("*_pb2.py"):
                shutil.move(module, rpc / module.name)


# setuptools writes build/ and *.egg-info beside setup.py by default, and pip builds in the source
# tree (`pip install ./client/python`): both go to a scratch folder instead, removed when the
# build ends, so that installing leaves the checkout as it was (tests/python/install_clean_test.py).
_SCRATCH = tempfile.mkdtemp(prefix="scanprep-client-build-")
atexit.register(shutil.rmtree, _SCRATCH, ignore_errors=True)

setup(cmdclass={"build_py": BuildPyWithApi},
      options={"build": {"build_base": f"{_SCRATCH}/build"},
               "egg_info": {"egg_base": _SCRATCH}})
