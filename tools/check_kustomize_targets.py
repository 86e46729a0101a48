#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Builds every kustomize target the docs name with the real `kubectl kustomize`, as a reader
would run it: each `kubectl apply -k DIR` / `kubectl kustomize DIR` in README.md, docs/*.md and
the comments of deploy/**/kustomization.yaml, plus every kustomization under deploy/ (an
undocumented one must build too). A target fails when kubectl fails (e.g. "cycle detected" for an
overlay inside its base), when an object it renders lacks the recommended labels
(tools/check_manifests.py: label_findings) or a Gateway leg lacks the TLS it needs
(gateway_tls_findings), or when it lacks what its purpose needs (EXPECTED:
the base's HPA on CPU only and gRPC admitted only from selected peers, the monitoring overlay's
queue metric with the adapter config serving it, --trusted_proxies behind the Gateway, the TLS
and mTLS overlays' cert-manager Certificate, mounted Secret and TLS flags, the large-jobs overlay's
16 M-point job limit on as many threads as CPUs, and for external-tls
all of these on both of the Gateway's legs: a listener with a cert-manager certificate, and a
BackendTLSPolicy on the routed Service with the CA and a hostname of the pods' Certificate); an
EXPECTED target that is missing fails too. Exit 0 all built, 1 with one line per failure, 77 (ctest
SKIP_RETURN_CODE) when kubectl is not installed."""
import pathlib
import re
import shutil
import sys

import yaml

from check_manifests import external_tls_purpose, gateway_tls_findings, kustomize, label_findings

ROOT = pathlib.Path(__file__).resolve().parent.parent
SKIP = 77
COMMAND = re.compile(r"kubectl\s+(?:apply\s+-k|kustomize)\s+([\w./-]+)")


def documented_targets(root):
    """{directory: where it is named} for every target a doc or kustomization comment names."""
    sources = [root / "README.md", *sorted((root / "docs").glob("*.md")),
               *sorted((root / "deploy").rglob("kustomization.yaml"))]
    found = {}
    for source in sources:
        text = source.read_text()
        for m in COMMAND.finditer(text):  # \s+ also spans a command wrapped across lines
            number = text.count("\n", 0, m.start()) + 1
            found.setdefault((root / m.group(1)).resolve(), f"{source.relative_to(root)}:{number}")
    return found


def all_targets(root):
    targets = documented_targets(root)
    for path in sorted((root / "deploy").rglob("kustomization.yaml")):
        if yaml.safe_load(path.read_text()).get("kind") != "Component":
            targets.setdefault(path.parent.resolve(), f"{path.relative_to(root)} (undocumented)")
    return targets


def of_kind(objects, kind):
    return [o for o in objects if o.get("kind") == kind]


def trusted_proxies(objects):
    return [] if any(a.startswith("--trusted_proxies=") for a in args(objects)) else [
        "no --trusted_proxies: behind the Gateway every MES host is one peer"]


def pod_spec(objects):
    return next((d["spec"]["template"]["spec"] for d in of_kind(objects, "Deployment")), {})


def args(objects):
    return [a for c in pod_spec(objects).get("containers", []) for a in c.get("args", [])]


def hpa_pods_metrics(objects):
    return [m["pods"]["metric"]["name"] for h in of_kind(objects, "HorizontalPodAutoscaler")
            for m in h["spec"]["metrics"] if m["type"] == "Pods"]


def grpc_open(objects):
    """gRPC port rules of the NetworkPolicies that admit every source."""
    return [r for n in of_kind(objects, "NetworkPolicy") for r in n["spec"].get("ingress", [])
            if not r.get("from") and any(p.get("port") in ("grpc", 50051) for p in r["ports"])]


def adapted(objects):
    return {rule.get("name", {}).get("as") for c in of_kind(objects, "ConfigMap")
            for rule in (yaml.safe_load(c.get("data", {}).get("config.yaml", "")) or {})
            .get("rules", [])}


def tls_findings(objects, client_ca):
    """A cert-manager Certificate whose Secret is mounted where --tls_cert/--tls_key (and
    --tls_client_ca for mTLS) point, no --plaintext, no gRPC probe (plaintext only)."""
    found = []
    issued = {c["spec"]["secretName"] for c in of_kind(objects, "Certificate")}
    if not issued:
        found.append("renders no cert-manager Certificate")
    pod = pod_spec(objects)
    secrets = {v["name"]: v["secret"]["secretName"] for v in pod.get("volumes", [])
               if "secret" in v}
    mounts = {m["mountPath"].rstrip("/"): m["name"] for c in pod.get("containers", [])
              for m in c.get("volumeMounts", [])}
    flags = ["tls_cert", "tls_key"] + (["tls_client_ca"] if client_ca else [])
    for name in flags:
        value = next((a.split("=", 1)[1] for a in args(objects)
                      if a.startswith(f"--{name}=")), None)
        volume = mounts.get(value.rsplit("/", 1)[0]) if value else None
        if value is None:
            found.append(f"no --{name}")
        elif secrets.get(volume) not in issued:
            found.append(f"--{name}={value} is not in the mounted Secret of a Certificate")
    if "--plaintext" in args(objects):
        found.append("still passes --plaintext")
    if any("grpc" in c.get(p, {}) for c in pod.get("containers", [])
           for p in ("readinessProbe", "livenessProbe")):
        found.append("a gRPC probe on the TLS port (the kubelet's speaks plaintext only)")
    return found


def large_job_findings(objects):
    """One job of 16 M points, on as many worker threads as the pod has CPUs."""
    values = dict(a[2:].split("=", 1) for a in args(objects) if a.startswith("--") and "=" in a)
    found = [] if int(values.get("max_points_per_job", 0)) >= 16_000_000 else [
        "takes no job of 16 M points (--max_points_per_job)"]
    cpus = {c["resources"]["limits"]["cpu"] for c in pod_spec(objects).get("containers", [])}
    if cpus != {values.get("threads")}:
        found.append(f"--threads={values.get('threads')} is not the CPU limit {sorted(cpus)}")
    return found


# What each target must render beyond building: {directory: check(objects) -> [failures]}.
EXPECTED = {
    "deploy/kubernetes/base": lambda o: (
        [f"HPA Pods metric {m} without a prometheus-adapter that serves it (never scales down)"
         for m in hpa_pods_metrics(o) if m not in adapted(o)] +
        ["the NetworkPolicy admits gRPC from every namespace" for _ in grpc_open(o)[:1]]),
    "deploy/kubernetes/overlays/monitoring": lambda o: (
        [] if "scanprep_jobs_queued" in hpa_pods_metrics(o) else
        ["the HPA does not scale on scanprep_jobs_queued"]) + (
        [] if "scanprep_jobs_queued" in adapted(o) else
        ["no prometheus-adapter config (ConfigMap config.yaml) serves scanprep_jobs_queued"]),
    "deploy/kubernetes/overlays/external": trusted_proxies,
    "deploy/kubernetes/overlays/tls": lambda o: tls_findings(o, client_ca=False),
    "deploy/kubernetes/overlays/external-tls": lambda o: (
        tls_findings(o, client_ca=False) + trusted_proxies(o) + external_tls_purpose(o)),
    "deploy/kubernetes/overlays/mtls": lambda o: tls_findings(o, client_ca=True),
    "deploy/kubernetes/overlays/large-jobs": large_job_findings,
}


def build(directory, where):
    objects, error = kustomize(directory)
    if error:
        return [f"{where}: kubectl kustomize {directory.relative_to(ROOT)}: {error}"]
    if not objects:
        return [f"{where}: kubectl kustomize {directory.relative_to(ROOT)} rendered nothing"]
    expected = EXPECTED.get(str(directory.relative_to(ROOT)), lambda o: [])
    return [f"{where}: {line}" for line in label_findings(objects) +
            gateway_tls_findings(objects)] + [
        f"{where}: {directory.relative_to(ROOT)} {line}" for line in expected(objects)]


def main():
    if shutil.which("kubectl") is None:
        print("SKIP: kubectl not installed, the documented kustomize targets were not built")
        return SKIP
    if not documented_targets(ROOT):
        print("no `kubectl apply -k` target found in README.md or docs/: the pattern is stale")
        return 1
    targets = all_targets(ROOT)
    failures = [f"{name}: expected kustomize target is missing" for name in EXPECTED
                if (ROOT / name).resolve() not in targets]
    for directory, where in sorted(targets.items()):
        found = build(directory, where) if directory.is_dir() else [
            f"{where}: {directory.relative_to(ROOT)} is not a directory"]
        failures += found
        print(f"{'FAIL' if found else 'ok  '} {directory.relative_to(ROOT)} ({where})")
    for line in failures:
        print(line)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
