#!/usr/bin/python3
"""Runs every shell command of the documentation as written (CTest: docs_commands).

Each ```sh (or ```bash) code block of README.md and docs/*.md is run with bash
(`set -e -o pipefail`), the blocks of one page in order, in one scratch folder
per page, with `quadid` (and `build/quadid`) being the program under test.
Blocks in ``` without a language (file contents, synopses, output) are not run.

An HTML comment right before a block (blank lines between are allowed) changes it:
  <!-- doc-test: skip REASON -->      the block is not run (e.g. it takes minutes)
  <!-- doc-test: setup
  COMMANDS
  -->                                   COMMANDS run first (hidden input files, e.g. a log)
`make build` is a no-op here (the program is already built); other `make` targets
and scripts/install-deps.sh are not run: mark such blocks skipped.

Usage: run_doc_commands.py --exe build/quadid --root . [--only docs/x.md] [-v]
Exit status 0 when every block that is not skipped succeeds.
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

FENCE = re.compile(r"^```\s*([A-Za-z0-9_+-]*)\s*$")
DIRECTIVE = re.compile(r"<!--\s*doc-test:\s*(skip|setup)\b(.*?)-->", re.S)
SHELL_LANGS = {"sh", "bash", "shell", "console"}


def blocks(text):
    """Yields (line, lang, body, directive, directive_text) for each fenced block."""
    lines = text.split("\n")
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        start, lang = i, m.group(1).lower()
        j = i + 1
        while j < len(lines) and not lines[j].startswith("```"):
            j += 1
        body = "\n".join(lines[i + 1:j])
        # The directive: the last HTML comment before the block, separated from it only by blank lines.
        before = "\n".join(lines[:start]).rstrip()
        directive, dtext = None, ""
        if before.endswith("-->"):
            k = before.rfind("<!--")
            d = DIRECTIVE.fullmatch(before[k:])
            if d:
                directive, dtext = d.group(1), d.group(2).strip()
        yield start + 1, lang, body, directive, dtext
        i = j + 1


PRELUDE = r"""
set -e -o pipefail
make() {
  if [ "$#" -eq 1 ] && [ "$1" = build ]; then return 0; fi
  echo "make $*: not run by the docs test (mark the block <!-- doc-test: skip ... -->)" >&2
  return 1
}
"""


def run_page(page, root, exe, verbose):
    text = page.read_text(encoding="utf-8")
    results = []
    with tempfile.TemporaryDirectory(prefix="quadid_docs_") as tmp:
        bindir = Path(tmp) / ".bin"
        bindir.mkdir()
        (bindir / "quadid").symlink_to(exe)
        (Path(tmp) / "build").mkdir()
        (Path(tmp) / "build" / "quadid").symlink_to(exe)
        env = dict(os.environ, PATH=f"{bindir}:{os.environ.get('PATH', '')}")
        for line, lang, body, directive, dtext in blocks(text):
            if lang not in SHELL_LANGS:
                continue
            where = f"{page.relative_to(root)}:{line}"
            if directive == "skip":
                results.append((where, "SKIP", 0.0, dtext))
                continue
            script = PRELUDE + (dtext + "\n" if directive == "setup" else "") + body + "\n"
            t0 = time.monotonic()
            p = subprocess.run(["bash", "-c", script], cwd=tmp, env=env, capture_output=True, text=True)
            dt = time.monotonic() - t0
            if p.returncode == 0:
                results.append((where, "PASS", dt, ""))
                if verbose:
                    sys.stdout.write(p.stdout)
            else:
                results.append((where, "FAIL", dt, f"exit {p.returncode}\n--- block ---\n{body}\n--- stderr ---\n"
                                f"{p.stderr[-4000:]}\n--- stdout ---\n{p.stdout[-2000:]}"))
    return results


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--exe", required=True, help="the quadid program to test")
    ap.add_argument("--root", default=".", help="repository root (README.md, docs/)")
    ap.add_argument("--only", action="append", default=[], help="run only this page (repeatable)")
    ap.add_argument("-v", "--verbose", action="store_true")
    a = ap.parse_args()
    root = Path(a.root).resolve()
    exe = Path(a.exe).resolve()
    if not exe.exists():
        sys.exit(f"run_doc_commands.py: --exe {exe}: no such program")
    pages = [root / p for p in a.only] if a.only else [root / "README.md"] + sorted((root / "docs").glob("*.md"))
    failed = 0
    total = time.monotonic()
    for page in pages:
        for where, status, dt, info in run_page(page, root, exe, a.verbose):
            print(f"{status:4}  {dt:6.2f} s  {where}" + (f"  ({info})" if status == "SKIP" else ""))
            if status == "FAIL":
                failed += 1
                print(info)
    print(f"{'FAILED' if failed else 'ok'}: {failed} block(s) failed, {time.monotonic() - total:.1f} s in all")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
