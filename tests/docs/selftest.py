#!/usr/bin/env python3
"""The docs checks can fail: check_docs.py run on a small tree with one planted
defect of each kind must report each one, and the same tree without them must
pass (ctest docs_check_selftest).  Usage: selftest.py GAT"""
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
CHECK = os.path.join(HERE, "check_docs.py")


def write(root, path, text):
    full = os.path.join(root, path)
    os.makedirs(os.path.dirname(full), exist_ok=True)
    with open(full, "w", encoding="utf-8") as f:
        f.write(text)


def tree(root, broken):
    write(root, "include/gatcore/real.hpp", "#pragma once\n")
    write(root, "docs/examples/ex.cpp", "int main() { return 0; }\n")
    write(root, "tests/docs/pending_paths.txt", "docs/coming.md   # another branch\n")
    write(root, "docs/other.md", "# Other\n\n## A heading\n\ntext\n")
    good = """# Page

```cpp
#include "gatcore/real.hpp"
```

See `include/gatcore/real.hpp`, [other](other.md#a-heading) and [soon](coming.md).
`gat train --epochs 3` and `gat dataset build -o x.json --seed 1`.

<!-- include: docs/examples/ex.cpp -->
```cpp
int main() { return 0; }
```

<!-- doc-test -->
```sh
gat --version > version.txt
test -s version.txt
```
"""
    bad = """
```cpp
#include "gatcore/missing.hpp"
```

`src/missing.cpp`, [gone](gone.md), [other](other.md#no-heading),
`gat train --no-such-option 1`, `gat frobnicate`.

<!-- include: docs/examples/ex.cpp -->
```cpp
int main() { return 1; }
```

<!-- doc-test -->
```sh
gat train --no-such-option 1
```
"""
    write(root, "README.md", "# Readme\n")
    write(root, "docs/page.md", good + (bad if broken else ""))


def run(mode, gat, root):
    r = subprocess.run([sys.executable, CHECK, mode, gat, root], capture_output=True, text=True)
    return r.returncode, r.stdout + r.stderr


def main():
    gat = os.path.abspath(sys.argv[1])
    failures = []
    with tempfile.TemporaryDirectory() as ok_root, tempfile.TemporaryDirectory() as bad_root:
        tree(ok_root, broken=False)
        tree(bad_root, broken=True)
        for mode in ("references", "examples"):
            rc, out = run(mode, gat, ok_root)
            if rc != 0:
                failures.append(f"{mode} failed on the clean tree:\n{out}")
        rc, out = run("references", gat, bad_root)
        expected = ["header gatcore/missing.hpp does not exist", "path src/missing.cpp does not exist",
                    "link gone.md points to nothing", "link other.md#no-heading: no such heading",
                    "gat train has no option --no-such-option", "'gat frobnicate' is not a gat command",
                    "the copy of docs/examples/ex.cpp differs"]
        if rc == 0:
            failures.append("references passed on the broken tree")
        failures += [f"references did not report: {e}\n{out}" for e in expected if e not in out]
        rc, out = run("examples", gat, bad_root)
        if rc == 0 or "FAILED: docs/page.md" not in out:
            failures.append(f"examples did not fail on a failing block:\n{out}")
        write(bad_root, "docs/coming.md", "# Now here\n")
        rc, out = run("references", gat, bad_root)
        if "docs/coming.md exists now" not in out:
            failures.append(f"a pending path that exists was not reported:\n{out}")
    for f in failures:
        print("FAILED:", f)
    print("docs check self-test:", "failed" if failures else "ok")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
