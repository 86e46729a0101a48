#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Checks the Kubernetes manifests in deploy/kubernetes/ without a cluster: builds the base and
every overlay as kustomize would (resources, components with their own resources, labels,
images; an overlay inside its base or a file outside a kustomization's directory is refused, as
kustomize refuses them) and,
when kubectl is installed, requires `kubectl kustomize` to build the same objects. It checks each
object against a schema of the fields it may use (required fields, types, no unknown keys: a typo
is an error, not a silently ignored field), then what must hold between them and the server:

  - the Deployment's memory limit holds the formula of the server's admission control,
    128 MiB + max_concurrent_jobs x (16 MiB + kBytesPerPoint x max_points_per_job), for its own
    flags (the constants read from server/admission/memory_reservation.h);
  - no `replicas` beside an HPA; clients rebalance (--max_connection_age); the termination grace
    covers --grace_period plus the preStop sleep;
  - Pod Security Standard "restricted" with a read-only root;
  - the image is a name kustomize's `images:` sets, never `:latest`, tagged with the release:
    CMakeLists.txt's project() version, which the Dockerfile's ARG VERSION (the image's
    org.opencontainers.image.version) and deploy/docker-compose.yml's image tag also carry;
  - selectors, ports and references (Service, HPA, PDB, ServiceMonitor, GRPCRoute) resolve;
  - the recommended app.kubernetes.io/* labels on every object and pod template, selectors
    without the version, and the version label equal to the image tag;
  - the NetworkPolicy admits every container port, and each only from a selected namespace or
    pod (the metrics port from a namespace);
  - the HPA's Pods metrics are metrics the server exports and a prometheus-adapter
    configuration (a ConfigMap's config.yaml) of the same build serves: an HPA whose metric
    nobody serves never scales down;
  - TLS: either --plaintext or --tls_cert/--tls_key, not both; the TLS files lie in a mounted
    Secret that a cert-manager Certificate of the build issues; no gRPC probe on a TLS port (the
    kubelet's gRPC probe speaks plaintext only); behind a Gateway, --trusted_proxies is set;
  - the Gateway's legs: every listener terminates TLS with a certificate (a cert-manager
    Certificate of the build that issues its Secret names the listener's hostname); a Service a
    GRPCRoute sends calls to, whose pods serve TLS, has a BackendTLSPolicy and claims no
    kubernetes.io/h2c; a BackendTLSPolicy targets such a Service, verifies with a CA (a ConfigMap
    of the build with ca.crt) and a hostname among the dnsNames of the pods' Certificate; and
    overlays/external-tls renders all of that (PURPOSES);
  - the PrometheusRule and the rules ConfigMap hold exactly deploy/prometheus/alerts.yml, whose
    alerts have severity critical or warning and a runbook_url into docs/deployment.md ("Alert runbooks").

Exit 0 when all hold, else 1 with one line per finding. --self-test breaks each rule in a copy
of the manifests and requires a finding for every break (the check can fail)."""
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

import yaml

from check_docs import anchors

ROOT = pathlib.Path(__file__).resolve().parent.parent
DEPLOY = ROOT / "deploy"
KUBERNETES = DEPLOY / "kubernetes"
RUNBOOKS = ROOT / "docs" / "deployment.md"
MIB = 1024 * 1024
# The Kubernetes recommended labels, each object carries all of them. Selectors may only use the
# stable ones (a Deployment's selector is immutable; the version changes every release).
RECOMMENDED_LABELS = ("app.kubernetes.io/name", "app.kubernetes.io/instance",
                      "app.kubernetes.io/component", "app.kubernetes.io/part-of",
                      "app.kubernetes.io/version")
SELECTOR_LABELS = {"app.kubernetes.io/name", "app.kubernetes.io/instance",
                   "app.kubernetes.io/component"}
SEVERITIES = {"critical", "warning"}
RUNBOOK = re.compile(r"https://[^/]+/docs/deployment\.md#([\w-]+)")


def reservation_constant(name):
    """A constant of the server's admission arithmetic, as server/admission/memory_reservation.h
    defines it."""
    header = (ROOT / "server" / "admission" / "memory_reservation.h").read_text()
    m = re.search(rf"constexpr uint64_t {name} = (?:uint64_t\{{(\d+)\}} << (\d+)|(\d+));", header)
    if not m:
        sys.exit(f"check_manifests: {name} not found in server/admission/memory_reservation.h")
    return int(m[1]) << int(m[2]) if m[1] else int(m[3])


BYTES_PER_POINT = reservation_constant("kBytesPerPoint")
JOB_OVERHEAD = reservation_constant("kJobOverheadBytes")
SERVER_RESERVE = reservation_constant("kServerOwnBytes")


def project_version():
    """The release: CMakeLists.txt's project() VERSION, which the binaries' --version prints."""
    m = re.search(r"^project\(scanprep VERSION ([0-9.]+)", (ROOT / "CMakeLists.txt").read_text(),
                  re.M)
    if not m:
        sys.exit("check_manifests: no project(scanprep VERSION ...) in CMakeLists.txt")
    return m[1]


VERSION = project_version()

# --- schemas ---------------------------------------------------------------------------------
# A schema is a type (str, int, bool, float), "any", a list [schema] or a dict of keys, where a
# key ending in "!" is required. Keys not listed are unknown.
QUANTITY = "quantity"  # a string like 2Gi or a number
METADATA = {"name!": str, "labels": {"*": str}, "annotations": {"*": str}, "namespace": str}
TEMPLATE_METADATA = {"labels!": {"*": str}, "annotations": {"*": str}}
LABEL_SELECTOR = {"matchLabels!": {"*": str}}
PROBE = {"grpc": {"port!": int, "service": str}, "tcpSocket": {"port!": "any"},
         "periodSeconds": int, "failureThreshold": int,
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
BACKEND_TLS_POLICY = {
    "metadata!": METADATA,
    "spec!": {"targetRefs!": [{"group!": str, "kind!": str, "name!": str, "sectionName": str}],
              "validation!": {"caCertificateRefs": [{"group!": str, "kind!": str, "name!": str}],
                              "wellKnownCACertificates": str, "hostname!": str,
                              "subjectAltNames": [{"type!": str, "hostname": str, "uri": str}]},
              "options": {"*": str}},
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
    ("cert-manager.io/v1", "Certificate"): {
        "metadata!": METADATA,
        "spec!": {"secretName!": str,
                  "issuerRef!": {"name!": str, "kind": str, "group": str},
                  "dnsNames": [str], "commonName": str, "duration": str, "renewBefore": str,
                  "usages": [str],
                  "privateKey": {"algorithm": str, "size": int, "rotationPolicy": str,
                                 "encoding": str}},
    },
    ("networking.k8s.io/v1", "NetworkPolicy"): {
        "metadata!": METADATA,
        "spec!": {"podSelector!": LABEL_SELECTOR, "policyTypes!": [str],
                  "ingress!": [{"from": [{"namespaceSelector": LABEL_SELECTOR,
                                          "podSelector": LABEL_SELECTOR}],
                                "ports!": [{"port!": "any", "protocol": str}]}]},
    },
    # Gateway API v1.4's standard channel; v1.1 to v1.3 serve the same fields as v1alpha3.
    ("gateway.networking.k8s.io/v1", "BackendTLSPolicy"): BACKEND_TLS_POLICY,
    ("gateway.networking.k8s.io/v1alpha3", "BackendTLSPolicy"): BACKEND_TLS_POLICY,
    ("gateway.networking.k8s.io/v1", "GRPCRoute"): {
        "metadata!": METADATA,
        "spec!": {"parentRefs!": [{"name!": str, "sectionName": str}],
                  "hostnames": [str],
                  "rules!": [{"matches": [{"method!": {"service!": str, "method": str}}],
                              "backendRefs!": [{"name!": str, "port!": int}]}]},
    },
}
LABELS = [{"pairs!": {"*": str}, "includeTemplates": bool}]
# JSON 6902 patches, inline, on one object each (what build() applies).
PATCHES = [{"target!": {"kind!": str, "name!": str}, "patch!": str}]
KUSTOMIZATION = {"apiVersion!": str, "kind!": str, "resources!": [str], "components": [str],
                 "labels": LABELS, "patches": PATCHES,
                 "images": [{"name!": str, "newName": str, "newTag": str}],
                 "configMapGenerator": [{"name!": str, "files!": [str]}],
                 "generatorOptions": {"disableNameSuffixHash": bool}}
COMPONENT = {"apiVersion!": str, "kind!": str, "resources": [str], "components": [str],
             "labels": LABELS, "patches": PATCHES}


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


def rel(path):
    path = pathlib.Path(path).resolve()
    return str(path.relative_to(ROOT) if inside(path, ROOT) else path)


def inside(path, directory):
    return path == directory or directory in path.parents


def build(directory, findings, seen=None):
    """The objects `kubectl apply -k directory` would create. `seen`: the directories whose
    build includes this one; kustomize refuses a resource directory that contains any of them
    ("cycle detected"), which is what an overlay inside its own base is."""
    directory = pathlib.Path(directory).resolve()
    seen = (directory,) if seen is None else seen
    path = directory / "kustomization.yaml"
    if not path.exists():
        findings.append(f"{rel(directory)}: no kustomization.yaml")
        return []
    kustomization = load_documents(path)[0]
    check_schema(kustomization, KUSTOMIZATION, rel(path), findings)
    return accumulate(directory, kustomization, [], findings, seen)


def accumulate(directory, kustomization, objects, findings, seen):
    """One Kustomization or Component in kustomize's order: its resources join `objects`, then
    its generators, then its components one after the other (each a kustomization of its own
    on everything so far: a component listed first does not see what a later one adds), then
    its patches, labels and images on all of it."""
    path = directory / "kustomization.yaml"
    objects = list(objects)
    for resource in kustomization.get("resources", []):
        target = (directory / resource).resolve()
        if target.is_dir():
            outer = next((s for s in seen if inside(s, target)), None)
            if outer is not None:
                findings.append(f"{rel(path)}: resource {resource} contains {rel(outer)}, which "
                                f"includes it (kustomize: cycle detected): put the overlay beside "
                                f"its base, not inside it")
                continue
            objects += build(target, findings, seen + (target,))
        elif not inside(target, directory):
            findings.append(f"{rel(path)}: resource {resource} is outside the kustomization's "
                            f"directory (kustomize refuses to load it)")
        elif target.exists():
            objects += [Obj(doc, rel(target)) for doc in load_documents(target)]
        else:
            findings.append(f"{rel(path)}: resource {resource} does not exist")
    for generator in kustomization.get("configMapGenerator", []):
        data = {}
        for name in generator.get("files", []):
            file = (directory / name).resolve()
            if not inside(file, directory) or not file.exists():
                findings.append(f"{rel(path)}: configMapGenerator file {name} does not exist in "
                                f"the kustomization's directory")
            else:
                data[pathlib.Path(name).name] = file.read_text()
        objects.append(Obj({"apiVersion": "v1", "kind": "ConfigMap",
                            "metadata": {"name": generator.get("name")}, "data": data},
                           rel(path)))
    for component in kustomization.get("components", []):
        component_dir = (directory / component).resolve()
        component_path = component_dir / "kustomization.yaml"
        if not component_path.exists():
            findings.append(f"{rel(path)}: component {component} does not exist")
            continue
        body = load_documents(component_path)[0]
        check_schema(body, COMPONENT, rel(component_path), findings)
        objects = accumulate(component_dir, body, objects, findings, seen)
    apply_patches(kustomization.get("patches", []), objects, rel(path), findings)
    apply_labels(kustomization.get("labels", []), objects)
    for image in kustomization.get("images", []):
        for obj in objects:
            for container in containers(obj):
                if container.get("image", "").split(":")[0] == image["name"]:
                    container["image"] = (image.get("newName", image["name"]) +
                                          (f":{image['newTag']}" if "newTag" in image else ""))
                    container["_image_set"] = True
    return objects


def apply_patches(entries, objects, where, findings):
    """kustomize's `patches:` with an inline JSON 6902 patch (add, replace, remove, test)."""
    for entry in entries:
        target = entry["target"]
        matched = [o for o in objects if o.body.get("kind") == target["kind"]
                   and o.body.get("metadata", {}).get("name") == target["name"]]
        if not matched:
            findings.append(f"{where}: patch target {target['kind']}/{target['name']} matches "
                            f"no object")
        for obj in matched:
            for op in yaml.safe_load(entry["patch"]):
                error = json_patch(obj.body, op)
                if error:
                    findings.append(f"{where}: patch on {obj.where}: {op['op']} {op['path']}: "
                                    f"{error}")
                    break


def json_patch(body, op):
    """One JSON 6902 operation on body in place; an error text, or None."""
    keys = [k.replace("~1", "/").replace("~0", "~") for k in op["path"].split("/")[1:]]
    parent = body
    for key in keys[:-1]:
        try:
            parent = parent[int(key)] if isinstance(parent, list) else parent[key]
        except (KeyError, IndexError, ValueError):
            return "no such path"
    last = keys[-1]
    if isinstance(parent, list):
        index = len(parent) if last == "-" else int(last)
        if op["op"] == "add" and index <= len(parent):
            parent.insert(index, op["value"])
            return None
        if index >= len(parent):
            return "index out of range"
    elif op["op"] != "add" and last not in parent:
        return "no such path"
    else:
        index = last
    if op["op"] == "test":
        return None if strip_private(parent[index]) == op["value"] else (
            f"is {parent[index]!r}, not {op['value']!r}")
    if op["op"] == "remove":
        del parent[index]
    elif op["op"] in ("add", "replace"):
        parent[index] = op["value"]
    else:
        return "unsupported operation"
    return None


def apply_labels(entries, objects):
    """kustomize's `labels:` without includeSelectors: metadata, and pod templates if asked."""
    for entry in entries:
        for obj in objects:
            obj.body.setdefault("metadata", {}).setdefault("labels", {}).update(entry["pairs"])
            template = obj.body.get("spec", {}).get("template")
            if entry.get("includeTemplates") and template is not None:
                template.setdefault("metadata", {}).setdefault("labels", {}).update(
                    entry["pairs"])


def kustomize(directory):
    """`kubectl kustomize directory`: (the objects, None), or (None, kubectl's error without its
    log prefix)."""
    result = subprocess.run(["kubectl", "kustomize", str(directory)], capture_output=True,
                            text=True)
    if result.returncode != 0:
        lines = result.stderr.strip().splitlines() or ["failed"]
        return None, re.sub(r"^[EWI]\d{4} [\d:.]+\s+\d+ [\w.]+:\d+\] ", "", lines[-1])
    return [body for body in yaml.safe_load_all(result.stdout) if body], None


def kubectl_findings(directory, objects):
    """What the real kustomize says: it must build the directory, and the same objects as
    build() (else these checks would judge objects nobody applies). Nothing without kubectl."""
    if shutil.which("kubectl") is None:
        return []
    bodies, error = kustomize(directory)
    if error:
        return [f"{rel(directory)}: kubectl kustomize: {error}"]
    identity = lambda body: (body.get("kind"), body["metadata"].get("name"))  # noqa: E731
    real = {identity(body): body for body in bodies}
    ours = {identity(o.body): strip_private(o.body) for o in objects}
    findings = [f"{rel(directory)}: kubectl kustomize builds {kind}/{name}, this check does not"
                for kind, name in real.keys() - ours.keys()]
    findings += [f"{rel(directory)}: this check builds {kind}/{name}, kubectl kustomize does not"
                 for kind, name in ours.keys() - real.keys()]
    findings += [f"{rel(directory)}: {kind}/{name} differs from what kubectl kustomize builds"
                 for (kind, name) in real.keys() & ours.keys()
                 if real[(kind, name)] != ours[(kind, name)]]
    return findings


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
        elif image.rsplit(":", 1)[1] != VERSION:
            findings.append(f"{cw}: image tag {image.rsplit(':', 1)[1]} is not the project "
                            f"version {VERSION} (CMakeLists.txt project()): a release sets both")
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
    alerts_text = (DEPLOY / "prometheus" / "alerts.yml").read_text()
    for rule in by_kind.get("PrometheusRule", []):
        if rule.body["spec"]["groups"] != yaml.safe_load(alerts_text)["groups"]:
            findings.append(f"{rule.where}: groups differ from deploy/prometheus/alerts.yml "
                            f"(run python3 tools/gen_prometheusrule.py)")
    for config_map in by_kind.get("ConfigMap", []):
        if config_map.body["data"].get("alerts.yml", alerts_text) != alerts_text:
            findings.append(f"{config_map.where}: alerts.yml differs from deploy/prometheus/"
                            f"alerts.yml (run python3 tools/gen_prometheusrule.py)")


def label_findings(bodies):
    """The recommended labels on every object and pod template; selectors on stable labels only;
    the version label is the image's tag. `bodies`: plain manifests, e.g. kubectl's output."""
    findings = []
    tags = {c["image"].rsplit(":", 1)[-1] for body in bodies for c in
            body.get("spec", {}).get("template", {}).get("spec", {}).get("containers", [])}
    for body in bodies:
        what = f"{body.get('kind')}/{body.get('metadata', {}).get('name')}"
        spec = body.get("spec", {})
        labelled = {"metadata": body.get("metadata", {}).get("labels", {})}
        if "template" in spec:
            labelled["pod template"] = spec["template"].get("metadata", {}).get("labels", {})
        for place, labels in labelled.items():
            missing = [k for k in RECOMMENDED_LABELS if not labels.get(k)]
            if missing:
                findings.append(f"{what}: {place} lacks label(s) {', '.join(missing)}")
            version = labels.get("app.kubernetes.io/version")
            if version and tags and version not in tags:
                findings.append(f"{what}: {place} app.kubernetes.io/version {version} is not the "
                                f"image tag ({', '.join(sorted(tags))})")
        selectors = [spec.get("selector"), spec.get("podSelector")]
        for selector in filter(None, selectors):
            keys = set(selector.get("matchLabels", selector))
            if not keys or keys - SELECTOR_LABELS:
                findings.append(f"{what}: selector on {sorted(keys)}; select by "
                                f"{sorted(SELECTOR_LABELS)} only (stable across releases)")
    return findings


def check_network_policy(by_kind, findings):
    """Every container port reachable, none from everywhere; the metrics port (plain HTTP) only
    from a namespace."""
    pods = [(d, d.body["spec"]["template"]["metadata"]["labels"])
            for d in by_kind.get("Deployment", [])]
    for d, labels in pods:
        policies = [n for n in by_kind.get("NetworkPolicy", [])
                    if selects(n.body["spec"]["podSelector"]["matchLabels"], labels)]
        if not policies:
            findings.append(f"{d.where}: no NetworkPolicy selects its pods (/metrics is open)")
        rules = [r for n in policies for r in n.body["spec"]["ingress"]]
        for c in containers(d):
            for port in c.get("ports", []):
                admitting = [r for r in rules if any(p["port"] in (port["name"],
                                                                   port["containerPort"])
                                                     for p in r["ports"])]
                if not admitting:
                    findings.append(f"{d.where}: no NetworkPolicy admits port {port['name']}")
                if port["name"] == "metrics" and any(not r.get("from") for r in admitting):
                    findings.append(f"{d.where}: a NetworkPolicy admits the metrics port from "
                                    f"anywhere; only the monitoring namespace may scrape it")
                elif any(not r.get("from") for r in admitting):
                    findings.append(f"{d.where}: a NetworkPolicy admits port {port['name']} from "
                                    f"every namespace; admit labelled namespaces or pods only")
                if port["name"] == "metrics" and any(
                        "namespaceSelector" not in peer for r in admitting
                        for peer in r.get("from", [])):
                    findings.append(f"{d.where}: the metrics port is admitted from a peer without "
                                    f"a namespaceSelector (only the monitoring namespace)")


def served_metrics():
    """Metric names the server registers (server/**/*.cc)."""
    exported = set()
    for source in (ROOT / "server").rglob("*.cc"):
        exported |= set(re.findall(r'Add(?:Gauge|Counter|Histogram)\(\s*"(\w+)"',
                                   source.read_text()))
    return exported


def adapted_metrics(by_kind):
    """Metrics the prometheus-adapter configurations (a ConfigMap's config.yaml) of this build
    serve through the custom metrics API."""
    adapted = set()
    for config_map in by_kind.get("ConfigMap", []):
        config = yaml.safe_load(config_map.body["data"].get("config.yaml", "")) or {}
        adapted |= {rule.get("name", {}).get("as") for rule in config.get("rules", [])}
    return adapted


def check_hpa_metrics(by_kind, findings):
    exported, adapted = served_metrics(), adapted_metrics(by_kind)
    for h in by_kind.get("HorizontalPodAutoscaler", []):
        for metric in h.body["spec"]["metrics"]:
            if metric["type"] != "Pods":
                continue
            name = metric["pods"]["metric"]["name"]
            if name not in exported:
                findings.append(f"{h.where}: Pods metric {name} is no metric the server exports")
            if name not in adapted:
                findings.append(f"{h.where}: Pods metric {name} is served by no "
                                f"prometheus-adapter config (ConfigMap config.yaml) of this build: "
                                f"the HPA would never scale down")


def check_tls(by_kind, findings):
    """TLS flags consistent, their files in a mounted cert-manager Secret, probes that work on a
    TLS port; --trusted_proxies set where a Gateway proxies the calls."""
    issued = {c.body["spec"]["secretName"] for c in by_kind.get("Certificate", [])}
    for d in by_kind.get("Deployment", []):
        pod = d.body["spec"]["template"]["spec"]
        secrets = {v["name"]: v["secret"]["secretName"] for v in pod.get("volumes", [])
                   if "secret" in v}
        for c in containers(d):
            cw = f"{d.where} container {c['name']}"
            args = c.get("args", [])
            tls = {name: flag(args, name) for name in ("tls_cert", "tls_key", "tls_client_ca")}
            if "--plaintext" in args and any(tls.values()):
                findings.append(f"{cw}: --plaintext beside TLS flags")
            if "--plaintext" not in args and not (tls["tls_cert"] and tls["tls_key"]):
                findings.append(f"{cw}: neither --plaintext nor --tls_cert and --tls_key (the "
                                f"server refuses to start)")
            if (by_kind.get("Gateway") or by_kind.get("GRPCRoute")) and not flag(
                    args, "trusted_proxies"):
                findings.append(f"{cw}: behind a Gateway without --trusted_proxies: every client "
                                f"host counts as the Gateway's proxy")
            if not any(tls.values()):
                continue
            for probe in ("readinessProbe", "livenessProbe", "startupProbe"):
                if "grpc" in c.get(probe, {}):
                    findings.append(f"{cw}: {probe} is a gRPC probe on a TLS port (the kubelet's "
                                    f"gRPC probe speaks plaintext only: use tcpSocket)")
            for name, file in tls.items():
                if not file:
                    continue
                mount = next((m for m in c.get("volumeMounts", [])
                              if file.startswith(m["mountPath"].rstrip("/") + "/")), None)
                if mount is None or mount["name"] not in secrets:
                    findings.append(f"{cw}: --{name}={file} lies in no mounted Secret")
                elif secrets[mount["name"]] not in issued:
                    findings.append(f"{cw}: --{name}: Secret {secrets[mount['name']]} is issued "
                                    f"by no cert-manager Certificate of this build")


def of_kind(bodies, kind):
    return [b for b in bodies if b.get("kind") == kind]


def pod_tls(deployment, certificates):
    """(whether the pods serve TLS, the dnsNames of the Certificate whose Secret holds their
    --tls_cert). `certificates`: {secretName: Certificate} of the build."""
    pod = deployment["spec"]["template"]["spec"]
    secrets = {v["name"]: v["secret"]["secretName"] for v in pod.get("volumes", [])
               if "secret" in v}
    for c in pod.get("containers", []):
        cert = flag(c.get("args", []), "tls_cert")
        if cert:
            mount = next((m for m in c.get("volumeMounts", [])
                          if cert.startswith(m["mountPath"].rstrip("/") + "/")), None)
            issued = certificates.get(secrets.get(mount["name"])) if mount else None
            return True, set(issued["spec"].get("dnsNames", [])) if issued else set()
    return False, set()


def covers(names, hostname):
    return hostname in names or any(n.startswith("*.") and "." in hostname and
                                    hostname.split(".", 1)[1] == n[2:] for n in names)


def gateway_tls_findings(bodies):
    """Both legs of a Gateway, on plain manifests (this build's, or kubectl's output): the
    client's leg terminates TLS on every listener, with a certificate for the listener's
    hostname where a Certificate of the build issues it; the leg to the pods is TLS, verified,
    wherever the pods serve TLS (a BackendTLSPolicy on the Service, no kubernetes.io/h2c claim),
    and a BackendTLSPolicy only targets such a Service, with a CA and a hostname among the
    dnsNames of the pods' Certificate."""
    findings = []
    certificates = {c["spec"]["secretName"]: c for c in of_kind(bodies, "Certificate")}
    services = {s["metadata"]["name"]: s for s in of_kind(bodies, "Service")}
    config_maps = {c["metadata"]["name"]: c for c in of_kind(bodies, "ConfigMap")}

    def tls_pods(service):
        """The dnsNames of the certificates of the TLS pods the Service selects, None if it
        selects no pods that serve TLS."""
        names, tls = set(), False
        for d in of_kind(bodies, "Deployment"):
            if selects(service["spec"]["selector"],
                       d["spec"]["template"]["metadata"].get("labels", {})):
                serves, dns = pod_tls(d, certificates)
                tls, names = tls or serves, names | dns
        return names if tls else None

    for g in of_kind(bodies, "Gateway"):
        for listener in g["spec"]["listeners"]:
            what = f"Gateway/{g['metadata']['name']}: listener {listener['name']}"
            refs = listener.get("tls", {}).get("certificateRefs", [])
            if listener["protocol"] not in ("HTTPS", "TLS") or not refs or listener.get(
                    "tls", {}).get("mode", "Terminate") != "Terminate":
                findings.append(f"{what} does not terminate TLS with a certificate "
                                f"(protocol HTTPS, tls.mode Terminate, certificateRefs): the "
                                f"MES's calls would cross the network in plaintext")
            for ref in refs:
                issued = certificates.get(ref["name"]) if ref.get("kind", "Secret") == \
                    "Secret" else None
                if issued and "hostname" in listener and not covers(
                        issued["spec"].get("dnsNames", []), listener["hostname"]):
                    findings.append(f"{what}: Certificate/{issued['metadata']['name']} issues "
                                    f"{ref['name']} for {issued['spec'].get('dnsNames', [])}, "
                                    f"not the listener's hostname {listener['hostname']}")
    policies = of_kind(bodies, "BackendTLSPolicy")
    protected = {ref["name"] for p in policies for ref in p["spec"]["targetRefs"]
                 if ref["kind"] == "Service" and ref["group"] == ""}
    routed = {ref["name"] for r in of_kind(bodies, "GRPCRoute") for rule in r["spec"]["rules"]
              for ref in rule["backendRefs"]}
    for name, service in services.items():
        if tls_pods(service) is None:
            continue
        if name in routed and name not in protected:
            findings.append(f"Service/{name}: a GRPCRoute sends calls to it, its pods serve TLS, "
                            f"and no BackendTLSPolicy targets it: the Gateway would speak "
                            f"cleartext to a TLS port")
        for port in service["spec"]["ports"]:
            if port.get("appProtocol") == "kubernetes.io/h2c":
                findings.append(f"Service/{name}: port {port['name']} claims kubernetes.io/h2c "
                                f"(HTTP/2 in cleartext) for pods that serve TLS")
    for p in policies:
        what = f"BackendTLSPolicy/{p['metadata']['name']}"
        validation = p["spec"]["validation"]
        for ref in p["spec"]["targetRefs"]:
            service = services.get(ref["name"]) if (ref["kind"], ref["group"]) == (
                "Service", "") else None
            names = tls_pods(service) if service else None
            if service is None:
                findings.append(f"{what}: target {ref['kind']}/{ref['name']} is no Service here")
            elif names is None:
                findings.append(f"{what}: Service/{ref['name']}'s pods serve no TLS: the "
                                f"Gateway's handshake with them fails")
            elif validation["hostname"] not in names:
                findings.append(f"{what}: hostname {validation['hostname']} is no dnsName of the "
                                f"pods' Certificate ({', '.join(sorted(names)) or 'none'}): the "
                                f"Gateway refuses their certificate")
        refs = validation.get("caCertificateRefs", [])
        if bool(refs) == bool(validation.get("wellKnownCACertificates")):
            findings.append(f"{what}: needs either caCertificateRefs or wellKnownCACertificates")
        for ref in refs:
            if (ref["kind"], ref["group"]) != ("ConfigMap", "") or "ca.crt" not in config_maps.get(
                    ref["name"], {}).get("data", {}):
                findings.append(f"{what}: CA {ref['kind']}/{ref['name']} is no ConfigMap of "
                                f"this build with a ca.crt")
    return findings


def external_tls_purpose(bodies):
    """What overlays/external-tls is for: a Gateway and GRPCRoute whose listeners present a
    certificate cert-manager issues, pods that serve TLS (--tls_cert and --tls_key, no
    --plaintext), and a BackendTLSPolicy. How they fit (the policy on the routed Service, its
    hostname and CA, no h2c) is gateway_tls_findings', which every build passes."""
    findings = [f"renders no {kind}" for kind in ("Gateway", "GRPCRoute", "BackendTLSPolicy")
                if not of_kind(bodies, kind)]
    issued = {c["spec"]["secretName"] for c in of_kind(bodies, "Certificate")}
    for g in of_kind(bodies, "Gateway"):
        for listener in g["spec"]["listeners"]:
            if not any(ref["name"] in issued
                       for ref in listener.get("tls", {}).get("certificateRefs", [])):
                findings.append(f"Gateway/{g['metadata']['name']}: listener {listener['name']} "
                                f"has no certificateRef to a Secret a cert-manager Certificate "
                                f"of the build issues")
    args = [a for d in of_kind(bodies, "Deployment")
            for c in d["spec"]["template"]["spec"]["containers"] for a in c.get("args", [])]
    if not (flag(args, "tls_cert") and flag(args, "tls_key")) or "--plaintext" in args:
        findings.append("the server does not serve TLS (--tls_cert, --tls_key, no --plaintext)")
    return findings


# What a target must render beyond the rules every build keeps: {overlay directory: check}.
PURPOSES = {"deploy/kubernetes/overlays/external-tls": external_tls_purpose}


def alert_findings(groups, runbook_anchors):
    """Each alert: severity critical or warning, a runbook_url into an existing heading of
    docs/deployment.md."""
    findings = []
    for group in groups:
        for rule in group["rules"]:
            if "alert" not in rule:
                continue
            where = f"deploy/prometheus/alerts.yml: {rule['alert']}"
            severity = rule.get("labels", {}).get("severity")
            if severity not in SEVERITIES:
                findings.append(f"{where}: severity {severity!r}, not one of "
                                f"{', '.join(sorted(SEVERITIES))}")
            url = rule.get("annotations", {}).get("runbook_url", "")
            m = RUNBOOK.fullmatch(url)
            if not m:
                findings.append(f"{where}: runbook_url {url!r} is not "
                                f"https://HOST/docs/deployment.md#ANCHOR")
            elif m.group(1) not in runbook_anchors:
                findings.append(f"{where}: runbook_url anchor #{m.group(1)} is no heading of "
                                f"docs/deployment.md")
    return findings


def check(objects, purpose=None, target=""):
    """Every rule on one build's objects, and `purpose` (PURPOSES): what `target` must
    render."""
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
    check_network_policy(by_kind, findings)
    check_hpa_metrics(by_kind, findings)
    check_tls(by_kind, findings)
    bodies = [strip_private(o.body) for o in objects]
    findings += located(objects, label_findings(bodies) + gateway_tls_findings(bodies))
    return findings + [f"{target}: {line}" for line in (purpose(bodies) if purpose else [])]


def located(objects, lines):
    """Lines "Kind/name: ..." prefixed with the file the object comes from."""
    sources = {f"{o.body['kind']}/{o.body['metadata']['name']}": o.source for o in objects}
    return [f"{sources.get(line.split(':')[0], 'build')}: {line}" for line in lines]


def judge(directory, objects):
    """check(), with what the target is for (PURPOSES)."""
    return check(objects, PURPOSES.get(rel(directory)), rel(directory))


def strip_private(value):
    if isinstance(value, dict):
        return {k: strip_private(v) for k, v in value.items() if not k.startswith("_")}
    if isinstance(value, list):
        return [strip_private(v) for v in value]
    return value


BASE = KUBERNETES / "base"


def targets():
    return [BASE] + sorted(p.parent for p in (KUBERNETES / "overlays").glob("*/kustomization.yaml"))


def alert_groups():
    return yaml.safe_load((DEPLOY / "prometheus" / "alerts.yml").read_text())["groups"]


def release_findings(version, dockerfile, compose):
    """The container carries the release: the Dockerfile's ARG VERSION (its
    org.opencontainers.image.version label), the compose file's image tag and build arg."""
    findings = []
    arg = re.search(r"^ARG VERSION=(\S*)$", dockerfile, re.M)
    if (arg[1] if arg else None) != version:
        findings.append(f"Dockerfile: ARG VERSION={arg[1] if arg else '(none)'} is not the "
                        f"project version {version}")
    if 'org.opencontainers.image.version="${VERSION}"' not in dockerfile:
        findings.append("Dockerfile: no LABEL org.opencontainers.image.version=\"${VERSION}\"")
    service = compose["services"]["scanprep"]
    if service.get("image", "").rsplit(":", 1)[-1] != version:
        findings.append(f"deploy/docker-compose.yml: image {service.get('image')} is not tagged "
                        f"with the project version {version}")
    if service.get("build", {}).get("args", {}).get("VERSION") != version:
        findings.append(f"deploy/docker-compose.yml: build arg VERSION is not {version}")
    return findings


def release_files():
    return ((ROOT / "Dockerfile").read_text(),
            yaml.safe_load((DEPLOY / "docker-compose.yml").read_text()))


def check_all():
    findings = alert_findings(alert_groups(), anchors(RUNBOOKS))
    findings += release_findings(VERSION, *release_files())
    for directory in targets():
        build_findings = []
        objects = build(directory, build_findings)
        findings += build_findings + judge(directory, objects) + kubectl_findings(directory,
                                                                                  objects)
    return findings


# --- self-test: every rule can fail ------------------------------------------------------------
def first(objects, kind):
    return next(o for o in objects if o.body["kind"] == kind)


def named(objects, kind, name):
    return next(o for o in objects if o.body["kind"] == kind and o.body["metadata"]["name"] == name)


def container(objects):
    return containers(first(objects, "Deployment"))[0]


def set_arg(objects, name, value):
    c = container(objects)
    c["args"] = [a for a in c["args"] if not a.startswith(f"--{name}=")] + [f"--{name}={value}"]


def set_release(objects, version):
    """Another version everywhere in the build (image tag and labels), not in CMakeLists.txt."""
    c = container(objects)
    c["image"] = c["image"].rsplit(":", 1)[0] + f":{version}"
    for o in objects:
        for place in (o.body, o.body.get("spec", {}).get("template", {})):
            labels = place.get("metadata", {}).get("labels", {})
            if "app.kubernetes.io/version" in labels:
                labels["app.kubernetes.io/version"] = version


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
    "HPA Pods metric without its adapter": lambda o: first(o, "HorizontalPodAutoscaler").body[
        "spec"]["metrics"].insert(0, {"type": "Pods", "pods": {
            "metric": {"name": "scanprep_jobs_queued"},
            "target": {"type": "AverageValue", "averageValue": "1"}}}),
    "pod template without a label": lambda o: first(o, "Deployment").body["spec"]["template"][
        "metadata"]["labels"].pop("app.kubernetes.io/part-of"),
    "version in a selector": lambda o: first(o, "Deployment").body["spec"]["selector"][
        "matchLabels"].update({"app.kubernetes.io/version": "0.1.0"}),
    "version label not the image tag": lambda o: first(o, "Deployment").body["metadata"][
        "labels"].update({"app.kubernetes.io/version": "0.2.0"}),
    "image tag not the project version": lambda o: set_release(o, "0.0.9"),
    "metrics open to every namespace": lambda o: first(o, "NetworkPolicy").body["spec"][
        "ingress"][1].pop("from"),
    "gRPC port not admitted": lambda o: first(o, "NetworkPolicy").body["spec"]["ingress"].pop(0),
    "gRPC open to every namespace": lambda o: first(o, "NetworkPolicy").body["spec"][
        "ingress"][0].pop("from"),
    "neither plaintext nor TLS": lambda o: container(o).update(
        args=[a for a in container(o)["args"] if a != "--plaintext"]),
    "stale rules ConfigMap": lambda o: first(o, "ConfigMap").body["data"].update(
        {"alerts.yml": "groups: []\n"}),
}
OVERLAY_BREAKS = {
    "stale PrometheusRule": ("monitoring", lambda o: first(o, "PrometheusRule").body["spec"][
        "groups"][0]["rules"].pop()),
    "ServiceMonitor on a wrong port": ("monitoring", lambda o: first(o, "ServiceMonitor").body[
        "spec"]["endpoints"][0].update(port="metric")),
    "GRPCRoute to a wrong port": ("external", lambda o: first(o, "GRPCRoute").body["spec"][
        "rules"][0]["backendRefs"][0].update(port=50052)),
    "HPA on a metric nobody serves": ("monitoring", lambda o: first(
        o, "HorizontalPodAutoscaler").body["spec"]["metrics"][0]["pods"]["metric"].update(
            name="scanprep_jobs_waiting")),
    "no --trusted_proxies behind the Gateway": ("external", lambda o: container(o).update(
        args=[a for a in container(o)["args"] if not a.startswith("--trusted_proxies=")])),
    "gRPC probe on the TLS port": ("tls", lambda o: container(o).update(
        readinessProbe={"grpc": {"port": 50051}})),
    "TLS secret not mounted": ("tls", lambda o: container(o).update(
        volumeMounts=[m for m in container(o)["volumeMounts"] if m["name"] != "tls"])),
    "TLS secret no Certificate issues": ("tls", lambda o: first(o, "Certificate").body["spec"]
                                         .update(secretName="scanprep-old-tls")),
    "plaintext beside TLS": ("mtls", lambda o: container(o)["args"].append("--plaintext")),
    "no BackendTLSPolicy in front of TLS pods": ("external-tls", lambda o: o.remove(
        first(o, "BackendTLSPolicy"))),
    "BackendTLSPolicy hostname not the pods' certificate": ("external-tls", lambda o: first(
        o, "BackendTLSPolicy").body["spec"]["validation"].update(hostname="scanprep-gateway")),
    "BackendTLSPolicy on another Service": ("external-tls", lambda o: first(
        o, "BackendTLSPolicy").body["spec"]["targetRefs"][0].update(name="scanprep")),
    "BackendTLSPolicy without its CA": ("external-tls", lambda o: o.remove(
        named(o, "ConfigMap", "scanprep-backend-ca"))),
    "h2c claimed for TLS pods": ("external-tls", lambda o: named(
        o, "Service", "scanprep-gateway").body["spec"]["ports"][0].update(
            appProtocol="kubernetes.io/h2c")),
    "Gateway listener in plaintext": ("external-tls", lambda o: first(o, "Gateway").body[
        "spec"].update(listeners=[{"name": "grpc-tls", "protocol": "HTTP", "port": 80}])),
    "Gateway certificate for another name": ("external-tls", lambda o: named(
        o, "Certificate", "scanprep-gateway").body["spec"].update(dnsNames=["mes.example.com"])),
    "Gateway certificate cert-manager does not issue": ("external-tls", lambda o: o.remove(
        named(o, "Certificate", "scanprep-gateway"))),
    "pods in plaintext behind a BackendTLSPolicy": ("external-tls", lambda o: container(o).update(
        args=["--plaintext"] + [a for a in container(o)["args"] if not a.startswith("--tls_")])),
    "gRPC probe on the TLS port behind the Gateway": ("external-tls", lambda o: container(
        o).update(livenessProbe={"grpc": {"port": 50051}})),
    "no --trusted_proxies behind the re-encrypting Gateway": ("external-tls", lambda o: container(
        o).update(args=[a for a in container(o)["args"]
                        if not a.startswith("--trusted_proxies=")])),
}


