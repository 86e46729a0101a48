#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Keeps the front door and the manual true and short:
- README.md at most 10,000 bytes; docs/hostile-inputs.md and docs/benchmarks.md at most 15,000
  (the method, how to run, the latest table: their history belongs to git); every other
  docs/*.md at most 30,000 (past that a page serves several readers and should be split);
- no heading of README.md or docs/*.md names a date or a time of day (a manual, not a diary);
- every relative Markdown link in README.md and docs/*.md points at a file that exists and, with
  a #anchor, at a heading of that file (GitHub's slugs).
Exit 1 with "file:line: message" per finding. --self-test writes a small tree that breaks each
rule once beside pages that keep them, and requires exactly those breaks to be reported (the
check can fail)."""
import pathlib
import re
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
README_LIMIT = 10_000
DOC_LIMIT = 30_000
# Pages that hold a benchmark's method and latest table, whose old runs went into the page
# before (hostile-inputs.md reached 106 KB, benchmarks.md 40 KB).
RESULT_PAGE_LIMIT = 15_000
DOC_LIMITS = {"hostile-inputs.md": RESULT_PAGE_LIMIT, "benchmarks.md": RESULT_PAGE_LIMIT}
DIARY = re.compile(r"\b(\d{4}-\d{2}-\d{2}|morning|evening|night|later|yesterday|today)\b",
                   re.IGNORECASE)
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^```")


def slug(heading):
    """GitHub's anchor for a heading: lower case, punctuation dropped (letters, digits, spaces,
    - and _ kept, in any script), spaces to hyphens."""
    text = heading.strip().lower()
    text = re.sub(r"[`*]", "", text)
    text = "".join(c for c in text if c.isalnum() or c in " -_")
    return text.replace(" ", "-")


def headings(path):
    in_code = False
    for number, line in enumerate(path.read_text().splitlines(), 1):
        if FENCE.match(line):
            in_code = not in_code
        m = None if in_code else re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if m:
            yield number, m.group(1)


def anchors(path):
    found, counts = set(), {}
    for _, text in headings(path):
        base = slug(text)
        n = counts.get(base, 0)
        counts[base] = n + 1
        found.add(base if n == 0 else f"{base}-{n}")
    return found


def size_findings(root, pages):
    findings = []
    for page in pages:
        name = page.relative_to(root)
        limit = README_LIMIT if page == root / "README.md" else DOC_LIMITS.get(page.name, DOC_LIMIT)
        size = len(page.read_bytes())
        if size > limit:
            findings.append(f"{name}:1: {size} bytes, more than {limit}: "
                            + ("move detail to docs/" if limit == README_LIMIT else
                               "keep the latest table, leave older runs to git"
                               if limit == RESULT_PAGE_LIMIT else "split it by reader"))
        for number, text in headings(page):
            m = DIARY.search(text)
            if m:
                findings.append(f"{name}:{number}: heading '{text}' names a date or time "
                                f"('{m.group(0)}'): a manual's sections say what, not when")
    return findings


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
    pages = [readme] + sorted((root / "docs").glob("*.md"))
    findings += size_findings(root, pages)
    for page in pages:
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
        # Each limit broken by one byte, and its control: a page at its limit, and a page
        # within the general limit that would break the results pages' limit.
        for name, size in [("benchmarks.md", RESULT_PAGE_LIMIT + 1),
                           ("hostile-inputs.md", RESULT_PAGE_LIMIT), ("server.md", DOC_LIMIT + 1),
                           ("cli.md", DOC_LIMIT), ("security.md", RESULT_PAGE_LIMIT + 1)]:
            (root / "docs" / name).write_text("# Page\n" + "x" * (size - len("# Page\n")))
        (root / "docs" / "diary.md").write_text("# Diary\n\n## Latest run\n\n"
                                                "## Memory (2026-11-25, evening)\n")
        found = check(root)
        expected = ["README.md:1: 10", "README.md:1: link to docs/b.md",
                    "docs/a.md:5: link to #nope", "docs/benchmarks.md:1: 15001 bytes",
                    "docs/server.md:1: 30001 bytes", "docs/diary.md:5: heading"]
        failures = [e for e in expected if not any(f.startswith(e) for f in found)]
        unexpected = [f for f in found if not any(f.startswith(e) for e in expected)]
        for f in found:
            print(f"self-test finding: {f}")
        if failures or unexpected:
            return [f"self-test: not reported: {e}" for e in failures] + [
                f"self-test: reported wrongly: {f}" for f in unexpected]
    print("self-test: an oversize README, results page and page, a dated heading, a missing file "
          "and a missing heading are reported; pages at their limits are not")
    return []


def main(argv):
    findings = self_test() if argv[1:] == ["--self-test"] else check(ROOT)
    for line in findings:
        print(line)
    if not findings and argv[1:] != ["--self-test"]:
        sizes = ", ".join(f"{p.name} {len(p.read_bytes())}" for p in
                          [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md")))
        print(f"bytes: {sizes}; every page within its limit, every link resolves")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
