#!/usr/bin/env python3
"""Prints which top-level library modules each module of src/ imports (its `crate::` paths), so
docs/architecture.md's layer table can be checked: `python3 tools/imports.py [repo root]`."""
import collections
import glob
import re
import sys

root = sys.argv[1] if len(sys.argv) > 1 else "."
edges = collections.defaultdict(set)
for path in glob.glob(f"{root}/src/**/*.rs", recursive=True):
    rel = path[len(root) + len("/src/"):]
    if rel.startswith("bin/") or rel in ("main.rs", "lib.rs"):
        continue
    top = rel.split("/")[0].removesuffix(".rs")
    text = re.sub(r"//[^\n]*", "", open(path, encoding="utf-8").read())
    for m in re.finditer(r"crate::(\{[^}]*\}|[a-z_]+)", text):
        group = m.group(1)
        names = re.findall(r"(?:^|[{,\s])([a-z_]+)(?=::|\s*[,}]|$)", group.strip("{}")) \
            if group.startswith("{") else [group]
        edges[top].update(n for n in names if n != top)
for module in sorted(edges):
    print(f"{module:12} -> {', '.join(sorted(edges[module]))}")
