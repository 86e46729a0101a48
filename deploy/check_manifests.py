#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Checks the Kubernetes manifests in deploy/ without a cluster (kubectl, kustomize and
kubeconform are not packaged in Debian 12): builds the base and every overlay as kustomize would
(resources, images, ConfigMap generator), checks each object against a schema of the fields it
may use (required fields, types, no unknown keys: a typo is an error, not a silently ignored
field), then what must hold between them and the server:

  - the Deployment's memory limit holds the formula of the server's admission control,
    128 MiB + max_concurrent_jobs x (16 MiB + kBytesPerPoint x max_points_per_job), for its own
    flags (the constants read from server/memory_budget.h);
  - no `replicas` beside an HPA; clients rebalance (--max_connection_age); the termination grace
    covers --grace_period plus the preStop sleep;
  - Pod Security Standard "restricted" with a read-only root;
  - the image is a name kustomize's `images:` sets, never `:latest`;
  - selectors, ports and references (Service, HPA, PDB, ServiceMonitor, GRPCRoute) resolve;
  - the PrometheusRule holds exactly the groups of deploy/prometheus/alerts.yml.

Exit 0 when all hold, else 1 with one line per finding. --self-test breaks each rule in a copy
of the manifests and requires a finding for every break (the check can fail)."""
import copy
import pathlib
import re
import sys

import yaml

DEPLOY = pathlib.Path(__file__).resolve().parent
MIB = 1024 * 1024


def budget_constant(name):
    """A constant of the server's admission arithmetic, as server/memory_budget.h defines it."""
    header = (DEPLOY.parent / "server" / "memory_budget.h").read_text()
    m = re.search(rf"constexpr uint64_t {name} = (?:uint64_t\{{(\d+)\}} << (\d+)|(\d+));", header)
    if not m:
        sys.exit(f"check_manifests: {name} not found in server/memory_budget.h")
    return int(m[1]) << int(m[2]) if m[1] else int(m[3])


BYTES_PER_POINT = budget_constant("kBytesPerPoint")
JOB_OVERHEAD = budget_constant("kJobOverheadBytes")
SERVER_RESERVE = budget_constant("kServerReserveBytes")

# --- schemas ---------------------------------------------------------------------------------
# A schema is a type (str, int, bool, float), "any", a list [schema] or a dict of keys, where a
# key ending in "!" is required. Keys not listed are unknown.
QUANTITY = "quantity"  # a string like 2Gi or a number
METADATA = {"name!": str, "labels": {"*": str}, "annotations": {"*": str}, "namespace": str}
TEMPLATE_METADATA = {"labels!": {"*": str}, "annotations": {"*": str}}
LABEL_SELECTOR = {"matchLabels!": {"*": str}}
PROBE = {"grpc": {"port!": int, "service": str}, "periodSeconds": int, "failureThreshold": int,
         "initialDelaySeconds": int, "timeoutSeconds": int}
