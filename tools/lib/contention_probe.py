# SPDX-License-Identifier: Apache-2.0
"""Issue 39's contention classes against a running scanprep-server (tools/run-contention-probe.sh
starts one per case): an ordinary job's latency alone, then beside slow legal uploads (four
declaring 20 M points each, sending 70 kB/s: the finding's case), then for a second client host
while another floods the server (resubmitting at once). Prints one markdown row per case.

Usage: contention_probe.py slow_uploads|host_flood TARGET METRICS_PORT [POINTS]
Run with the Python client's venv (build/tests/python-client-venv/bin/python)."""

import multiprocessing
import statistics
import sys
import threading
import time
import urllib.request

import grpc
import numpy as np

from scanprep.v1 import scanprep_pb2 as pb
from scanprep.v1 import scanprep_pb2_grpc as pb_grpc
from scanprep_client import Scan
from scanprep_client.client import _header, _requests, _result

SLOW_UPLOADS = 4
SLOW_DECLARED = 20_000_000
SLOW_BYTES_PER_SECOND = 70_000
FLOOD_CALLS = 12  # max_concurrent_jobs + max_queued_jobs at the defaults


def plane(points: int) -> Scan:
    """A noisy plane, 0.5 mm spacing: the ordinary job."""
    side = int(points ** 0.5)
    u, v = np.meshgrid(np.arange(side) * 0.5, np.arange(side) * 0.5)
    rng = np.random.default_rng(1)
    xyz = np.stack([u.ravel(), v.ravel(), rng.normal(0, 0.01, side * side)], axis=1)
    return Scan(points=xyz.astype(np.float32), scanline=np.repeat(np.arange(side), side),
                scanline_spacing=0.5, uncertainty=0.01)


def run_job(stub, scan: Scan, host: str = "") -> tuple[float, float, float]:
    """Seconds from the call's start to the server's last upload progress (all its points
    held), to its first processing progress (its slot taken) and to its last message; raises
    grpc.RpcError."""
    header = _header([scan], [None], None, "mm", None, None, "", False, None, 0.0, "",
                     {}, pb.ARRAY_ENCODING_PACKED)
    metadata = [("x-forwarded-for", host)] if host else None
    start = time.monotonic()
    uploaded, slot = [0.0], []

    def progress(p: pb.Progress) -> None:
        if p.phase == pb.Progress.PHASE_UPLOAD:
            uploaded[0] = time.monotonic() - start
        elif p.phase == pb.Progress.PHASE_PROCESSING and not slot:
            slot.append(time.monotonic() - start)
    _result(stub.Process(_requests(header, [scan], [None], 32_768), timeout=600,
                         metadata=metadata), None, progress, 0)
    return uploaded[0], slot[0], time.monotonic() - start


def metric(port: int, name: str) -> float:
    body = urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=10).read().decode()
    for line in body.splitlines():
        if line.startswith(name + " "):
            return float(line.split()[1])
    return float("nan")


def slow_upload(stub, stop: threading.Event) -> None:
    """A legal upload: 20 M points declared, 70 kB/s sent, until `stop` (then cancelled)."""
    header = pb.JobHeader(unit=pb.LENGTH_UNIT_MILLIMETRE, total_points=SLOW_DECLARED)
    header.scans.add(scan_id="slow", uncertainty=0.01)
    points = 1_000  # 12 kB of xyz a message
    chunk = pb.PointChunk(xyz_packed=np.zeros((points, 3), dtype="<f4").tobytes())

    def requests():
        yield pb.ProcessRequest(header=header)
        while not stop.is_set():
            yield pb.ProcessRequest(points=chunk)
            time.sleep(len(chunk.xyz_packed) / SLOW_BYTES_PER_SECOND)
    call = stub.Process(requests(), timeout=3600)
    try:
        for _ in call:
            pass
    except grpc.RpcError:
        pass


def slow_uploads(stub, port: int, scan: Scan) -> None:
    alone = statistics.median(run_job(stub, scan)[2] for _ in range(3))
    stop = threading.Event()
    threads = [threading.Thread(target=slow_upload, args=(stub, stop)) for _ in range(SLOW_UPLOADS)]
    for t in threads:
        t.start()
    time.sleep(5)  # uploading
    beside = statistics.median(run_job(stub, scan)[2] for _ in range(3))
    reserved = metric(port, "scanprep_memory_reserved_bytes") / 2**20
    uploading = metric(port, "scanprep_jobs_uploading")
    stop.set()
    for t in threads:
        t.join()
    print(f"| slow_uploads ({SLOW_UPLOADS} × {SLOW_DECLARED // 10**6} M points declared at "
          f"{SLOW_BYTES_PER_SECOND // 1000} kB/s) | {alone:.2f} s alone, {beside:.2f} s beside them "
          f"({beside / alone:.2f}×) | {uploading:.0f} uploading, {reserved:.0f} MiB reserved |")


def flood(target: str, points: int, stop, in_slot) -> None:
    """Host A's calls, one after another, resubmitted at once when refused or displaced; each job's
    seconds in its slot go to `in_slot`. A process of its own, so that host B's client is not
    slowed by these calls' Python."""
    stub, scan = pb_grpc.ScanPrepStub(grpc.insecure_channel(target)), plane(points)
    while not stop.is_set():
        try:
            _, slot, end = run_job(stub, scan, "203.0.113.1")
            in_slot.append(end - slot)
        except grpc.RpcError:
            time.sleep(0.01)


def host_flood(stub, scan: Scan, target: str, points: int) -> None:
    alone = statistics.median(run_job(stub, scan, "203.0.113.2")[2] for _ in range(3))
    spawn = multiprocessing.get_context("spawn")
    with spawn.Manager() as manager:
        stop, in_slot = manager.Event(), manager.list()
        flooders = [spawn.Process(target=flood, args=(target, points, stop, in_slot))
                    for _ in range(FLOOD_CALLS)]
        for f in flooders:
            f.start()
        time.sleep(5 + 3 * alone)  # every slot and ticket taken
        waits, refusals = [], 0  # host B's, from its upload's end to its slot
        for _ in range(3):
            while True:
                try:
                    uploaded, slot, _ = run_job(stub, scan, "203.0.113.2")
                    break
                except grpc.RpcError as e:
                    if e.code() != grpc.StatusCode.RESOURCE_EXHAUSTED:
                        raise
                    refusals += 1
                    time.sleep(1)
            waits.append(slot - uploaded)
        stop.set()
        for f in flooders:
            f.join()
        job = statistics.median(in_slot)
    print(f"| host_flood (host A resubmits {FLOOD_CALLS} calls at once) | host B {alone:.2f} s a "
          f"job alone; beside the flood, from its upload's end to its slot "
          f"{statistics.median(waits):.2f} s (max {max(waits):.2f}), {refusals} refusals | a "
          f"job's time in its slot {job:.2f} s: B starts within {max(waits) / job:.2f} of one |")


def main() -> None:
    case, target, port = sys.argv[1], sys.argv[2], int(sys.argv[3])
    points = int(sys.argv[4]) if len(sys.argv) > 4 else 100_000
    stub = pb_grpc.ScanPrepStub(grpc.insecure_channel(target))
    scan = plane(points)
    if case == "slow_uploads":
        slow_uploads(stub, port, scan)
    else:
        host_flood(stub, scan, target, points)


if __name__ == "__main__":
    main()
