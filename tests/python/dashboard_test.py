#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The Grafana dashboard (deploy/grafana/scanprep-dashboard.json) against real data: a real
scanprep-server under `scanprep load` (jobs that meet and miss their budget, jobs refused by a
limit, jobs of two named sensors), a real Prometheus scraping it every second, and every panel's query run through
Prometheus's HTTP API with Grafana's variables filled in. Each query must return at least one
finite value; a misspelled metric in a control panel must be reported.

Run by ctest with SCANPREP_SERVER, SCANPREP_CLI and PROMETHEUS set (tests/CMakeLists.txt)."""
import json
import math
import os
import pathlib
import re
import shutil
import socket
import subprocess
import tempfile
import time
import unittest
import urllib.parse
import urllib.request

ROOT = pathlib.Path(__file__).resolve().parents[2]
DASHBOARD = ROOT / "deploy" / "grafana" / "scanprep-dashboard.json"
# What Grafana puts in for its variables here: a rate window of several 1 s scrapes, every replica.
VARIABLES = {"$__rate_interval": "10s", "$__interval": "2s", "$__range": "5m",
             "$instance": ".*", "${instance}": ".*"}


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def panels_of(dashboard):
    """Every panel, including those nested in collapsed rows."""
    for panel in dashboard["panels"]:
        yield panel
        yield from panel.get("panels", [])


def query_text(expr):
    for name, value in sorted(VARIABLES.items(), key=lambda kv: -len(kv[0])):
        expr = expr.replace(name, value)
    return expr


def finite_values(result):
    """The finite sample values of an instant query's result (vector or scalar)."""
    data = result["data"]
    samples = [data["result"]] if data["resultType"] == "scalar" else [
        item["value"] for item in data["result"]]
    return [float(v) for _, v in samples if math.isfinite(float(v))]


class Prometheus:
    def __init__(self, binary, target_port, directory):
        self.port = free_port()
        config = directory / "prometheus.yml"
        config.write_text(
            "global:\n  scrape_interval: 1s\n  evaluation_interval: 1s\n"
            "scrape_configs:\n  - job_name: scanprep\n    static_configs:\n"
            f"      - targets: ['127.0.0.1:{target_port}']\n")
        self.log = open(directory / "prometheus.log", "w")
        self.process = subprocess.Popen(
            [binary, f"--config.file={config}", f"--storage.tsdb.path={directory / 'data'}",
             f"--web.listen-address=127.0.0.1:{self.port}"],
            stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.time() + 30
        while time.time() < deadline:
            try:
                urllib.request.urlopen(f"http://127.0.0.1:{self.port}/-/ready", timeout=1)
                return
            except OSError:
                time.sleep(0.2)
        raise RuntimeError("prometheus did not become ready")

    def query(self, expr):
        url = (f"http://127.0.0.1:{self.port}/api/v1/query?" +
               urllib.parse.urlencode({"query": expr}))
        with urllib.request.urlopen(url, timeout=10) as response:
            return json.load(response)

    def stop(self):
        self.process.terminate()
        self.process.wait(timeout=10)
        self.log.close()


class DashboardTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dashboard = json.loads(DASHBOARD.read_text())

    def test_panels_are_complete(self):
        ids = [p["id"] for p in panels_of(self.dashboard)]
        self.assertEqual(len(ids), len(set(ids)), "panel ids must be unique")
        names = [v["name"] for v in self.dashboard["templating"]["list"]]
        self.assertIn("datasource", names)
        self.assertIn("instance", names)
        for panel in panels_of(self.dashboard):
            self.assertTrue(panel.get("title"), panel)
            self.assertIn("gridPos", panel, panel["title"])
            if panel["type"] == "row":
                continue
            self.assertTrue(panel.get("description"), panel["title"])
            self.assertTrue(panel.get("targets"), panel["title"])
            for target in panel["targets"]:
                self.assertTrue(target.get("refId") and target.get("expr"), panel["title"])

    def test_every_query_returns_data_under_load(self):
        server_binary, cli = os.environ["SCANPREP_SERVER"], os.environ["SCANPREP_CLI"]
        prometheus_binary = os.environ.get("PROMETHEUS") or shutil.which("prometheus")
        if not prometheus_binary:
            self.skipTest("prometheus is not installed")
        directory = pathlib.Path(tempfile.mkdtemp(prefix="scanprep_dashboard_"))
        # Two slots and a queue, so jobs wait; a default budget that the 20 k-point jobs sometimes
        # meet and sometimes miss; a job limit that refuses the 50 k-point jobs.
        server = subprocess.Popen(
            [server_binary, "--plaintext", "--listen=127.0.0.1:0", "--metrics_listen=127.0.0.1:0",
             "--threads=2", "--max_concurrent_jobs=2", "--max_queued_jobs=4",
             "--max_calls_per_peer=5", "--default_budget_seconds=0.15",
             "--max_points_per_job=30000"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        loads, prometheus = [], None
        try:
            grpc_port = metrics_port = None
            while grpc_port is None or metrics_port is None:
                line = server.stdout.readline()
                self.assertTrue(line, "scanprep-server exited before reporting its ports")
                if m := re.search(r"listening on port (\d+)", line):
                    grpc_port = int(m.group(1))
                if m := re.search(r"metrics on port (\d+)", line):
                    metrics_port = int(m.group(1))
            prometheus = Prometheus(prometheus_binary, metrics_port, directory)
            target = f"127.0.0.1:{grpc_port}"
            # The third load's two overlapping scans name their sensors, for the sensor health
            # row (per sensor and per pair).
            sensors = ["--scans", "2", "--sensor_id", "frontal=cam-front",
                       "--sensor_id", "oblique=cam-oblique"]
            for points, concurrency, extra in ((20000, 3, []), (50000, 1, []),
                                               (10000, 1, sensors)):
                loads.append(subprocess.Popen(
                    [cli, "load", "--server", target, "--simulate", str(points),
                     "--concurrency", str(concurrency), "--duration", "40s", "--timeout", "30s",
                     *extra],
                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
            targets = [(panel["title"], t["expr"]) for panel in panels_of(self.dashboard)
                       for t in panel.get("targets", [])]
            # Poll until every query has data (the windows fill as Prometheus scrapes), at most
            # 30 s; then report the ones that never did.
            missing = targets
            deadline = time.time() + 30
            time.sleep(5)
            while missing and time.time() < deadline:
                missing = [(title, expr) for title, expr in missing
                           if not self.has_data(prometheus, expr)]
                if missing:
                    time.sleep(1)
            self.assertEqual(missing, [], "panel queries without data")

            # The control: the same check on a misspelled metric reports it.
            self.assertFalse(self.has_data(
                prometheus, 'sum(rate(scanprep_points_recieved_total[$__rate_interval]))'))
        finally:
            for load in loads:
                load.terminate()
                load.wait(timeout=10)
            if prometheus:
                prometheus.stop()
            server.terminate()
            server.wait(timeout=60)
            server.stdout.close()
            shutil.rmtree(directory, ignore_errors=True)

    def has_data(self, prometheus, expr):
        result = prometheus.query(query_text(expr))
        self.assertEqual(result["status"], "success", expr)
        return bool(finite_values(result))


if __name__ == "__main__":
    unittest.main()