CONTAINER = {
    "name!": str, "image!": str, "args": [str], "command": [str],
    "env": [{"name!": str, "value": str}],
    "ports": [{"name!": str, "containerPort!": int, "protocol": str}],
    "resources!": {"requests!": {"cpu": QUANTITY, "memory!": QUANTITY},
                   "limits!": {"cpu": QUANTITY, "memory!": QUANTITY}},
    "securityContext!": {"allowPrivilegeEscalation!": bool, "readOnlyRootFilesystem!": bool,
                         "runAsNonRoot": bool, "runAsUser": int,
                         "capabilities!": {"drop!": [str], "add": [str]},
                         "seccompProfile": {"type!": str}},
    "volumeMounts": [{"name!": str, "mountPath!": str, "readOnly": bool}],
    "readinessProbe": PROBE, "livenessProbe": PROBE, "startupProbe": PROBE,
    "lifecycle": {"preStop": {"exec": {"command!": [str]}}},
}
POD_SPEC = {
    "terminationGracePeriodSeconds!": int, "automountServiceAccountToken": bool,
    "enableServiceLinks": bool, "serviceAccountName": str,
    "securityContext!": {"runAsNonRoot!": bool, "runAsUser": int, "runAsGroup": int,
                         "fsGroup": int, "seccompProfile!": {"type!": str}},
    "containers!": [CONTAINER],
    "volumes": [{"name!": str, "emptyDir": {"sizeLimit": QUANTITY, "medium": str},
                 "secret": {"secretName!": str}}],
}
SCHEMAS = {
    ("apps/v1", "Deployment"): {
        "metadata!": METADATA,
        "spec!": {"replicas": int, "selector!": LABEL_SELECTOR,
                  "template!": {"metadata!": TEMPLATE_METADATA, "spec!": POD_SPEC},
                  "strategy": "any"},
    },
    ("v1", "Service"): {
        "metadata!": METADATA,
        "spec!": {"type": str, "clusterIP": str, "selector!": {"*": str},
                  "ports!": [{"name!": str, "port!": int, "targetPort!": "any",
                              "appProtocol": str, "protocol": str}]},
    },
    ("autoscaling/v2", "HorizontalPodAutoscaler"): {
        "metadata!": METADATA,
        "spec!": {"scaleTargetRef!": {"apiVersion!": str, "kind!": str, "name!": str},
                  "minReplicas!": int, "maxReplicas!": int, "metrics!": "any",
                  "behavior": "any"},
    },
    ("policy/v1", "PodDisruptionBudget"): {
        "metadata!": METADATA,
        "spec!": {"maxUnavailable": "any", "minAvailable": "any", "selector!": LABEL_SELECTOR},
    },
    ("v1", "ConfigMap"): {"metadata!": METADATA, "data!": {"*": str}},
    ("monitoring.coreos.com/v1", "ServiceMonitor"): {
        "metadata!": METADATA,
        "spec!": {"selector!": LABEL_SELECTOR,
                  "endpoints!": [{"port!": str, "path": str, "interval": str,
                                  "scheme": str}]},
    },
    ("monitoring.coreos.com/v1", "PrometheusRule"): {
        "metadata!": METADATA, "spec!": {"groups!": [{"name!": str, "rules!": [dict]}]},
    },
    ("gateway.networking.k8s.io/v1", "Gateway"): {
        "metadata!": METADATA,
        "spec!": {"gatewayClassName!": str,
                  "listeners!": [{"name!": str, "protocol!": str, "port!": int,
                                  "hostname": str,
                                  "tls": {"mode!": str,
                                          "certificateRefs!": [{"kind": str, "name!": str}]},
                                  "allowedRoutes": {"kinds": [{"kind!": str}]}}]},
    },
    ("gateway.networking.k8s.io/v1", "GRPCRoute"): {
        "metadata!": METADATA,
        "spec!": {"parentRefs!": [{"name!": str, "sectionName": str}],
                  "hostnames": [str],
                  "rules!": [{"matches": [{"method!": {"service!": str, "method": str}}],
                              "backendRefs!": [{"name!": str, "port!": int}]}]},
    },
}
KUSTOMIZATION = {"apiVersion!": str, "kind!": str, "resources!": [str],
                 "images": [{"name!": str, "newName": str, "newTag": str}],
                 "configMapGenerator": [{"name!": str, "files!": [str]}],
                 "generatorOptions": {"disableNameSuffixHash": bool}}


