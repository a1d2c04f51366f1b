#!/usr/bin/env python3
"""Mutation check of rocklab's physics tests.

Each mutant is one small, wrong change to the physics (a sign, a factor, a
swapped term) in the Housner right-hand side, the complex model's eq. (10),
the impact and restitution, the reconstruction and the comparator. For each,
in a scratch copy of the committed tree (`git archive HEAD`, never the
working tree), the test targets of its layer are rebuilt (ccache) and their
ctest subset is run: the mutant must make at least one test fail ("killed").
A mutant that passes every test has "survived": the script exits 1.

Not in CI (a first build of the scratch tree takes minutes on a 2-core
machine). Run from anywhere inside the repository:

    python3 tests/mutation/run.py              # every mutant
    python3 tests/mutation/run.py housner_forcing comparator_error_sign
    ROCKLAB_MUTATION_DIR=/tmp/mut python3 tests/mutation/run.py   # reuse a scratch build

The last result and its command are in docs/testing.md.
"""

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

# Test targets per layer, and the layer of each mutant.
LAYERS = {
    "model": [
        "model_block_test", "model_rocking_test", "model_complex_test", "model_oracle_test",
        "model_free_rocking_test", "model_scenario_test", "model_asymmetric_test",
        "model_discontinuity_test", "rocklab_model_node_test",
    ],
    "daq": ["daq_tests", "daq_independent_oracle_test"],
    "compare": ["rocklab_comparator_test", "rocklab_compare_node_test"],
}

# name, layer, file, the text replaced (exactly once), its replacement, why it is wrong.
MUTANTS = [
    ("housner_forcing", "model", "model/housner.cpp",
     "ug / kGravity * std::cos(phi)", "ug / kGravity * std::cos(sp_.alpha * side_)",
     "Housner RHS: the forcing term's cos(alpha s - theta) frozen at theta = 0 (a plausible slip)"),
    ("housner_gravity_sign", "model", "model/housner.cpp",
     "-sp_.p * sp_.p * (std::sin(phi) +", "-sp_.p * sp_.p * (-std::sin(phi) +",
     "Housner RHS: the restoring term's sign"),
    ("housner_restitution", "model", "model/housner.cpp",
     "y[1] *= sp_.mu;", "y[1] *= sp_.mu * sp_.mu;",
     "impact: the angular velocity times mu^2 instead of mu"),
    ("complex_damping_factor", "model", "model/complex.cpp",
     "s.damping = 2.0 * std::log(sp.mu) / kPi;", "s.damping = std::log(sp.mu) / kPi;",
     "eq. (10): eq. (7)'s damping coefficient, half the right one (docs/errata.md item 3)"),
    ("complex_gravity_sign", "model", "model/complex.cpp",
     "const double force = -std::sin(a - a * chi) / a +", "const double force = std::sin(a - a * chi) / a +",
     "eq. (10): the sign of the gravity term"),
    ("complex_forcing_swap", "model", "model/complex.cpp",
     "forcing * std::cos(a - a * chi) * (y[0] / chi);", "forcing * std::sin(a - a * chi) * (y[0] / chi);",
     "eq. (10): sin for cos in the forcing term"),
    ("restitution_general_sign", "model", "model/block.cpp",
     "out.plus.mu = (i_g_per_area + r_dot) / out.plus.i_o_per_area;",
     "out.plus.mu = (i_g_per_area - r_dot) / out.plus.i_o_per_area;",
     "restitution of a general section (docs/errata.md item 8): the sign of r_new . r_old"),
    ("mirror_factor", "daq", "daq/reconstruction.cpp",
     "out.theta_mirror = 0.5 * std::atan(", "out.theta_mirror = std::atan(",
     "LED-mirror: the beam turns by 2 theta, the factor 1/2 dropped"),
    ("camera_sign", "daq", "daq/reconstruction.cpp",
     "out.theta_camera = -fit.phi;", "out.theta_camera = fit.phi;",
     "lateral cameras: the sign of the fitted rotation"),
    ("comparator_error_sign", "compare", "compare/comparator.cpp",
     "m_.error = theta_model - theta_measured;", "m_.error = theta_model + theta_measured;",
     "comparator: the error as a sum"),
    ("comparator_timing_sign", "compare", "compare/comparator.cpp",
     "m_.impact_timing_error = model.time_s - measured.time_s;",
     "m_.impact_timing_error = measured.time_s - model.time_s;",
     "comparator: the sign of the impact-timing error (model late is positive)"),
]