def set_alert(groups, **changes):
    for key, value in changes.items():
        groups[0]["rules"][0].setdefault(key, {}).update(value)


ALERT_BREAKS = {
    "severity page": lambda g: set_alert(g, labels={"severity": "page"}),
    "runbook to a missing heading": lambda g: set_alert(g, annotations={
        "runbook_url": "https://docs.example.com/docs/deployment.md#no-such-heading"}),
    "no runbook_url": lambda g: g[0]["rules"][0]["annotations"].pop("runbook_url"),
}


def layout_findings():
    """An overlay inside its base (the layout kustomize refused for deploy/overlays/*), in a
    scratch tree: build() and, when installed, kubectl must both refuse it."""
    with tempfile.TemporaryDirectory() as scratch:
        base = pathlib.Path(scratch).resolve()
        (base / "overlay").mkdir()
        (base / "kustomization.yaml").write_text(
            "apiVersion: kustomize.config.k8s.io/v1beta1\nkind: Kustomization\nresources: []\n")
        (base / "overlay" / "kustomization.yaml").write_text(
            "apiVersion: kustomize.config.k8s.io/v1beta1\nkind: Kustomization\n"
            "resources: [..]\n")
        findings = []
        objects = build(base / "overlay", findings)
        return findings + kubectl_findings(base / "overlay", objects)