def check_schema(value, schema, where, findings):
    if schema == "any":
        return
    if schema == QUANTITY:
        if not isinstance(value, (str, int, float)) or isinstance(value, bool):
            findings.append(f"{where}: expected a quantity, got {value!r}")
        return
    if isinstance(schema, list):
        if not isinstance(value, list):
            findings.append(f"{where}: expected a list, got {type(value).__name__}")
            return
        for i, item in enumerate(value):
            check_schema(item, schema[0], f"{where}[{i}]", findings)
        return
    if isinstance(schema, dict):
        if not isinstance(value, dict):
            findings.append(f"{where}: expected a mapping, got {type(value).__name__}")
            return
        if "*" in schema:  # a map of free keys
            for key, item in value.items():
                check_schema(item, schema["*"], f"{where}.{key}", findings)
            return
        known = {key.rstrip("!"): sub for key, sub in schema.items()}
        for key in schema:
            if key.endswith("!") and key[:-1] not in value:
                findings.append(f"{where}: missing {key[:-1]}")
        for key, item in value.items():
            if key not in known:
                findings.append(f"{where}: unknown field {key!r}")
            else:
                check_schema(item, known[key], f"{where}.{key}", findings)
        return
    if schema is float:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    elif schema is int:
        ok = isinstance(value, int) and not isinstance(value, bool)
    else:
        ok = isinstance(value, schema)
    if not ok:
        findings.append(f"{where}: expected {schema.__name__}, got {value!r}")


# --- building a kustomization ----------------------------------------------------------------
class Obj:
    """One manifest object and where it came from."""

    def __init__(self, body, source):
        self.body, self.source = body, source

    @property
    def where(self):
        return f"{self.source}: {self.body.get('kind')}/{self.body.get('metadata', {}).get('name')}"


def load_documents(path):
    with open(path) as f:
        return [doc for doc in yaml.safe_load_all(f) if doc is not None]


def build(directory, findings, seen=()):
    """The objects `kubectl apply -k directory` would create."""
    directory = pathlib.Path(directory)
    rel = lambda p: str(pathlib.Path(p).resolve().relative_to(DEPLOY.parent))  # noqa: E731
    path = directory / "kustomization.yaml"
    if not path.exists():
        findings.append(f"{rel(directory)}: no kustomization.yaml")
        return []
    kustomization = load_documents(path)[0]
    check_schema(kustomization, KUSTOMIZATION, rel(path), findings)
    objects = []
    for resource in kustomization.get("resources", []):
        target = (directory / resource).resolve()
        if target.is_dir():
            if target in seen:
                findings.append(f"{rel(path)}: resource {resource} includes itself")
                continue
            objects += build(target, findings, seen + (target,))
        elif target.exists():
            objects += [Obj(doc, rel(target)) for doc in load_documents(target)]
        else:
            findings.append(f"{rel(path)}: resource {resource} does not exist")
    for generator in kustomization.get("configMapGenerator", []):
        data = {}
        for name in generator.get("files", []):
            file = directory / name
            if not file.exists():
                findings.append(f"{rel(path)}: configMapGenerator file {name} does not exist")
            else:
                data[pathlib.Path(name).name] = file.read_text()
        objects.append(Obj({"apiVersion": "v1", "kind": "ConfigMap",
                            "metadata": {"name": generator.get("name")}, "data": data},
                           rel(path)))
    for image in kustomization.get("images", []):
        for obj in objects:
            for container in containers(obj):
                if container.get("image", "").split(":")[0] == image["name"]:
                    container["image"] = (image.get("newName", image["name"]) +
                                          (f":{image['newTag']}" if "newTag" in image else ""))
                    container["_image_set"] = True
    return objects


def containers(obj):
    if obj.body.get("kind") != "Deployment":
        return []
    return obj.body.get("spec", {}).get("template", {}).get("spec", {}).get("containers", [])


# --- the rules -------------------------------------------------------------------------------
def flag(args, name):
    for arg in args:
        if arg.startswith(f"--{name}="):
            return arg.split("=", 1)[1]
    return None


def quantity_bytes(text):
    units = {"Ki": 1024, "Mi": MIB, "Gi": 1024 * MIB, "K": 1000, "M": 1000**2, "G": 1000**3}
    m = re.fullmatch(r"([0-9.]+)([KMG]i?)?", str(text))
    if not m:
        return None
    return float(m.group(1)) * units.get(m.group(2) or "", 1)


def seconds(text):
    m = re.fullmatch(r"([0-9.]+)(ms|s|m)?", text or "")
    if not m:
        return None
    return float(m.group(1)) * {"ms": 0.001, "s": 1, "m": 60, None: 1}[m.group(2)]


