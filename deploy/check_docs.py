#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Keeps the front door and the manual true: README.md at most 10,000 bytes, and every relative
Markdown link in README.md and docs/*.md pointing at a file that exists and, with a #anchor, at
a heading of that file (GitHub's slugs). Exit 1 with "file:line: message" per broken link.
--self-test writes a small tree with a broken link, a broken anchor and an oversize README and
requires each to be reported (the check can fail)."""
import pathlib
import re
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
README_LIMIT = 10_000
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^```")


def slug(heading):
    """GitHub's anchor for a heading: lower case, punctuation dropped (letters, digits, spaces,
    - and _ kept, in any script), spaces to hyphens."""
    text = heading.strip().lower()
    text = re.sub(r"[`*]", "", text)
    text = "".join(c for c in text if c.isalnum() or c in " -_")
    return text.replace(" ", "-")


def anchors(path):
    found, counts = set(), {}
    in_code = False
    for line in path.read_text().splitlines():
        if FENCE.match(line):
            in_code = not in_code
        m = None if in_code else re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if m:
            base = slug(m.group(1))
            n = counts.get(base, 0)
            counts[base] = n + 1
            found.add(base if n == 0 else f"{base}-{n}")
    return found


def links(path):
    in_code = False
    for number, line in enumerate(path.read_text().splitlines(), 1):
        if FENCE.match(line):
            in_code = not in_code
            continue
        if in_code:
            continue
        line = re.sub(r"`[^`]*`", "", line)  # code spans are not links
        for m in LINK.finditer(line):
            yield number, m.group(1)


def check(root):
    findings = []
    readme = root / "README.md"
    if not readme.exists():
        return [f"{readme}: missing"]
    size = len(readme.read_bytes())
    if size > README_LIMIT:
        findings.append(f"README.md:1: {size} bytes, more than {README_LIMIT}: move detail to docs/")
    for page in [readme] + sorted((root / "docs").glob("*.md")):
        name = page.relative_to(root)
        for number, target in links(page):
            if re.match(r"^[a-z]+:", target):  # http:, https:, mailto:
                continue
            file_part, _, anchor = target.partition("#")
            dest = (page.parent / file_part).resolve() if file_part else page
            if not dest.exists():
                findings.append(f"{name}:{number}: link to {target}: {file_part} does not exist")
            elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                findings.append(f"{name}:{number}: link to {target}: no heading "
                                f"'#{anchor}' in {dest.relative_to(root)}")
    return findings


def self_test():
    with tempfile.TemporaryDirectory() as tmp:
        root = pathlib.Path(tmp)
        (root / "docs").mkdir()
        (root / "docs" / "a.md").write_text("# A page\n\n## Föö bar (baz)\n\n[ok](#föö-bar-baz) "
                                            "[up](../README.md) [bad anchor](#nope)\n")
        (root / "README.md").write_text("[ok](docs/a.md#a-page) [missing](docs/b.md)\n" +
                                        "x" * README_LIMIT)
        found = check(root)
        expected = ["README.md:1: 10", "README.md:1: link to docs/b.md",
                    "docs/a.md:5: link to #nope"]
        failures = [e for e in expected if not any(f.startswith(e) for f in found)]
        unexpected = [f for f in found if not any(f.startswith(e) for e in expected)]
        for f in found:
            print(f"self-test finding: {f}")
        if failures or unexpected:
            return [f"self-test: not reported: {e}" for e in failures] + [
                f"self-test: reported wrongly: {f}" for f in unexpected]
    print("self-test: an oversize README, a missing file and a missing heading are reported")
    return []


def main(argv):
    findings = self_test() if argv[1:] == ["--self-test"] else check(ROOT)
    for line in findings:
        print(line)
    if not findings and argv[1:] != ["--self-test"]:
        print(f"README.md {len((ROOT / 'README.md').read_bytes())} bytes; every link resolves")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
