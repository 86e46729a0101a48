# SPDX-License-Identifier: Apache-2.0
"""Python client of the scanprep service: numpy arrays and scanner metadata in, points, normals,
flags, the scans' scanline, quality and intensity, the report and the scans' own per-point
attributes (Result.attributes, by source_index) out, with typed errors, a deadline on every call
and retries where the service asks for them; scan files and .conf poses read as the CLI reads them
(readers, keeping a file's other per-point fields in Scan.attributes), the report as dataclasses
(Result.typed_report), scans checked before the upload (check_scans). Install: pip install
--no-index --no-build-isolation ./client/python into a venv made with --system-site-packages (the
build generates the API modules from proto/)."""

from scanprep_client.client import (STRICT_WARNING_CODES, Client, Flag, Result, Scan, check_scans,
                                    local_origin)
from scanprep_client.errors import ScanprepError
from scanprep_client.health import Health, PairHealth, ScanHealth
from scanprep_client.readers import read_conf, read_scan, read_scans
from scanprep_client.registration import ScanRegistration
from scanprep_client.report import Budget, Report, Stage, Warning
from scanprep_client.retry import RetryPolicy

__all__ = ["Budget", "Client", "Flag", "Health", "PairHealth", "Report", "Result", "RetryPolicy",
           "Scan", "ScanHealth", "ScanRegistration", "ScanprepError", "Stage",
           "STRICT_WARNING_CODES", "Warning", "check_scans", "local_origin", "read_conf",
           "read_scan", "read_scans"]
