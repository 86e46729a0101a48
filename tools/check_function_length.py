#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""No C++ function longer than 80 lines, counted from its signature line to its closing brace: a
function past that does several things that want names of their own (issue 37).

  tools/check_function_length.py [DIR|FILE...]   default: server client core (from the root)
  tools/check_function_length.py --self-test     the check on embedded snippets (it can fail)

Exit 1 with "file:line name N lines" per function over the limit, else 0.

A brace-matching heuristic, not a parser: comments, string and character literals (raw strings
too) and preprocessor lines are blanked first; a brace at namespace or class level opens a
container (namespace, class, struct, union, enum, extern "C"), a function (its head has a
parameter list) or data (an initialiser), and everything inside a function, lambdas and local
classes included, counts as that function's."""
import os
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
DEFAULT_DIRS = ("server", "client", "core")
MAX_LINES = 80
SUFFIXES = {".cc", ".h", ".cpp", ".hpp", ".cxx", ".hh"}
CONTAINER_WORDS = {"namespace", "class", "struct", "union", "enum", "extern"}
# What may precede a container's or function's own words at the head's start.
HEAD_PREFIX = re.compile(
    r"^(?:\s+|\[\[.*?\]\]|(?:public|protected|private)\s*:(?!:)|(?:inline|export)\b)+", re.S)
# The function's name: the (qualified) identifier or operator just before its parameter list.
NAME = re.compile(r"((?:[A-Za-z_]\w*\s*::\s*)*"
                  r"(?:operator\s*(?:[^\s\w(]+|\w+)|~?[A-Za-z_]\w*))\s*(?:<[^<>()]*>)?\s*$")


def blank(text):
    """The text with comments, literals and preprocessor lines turned to spaces, newlines kept, so
    that braces in them do not count and offsets still give line numbers."""
    out = list(text)
    i, n = 0, len(text)

    def clear(start, end):
        for k in range(start, min(end, n)):
            if out[k] != "\n":
                out[k] = " "

    line_start = True
    while i < n:
        c = text[i]
        if line_start and c == "#":
            # A directive runs to the end of the line, continued by a trailing backslash.
            end = i
            while end < n and not (text[end] == "\n" and text[end - 1] != "\\"):
                end += 1
            clear(i, end)
            i = end
            continue
        if c == "\n":
            line_start = True
            i += 1
            continue
        if not c.isspace():
            line_start = False
        if text.startswith("//", i):
            end = text.find("\n", i)
            end = n if end < 0 else end
            clear(i, end)
            i = end
        elif text.startswith("/*", i):
            end = text.find("*/", i + 2)
            end = n if end < 0 else end + 2
            clear(i, end)
            i = end
        elif c == '"' and raw_string_prefix(text, i):
            delimiter = text[i + 1:text.find("(", i)]
            end = text.find(")" + delimiter + '"', i)
            end = n if end < 0 else end + len(delimiter) + 2
            clear(i, end)
            i = end
        elif c == '"' or (c == "'" and not digit_separator(text, i)):
            end = i + 1
            while end < n and text[end] != c and text[end] != "\n":
                end += 2 if text[end] == "\\" else 1
            clear(i, end + 1)
            i = end + 1
        else:
            i += 1
    return "".join(out)


def raw_string_prefix(text, quote):
    """Whether the quote at `quote` opens a raw string: R, u8R, uR, UR or LR before it, not the
    end of a longer identifier."""
    match = re.search(r"(?:u8|[uUL])?R$", text[max(0, quote - 3):quote])
    if not match:
        return False
    start = quote - len(match.group(0))
    return start == 0 or not (text[start - 1].isalnum() or text[start - 1] == "_")


def digit_separator(text, quote):
    """Whether the ' at `quote` separates digits (1'000'000) rather than opening a character
    literal (which an encoding prefix such as u8 or L may precede)."""
    start = quote
    while start > 0 and (text[start - 1].isalnum() or text[start - 1] in "_'."):
        start -= 1
    return start < quote and text[start].isdigit()


def matching(code, open_index):
    """The index of the brace that closes the one at `open_index`."""
    depth = 0
    for k in range(open_index, len(code)):
        if code[k] == "{":
            depth += 1
        elif code[k] == "}":
            depth -= 1
            if depth == 0:
                return k
    return len(code) - 1


def strip_template(head):
    """The head without its leading template<...> clauses (whose `class T` is no container)."""
    while True:
        head = HEAD_PREFIX.sub("", head)
        if not head.startswith("template"):
            return head
        depth, k = 0, len("template")
        while k < len(head):
            depth += {"<": 1, ">": -1}.get(head[k], 0)
            k += 1
            if depth == 0 and head[k - 1] == ">":
                break
        head = head[k:]


def top_level_parens(head):
    """(first '(' at depth 0, index after its matching ')', whether every '(' and '[' closes)."""
    depth, first, after = 0, -1, -1
    for k, c in enumerate(head):
        if c in "([":
            if depth == 0 and c == "(" and first < 0:
                first = k
            depth += 1
        elif c in ")]":
            depth -= 1
            if depth == 0 and first >= 0 and after < 0:
                after = k + 1
    return first, after, depth == 0


