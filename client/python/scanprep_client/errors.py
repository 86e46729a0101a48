# SPDX-License-Identifier: Apache-2.0
"""ScanprepError: a refused or failed call with the machine-readable details the service sends in
the grpc-status-details-bin trailer (a serialized google.rpc.Status): ErrorInfo's reason, domain
and metadata, BadRequest's field violations, RetryInfo's delay."""

from __future__ import annotations

from typing import Mapping, Optional, Sequence

import grpc

from scanprep_client._rpc import error_details_pb2, status_pb2

_DETAILS_KEY = "grpc-status-details-bin"


class ScanprepError(Exception):
    """A call the service refused or could not finish.

    code: the grpc.StatusCode; message: the service's text; reason and domain: ErrorInfo's stable
    name of the refusal (e.g. QUEUE_FULL, JOB_TOO_LARGE, INVALID_PARAMETER); metadata: ErrorInfo's
    numbers behind it (e.g. a limit); field: the request field at fault (first of violations, each
    (field, description)); retry_delay: seconds the service asks to wait before the same call can
    succeed, None when it cannot (only then is the call worth repeating, or on UNAVAILABLE)."""

    def __init__(self, code: grpc.StatusCode, message: str, *, reason: str = "",
                 domain: str = "", metadata: Optional[Mapping[str, str]] = None,
                 violations: Sequence[tuple[str, str]] = (),
                 retry_delay: Optional[float] = None):
        super().__init__(f"{code.name}: {message}" + (f" ({reason})" if reason else ""))
        self.code, self.message, self.reason, self.domain = code, message, reason, domain
        self.metadata = dict(metadata or {})
        self.violations = list(violations)
        self.field = self.violations[0][0] if self.violations else ""
        self.retry_delay = retry_delay

    @property
    def retryable(self) -> bool:
        """The service asked for a retry (RetryInfo: queue full, replica shutting down), or no
        server answered at all (UNAVAILABLE: a transport failure or a replica going away)."""
        return self.retry_delay is not None or self.code == grpc.StatusCode.UNAVAILABLE


def error_from_rpc(error: grpc.RpcError) -> ScanprepError:
    """The ScanprepError for a failed call (a grpc.RpcError that is also a grpc.Call)."""
    fields: dict = {}
    for key, value in error.trailing_metadata() or ():
        if key == _DETAILS_KEY:
            fields = _details(status_pb2.Status.FromString(value))
    return ScanprepError(error.code(), error.details() or "", **fields)


def _details(status: status_pb2.Status) -> dict:
    fields: dict = {}
    info = error_details_pb2.ErrorInfo()
    bad = error_details_pb2.BadRequest()
    retry = error_details_pb2.RetryInfo()
    for detail in status.details:
        if detail.Unpack(info):
            fields.update(reason=info.reason, domain=info.domain, metadata=info.metadata)
        elif detail.Unpack(bad):
            fields["violations"] = [(v.field, v.description) for v in bad.field_violations]
        elif detail.Unpack(retry):
            fields["retry_delay"] = retry.retry_delay.ToTimedelta().total_seconds()
    return fields
