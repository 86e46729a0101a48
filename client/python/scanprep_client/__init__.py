# SPDX-License-Identifier: Apache-2.0
"""Python client of the scanprep service: numpy arrays and scanner metadata in, points, normals,
flags and the report out. The generated modules (scanprep.v1.scanprep_pb2 and _grpc, google.rpc)
come from the build (`cmake --build build --target python_stubs`, into build/python): put that
directory and this one on PYTHONPATH."""

from scanprep_client.client import Client, Flag, Result, Scan, ScanprepError, local_origin

__all__ = ["Client", "Flag", "Result", "Scan", "ScanprepError", "local_origin"]
