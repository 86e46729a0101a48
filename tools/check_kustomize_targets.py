#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Builds every kustomize target the docs name with the real `kubectl kustomize`, as a reader
would run it: each `kubectl apply -k DIR` / `kubectl kustomize DIR` in README.md, docs/*.md and
the comments of deploy/**/kustomization.yaml, plus every kustomization under deploy/ (an
undocumented one must build too). A target fails when kubectl fails (e.g. "cycle detected" for an
overlay inside its base) or when an object it renders lacks the recommended labels
(tools/check_manifests.py: label_findings). Exit 0 all built, 1 with one line per failure, 77
(ctest SKIP_RETURN_CODE) when kubectl is not installed."""
import pathlib
import re
import shutil
import sys

import yaml

from check_manifests import kustomize, label_findings

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


def build(directory, where):
    objects, error = kustomize(directory)
    if error:
        return [f"{where}: kubectl kustomize {directory.relative_to(ROOT)}: {error}"]
    if not objects:
        return [f"{where}: kubectl kustomize {directory.relative_to(ROOT)} rendered nothing"]
    return [f"{where}: {line}" for line in label_findings(objects)]


def main():
    if shutil.which("kubectl") is None:
        print("SKIP: kubectl not installed, the documented kustomize targets were not built")
        return SKIP
    if not documented_targets(ROOT):
        print("no `kubectl apply -k` target found in README.md or docs/: the pattern is stale")
        return 1
    failures = []
    for directory, where in sorted(all_targets(ROOT).items()):
        found = build(directory, where) if directory.is_dir() else [
            f"{where}: {directory.relative_to(ROOT)} is not a directory"]
        failures += found
        print(f"{'FAIL' if found else 'ok  '} {directory.relative_to(ROOT)} ({where})")
    for line in failures:
        print(line)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
