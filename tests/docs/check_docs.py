#!/usr/bin/env python3
"""Checks that the user documentation matches the code (ctests docs_*).

  check_docs.py cli        GAT SRC   docs/cli.md equals what scripts/gen_cli_doc.sh writes now
  check_docs.py examples   GAT SRC   runs every ```sh block preceded by <!-- doc-test --> of the
                                     front-path pages, page by page, in a fresh temp folder with
                                     the built gat first on PATH (the blocks of a page share it)
  check_docs.py references GAT SRC   every #include "gatcore/...", repository path, relative link
                                     and `gat CMD --option` of the front-path pages exists, and
                                     every <!-- include: FILE --> block equals FILE

Front-path pages: README.md and docs/*.md (not docs/experiments/, the verbatim history).
Paths another branch is about to create are listed in tests/docs/pending_paths.txt: they are
accepted while missing, and reported once they exist so the list cannot go stale.
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

TOP_DIRS = ("include", "src", "kernels", "shaders", "tests", "tools", "examples", "scripts",
            "bench", "docs", "cmake")


def pages(src):
    out = [os.path.join(src, "README.md")]
    docs = os.path.join(src, "docs")
    out += sorted(os.path.join(docs, f) for f in os.listdir(docs) if f.endswith(".md"))
    return out


def rel(src, path):
    return os.path.relpath(path, src)


# ---------------------------------------------------------------------------------------------
def check_cli(gat, src):
    gen = os.path.join(src, "scripts", "gen_cli_doc.sh")
    now = subprocess.run(["bash", gen, gat], check=True, capture_output=True, text=True).stdout
    with open(os.path.join(src, "docs", "cli.md"), encoding="utf-8") as f:
        committed = f.read()
    if now == committed:
        print("docs/cli.md matches gat help")
        return 0
    import difflib
    sys.stdout.writelines(difflib.unified_diff(committed.splitlines(True), now.splitlines(True),
                                               "docs/cli.md (committed)", "gat help (now)"))
    print("docs/cli.md differs from the built gat's help: run "
          "bash scripts/gen_cli_doc.sh GAT docs/cli.md and commit the result")
    return 1


# ---------------------------------------------------------------------------------------------
def doc_test_blocks(text):
    """The ```sh blocks whose previous non-empty line is <!-- doc-test -->."""
    lines = text.splitlines()
    blocks, i = [], 0
    while i < len(lines):
        if lines[i].strip() == "<!-- doc-test -->":
            j = i + 1
            while j < len(lines) and not lines[j].strip():
                j += 1
            if j >= len(lines) or lines[j].strip() not in ("```sh", "```bash"):
                raise SystemExit(f"a <!-- doc-test --> marker (line {i + 1}) is not followed by a ```sh block")
            k = j + 1
            while k < len(lines) and lines[k].strip() != "```":
                k += 1
            blocks.append((j + 1, "\n".join(lines[j + 1:k])))
            i = k
        i += 1
    return blocks


def check_examples(gat, src):
    failures, ran = 0, 0
    for page in pages(src):
        with open(page, encoding="utf-8") as f:
            blocks = doc_test_blocks(f.read())
        if not blocks:
            continue
        work = tempfile.mkdtemp(prefix="gatcore-doc-")
        bindir = os.path.join(work, ".bin")
        os.mkdir(bindir)
        os.symlink(os.path.abspath(gat), os.path.join(bindir, "gat"))
        env = dict(os.environ, PATH=bindir + os.pathsep + os.environ.get("PATH", ""),
                   GATCORE_SOURCE_DIR=src)
        ok = True
        for line, code in blocks:
            ran += 1
            print(f"== {rel(src, page)}:{line}\n{code}", flush=True)
            r = subprocess.run(["bash", "-euo", "pipefail", "-c", code], cwd=work, env=env)
            if r.returncode != 0:
                print(f"FAILED: {rel(src, page)}:{line} exited {r.returncode} (in {work})", flush=True)
                failures += 1
                ok = False
                break  # later blocks of the page build on this one
        if ok:
            shutil.rmtree(work, ignore_errors=True)
    print(f"{ran} doc-test blocks run, {failures} failed")
    return 1 if failures or ran == 0 else 0


# ---------------------------------------------------------------------------------------------
def help_text(gat, cmd, cache={}):
    key = tuple(cmd)
    if key not in cache:
        r = subprocess.run([gat, "help", *cmd] if cmd else [gat, "--help"], capture_output=True, text=True)
        cache[key] = r.stdout if r.returncode == 0 else None
    return cache[key]


def subcommand_names(help_out):
    names, on = [], False
    for line in (help_out or "").splitlines():
        if line.startswith("Subcommands:"):
            on = True
        elif on and line and not line.startswith(" "):
            on = False
        elif on and re.match(r"^  [a-z]", line):
            names.append(line.split()[0])
    return names


OPTION = re.compile(r"(?<![\w-])(--[a-z][a-z0-9-]*)")
# "gat" as a command: at a word start, or as the last part of a path (build/tools/gat);
# group 1 says which, group 2 holds up to two command words, group 3 the rest of the call.
GAT_CALL = re.compile(r"(?:^|[\s`(=$]|(/))gat(?![\w.-])((?:\s+[a-z][a-z-]*){0,2})([^`|;&]*)")


