# SPDX-License-Identifier: Apache-2.0
"""Python client codec: 1 M points encoded into request messages and decoded from result messages,
with the packed arrays (what client/python sends and asks for) and with the repeated fields, in the
same run. Run with the client installed (client/python/install-venv.sh VENV, then VENV/bin/python;
tools/run-benchmarks.sh does)."""

import sys
import time

import numpy as np

from scanprep.v1 import scanprep_pb2 as pb
from scanprep_client.client import Scan, _header, _requests

N = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
CHUNK = 32768


def encode_packed(scan):
    offsets = [None]  # float32 points: sent as they are
    header = _header([scan], offsets, None, "mm", stages=None, params=None, preset="",
                     include_removed=False, labels=None, budget_seconds=0.0, job_id="",
                     fail_on=(), result_arrays=pb.ARRAY_ENCODING_PACKED)
    return [r.SerializeToString() for r in _requests(header, [scan], offsets, CHUNK)]


def encode_repeated(scan):
    out = []
    for begin in range(0, N, CHUNK):
        chunk = pb.PointChunk()
        chunk.xyz.extend(scan.points[begin:begin + CHUNK].ravel())
        out.append(pb.ProcessRequest(points=chunk).SerializeToString())
    return out


def results(points, normals, packed):
    """Result messages as the server sends them (xyz, scan_index, normal, flags)."""
    out = []
    for begin in range(0, N, CHUNK):
        chunk, end = pb.PointChunk(), begin + CHUNK
        if packed:
            chunk.xyz_packed = points[begin:end].tobytes()
            chunk.scan_index_packed = np.zeros(len(points[begin:end]), "<u4").tobytes()
            chunk.normal_packed = normals[begin:end].tobytes()
        else:
            chunk.xyz.extend(points[begin:end].ravel())
            chunk.scan_index.extend(np.zeros(len(points[begin:end]), np.uint32))
            chunk.normal.extend(normals[begin:end].ravel())
        chunk.flags = bytes(len(points[begin:end]))
        out.append(pb.ProcessResponse(points=chunk).SerializeToString())
    return out


def decode(messages, packed):
    xyz, normals, flags = [], [], []
    for data in messages:
        chunk = pb.ProcessResponse.FromString(data).points
        if packed:
            xyz.append(chunk.xyz_packed)
            normals.append(chunk.normal_packed)
        else:
            xyz.append(np.array(chunk.xyz, dtype=np.float32))
            normals.append(np.array(chunk.normal, dtype=np.float32))
        flags.append(chunk.flags)
    if packed:
        return (np.frombuffer(b"".join(xyz), "<f4").reshape(-1, 3),
                np.frombuffer(b"".join(normals), "<f4").reshape(-1, 3))
    return np.concatenate(xyz).reshape(-1, 3), np.concatenate(normals).reshape(-1, 3)


def best_of(runs, f):
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return min(times)


rng = np.random.default_rng(1)
points = rng.random((N, 3), dtype=np.float32)
normals = rng.random((N, 3), dtype=np.float32)
scan = Scan(points=points)
print(f"| Python client codec, {N:,} points | encode (s) | decode (s) | encode + decode (s) |")
print("|---|---:|---:|---:|")
for packed in (True, False):
    encode = best_of(3, lambda: encode_packed(scan) if packed else encode_repeated(scan))
    messages = results(points, normals, packed)
    decoded = decode(messages, packed)
    assert np.array_equal(decoded[0], points) and np.array_equal(decoded[1], normals)
    decode_s = best_of(3, lambda: decode(messages, packed))
    name = "packed bytes (client/python)" if packed else "repeated float"
    print(f"| {name} | {encode:.3f} | {decode_s:.3f} | {encode + decode_s:.3f} |")
