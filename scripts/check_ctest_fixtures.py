#!/usr/bin/env python3
"""Checks that excluding tests from a ctest run leaves no test without the
set-up it needs: ctest does not add an excluded FIXTURES_SETUP test back, so
a test that requires its fixture would fail in that run for a reason that has
nothing to do with the code it tests.

Usage: check_ctest_fixtures.py BUILD_DIR EXCLUDE_REGEX_FILE
Exit 0 when every remaining test's fixtures have a set-up that remains;
1 naming each test and fixture that does not; 2 on bad arguments.
"""
import json
import subprocess
import sys


def props(test):
    return {p["name"]: p["value"] for p in test.get("properties", [])}


def as_list(v):
    if v is None:
        return []
    return v if isinstance(v, list) else [v]


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    build, regex_file = argv[1], argv[2]
    try:
        with open(regex_file, encoding="utf-8") as f:
            regex = f.read().strip()
    except OSError as e:
        print(f"check_ctest_fixtures: {regex_file}: {e.strerror}", file=sys.stderr)
        return 2
    if not regex:
        print(f"check_ctest_fixtures: {regex_file} is empty", file=sys.stderr)
        return 2
    run = subprocess.run(["ctest", "--test-dir", build, "--show-only=json-v1", "-E", regex],
                         capture_output=True, text=True)
    if run.returncode != 0:
        print(f"check_ctest_fixtures: ctest --show-only in {build} failed:\n{run.stderr}", file=sys.stderr)
        return 2
    tests = json.loads(run.stdout)["tests"]
    setups = set()
    for t in tests:
        setups.update(as_list(props(t).get("FIXTURES_SETUP")))
    missing = []
    for t in tests:
        for fx in as_list(props(t).get("FIXTURES_REQUIRED")):
            if fx not in setups:
                missing.append((t["name"], fx))
    for name, fx in missing:
        print(f"check_ctest_fixtures: {name} needs fixture '{fx}', whose set-up {regex_file} excludes;"
              f" exclude {name} too or keep the set-up", file=sys.stderr)
    if missing:
        return 1
    print(f"check_ctest_fixtures: {len(tests)} tests kept, every fixture they need is set up")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
