"""`pip install --no-build-isolation .` as a user runs it (pyproject.toml,
setup.py): a venv made with --system-site-packages (Debian's numpy and
scikit-build), the install from a copy of the source tree (scikit-build
writes _skbuild/ beside setup.py), then, from a folder outside both, the
import and one call. Long (the module's libraries are compiled): registered
under ROCKLAB_SOAK_TESTS (docs/testing.md).

    pip_install_test.py --source SRC --work DIR [--python /usr/bin/python3]
"""

import argparse
import math
import os
import shutil
import subprocess
import sys
import time

ap = argparse.ArgumentParser()
ap.add_argument("--source", required=True)
ap.add_argument("--work", required=True)
ap.add_argument("--python", default="/usr/bin/python3")
ap.add_argument("--jobs", type=int, default=2, help="parallel compile jobs (docs/testing.md: at most 2)")
args = ap.parse_args()

work = os.path.abspath(args.work)
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
src = os.path.join(work, "src")
# Build trees, scikit-build's own, git and node's folders are no part of the source.
top_skip = {".git", "_skbuild", "node_modules", "out"}
shutil.copytree(
    args.source,
    src,
    ignore=lambda d, names: [
        n for n in names
        if os.path.samefile(d, args.source) and (n in top_skip or n.startswith("build") or n.endswith(".egg-info"))
    ],
)

venv = os.path.join(work, "venv")
subprocess.run([args.python, "-m", "venv", "--system-site-packages", venv], check=True)
vpython = os.path.join(venv, "bin", "python")
env = dict(os.environ, CMAKE_BUILD_PARALLEL_LEVEL=str(args.jobs), SKBUILD_BUILD_OPTIONS=f"-j{args.jobs}",
           PIP_NO_INPUT="1")
env.pop("PYTHONPATH", None)
t0 = time.monotonic()
cpu0 = os.times()
subprocess.run(
    [vpython, "-m", "pip", "install", "--no-build-isolation", "--no-index", "--no-cache-dir", "."],
    cwd=src, env=env, check=True,
)
cpu1 = os.times()
wall = time.monotonic() - t0
cpu = (cpu1.children_user - cpu0.children_user) + (cpu1.children_system - cpu0.children_system)
print(f"pip install: {wall:.1f} s wall, {cpu:.1f} s CPU (children)")

# The import from outside the trees: the venv's site-packages alone.
run = os.path.join(work, "run")
os.makedirs(run)
probe = (
    "import json, os, sys, rocklab\n"
    "p = rocklab.block_params(0.247, 1.0)\n"
    "print(json.dumps({'file': rocklab.__file__, 'version': rocklab.__version__, 'alpha': p['alpha'], "
    "'prefix': sys.prefix}))\n"
)
out = subprocess.run([vpython, "-c", probe], cwd=run, env=env, check=True, capture_output=True, text=True).stdout
import json  # noqa: E402

r = json.loads(out.strip().splitlines()[-1])
problems = []
if not os.path.realpath(r["file"]).startswith(os.path.realpath(venv) + os.sep):
    problems.append(f"rocklab imported from {r['file']}, not from the venv {venv}")
if r["version"] != subprocess.run([vpython, "-m", "pip", "show", "rocklab"], env=env, capture_output=True,
                                  text=True).stdout.split("Version: ")[1].split()[0]:
    problems.append(f"rocklab.__version__ {r['version']} is not the installed distribution's")
# Oracle: a 0.247 x 1.0 m rectangle's slenderness, alpha = atan(b / h) (closed form).
if abs(r["alpha"] - math.atan(0.247 / 1.0)) > 1e-12:
    problems.append(f"block_params(0.247, 1.0)['alpha'] = {r['alpha']!r}, expected atan(0.247)")
for p in problems:
    print("FAIL:", p)
print("ok" if not problems else "failed", r)
sys.exit(1 if problems else 0)