def check_deployment(obj, by_kind, findings):
    spec = obj.body["spec"]
    pod = spec["template"]["spec"]
    where = obj.where
    labels = spec["template"]["metadata"].get("labels", {})
    if any(labels.get(k) != v for k, v in spec["selector"]["matchLabels"].items()):
        findings.append(f"{where}: selector does not match the pod template's labels")
    hpa_targets = {h.body["spec"]["scaleTargetRef"]["name"]
                   for h in by_kind.get("HorizontalPodAutoscaler", [])}
    if "replicas" in spec and obj.body["metadata"]["name"] in hpa_targets:
        findings.append(f"{where}: sets replicas although an HPA scales it (each apply resets "
                        f"the HPA's count)")
    security = pod["securityContext"]
    if security.get("runAsNonRoot") is not True:
        findings.append(f"{where}: pod securityContext.runAsNonRoot must be true (restricted)")
    if security.get("seccompProfile", {}).get("type") not in ("RuntimeDefault", "Localhost"):
        findings.append(f"{where}: pod seccompProfile must be RuntimeDefault (restricted)")
    volumes = {v["name"] for v in pod.get("volumes", [])}
    for c in pod["containers"]:
        cw = f"{where} container {c['name']}"
        sc = c["securityContext"]
        if sc.get("allowPrivilegeEscalation") is not False:
            findings.append(f"{cw}: allowPrivilegeEscalation must be false (restricted)")
        if "ALL" not in sc.get("capabilities", {}).get("drop", []):
            findings.append(f"{cw}: capabilities must drop ALL (restricted)")
        if sc.get("capabilities", {}).get("add"):
            findings.append(f"{cw}: adds capabilities (restricted allows none)")
        if sc.get("readOnlyRootFilesystem") is not True:
            findings.append(f"{cw}: the root filesystem must be read-only")
        for mount in c.get("volumeMounts", []):
            if mount["name"] not in volumes:
                findings.append(f"{cw}: volumeMount {mount['name']} names no volume")
        image = c["image"]
        if image.endswith(":latest") or ":" not in image.split("/")[-1]:
            findings.append(f"{cw}: image {image} has no version tag (or :latest)")
        if not c.get("_image_set"):
            findings.append(f"{cw}: image {image} is not set by kustomize's images:")
        ports = {p["name"] for p in c.get("ports", [])}
        for probe in ("readinessProbe", "livenessProbe"):
            if probe not in c:
                findings.append(f"{cw}: no {probe}")
        args = c.get("args", [])
        jobs, points = flag(args, "max_concurrent_jobs"), flag(args, "max_points_per_job")
        limit = quantity_bytes(c["resources"]["limits"]["memory"])
        if jobs is None or points is None:
            findings.append(f"{cw}: --max_concurrent_jobs and --max_points_per_job must be set "
                            f"(the memory limit is derived from them)")
        elif limit is not None:
            need = SERVER_RESERVE + int(jobs) * (JOB_OVERHEAD + BYTES_PER_POINT * int(points))
            if need > limit:
                findings.append(
                    f"{cw}: memory limit {c['resources']['limits']['memory']} is below "
                    f"{SERVER_RESERVE // MIB} MiB + {jobs} x ({JOB_OVERHEAD // MIB} MiB + "
                    f"{BYTES_PER_POINT} B x {points}) = {need / MIB:.0f} MiB")
        if c["resources"]["requests"]["memory"] != c["resources"]["limits"]["memory"]:
            findings.append(f"{cw}: memory request differs from the limit (Guaranteed QoS)")
        if flag(args, "max_connection_age") is None:
            findings.append(f"{cw}: no --max_connection_age: clients never rebalance onto new pods")
        grace = seconds(flag(args, "grace_period") or "30s")
        pre_stop = c.get("lifecycle", {}).get("preStop", {}).get("exec", {}).get("command", [])
        sleep = float(pre_stop[-1]) if pre_stop and pre_stop[0].endswith("sleep") else 0
        if pod["terminationGracePeriodSeconds"] <= grace + sleep:
            findings.append(f"{where}: terminationGracePeriodSeconds "
                            f"{pod['terminationGracePeriodSeconds']} must exceed --grace_period "
                            f"{grace:g} s + preStop {sleep:g} s")
        c["_ports"] = ports


