#!/usr/bin/env python3
"""Checks the module graph against the sources and the docs (issue 36).

  check_modules.py MODULES_TXT SOURCE_DIR

MODULES_TXT is build/modules.txt, written by cmake/QuadidModules.cmake ("module: deps").
Fails (exit 1, one line per problem) when
  * a file in src/M/ (or the public header include/quadid/M.hpp, include/quadid/M/*)
    includes a quadid header of a module that M does not depend on, directly or
    through its declared dependencies: the CMake graph would then be a lie and a
    cycle could hide behind it;
  * a quadid header is included that belongs to no module;
  * docs/architecture.md's module table (rows "| `name` | deps |") differs from the
    CMake targets or their declared dependencies.
"""
import re
import sys
from pathlib import Path

INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]quadid/([\w]+)(?:\.hpp|/)', re.M)


def read_graph(path):
    graph = {}
    for line in Path(path).read_text().splitlines():
        if ":" in line:
            name, deps = line.split(":", 1)
            graph[name.strip()] = deps.split()
    return graph


def closure(graph, m, seen=None):
    seen = set() if seen is None else seen
    for d in graph.get(m, []):
        if d not in seen:
            seen.add(d)
            closure(graph, d, seen)
    return seen


def module_files(root, m):
    files = list((root / "src" / m).glob("*.[ch]pp"))
    header = root / "include" / "quadid" / f"{m}.hpp"
    if header.exists():
        files.append(header)
    files += list((root / "include" / "quadid" / m).glob("*.hpp"))
    return files


def check_includes(root, graph):
    problems = []
    for m in graph:
        allowed = closure(graph, m) | {m}
        for f in module_files(root, m):
            for used in INCLUDE.findall(f.read_text(encoding="utf-8")):
                if used == "quadid":  # the front door, only outside the library
                    problems.append(f"{f.relative_to(root)}: includes quadid/quadid.hpp; a module includes what it uses")
                elif used not in graph:
                    problems.append(f"{f.relative_to(root)}: includes quadid/{used}, which is no module")
                elif used not in allowed:
                    problems.append(f"{f.relative_to(root)}: module '{m}' includes quadid/{used} but does not "
                                    f"depend on '{used}' (src/{m}/CMakeLists.txt DEPS)")
    return problems


def check_docs(root, graph):
    doc = root / "docs" / "architecture.md"
    if not doc.exists():
        return ["docs/architecture.md is missing"]
    rows = re.findall(r"^\|\s*`(\w+)`\s*\|([^|]*)\|", doc.read_text(encoding="utf-8"), re.M)
    documented = {name: sorted(re.findall(r"\w+", deps.replace("—", ""))) for name, deps in rows}
    problems = []
    for m, deps in graph.items():
        if m not in documented:
            problems.append(f"docs/architecture.md: module '{m}' (a CMake target) is not in the module table")
        elif documented[m] != sorted(deps):
            problems.append(f"docs/architecture.md: module '{m}' lists deps {documented[m]}, CMake declares {sorted(deps)}")
    for m in documented:
        if m not in graph:
            problems.append(f"docs/architecture.md: module '{m}' is in the table but is no CMake target")
    return problems


def main(argv):
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    graph = read_graph(argv[0])
    root = Path(argv[1])
    problems = check_includes(root, graph) + check_docs(root, graph)
    for p in problems:
        print(p)
    if not problems:
        print(f"check_modules: {len(graph)} modules, includes within declared dependencies, docs match")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
