#!/usr/bin/env python3
"""Import cycles between the top-level modules of each library crate.

For every `crates/*/src` (or the directories given), a module's
dependencies are the `crate::NAME` paths in its code (comments and the
`#[cfg(test)]` part left out); a module is a top-level `src/NAME.rs` or
`src/NAME/` directory. Prints each cycle and exits 1 if there is one, 0
otherwise. Usage: scripts/module_cycles.py [SRC_DIR...]
"""
import glob
import os
import re
import sys


def module_deps(src):
    """{module: set of modules it uses} for one crate's src directory."""
    deps = {}
    for path in glob.glob(os.path.join(src, "**", "*.rs"), recursive=True):
        rel = os.path.relpath(path, src).split(os.sep)
        name = rel[0][:-3] if len(rel) == 1 else rel[0]
        if name in ("lib", "main"):
            continue
        with open(path, encoding="utf-8") as f:
            text = f.read()
        cut = text.find("#[cfg(test)]")
        if cut >= 0:
            text = text[:cut]
        code = "\n".join(l for l in text.split("\n") if not l.strip().startswith("//"))
        deps.setdefault(name, set()).update(set(re.findall(r"crate::(\w+)", code)) - {name})
    return deps


def cycles(deps):
    """Every elementary cycle once, rotated to start at its least module."""
    found = set()

    def walk(node, path):
        for d in sorted(deps.get(node, ())):
            if d in path:
                c = path[path.index(d):]
                k = c.index(min(c))
                found.add(tuple(c[k:] + c[:k]))
            elif d in deps:
                walk(d, path + [d])

    for n in sorted(deps):
        walk(n, [n])
    return sorted(found)


def main(argv):
    srcs = argv[1:] or sorted(glob.glob("crates/*/src"))
    bad = 0
    for src in srcs:
        for c in cycles(module_deps(src)):
            bad += 1
            print(f"{src}: import cycle " + " -> ".join(c + (c[0],)))
    if bad == 0:
        print(f"no import cycles between modules in {len(srcs)} crates")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
