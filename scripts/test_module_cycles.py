#!/usr/bin/env python3
"""Tests scripts/module_cycles.py on synthetic crates: a cycle through a
`use` is found, one only in comments or tests is not, a clean crate passes."""
import os
import subprocess
import sys
import tempfile

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "module_cycles.py")


def crate(files):
    d = tempfile.mkdtemp()
    for name, text in files.items():
        path = os.path.join(d, name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
    return d


def run(src):
    r = subprocess.run([sys.executable, SCRIPT, src], capture_output=True, text=True)
    return r.returncode, r.stdout


def main():
    cyc = crate({"a.rs": "use crate::b::X;\n", "b/mod.rs": "use crate::c::Y;\n", "c.rs": "pub use crate::a::Z;\n"})
    code, out = run(cyc)
    assert code == 1 and "a -> b -> c -> a" in out, out
    quiet = crate({
        "a.rs": "use crate::b::X;\n",
        "b.rs": "/// see [`crate::a`]\n// crate::a too\n#[cfg(test)]\nmod tests { use crate::a::Z; }\n",
    })
    code, out = run(quiet)
    assert code == 0, out
    print("module_cycles: 2 checks passed")


if __name__ == "__main__":
    main()