def gat_calls(text):
    """(command words, the rest, whether gat stands alone) of every gat call: code lines and `spans`."""
    calls = []
    in_code = False
    pending = ""
    for line in text.splitlines():
        if line.strip().startswith("```"):
            in_code = not in_code
            continue
        if in_code:
            if line.rstrip().endswith("\\"):
                pending += line.rstrip()[:-1] + " "
                continue
            line, pending = pending + line, ""
            line = re.sub(r"\s#\s.*$", "", line)  # a trailing shell comment
            for m in GAT_CALL.finditer(line):
                calls.append((m.group(2).split(), m.group(3), m.group(1) is None))
        else:
            for span in re.findall(r"`([^`]+)`", line):
                for m in GAT_CALL.finditer(" " + span):
                    calls.append((m.group(2).split(), m.group(3), m.group(1) is None))
    return calls


def resolve(gat, words):
    """The longest prefix of words that names a gat (sub)command; None when the first does not."""
    cmd = []
    for w in words:
        if w in subcommand_names(help_text(gat, cmd)):
            cmd.append(w)
        else:
            break
    if words and not cmd and words[0] != "help":
        return None
    return cmd


def load_pending(src):
    path = os.path.join(src, "tests", "docs", "pending_paths.txt")
    out = set()
    if os.path.exists(path):
        with open(path, encoding="utf-8") as f:
            for line in f:
                line = line.split("#", 1)[0].strip()
                if line:
                    out.add(line)
    return out


def anchors(path):
    """GitHub's heading anchors of a Markdown file."""
    out, in_code = set(), False
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.strip().startswith("```"):
                in_code = not in_code
            elif not in_code and line.startswith("#"):
                title = line.lstrip("#").strip().lower()
                out.add(re.sub(r"[^\w\- ]", "", title).replace(" ", "-"))
    return out


def check_references(gat, src):
    errors, pending_used = [], set()
    pending = load_pending(src)
    for page in pages(src):
        name = rel(src, page)
        with open(page, encoding="utf-8") as f:
            text = f.read()
        if name == os.path.join("docs", "cli.md"):
            continue  # generated from gat help; docs_cli_reference checks it
        # <!-- include: PATH --> blocks hold that file verbatim
        for m in re.finditer(r"<!-- include: (\S+) -->\n```[a-z]*\n(.*?)\n```", text, re.S):
            path = os.path.join(src, m.group(1))
            if not os.path.exists(path):
                errors.append(f"{name}: included file {m.group(1)} does not exist")
                continue
            with open(path, encoding="utf-8") as f:
                if f.read().rstrip("\n") != m.group(2):
                    errors.append(f"{name}: the copy of {m.group(1)} differs from the file: paste the file again")
        # headers
        for h in sorted(set(re.findall(r'#include\s*[<"](gatcore/[^>"]+)[>"]', text))):
            if not os.path.exists(os.path.join(src, "include", h)) and f"include/{h}" not in pending:
                errors.append(f"{name}: header {h} does not exist under include/")
            elif f"include/{h}" in pending:
                pending_used.add(f"include/{h}")
        # repository paths in `code`
        for p in sorted(set(re.findall(r"`((?:%s)/[A-Za-z0-9_./+-]*)`" % "|".join(TOP_DIRS), text))):
            p = p.rstrip("/.")
            if p in pending:
                pending_used.add(p)
            elif not os.path.exists(os.path.join(src, p)):
                errors.append(f"{name}: path {p} does not exist")
        # relative links
        for target in sorted(set(re.findall(r"\]\(([^)\s]+)\)", text))):
            if re.match(r"^[a-z]+:", target):
                continue
            path = target.split("#", 1)[0] or os.path.basename(page)
            full = os.path.normpath(os.path.join(os.path.dirname(page), path))
            r = rel(src, full)
            if r in pending:
                pending_used.add(r)
            elif not os.path.exists(full):
                errors.append(f"{name}: link {target} points to nothing")
            elif "#" in target and full.endswith(".md") and target.split("#", 1)[1] not in anchors(full):
                errors.append(f"{name}: link {target}: no such heading in {r}")
        # gat commands and their options
        for words, rest, alone in gat_calls(text):
            cmd = resolve(gat, words)
            if cmd is None:
                if alone:  # a path's gat may be followed by its arguments' paths
                    errors.append(f"{name}: 'gat {' '.join(words)}' is not a gat command")
                continue
            h = help_text(gat, cmd)
            for opt in OPTION.findall(" ".join(words[len(cmd):]) + " " + rest):
                if h is None or not re.search(r"(?<![\w-])%s(?![\w-])" % re.escape(opt), h):
                    errors.append(f"{name}: gat {' '.join(cmd)} has no option {opt}")
    for p in sorted(pending):
        if os.path.exists(os.path.join(src, p)):
            errors.append(f"tests/docs/pending_paths.txt: {p} exists now: remove it from the list")
    for e in errors:
        print(e)
    unused = pending - pending_used
    for p in sorted(unused):
        print(f"note: pending path {p} is cited by no page")
    print(f"{len(errors)} broken references")
    return 1 if errors else 0


def main():
    if len(sys.argv) != 4 or sys.argv[1] not in ("cli", "examples", "references"):
        print(__doc__)
        return 2
    mode, gat, src = sys.argv[1], os.path.abspath(sys.argv[2]), os.path.abspath(sys.argv[3])
    return {"cli": check_cli, "examples": check_examples, "references": check_references}[mode](gat, src)


if __name__ == "__main__":
    sys.exit(main())