def self_test():
    failures = []
    if check_all():
        return ["the manifests themselves fail; fix them first"]
    cases = [(name, BASE, fn) for name, fn in BREAKS.items()]
    cases += [(name, KUBERNETES / "overlays" / overlay, fn)
              for name, (overlay, fn) in OVERLAY_BREAKS.items()]
    results = []
    for name, directory, fn in cases:
        objects = build(directory, [])
        fn(objects)
        results.append((name, judge(directory, objects)))
    for name, fn in ALERT_BREAKS.items():
        groups = alert_groups()
        fn(groups)
        results.append((name, alert_findings(groups, anchors(RUNBOOKS))))
    results.append(("overlay inside its base", layout_findings()))
    dockerfile, compose = release_files()
    results.append(("Dockerfile ARG VERSION not the project version", release_findings(
        VERSION, dockerfile.replace(f"ARG VERSION={VERSION}", "ARG VERSION=0.0.9"), compose)))
    compose["services"]["scanprep"]["image"] = "scanprep:latest"
    results.append(("compose image not the project version",
                    release_findings(VERSION, dockerfile, compose)))
    if shutil.which("kubectl"):  # this check's build drifting from kustomize's
        objects = build(BASE, [])
        first(objects, "Service").body["spec"]["ports"][0].update(port=50052)
        results.append(("build unlike kubectl's", kubectl_findings(BASE, objects)))
    for name, found in results:
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
        print("self-test: every break caught" if testing else
              "manifests ok: " + ", ".join(str(t.relative_to(ROOT)) for t in targets()))
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
