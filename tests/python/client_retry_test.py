# SPDX-License-Identifier: Apache-2.0
"""The Python client's errors, retries and deadlines against a scripted in-process server: each
call to it answers with the next refusal of its script (a google.rpc.Status in the
grpc-status-details-bin trailer, as scanprep-server sends it), then succeeds. Run by ctest with
the installed package's venv (tests/CMakeLists.txt, python_client_* tests)."""

import datetime
import threading
import time
import unittest
from concurrent import futures

import grpc
import numpy as np
from google.protobuf import any_pb2

from scanprep.v1 import scanprep_pb2 as pb
from scanprep.v1 import scanprep_pb2_grpc as pb_grpc
from scanprep_client import Client, RetryPolicy, Scan, ScanprepError
from scanprep_client._rpc import error_details_pb2, status_pb2

QUICK = RetryPolicy(initial_backoff=0.01, jitter=0)  # backoff far below any RetryInfo delay


def refusal(code, reason="", retry_seconds=None, field="", **metadata):
    """(code, the serialized google.rpc.Status the service would send)."""
    details = [error_details_pb2.ErrorInfo(reason=reason, domain="scanprep.v1", metadata=metadata)]
    if field:
        details.append(error_details_pb2.BadRequest(field_violations=[
            error_details_pb2.BadRequest.FieldViolation(field=field, description="out of range")]))
    if retry_seconds is not None:
        retry = error_details_pb2.RetryInfo()
        retry.retry_delay.FromTimedelta(datetime.timedelta(seconds=retry_seconds))
        details.append(retry)
    status = status_pb2.Status(code=code.value[0], message=f"refused: {reason}")
    for detail in details:
        packed = any_pb2.Any()
        packed.Pack(detail)
        status.details.append(packed)
    return code, status.SerializeToString()


class ScriptedService(pb_grpc.ScanPrepServicer):
    def __init__(self):
        self.script, self.arrivals, self.hang = [], [], threading.Event()

    def _answer(self, context):
        self.arrivals.append(time.monotonic())
        if not self.script:
            return True
        code, details = self.script.pop(0)
        if code is None:  # hang until the client gives up
            self.hang.wait(30)
            return False
        context.set_trailing_metadata([("grpc-status-details-bin", details)])
        context.abort(code, f"refused ({code.name})")

    def GetInfo(self, request, context):
        self._answer(context)
        return pb.GetInfoResponse(version="scripted")

    def Process(self, request_iterator, context):
        received = sum(1 for _ in request_iterator)
        if self._answer(context):
            yield pb.ProcessResponse(report=pb.Report(points_received=received))
            yield pb.ProcessResponse(end=pb.StreamEnd(points=0, crc32=0))


class ClientRetryTest(unittest.TestCase):
    def setUp(self):
        self.service = ScriptedService()
        self.server = grpc.server(futures.ThreadPoolExecutor(max_workers=4))
        pb_grpc.add_ScanPrepServicer_to_server(self.service, self.server)
        self.target = f"127.0.0.1:{self.server.add_insecure_port('127.0.0.1:0')}"
        self.server.start()
        self.scan = Scan(points=np.zeros((10, 3), dtype=np.float32))

    def tearDown(self):
        self.service.hang.set()
        self.server.stop(None)

    def test_a_refusal_carries_its_details_and_its_cause(self):
        self.service.script = [refusal(grpc.StatusCode.INVALID_ARGUMENT, "INVALID_PARAMETER",
                                       field="header.options.params['smoothing.lambda']",
                                       limit="1")]
        with Client(self.target, retry=QUICK) as client, \
                self.assertRaises(ScanprepError) as caught:
            client.process([self.scan], unit="mm")
        error = caught.exception
        self.assertEqual(error.code, grpc.StatusCode.INVALID_ARGUMENT)
        self.assertEqual((error.reason, error.domain), ("INVALID_PARAMETER", "scanprep.v1"))
        self.assertEqual(error.field, "header.options.params['smoothing.lambda']")
        self.assertEqual(error.violations, [(error.field, "out of range")])
        self.assertEqual(error.metadata, {"limit": "1"})
        self.assertIsNone(error.retry_delay)
        self.assertIsInstance(error.__cause__, grpc.RpcError)  # kept, not `from None`
        self.assertEqual(error.__cause__.code(), grpc.StatusCode.INVALID_ARGUMENT)
        self.assertEqual(len(self.service.arrivals), 1)  # a bad request is not repeated

    def test_a_full_queue_is_retried_after_the_delay_the_service_asks(self):
        full = refusal(grpc.StatusCode.RESOURCE_EXHAUSTED, "QUEUE_FULL", retry_seconds=0.3)
        self.service.script = [full, full]
        with Client(self.target, retry=QUICK) as client:
            result = client.process([self.scan], unit="mm")
        self.assertEqual(result.report.points_received, 3)  # header, one chunk, end: sent whole
        arrivals = self.service.arrivals
        self.assertEqual(len(arrivals), 3)
        # RetryInfo's 0.3 s, not the policy's 0.01 s backoff.
        self.assertGreaterEqual(min(np.diff(arrivals)), 0.3)

    def test_a_job_too_large_is_not_retried(self):
        self.service.script = [refusal(grpc.StatusCode.RESOURCE_EXHAUSTED, "JOB_TOO_LARGE",
                                       max_points_per_job="5")]
        with Client(self.target, retry=QUICK) as client, \
                self.assertRaises(ScanprepError) as caught:
            client.process([self.scan], unit="mm")
        self.assertEqual(caught.exception.reason, "JOB_TOO_LARGE")
        self.assertEqual(caught.exception.metadata, {"max_points_per_job": "5"})
        self.assertEqual(len(self.service.arrivals), 1)

    def test_attempts_are_bounded(self):
        self.service.script = [refusal(grpc.StatusCode.UNAVAILABLE, "SHUTTING_DOWN")] * 5
        policy = RetryPolicy(max_attempts=3, initial_backoff=0.01, jitter=0)
        with Client(self.target, retry=policy) as client, \
                self.assertRaises(ScanprepError) as caught:
            client.info()
        self.assertEqual(caught.exception.code, grpc.StatusCode.UNAVAILABLE)
        self.assertEqual(len(self.service.arrivals), 3)

    def test_a_delay_beyond_the_deadline_is_not_waited_for(self):
        self.service.script = [refusal(grpc.StatusCode.RESOURCE_EXHAUSTED, "QUEUE_FULL",
                                       retry_seconds=60)]
        start = time.monotonic()
        with Client(self.target, retry=QUICK, timeout=5) as client, \
                self.assertRaises(ScanprepError) as caught:
            client.process([self.scan], unit="mm")
        self.assertEqual(caught.exception.retry_delay, 60)
        self.assertLess(time.monotonic() - start, 5)  # gave up at once, not at the deadline
        self.assertEqual(len(self.service.arrivals), 1)

    def test_every_call_has_a_deadline_by_default(self):
        self.service.script = [(None, b"")]  # the server never answers
        start = time.monotonic()
        with Client(self.target, timeout=0.5) as client, \
                self.assertRaises(ScanprepError) as caught:
            client.process([self.scan], unit="mm")
        self.assertEqual(caught.exception.code, grpc.StatusCode.DEADLINE_EXCEEDED)
        self.assertLess(time.monotonic() - start, 10)

    def test_the_unit_is_required(self):
        with Client(self.target) as client, self.assertRaisesRegex(TypeError, "'unit'"):
            client.process([self.scan])
        self.assertEqual(self.service.arrivals, [])  # nothing was sent


if __name__ == "__main__":
    unittest.main()