def run(cmd, cwd=None, env=None, quiet=True):
    out = subprocess.run(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if not quiet:
        sys.stdout.write(out.stdout)
    return out.returncode, out.stdout


def main(argv):
    repo = subprocess.check_output(["git", "rev-parse", "--show-toplevel"], text=True).strip()
    head = subprocess.check_output(["git", "-C", repo, "rev-parse", "--short", "HEAD"], text=True).strip()
    wanted = argv[1:]
    unknown = [w for w in wanted if w not in {m[0] for m in MUTANTS}]
    if unknown:
        print("unknown mutant(s): " + ", ".join(unknown), file=sys.stderr)
        return 2
    mutants = [m for m in MUTANTS if not wanted or m[0] in wanted]

    work = os.environ.get("ROCKLAB_MUTATION_DIR") or tempfile.mkdtemp(prefix="rocklab-mutation-")
    tree = os.path.join(work, "tree")
    build = os.path.join(work, "build")
    if os.path.isdir(tree):
        shutil.rmtree(tree)
    os.makedirs(tree)
    archive = subprocess.Popen(["git", "-C", repo, "archive", "HEAD"], stdout=subprocess.PIPE)
    subprocess.check_call(["tar", "-x", "-C", tree], stdin=archive.stdout)
    if archive.wait() != 0:
        raise SystemExit("git archive failed")
    # ccache keyed on paths relative to the scratch tree, whatever its folder.
    env = dict(os.environ, CCACHE_BASEDIR=tree, CCACHE_NOHASHDIR="1")
    print(f"rocklab mutation check of {head} in {work}")
    code, out = run(["cmake", "-S", tree, "-B", build, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=RelWithDebInfo",
                     "-DCMAKE_CXX_COMPILER_LAUNCHER=ccache", "-DROCKLAB_LCM_JAVA=OFF"], env=env)
    if code != 0:
        print(out)
        return 2

    layers = sorted({m[1] for m in mutants})
    targets = {layer: LAYERS[layer] for layer in layers}
    # The ctest subset of a layer: the test suites its executables hold.
    regex = {}
    t0 = time.time()
    for layer in layers:
        code, out = run(["cmake", "--build", build, "-j2", "--target"] + targets[layer], env=env)
        if code != 0:
            print(out[-4000:])
            print(f"baseline build of {layer} failed")
            return 2
        suites = set()
        for target in targets[layer]:
            exe = next((os.path.join(d, target) for d, _, files in os.walk(os.path.join(build, "tests"))
                        if target in files), None)
            listed = subprocess.check_output([exe, "--gtest_list_tests"], text=True)
            suites |= {line.split(".")[0] for line in listed.splitlines() if line and not line.startswith(" ")}
        regex[layer] = "^(" + "|".join(sorted(suites)) + ")\\."
        code, out = run(["ctest", "--test-dir", build, "-R", regex[layer], "-j2", "--timeout", "300"], env=env)
        if code != 0:
            print(out[-4000:])
            print(f"the unmutated {layer} tests fail: no mutant can be judged")
            return 2
        print(f"baseline {layer}: {len(targets[layer])} test programs pass ({time.time() - t0:.0f} s so far)")

    rows = []
    for name, layer, rel, old, new, why in mutants:
        path = os.path.join(tree, rel)
        with open(path) as f:
            original = f.read()
        if original.count(old) != 1:
            print(f"{name}: '{old}' found {original.count(old)} times in {rel}: the mutant is stale")
            rows.append((name, rel, "STALE", 0, why))
            continue
        with open(path, "w") as f:
            f.write(original.replace(old, new))
        start = time.time()
        try:
            code, out = run(["cmake", "--build", build, "-j2", "--target"] + targets[layer], env=env)
            if code != 0:
                verdict = "killed (does not build)"
            else:
                code, out = run(["ctest", "--test-dir", build, "-R", regex[layer], "-j2", "--timeout", "300"],
                                env=env)
                failed = re.findall(r"^\s*\d+ - (\S+) \(Failed\)", out, re.M)
                verdict = f"killed by {len(failed)} test(s): " + ", ".join(failed) if code != 0 else "SURVIVED"
        finally:
            with open(path, "w") as f:
                f.write(original)
        rows.append((name, rel, verdict, time.time() - start, why))
        print(f"{name:26s} {verdict} ({time.time() - start:.0f} s)")

    # Leave the scratch build matching the tree (a reused ROCKLAB_MUTATION_DIR starts clean).
    for layer in layers:
        run(["cmake", "--build", build, "-j2", "--target"] + targets[layer], env=env)
    print()
    print("| mutant | file | what is wrong | result |")
    print("|---|---|---|---|")
    for name, rel, verdict, _, why in rows:
        print(f"| `{name}` | `{rel}` | {why} | {verdict} |")
    survived = [r[0] for r in rows if r[2] in ("SURVIVED", "STALE")]
    print()
    print(f"{len(rows) - len(survived)} of {len(rows)} mutants killed" +
          (f"; survived or stale: {', '.join(survived)}" if survived else ""))
    return 1 if survived else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
