#!/usr/bin/env python3
"""Runs README.md's "A day in the lab" and docs/python.md's Python blocks.

Every ```sh block of the README's section "A day in the lab" runs in order
in one scratch folder (bash -euo pipefail, B= the build's rocklab, the
repository's data/ linked in as ./data), then its ```python blocks and
those of docs/python.md, in order, in the same folder (PYTHONPATH at the
build's module). A step that fails fails the test, naming the block's
file and line; so the documentation cannot drift from what the commands do.

The rule for blocks that cannot run here (docs/testing.md, "The README
runs"): a block is skipped only when an HTML comment right before it says
so, with the reason,

    <!-- doc-test: skip (REASON) -->

(the lab LAN's udpm bus, a server that runs until stopped, a fragment),
and a block that needs a Python module rocklab does not depend on says

    <!-- doc-test: needs MODULE[,MODULE] -->

and is skipped, saying so, when one is missing; under CI=true a missing
module fails the test instead (as the browser tests). Every skip is
printed with its reason; a marker without a reason is an error.
"""
import argparse
import importlib.util
import os
import re
import shutil
import subprocess
import sys

MARKER = re.compile(r"<!--\s*doc-test:\s*(skip|needs)\s*(.*?)\s*-->")


def section(lines, title):
    """(first line number, lines) of the '## title' section."""
    start = None
    for i, line in enumerate(lines):
        if start is None and line.strip() == "## " + title:
            start = i + 1
        elif start is not None and line.startswith("## "):
            return start, lines[start:i]
    if start is None:
        raise SystemExit("no section '## %s'" % title)
    return start, lines[start:]


def blocks(lines, first_line, langs):
    """[(lang, line number, code, marker)] of the fenced blocks in `langs`."""
    out = []
    marker = None
    i = 0
    while i < len(lines):
        line = lines[i]
        m = MARKER.search(line)
        if m:
            kind, arg = m.group(1), m.group(2)
            if kind == "skip":
                reason = arg.strip("() ")
                if not reason:
                    raise SystemExit("line %d: a doc-test skip marker must give its reason" % (first_line + i + 1))
                marker = ("skip", reason)
            else:
                modules = [x.strip() for x in arg.split(",") if x.strip()]
                if not modules:
                    raise SystemExit("line %d: doc-test needs: name the module(s)" % (first_line + i + 1))
                marker = ("needs", modules)
            i += 1
            continue
        fence = re.match(r"^```(\w+)\s*$", line)
        if fence:
            lang = fence.group(1)
            start = i
            i += 1
            code = []
            while i < len(lines) and not lines[i].startswith("```"):
                code.append(lines[i])
                i += 1
            if lang in langs:
                out.append((lang, first_line + start + 1, "\n".join(code) + "\n", marker))
            marker = None
        elif line.strip():
            marker = None if not line.lstrip().startswith("<!--") else marker
        i += 1
    return out


def missing_modules(python, modules):
    code = "import importlib.util, sys\nprint(','.join(m for m in sys.argv[1:] if importlib.util.find_spec(m) is None))"
    r = subprocess.run([python, "-c", code] + modules, capture_output=True, text=True, check=True)
    return [m for m in r.stdout.strip().split(",") if m]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--rocklab", required=True, help="the build's rocklab binary")
    ap.add_argument("--scratch", required=True, help="folder to run in (emptied first)")
    ap.add_argument("--python", default=sys.executable)
    ap.add_argument("--python-path", default="", help="the build's Python package folder; empty: no Python blocks")
    args = ap.parse_args()
    ci = os.environ.get("CI", "") == "true"

    todo = []
    with open(os.path.join(args.repo, "README.md")) as f:
        first, lines = section(f.read().split("\n"), "A day in the lab")
    todo += [("README.md",) + b for b in blocks(lines, first, ("sh", "python"))]
    with open(os.path.join(args.repo, "docs", "python.md")) as f:
        text = f.read().split("\n")
    todo += [("docs/python.md",) + b for b in blocks(text, 0, ("python",))]
    # The shell blocks first (they make the files the Python blocks read).
    todo.sort(key=lambda b: 0 if b[1] == "sh" else 1)

    shutil.rmtree(args.scratch, ignore_errors=True)
    os.makedirs(args.scratch)
    os.symlink(os.path.join(os.path.abspath(args.repo), "data"), os.path.join(args.scratch, "data"))
    env = dict(os.environ)
    env["B"] = os.path.abspath(args.rocklab)
    env["PYTHONPATH"] = os.path.abspath(args.python_path) if args.python_path else ""
    env["MPLBACKEND"] = "Agg"
    env["PYTHONDONTWRITEBYTECODE"] = "1"

    ran, skipped, failed = 0, [], []
    for doc, lang, line, code, marker in todo:
        where = "%s:%d (%s)" % (doc, line, lang)
        if marker and marker[0] == "skip":
            skipped.append("%s: %s" % (where, marker[1]))
            continue
        if lang == "python" and not args.python_path:
            skipped.append("%s: the Python module is not built (ROCKLAB_PYTHON off)" % where)
            continue
        if marker and marker[0] == "needs":
            missing = missing_modules(args.python, marker[1])
            if missing:
                msg = "%s: needs the Python module(s) %s, not installed" % (where, ", ".join(missing))
                if ci:
                    failed.append(msg + " (CI=true: a missing module is a failure)")
                else:
                    skipped.append(msg)
                continue
        print("--- %s" % where, flush=True)
        if lang == "sh":
            cmd = ["bash", "-euo", "pipefail", "-c", code]
        else:
            cmd = [args.python, "-c", code]
        r = subprocess.run(cmd, cwd=args.scratch, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           text=True, errors="replace")
        sys.stdout.write(r.stdout[-4000:])
        if r.returncode != 0:
            failed.append("%s: exit %d" % (where, r.returncode))
            print("FAILED %s: exit %d; the block:\n%s" % (where, r.returncode, code), flush=True)
            break  # later blocks read what this one makes
        ran += 1
    for s in skipped:
        print("SKIPPED %s" % s)
    print("%d blocks ran, %d skipped, %d failed" % (ran, len(skipped), len(failed)))
    for f in failed:
        print("FAILED %s" % f)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
