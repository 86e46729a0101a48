# SPDX-License-Identifier: Apache-2.0
"""Python client of the scanprep service: numpy arrays and scanner metadata in, points, normals,
flags and the report out, with typed errors, a deadline on every call and retries where the
service asks for them. Install: pip install --no-index --no-build-isolation ./client/python into
a venv made with --system-site-packages (the build generates the API modules from proto/)."""

from scanprep_client.client import STRICT_WARNING_CODES, Client, Flag, Result, Scan, local_origin
from scanprep_client.errors import ScanprepError
from scanprep_client.health import Health, PairHealth, ScanHealth
from scanprep_client.retry import RetryPolicy

__all__ = ["Client", "Flag", "Health", "PairHealth", "Result", "RetryPolicy", "Scan", "ScanHealth",
           "ScanprepError", "STRICT_WARNING_CODES", "local_origin"]
