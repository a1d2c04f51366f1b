#!/usr/bin/env python3
"""Lint of the tests themselves, a ctest (Lint.tests).

Fails on:
- GTEST_SKIP outside tests/skip.h (every skip goes through ROCKLAB_SKIP,
  which fails under CI=true), and pytest/unittest skips in Python tests;
- a fixed sleep followed by an expectation: sleep_for / sleep_until /
  usleep / sleep( not inside a loop (a polling loop waits for a condition)
  with an EXPECT_/ASSERT_ within the next 6 lines. A sleep that only makes
  host time pass (a lower bound a loaded machine can only lengthen: "a
  stale threshold of 50 ms, then 300 ms without data") says so on its line
  or the line above with `lint: sleep-ok` and why;
- a file written under a fixed name in the working directory:
  std::ofstream / fopen of a bare string literal (no folder), or a path
  variable set to a bare file name ("x.bin"), outside tests/scratch.h's
  ScratchDir (a name never opened says `lint: name-ok` and why).

Usage: lint_tests.py [TESTS_DIR]   (default: the folder of this script)
"""

import os
import re
import sys

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else here

SLEEP = re.compile(r"\b(sleep_for|sleep_until|usleep|nanosleep)\s*\(|(?<![\w.])sleep\s*\(\s*\d")
EXPECT = re.compile(r"\b(EXPECT_|ASSERT_)\w*\s*\(")
LOOP = re.compile(r"^\s*(\}\s*)?(while|for|do)\b")
FIXED_NAME = re.compile(r"(std::ofstream|std::ifstream|fopen)\s*\w*\s*\(\s*\"[^\"/]+\"|"
                        r"=\s*\"[\w.-]+\.(bin|csv|lcm|h5|hdf5|mat|json|txt|toml|svg|png|log|lvm)\"\s*;")
OK = "lint: sleep-ok"
NAME_OK = "lint: name-ok"  # a name that is never opened (an option checked, say), and why


def indent(line):
    return len(line) - len(line.lstrip())


def in_loop(lines, i):
    """Whether line i is in the body of a loop: the nearest line above it
    with less indentation opens a loop (while / for / do)."""
    level = indent(lines[i])
    for j in range(i - 1, max(-1, i - 40), -1):
        s = lines[j]
        if not s.strip():
            continue
        if indent(s) < level:
            return bool(LOOP.match(s)) or bool(re.search(r"\b(while|for)\s*\(", s))
    return False


def lint_cpp(path, rel, problems):
    lines = open(path, encoding="utf-8", errors="replace").read().split("\n")
    for i, line in enumerate(lines):
        code = line.split("//")[0]
        if "GTEST_SKIP" in code and rel != "skip.h":
            problems.append(f"{rel}:{i + 1}: GTEST_SKIP outside tests/skip.h: use ROCKLAB_SKIP(reason)")
        if SLEEP.search(code):
            if OK in line or (i > 0 and OK in lines[i - 1]) or in_loop(lines, i):
                continue
            for k in range(i + 1, min(len(lines), i + 7)):
                if EXPECT.search(lines[k].split("//")[0]):
                    problems.append(f"{rel}:{i + 1}: a fixed sleep followed by an expectation (line {k + 1}): "
                                    f"wait for a condition with a deadline (test::WaitUntil), or mark a "
                                    f"lower bound of host time with '{OK}: why'")
                    break
        if FIXED_NAME.search(code) and "ScratchDir" not in code and NAME_OK not in line:
            problems.append(f"{rel}:{i + 1}: a fixed file name in the working directory: "
                            f"write under test::ScratchDir (tests/scratch.h)")


def lint_py(path, rel, problems):
    for i, line in enumerate(open(path, encoding="utf-8", errors="replace")):
        if re.search(r"\bpytest\.skip\b|\bpytest\.mark\.skip|\bunittest\.skip|\bskipTest\(", line):
            problems.append(f"{rel}:{i + 1}: a Python skip: exit 77 through a skip() that fails under CI=true")


def main():
    problems = []
    files = 0
    for d, dirs, names in os.walk(root):
        dirs[:] = [x for x in dirs if x not in ("corpus", "golden", "__pycache__")]
        for n in sorted(names):
            path = os.path.join(d, n)
            rel = os.path.relpath(path, root)
            if rel == os.path.relpath(os.path.abspath(__file__), root):
                continue
            if n.endswith((".cpp", ".h", ".cc", ".hpp")):
                files += 1
                lint_cpp(path, rel, problems)
            elif n.endswith(".py"):
                files += 1
                lint_py(path, rel, problems)
    for p in problems:
        print(p)
    print(f"lint of {files} test files under {root}: {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