def classify(head):
    """What a brace at namespace or class level opens, by the text since the last ';', '{' or
    '}': "container", "function", "member-init" (a brace initialiser in a constructor's
    initialiser list, before the body) or "data"."""
    bare = strip_template(head)
    first_word = re.match(r"\w*", bare).group(0)
    first, after, balanced = top_level_parens(bare)
    if not balanced:
        return "data"  # a brace inside an expression's parentheses
    if first_word in CONTAINER_WORDS and (first < 0 or first_word != "extern"):
        return "container"
    if first < 0:
        return "data"
    rest = bare[after:]
    if re.search(r"(?<!:):(?!:)", rest) and re.search(r"[\w>]\s*$", rest):
        return "member-init"
    return "function"


def functions(text):
    """(line, name, lines) of every function definition in C++ source `text`."""
    code = blank(text)
    found = []
    line_of = [0] * (len(code) + 1)
    line = 1
    for k, c in enumerate(code):
        line_of[k] = line
        if c == "\n":
            line += 1
    line_of[len(code)] = line
    head_start = 0
    k = 0
    while k < len(code):
        c = code[k]
        if c in ";}":
            head_start = k + 1
        elif c == "{":
            head = code[head_start:k]
            kind = classify(head)
            if kind == "container":
                head_start = k + 1  # its members are heads of their own
            elif kind == "member-init":
                k = matching(code, k)  # the body's head goes on after the initialiser
            else:
                end = matching(code, k)
                if kind == "function":
                    found.append(describe(code, head_start, head, end, line_of))
                k = end
                head_start = k + 1
        k += 1
    return found


def describe(code, head_start, head, end, line_of):
    bare = strip_template(head)
    start = head_start + len(head) - len(bare)
    first, _, _ = top_level_parens(bare)
    match = NAME.search(bare[:first])
    name = re.sub(r"\s+", "", match.group(1)) if match else "(lambda)"
    if name.endswith("operator"):  # operator(): its first parentheses are its name's
        name += "()"
    return line_of[start], name, line_of[end] - line_of[start] + 1


def too_long(paths, limit=MAX_LINES):
    findings = []
    for path in paths:
        text = path.read_text(encoding="utf-8", errors="replace")
        for line, name, lines in functions(text):
            if lines > limit:
                findings.append(f"{os.path.relpath(path)}:{line} {name} {lines} lines")
    return findings


def sources(args):
    roots = [pathlib.Path(a) for a in args] or [ROOT / d for d in DEFAULT_DIRS]
    files = []
    for root in roots:
        if root.is_file():
            files.append(root)
        elif root.is_dir():
            files.extend(sorted(p for p in root.rglob("*") if p.suffix in SUFFIXES))
        else:
            raise SystemExit(f"check_function_length: no such file or directory: {root}")
    return files


# --- self-test: the check can fail, and does not fail what it must pass -------------------------


def body(lines):
    """A function whose definition spans exactly `lines` lines."""
    statements = "".join(f"  x += {k};\n" for k in range(lines - 3))
    return f"int Long(int x) {{\n{statements}  return x;\n}}\n"


def self_test():
    cases = {
        # (snippet, the functions expected over 80 lines)
        "81 lines": (body(81), ["Long 81"]),
        "80 lines": (body(80), []),
        "a class of many short methods": (
            "namespace a {\nclass Many {\n public:\n" +
            "".join(f"  int F{k}() const {{\n    return {k};\n  }}\n" for k in range(40)) +
            "};\n}  // namespace a\n", []),
        "braces in comments, strings and init lists": (
            "struct S {\n  S() : a_{1}, b_(\"}}\") {\n    // }\n    auto f = [] { return '}'; };\n"
            "    const char* r = R\"x(}{)x\";\n" + "".join("    a_ += 1;\n" for _ in range(76)) +
            "  }\n  int a_;\n  const char* b_;\n};\n", ["S 81"]),
        "a template, a digit separator, a table": (
            "template <class T>\nT Big(T t) {\n  t += 1'000;\n" +
            "".join("  t += 'a';\n" for _ in range(77)) + "  return t;\n}\n"
            "const int kTable[] = {\n" + "".join("  1,\n" for _ in range(90)) + "};\n",
            ["Big 81"]),
    }
    failures = []
    for title, (snippet, expected) in cases.items():
        got = [f"{name} {lines}" for _, name, lines in functions(snippet) if lines > MAX_LINES]
        if got != expected:
            failures.append(f"self-test: {title}: expected {expected}, found {got}")
    if not failures:
        print(f"self-test: {len(cases)} snippets measured as expected (81 lines fail, 80 pass)")
    return failures


def main(argv):
    if argv[1:] == ["--self-test"]:
        failures = self_test()
        for f in failures:
            print(f, file=sys.stderr)
        return 1 if failures else 0
    findings = too_long(sources(argv[1:]))
    for f in findings:
        print(f)
    if findings:
        print(f"{len(findings)} functions over {MAX_LINES} lines: split them into named steps",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