def selects(selector, labels):
    return all(labels.get(k) == v for k, v in selector.items())


def check_references(by_kind, findings):
    deployments = by_kind.get("Deployment", [])
    pods = [(d, d.body["spec"]["template"]["metadata"].get("labels", {})) for d in deployments]
    services = by_kind.get("Service", [])
    for s in services:
        selected = [d for d, labels in pods if selects(s.body["spec"]["selector"], labels)]
        if not selected:
            findings.append(f"{s.where}: selects no Deployment's pods")
        for port in s.body["spec"]["ports"]:
            target = port["targetPort"]
            for d in selected:
                names = set().union(*(c.get("_ports", set()) for c in containers(d)))
                if isinstance(target, str) and target not in names:
                    findings.append(f"{s.where}: targetPort {target} is no port of {d.where}")
    names = {d.body["metadata"]["name"] for d in deployments}
    for h in by_kind.get("HorizontalPodAutoscaler", []):
        if h.body["spec"]["scaleTargetRef"]["name"] not in names:
            findings.append(f"{h.where}: scales no Deployment of these manifests")
    for p in by_kind.get("PodDisruptionBudget", []):
        if not any(selects(p.body["spec"]["selector"]["matchLabels"], l) for _, l in pods):
            findings.append(f"{p.where}: selects no pods")
    for m in by_kind.get("ServiceMonitor", []):
        matched = [s for s in services
                   if selects(m.body["spec"]["selector"]["matchLabels"],
                              s.body["metadata"].get("labels", {}))]
        if not matched:
            findings.append(f"{m.where}: selects no Service by its labels")
        for e in m.body["spec"]["endpoints"]:
            if not any(e["port"] in {p["name"] for p in s.body["spec"]["ports"]} for s in matched):
                findings.append(f"{m.where}: port {e['port']} is no port of the Service")
    gateways = {g.body["metadata"]["name"]: g for g in by_kind.get("Gateway", [])}
    for r in by_kind.get("GRPCRoute", []):
        for parent in r.body["spec"]["parentRefs"]:
            g = gateways.get(parent["name"])
            if g is None:
                findings.append(f"{r.where}: parent {parent['name']} is no Gateway here")
            elif "sectionName" in parent and parent["sectionName"] not in {
                    l["name"] for l in g.body["spec"]["listeners"]}:
                findings.append(f"{r.where}: listener {parent['sectionName']} is not in {g.where}")
        for rule in r.body["spec"]["rules"]:
            for ref in rule["backendRefs"]:
                ports = [p["port"] for s in services if s.body["metadata"]["name"] == ref["name"]
                         for p in s.body["spec"]["ports"]]
                if ref["port"] not in ports:
                    findings.append(f"{r.where}: backend {ref['name']}:{ref['port']} is no "
                                    f"Service port here")
    alerts = yaml.safe_load((DEPLOY / "prometheus" / "alerts.yml").read_text())["groups"]
    for rule in by_kind.get("PrometheusRule", []):
        if rule.body["spec"]["groups"] != alerts:
            findings.append(f"{rule.where}: groups differ from deploy/prometheus/alerts.yml "
                            f"(run python3 deploy/gen_prometheusrule.py)")


def check(objects):
    findings = []
    by_kind = {}
    for obj in objects:
        key = (obj.body.get("apiVersion"), obj.body.get("kind"))
        if key not in SCHEMAS:
            findings.append(f"{obj.where}: no schema for {key[0]} {key[1]}")
            continue
        body = {k: v for k, v in obj.body.items() if k not in ("apiVersion", "kind")}
        clean = strip_private(body)
        check_schema(clean, SCHEMAS[key], obj.where, findings)
        by_kind.setdefault(key[1], []).append(obj)
    if findings:
        return findings  # the rules below rely on the schema
    for d in by_kind.get("Deployment", []):
        check_deployment(d, by_kind, findings)
    check_references(by_kind, findings)
    return findings


