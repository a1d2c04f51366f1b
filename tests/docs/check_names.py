#!/usr/bin/env python3
"""Checks that the docs name only what exists in the code.

Usage: check_names.py SOURCE_DIR. Reads README.md, CONTRIBUTING.md and
docs/*.md and fails (exit 1, one line per problem: page:line: what) when
- a `rocklab::NAME` that is not a C++ namespace or an LCM type is not a
  CMake target (an ALIAS, an installed export name, or rocklabConfig's),
- `rocklab COMMAND` (in backticks, or a `$B COMMAND` / `rocklab COMMAND`
  line of a code block) is not a subcommand the sources register with
  add_subcommand,
- a repository path (`folder/...` of a top-level folder, or a Markdown
  link's target) does not exist,
- a test named as `Suite.Case` has no TEST/TEST_F/TEST_P(Suite, Case), or a
  ctest target `NAME_test` is not registered (rocklab_add_gtest, add_test),
- a code name in backticks (`ns::Name`, `Class::Member`, a CamelCase
  identifier such as `LiveState`) appears nowhere in the code, CMake,
  scripts or unit files;
and, the other way round, when a source file's comment points to a
`docs/PAGE.md` that does not exist, or quotes from it (`docs/PAGE.md,
"Section"`) a heading or phrase the page does not hold.
Oracle: the source tree itself, read as text; nothing is built or run.
"""
import os
import re
import sys

root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else ".")
SKIP_DIRS = {".git", "build", "node_modules"}


def files_under(exts):
    for dp, dn, fn in os.walk(root):
        dn[:] = [d for d in dn if d not in SKIP_DIRS and not d.startswith("build")]
        for n in fn:
            if n.endswith(exts) or n in exts:
                yield os.path.join(dp, n)


def read(path):
    with open(path, encoding="utf-8", errors="replace") as f:
        return f.read()


# CMake targets: aliases, installed export names, rocklabConfig's imported targets.
targets = set()
cmake_text = {p: read(p) for p in files_under((".cmake", ".cmake.in", "CMakeLists.txt"))}
renamed = set()
for text in cmake_text.values():
    targets.update(re.findall(r"add_library\(rocklab::(\w+)", text))
    m = re.search(r"foreach\(folder ([\w ]+)\)\s*\n\s*if\(TARGET rocklab_\$\{folder\}\)", text)
    if m:
        renamed.update(m.group(1).split())
for text in cmake_text.values():
    for group in re.findall(r"install\(TARGETS ([\w ]+?) EXPORT", text):
        for t in group.split():
            folder = t[len("rocklab_"):] if t.startswith("rocklab_") else None
            targets.add(folder if folder in renamed else t)
# The old names rocklabConfig keeps as aliases (foreach(rocklab_old_name ...)).
for text in cmake_text.values():
    for group in re.findall(r"foreach\(rocklab_old_name ([\w ]+)\)", text):
        targets.update("rocklab_" + n for n in group.split())

# C++ namespaces and LCM types under rocklab:: are not targets.
namespaces = set()
for p in files_under((".h", ".cpp", ".hpp")):
    namespaces.update(re.findall(r"namespace rocklab::(\w+)", read(p)))
lcm_types = {os.path.splitext(n)[0] for n in os.listdir(os.path.join(root, "lcm_types")) if n.endswith(".lcm")}

# Subcommands registered anywhere in the sources (tools/cmd_*.cpp today).
commands = set()
for p in files_under((".cpp",)):
    if os.sep + "tests" + os.sep in p:
        continue
    commands.update(re.findall(r'add_subcommand\(\s*"([\w-]+)"', read(p)))
# `rocklab help [CMD]` and `rocklab completion bash`, handled before the
# subcommands are parsed.
for word in ("help", "completion"):
    if re.search(r'first == "' + word + '"', read(os.path.join(root, "tools", "main.cpp"))):
        commands.add(word)

# Tests: GoogleTest cases and ctest names.
gtests = set()
ctest_names = set()
for p in files_under((".cpp", "CMakeLists.txt")):
    text = read(p)
    gtests.update(re.findall(r"\bTEST(?:_F|_P)?\(\s*(\w+),\s*(\w+)\)", text))
    ctest_names.update(re.findall(r"rocklab_add_gtest\((\w+)", text))
    ctest_names.update(re.findall(r"add_test\(NAME ([\w.]+)", text))
gtest_suites = {suite for suite, _ in gtests}

# Every word of the code, CMake files, scripts and unit files.
code_words = set()
for p in files_under((".h", ".cpp", ".hpp", ".py", ".pyi", ".lcm", ".cmake", ".in", ".js", ".sh",
                      ".toml", ".service", ".timer", "CMakeLists.txt")):
    code_words.update(re.findall(r"\w+", read(p)))

# Build folders (build/, build-release/, build-asan/: generated, maybe
# present) are not the source's: a path into one is not checked.
top_dirs = {d for d in os.listdir(root)
            if os.path.isdir(os.path.join(root, d)) and d not in SKIP_DIRS and not d.startswith("build")}

pages = [os.path.join(root, n) for n in ("README.md", "CONTRIBUTING.md") if os.path.exists(os.path.join(root, n))]
pages += sorted(os.path.join(root, "docs", n) for n in os.listdir(os.path.join(root, "docs")) if n.endswith(".md"))

