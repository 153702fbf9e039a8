#!/usr/bin/env python3
"""Every document a message cites exists, and so does the section it names (issue 37).

  check_doc_refs.py SOURCE_DIR

Scans src/, apps/, include/ and python/ for `docs/NAME.md` and the form
`docs/NAME.md, "Section"`; fails (exit 1, one line each) when the file is
missing or has no heading containing the section's text. Advice that sends a
user to a page that is not there is advice that fails when followed.
"""
import re
import sys
from pathlib import Path

REF = re.compile(r'docs/([\w.-]+\.md)(?:, \\?"([^"\\]+)\\?")?')


def main(root: Path) -> int:
    problems = []
    headings = {}
    for sub in ("src", "apps", "include", "python"):
        for f in sorted((root / sub).rglob("*")):
            if f.suffix not in (".cpp", ".hpp", ".py") or not f.is_file():
                continue
            for n, line in enumerate(f.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
                for doc, section in REF.findall(line):
                    path = root / "docs" / doc
                    where = f"{f.relative_to(root)}:{n}"
                    if not path.exists():
                        problems.append(f"{where}: cites docs/{doc}, which does not exist")
                        continue
                    if section:
                        hs = headings.setdefault(doc, [h for h in path.read_text(encoding="utf-8").splitlines()
                                                        if h.startswith("#")])
                        if not any(section in h for h in hs):
                            problems.append(f'{where}: cites docs/{doc}, "{section}", a section it does not have')
    for p in problems:
        print(p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent.parent))