def strip_private(value):
    if isinstance(value, dict):
        return {k: strip_private(v) for k, v in value.items() if not k.startswith("_")}
    if isinstance(value, list):
        return [strip_private(v) for v in value]
    return value


def targets():
    return [DEPLOY] + sorted(p.parent for p in (DEPLOY / "overlays").glob("*/kustomization.yaml"))


def check_all():
    findings = []
    for directory in targets():
        build_findings = []
        objects = build(directory, build_findings)
        findings += build_findings + check(objects)
    return findings


# --- self-test: every rule can fail ------------------------------------------------------------
def first(objects, kind):
    return next(o for o in objects if o.body["kind"] == kind)


def container(objects):
    return containers(first(objects, "Deployment"))[0]


def set_arg(objects, name, value):
    c = container(objects)
    c["args"] = [a for a in c["args"] if not a.startswith(f"--{name}=")] + [f"--{name}={value}"]


BREAKS = {
    "replicas beside the HPA": lambda o: first(o, "Deployment").body["spec"].update(replicas=2),
    "no seccomp profile": lambda o: first(o, "Deployment").body["spec"]["template"]["spec"][
        "securityContext"].pop("seccompProfile"),
    "writable root": lambda o: container(o)["securityContext"].update(
        readOnlyRootFilesystem=False),
    "capabilities kept": lambda o: container(o)["securityContext"]["capabilities"].update(drop=[]),
    "memory formula over the limit": lambda o: set_arg(o, "max_points_per_job", "4000000"),
    "no connection age": lambda o: container(o).update(
        args=[a for a in container(o)["args"] if not a.startswith("--max_connection_age=")]),
    "image :latest": lambda o: container(o).update(image="scanprep:latest"),
    "misnamed Service port": lambda o: first(o, "Service").body["spec"]["ports"][0].update(
        targetPort="grcp"),
    "unknown field": lambda o: container(o).update(imagePullPolice="Always"),
    "grace shorter than the drain": lambda o: set_arg(o, "grace_period", "60s"),
    "HPA on a missing Deployment": lambda o: first(o, "HorizontalPodAutoscaler").body["spec"][
        "scaleTargetRef"].update(name="scanprep-old"),
}
OVERLAY_BREAKS = {
    "stale PrometheusRule": ("monitoring", lambda o: first(o, "PrometheusRule").body["spec"][
        "groups"][0]["rules"].pop()),
    "ServiceMonitor on a wrong port": ("monitoring", lambda o: first(o, "ServiceMonitor").body[
        "spec"]["endpoints"][0].update(port="metric")),
    "GRPCRoute to a wrong port": ("external", lambda o: first(o, "GRPCRoute").body["spec"][
        "rules"][0]["backendRefs"][0].update(port=50052)),
}


def self_test():
    failures = []
    base_findings = []
    base = build(DEPLOY, base_findings)
    if base_findings or check(copy.deepcopy(base)):
        return ["the manifests themselves fail; fix them first"]
    cases = [(name, DEPLOY, fn) for name, fn in BREAKS.items()]
    cases += [(name, DEPLOY / "overlays" / overlay, fn)
              for name, (overlay, fn) in OVERLAY_BREAKS.items()]
    for name, directory, fn in cases:
        objects = build(directory, [])
        fn(objects)
        found = check(objects)
        print(f"{name}: {found[0] if found else 'NOT CAUGHT'}")
        if not found:
            failures.append(f"self-test: '{name}' was not caught")
    return failures


def main(argv):
    testing = argv[1:] == ["--self-test"]
    findings = self_test() if testing else check_all()
    for line in findings:
        print(line)
    if not findings:
        print(f"self-test: all {len(BREAKS) + len(OVERLAY_BREAKS)} breaks caught" if testing else
              "manifests ok: " + ", ".join(str(t.relative_to(DEPLOY.parent)) for t in targets()))
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