problems = []
checked = {"targets": 0, "commands": 0, "paths": 0, "tests": 0, "names": 0}


def check_path(page, lineno, token, base):
    token = token.split("#")[0].rstrip(".,;:)")
    token = re.sub(r":\d+(-\d+)?$", "", token)  # file.cpp:58-148
    if not token or re.search(r"[*?<>{}$ ]|\.\.\.", token):
        return
    full = os.path.normpath(os.path.join(base, token))
    checked["paths"] += 1
    if not os.path.exists(full):
        problems.append(f"{os.path.relpath(page, root)}:{lineno}: no such file: {token}")


for page in pages:
    in_code = False
    for lineno, line in enumerate(read(page).split("\n"), 1):
        if line.lstrip().startswith("```"):
            in_code = not in_code
            continue
        for name in re.findall(r"rocklab::(\w+)(?!\w|::|\()", line):
            if name in namespaces or name in lcm_types or name.endswith("_t"):
                continue
            checked["targets"] += 1
            if name not in targets:
                problems.append(f"{os.path.relpath(page, root)}:{lineno}: no CMake target rocklab::{name}")
        spans = re.findall(r"`([^`]+)`", line) if not in_code else [line]
        for span in spans:
            cmd = re.match(r"\s*(?:\$B|rocklab|build/tools/rocklab)\s+([a-z][\w-]*)", span)
            if cmd and (not in_code or span.lstrip().startswith(("$B ", "rocklab "))):
                checked["commands"] += 1
                if cmd.group(1) not in commands:
                    problems.append(f"{os.path.relpath(page, root)}:{lineno}: no command rocklab {cmd.group(1)}")
            if in_code:
                continue
            tok = span.strip()
            case = re.fullmatch(r"([A-Z]\w+)\.([A-Z]\w+)", tok)
            if case and (case.group(1) in gtest_suites or case.group(1).endswith("Test")):
                checked["tests"] += 1
                if (case.group(1), case.group(2)) not in gtests:
                    problems.append(f"{os.path.relpath(page, root)}:{lineno}: no test {tok}")
            names = [w for m in re.finditer(r"\b(?:\w+::)+\w+", tok) for w in re.findall(r"\w+", m.group(0))]
            names += re.findall(r"(?<![\w.*:-])([A-Z][a-z0-9]+(?:[A-Z][a-z0-9]*)+)(?![\w.*:-])", tok)
            for w in names:
                checked["names"] += 1
                if w not in code_words:
                    problems.append(f"{os.path.relpath(page, root)}:{lineno}: no such name in the code: {w} (in `{tok}`)")
            if re.fullmatch(r"[a-z][a-z0-9_]*_test", tok):
                checked["tests"] += 1
                if tok not in ctest_names:
                    problems.append(f"{os.path.relpath(page, root)}:{lineno}: no ctest target {tok}")
            first = tok.split("/")[0]
            if "/" in tok and first in top_dirs and " " not in tok:
                check_path(page, lineno, tok, root)
        if not in_code:
            for target in re.findall(r"\]\(([^)\s]+)\)", line):
                if re.match(r"[a-z]+:", target) or target.startswith("#"):
                    continue
                check_path(page, lineno, target, os.path.dirname(page))

# Pointers from the code to the docs.
def flat(text):
    return re.sub(r"\s+", " ", re.sub(r"[`*]", "", text)).lower()

doc_text = {os.path.basename(p): flat(read(p)) for p in pages if os.sep + "docs" + os.sep in p}
checked["pointers"] = 0
errata_page = read(os.path.join(root, "docs", "errata.md"))
for p in files_under((".h", ".cpp", ".hpp", ".py", ".sh", ".cmake", "CMakeLists.txt")):
    if os.path.samefile(p, __file__):
        continue
    text = read(p)
    for m in re.finditer(r'docs/([\w-]+\.md)(?:,? \(?"([^"]+)")?', text):
        checked["pointers"] += 1
        line = text.count("\n", 0, m.start()) + 1
        where = f"{os.path.relpath(p, root)}:{line}"
        page, quote = m.group(1), m.group(2)
        if page not in doc_text:
            problems.append(f"{where}: no such page docs/{page}")
        elif quote:
            quote = flat(re.sub(r"\s*\n\s*(//+|#)?", " ", quote)).rstrip(".,:; ")
            if quote not in doc_text[page]:
                problems.append(f'{where}: docs/{page} holds no "{quote}"')
    for m in re.finditer(r"docs/errata\.md items? (\d+)(?:(?:-|, | and )(\d+))*", text):
        for n in re.findall(r"\d+", m.group(0)[len("docs/errata.md"):]):
            checked["pointers"] += 1
            if f'<a id="item-{n}"></a>' not in errata_page:
                line = text.count("\n", 0, m.start()) + 1
                problems.append(f"{os.path.relpath(p, root)}:{line}: docs/errata.md has no item {n}")

print(f"checked {len(pages)} pages: {checked['targets']} targets, "
      f"{checked['commands']} commands, {checked['paths']} paths, {checked['tests']} tests, "
      f"{checked['names']} code names; {checked['pointers']} pointers from the code")
for p in problems:
    print(p)
sys.exit(1 if problems else 0)
