#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Keeps the front door and the manual true and short:
- README.md at most 10,000 bytes; docs/hostile-inputs.md and docs/benchmarks.md at most 15,000
  (the method, how to run, the latest table: their history belongs to git); every other
  docs/*.md at most 30,000 (past that a page serves several readers and should be split);
- no heading of README.md or docs/*.md names a date, a time of day or a change (a manual, not a
  diary);
- no body text tells history either: outside code, a date (YYYY-MM-DD) stands only right after
  "measured" ("Measured 2026-11-26 at commit …", "measured on …"), or in a row of a table with a
  "date" or "measured" column; and no phrase narrates change ("now", "no longer", "used to",
  "a turn ago", "this round", "was changed", "as before", "after issue 12", "the previous
  table", …): a page says what the software does and why, and git keeps how it got there;
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
DATE = re.compile(r"\b\d{4}-\d{2}-\d{2}\b")
# A dated figure: the date right after "measured" (the words may wrap onto the next line).
MEASURED_BEFORE = re.compile(r"\bmeasured\s+(?:on\s+)?$", re.IGNORECASE)
# Phrases that narrate how the software or its figures changed. Chosen to have no reading that
# describes what the software does: "used to" not after a form of "be" ("is used to derive"),
# "no longer" not before "than" ("a move no longer than δ"), "now" only as a word ("known").
HISTORY = re.compile("|".join([
    r"\bnow\b", r"\bago\b", r"\bno longer\b(?!\s+than)",
    r"(?<!\bis )(?<!\bare )(?<!\bwas )(?<!\bwere )(?<!\bbe )(?<!\bbeen )(?<!\bbeing )\bused to\b",
    r"\b(?:this|last|previous) (?:round|turn|session)s?\b",
    r"\b(?:was|were|has been|have been) (?:changed|added|dropped|replaced|fixed|introduced|renamed"
    r"|reverted|rewritten)\b",
    r"\b(?:before|after|since|until) (?:this|that|the) (?:change|commit|fix|merge|session)s?\b",
    r"\b(?:before|after|since|until) (?:the )?issue[- ]?\d+",
    r"\bissue[- ]?\d+(?:'s)? (?:work|merges?)\b",
    r"\bas before\b", r"\bpreviously\b", r"\bformerly\b", r"\bsince then\b", r"\buntil now\b",
    r"\b(?:earlier|previous) (?:code|runs?|tables?|versions?|figures?|commits?)\b",
    r"\bthe run before\b"]), re.IGNORECASE)
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
            m = DIARY.search(text) or HISTORY.search(text)
            if m:
                findings.append(f"{name}:{number}: heading '{text}' names a date, a time or a "
                                f"change ('{m.group(0)}'): a manual's sections say what, not when")
    return findings


def blocks(path):
    """The body outside code fences and headings, as (kind, [(line number, text)]): each
    paragraph (lines up to a blank line, a heading or a table) is one block, so a phrase or a
    "measured DATE" may wrap; each table row is its own block, kind 'row' when the table's header
    has a "date" or "measured" column, else 'table'."""
    para, table_dated, in_code, prev_is_table = [], False, False, False
    for number, line in enumerate(path.read_text().splitlines() + [""], 1):
        if FENCE.match(line):
            in_code = not in_code
        if in_code or FENCE.match(line) or not line.strip() or re.match(r"^#{1,6}\s", line) \
                or line.lstrip().startswith("|"):
            if para:
                yield "text", para
                para = []
            if not in_code and line.lstrip().startswith("|"):
                cells = [c.strip().lower() for c in line.strip().strip("|").split("|")]
                if not prev_is_table:
                    table_dated = "date" in cells or "measured" in cells
                yield ("row" if table_dated else "table"), [(number, line)]
            prev_is_table = not in_code and line.lstrip().startswith("|")
            continue
        prev_is_table = False
        para.append((number, line))


def body_findings(root, pages):
    findings = []
    for page in pages:
        name = page.relative_to(root)
        for kind, lines in blocks(page):
            text = " ".join(line for _, line in lines)
            # Code spans (they may wrap) are blanked, keeping every other character's offset.
            text = re.sub(r"`[^`]*`", lambda m: " " * len(m.group(0)), text)
            starts, offset = [], 0
            for number, line in lines:
                starts.append((offset, number))
                offset += len(line) + 1

            def line_of(pos):
                return max((s, n) for s, n in starts if s <= pos)[1]
            for m in DATE.finditer(text):
                if kind != "row" and not MEASURED_BEFORE.search(text[:m.start()]):
                    findings.append(f"{name}:{line_of(m.start())}: date {m.group(0)} outside a "
                                    "measurement: write 'Measured DATE at commit …' for a figure, "
                                    "else leave when to git")
            for m in HISTORY.finditer(text):
                findings.append(f"{name}:{line_of(m.start())}: '{m.group(0)}' narrates history: "
                                "say what the software does and why (git keeps the story)")
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
    findings += body_findings(root, pages)
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
        # Body text: each line of history.md that tells a story, one case a paragraph; beside
        # it manual.md, whose dated measurements, look-alike phrases and code must pass.
        (root / "docs" / "history.md").write_text(
            "# History\n\n"
            "Last run (2026-11-22), 60 s each.\n\n"                   # 3: a bare date
            "The result now ends with its end message.\n\n"           # 5
            "It read 6.71x a turn ago.\n\n"                           # 7
            "With the cap that used to be the default.\n\n"           # 9
            "No finding in this round.\n\n"                           # 11
            "Code of 69c0f92, after issue 12.\n\n"                    # 13
            "Components near 1e200 no\nlonger collapse.\n\n"          # 15: wrapped
            "The selector was changed in 0.1.0.\n\n"                  # 18
            "Figures as before.\n\n"                                  # 20
            "| case | seconds |\n|---|---|\n| run of 2026-11-23 | 0.41 |\n\n"  # 24: undated table
            "The figure was measured\nweekly, 2026-11-24.\n\n"        # 27: not right after
            "## What changed since then\n")                           # 29: heading
        (root / "docs" / "manual.md").write_text(
            "# Manual\n\n"
            "Measured 2026-11-26 at commit 2ff14bc on a 2-core machine; measured on\n"
            "2026-11-27 too.\n\n"
            "The median is used to derive r_g; a move no longer than δ is kept; the\n"
            "known points so far, nowhere else; seed 20261123.\n\n"
            "A command wraps: `git log --since\n2026-01-02 --now` in a code span.\n\n"
            "```\nnow 2026-01-03, as before\n```\n\n"
            "| case | date | seconds |\n|---|---|---|\n| ordinary | 2026-11-26 | 0.41 |\n\n"
            "| case | measured |\n|---|---|\n| ordinary | 0.41 s (2026-11-26) |\n")
        found = check(root)
        expected = ["README.md:1: 10", "README.md:1: link to docs/b.md",
                    "docs/a.md:5: link to #nope", "docs/benchmarks.md:1: 15001 bytes",
                    "docs/server.md:1: 30001 bytes", "docs/diary.md:5: heading",
                    "docs/history.md:3: date 2026-11-22", "docs/history.md:5: 'now'",
                    "docs/history.md:7: 'ago'", "docs/history.md:9: 'used to'",
                    "docs/history.md:11: 'this round'", "docs/history.md:13: 'after issue 12'",
                    "docs/history.md:15: 'no longer'", "docs/history.md:18: 'was changed'",
                    "docs/history.md:20: 'as before'", "docs/history.md:24: date 2026-11-23",
                    "docs/history.md:27: date 2026-11-24", "docs/history.md:29: heading"]
        failures = [e for e in expected if not any(f.startswith(e) for f in found)]
        unexpected = [f for f in found if not any(f.startswith(e) for e in expected)]
        for f in found:
            print(f"self-test finding: {f}")
        if failures or unexpected:
            return [f"self-test: not reported: {e}" for e in failures] + [
                f"self-test: reported wrongly: {f}" for f in unexpected]
    print("self-test: an oversize README, results page and page, a dated heading, a bare date and "
          "each kind of history phrase in the body, a missing file and a missing heading are "
          "reported; pages at their limits, measured dates, look-alike phrases and code are not")
    return []


def main(argv):
    findings = self_test() if argv[1:] == ["--self-test"] else check(ROOT)
    for line in findings:
        print(line)
    if not findings and argv[1:] != ["--self-test"]:
        sizes = ", ".join(f"{p.name} {len(p.read_bytes())}" for p in
                          [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md")))
        print(f"bytes: {sizes}; every page within its limit, no history in its text, every link resolves")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
