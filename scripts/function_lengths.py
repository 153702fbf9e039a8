#!/usr/bin/env python3
"""Lists C++ functions in src/ longer than a limit (issue 36: no function over 120 lines).

A function is a brace block opened at namespace scope (depth 0 outside any class body,
or inside `namespace ... {`) whose opening brace follows a `)` (after optional
qualifiers such as const, noexcept, override or a trailing return type). Lambdas and
nested blocks count toward the enclosing function, as a reader sees them. Comments,
string and character literals are blanked first so braces inside them do not count.

Usage: function_lengths.py [--limit N] DIR...   exit 1 if any function is longer.
"""
import re
import sys
from pathlib import Path


def strip(text):
    """Blanks comments and literals, keeping newlines so line numbers stay true."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i)); i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j])); i = j
        elif text.startswith('R"', i):
            m = re.match(r'R"([^(]*)\(', text[i:])
            end = text.find(")" + m.group(1) + '"', i) if m else -1
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j])); i = j
        elif c in "\"'":
            # a digit separator (1'000) is not a character literal
            if c == "'" and i > 0 and text[i - 1].isalnum() and i + 1 < n and text[i + 1].isalnum():
                out.append(" "); i += 1; continue
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            out.append(" " * (j + 1 - i)); i = j + 1
        else:
            out.append(c); i += 1
    return "".join(out)


HEAD = re.compile(r"\)\s*(const|noexcept|override|final|mutable|->\s*[\w:<>,\s&*]+|\s)*$")


def functions(text):
    """Yields (name, first_line, line_count) for each top-level function body."""
    code = strip(text)
    stack = []  # kinds of open braces: 'ns', 'class', 'fn', 'other'
    start = {}
    for i, c in enumerate(code):
        if c == "{":
            before = code[max(0, i - 400):i]
            if "fn" in stack:
                kind = "other"
            elif re.search(r"\bnamespace\b[\w:\s]*$", before) or re.search(r'extern\s*$', before):
                kind = "ns"
            elif re.search(r"\b(class|struct|union|enum)\b[^;{}()]*$", before):
                kind = "class"
            elif HEAD.search(before):
                kind = "fn"
                start[len(stack)] = i
            else:
                kind = "other"
            stack.append(kind)
        elif c == "}" and stack:
            kind = stack.pop()
            if kind == "fn":
                s = start.pop(len(stack))
                head = code[max(0, s - 400):s]
                m = re.search(r"([~\w:]+(?:operator\S*)?)\s*\([^;{}]*\)[^;{}()]*$", head)
                name = m.group(1) if m else "?"
                first = code.count("\n", 0, s) + 1
                last = code.count("\n", 0, i) + 1
                yield name, first, last - first + 1


def main(argv):
    limit, dirs = 120, []
    it = iter(argv)
    for a in it:
        if a == "--limit":
            limit = int(next(it))
        else:
            dirs.append(a)
    long_ones = []
    for d in dirs or ["src"]:
        for p in sorted(Path(d).rglob("*")):
            if p.suffix not in (".cpp", ".hpp", ".h", ".cc"):
                continue
            for name, first, count in functions(p.read_text(encoding="utf-8")):
                if count > limit:
                    long_ones.append((count, f"{p}:{first}", name))
    for count, where, name in sorted(long_ones, reverse=True):
        print(f"{where}: {name} is {count} lines (limit {limit})")
    return 1 if long_ones else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
