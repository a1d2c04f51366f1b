#!/usr/bin/env python3
"""Mutation check of rocklab's tests over every library.

Each mutant is one small, wrong change (a sign, a factor, a swapped term, a
wrong unit, an off-by-one count) in the physics (Housner, eq. (10), impact
and restitution), the reconstruction, the comparator, the export (fields
and units), `rocklab info`, the sweep and its fragility fit, the parameter
fit, the live sources, the recorder and the monitor. For each, in a scratch
copy of the committed tree (`git archive HEAD`, never the working tree),
the test targets of its layer are rebuilt (ccache) and only that layer's
ctest subset is run: the mutant must make at least one test fail
("killed"). A mutant that passes every test has "survived": the script
exits 1.

Not in CI (CPU heavy). Run from anywhere inside the repository, niced on a
shared machine:

    nice -n 15 python3 tests/mutation/run.py            # every mutant
    nice -n 15 python3 tests/mutation/run.py housner_forcing comparator_error_sign
    nice -n 15 python3 tests/mutation/run.py --update-docs   # all, then docs/testing.md's table
    ROCKLAB_MUTATION_DIR=/tmp/mut python3 tests/mutation/run.py   # reuse a scratch build

The scratch tree is WORK/src with its build in WORK/src/build, configured as
a developer's build/ (RelWithDebInfo, ROCKLAB_WERROR=OFF, ccache): with
CCACHE_BASEDIR at the tree, the compiler sees the same relative paths as in
a worktree's build/, so ccache serves the unchanged objects. --update-docs
(all mutants only) rewrites the table between the mutation-table markers of
docs/testing.md with the date, the commit and the command.
"""

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

# Test executables per layer (each test folder is one, rocklab_tests_<folder>:
# tests/CMakeLists.txt), and the layer of each mutant.
LAYERS = {
    "model": ["rocklab_tests_model"],
    "daq": ["rocklab_tests_daq"],
    "compare": ["rocklab_tests_compare"],
    "export": ["rocklab_tests_export"],
    "sweep": ["rocklab_tests_sweep"],
    "fit": ["rocklab_tests_model"],
    "live": ["rocklab_tests_daq"],
    "record": ["rocklab_tests_record"],
    "monitor": ["rocklab_tests_monitor"],
}
# Only these gtest suites of a layer's programs (default: all of them).
LAYER_SUITES = {
    "live": ["LiveSources", "LiveFaults", "LiveEndToEnd"],
}
# ctest tests of a layer that are not gtest suites (the Python oracles of
# tests/CMakeLists.txt), by exact name.
EXTRA_TESTS = {
    "export": ["External.export_readback"],
    "sweep": ["External.fragility_oracle"],
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
     "forcing * std::cos(a - a * chi) * (ActualX(y[0], y[1]) / chi);",
     "forcing * std::sin(a - a * chi) * (ActualX(y[0], y[1]) / chi);",
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
    # Every other library.
    ("export_unit_theta_dot", "export", "export/fields.cpp",
     'v.Real("theta_dot", m.theta_dot, "rad/s");\n  v.Real("theta_mirror"',
     'v.Real("theta_dot", m.theta_dot, "rad");\n  v.Real("theta_mirror"',
     "export: RL_THETA's theta_dot in rad instead of rad/s)"),
    ("export_unit_accel", "export", "export/fields.cpp",
     'v.Real("acceleration", m.acceleration, "m/s^2");', 'v.Real("acceleration", m.acceleration, "m/s");',
     "export: the table acceleration's unit"),
    ("export_field_swap", "export", "export/fields.cpp",
     'v.Real("jump", m.jump, "m");', 'v.Real("jump", m.sliding, "m");',
     "export: the jump column holds the sliding value"),
    ("info_rate", "export", "export/info.cpp",
     "static_cast<double>(decoded - 1) / span", "static_cast<double>(decoded) / span",
     "info: a channel's rate as messages / span instead of intervals / span"),
    ("info_seq_missing", "export", "export/info.cpp",
     "c.seq_missing += s - ch.last_seq - 1;", "c.seq_missing += s - ch.last_seq;",
     "info: a gap's missing count off by one"),
    ("sweep_pga_scale", "sweep", "sweep/sweep.cpp",
     "s.factor = grid * common::kGravity / r.pga_mps2;", "s.factor = grid / r.pga_mps2;",
     "sweep: --pga-g scale factor without g (a PGA in m/s^2 taken as g)"),
    ("fragility_inv_sqrt2", "sweep", "sweep/fragility.cpp",
     "constexpr double kInvSqrt2 = 0.70710678118654752440;",
     "constexpr double kInvSqrt2 = 0.70710678118654752440 * 1.01;",
     "fragility: Phi's argument scaled by 1.01 (beta 1 % off)"),
    ("fragility_separation", "sweep", "sweep/fragility.cpp",
     "if (safe_max <= over_min) {", "if (safe_max < over_min) {",
     "fragility: a tie at one intensity taken as overlapping outcomes (no finite maximum exists)"),
    ("fit_mu_exponent", "fit", "model/free_rocking.cpp",
     "1.0 / (2.0 * n));", "1.0 / (2.0 * n + 1.0));",
     "fit: eq. (14)'s exponent 1/(2n) off by one impact"),
    ("fit_mu_mean", "fit", "model/fit_impacts.cpp",
     "/ static_cast<double>(mus.size());", "/ static_cast<double>(mus.size() + 1);",
     "fit: the mean of the mu_n divided by one too many"),
    ("live_restart_lost", "live", "daq/text_source.h",
     "std::llround((t - *last_time_) * rate_hz_) - 1;", "std::llround((t - *last_time_) * rate_hz_);",
     "live sources: samples lost across a restart off by one"),
    ("record_seq_field", "record", "record/recorder.cpp",
     "c.seq.Add(GetBe64(ev.data + 16));", "c.seq.Add(GetBe64(ev.data + 8));",
     "record: the sequence check reads utime (offset 8) instead of seq (16)"),
    ("record_count", "record", "record/recorder.cpp",
     "    ++c.count;\n    c.bytes += ev.size;", "    c.bytes += ev.size;",
     "record: written events not counted"),
    ("monitor_theta_degrees", "monitor", "monitor/live_ingest.cpp",
     "AddPoint(measured, m.utime, m.theta * kDegPerRad, 0.0);", "AddPoint(measured, m.utime, m.theta, 0.0);",
     "monitor: the measured theta plotted in rad where the page says degrees"),
    ("monitor_table_peak", "monitor", "monitor/live_ingest.cpp",
     "table_peak_accel = std::fmax(table_peak_accel, std::fabs(m.acceleration));",
     "table_peak_accel = std::fmax(table_peak_accel, m.acceleration);",
     "monitor: the table's peak acceleration without the absolute value"),
]


def run(cmd, cwd=None, env=None, quiet=True):
    out = subprocess.run(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if not quiet:
        sys.stdout.write(out.stdout)
    return out.returncode, out.stdout


def main(argv):
    repo = subprocess.check_output(["git", "rev-parse", "--show-toplevel"], text=True).strip()
    head = subprocess.check_output(["git", "-C", repo, "rev-parse", "--short", "HEAD"], text=True).strip()
    update_docs = "--update-docs" in argv[1:]
    wanted = [a for a in argv[1:] if a != "--update-docs"]
    if update_docs and wanted:
        print("--update-docs runs every mutant: name none", file=sys.stderr)
        return 2
    unknown = [w for w in wanted if w not in {m[0] for m in MUTANTS}]
    if unknown:
        print("unknown mutant(s): " + ", ".join(unknown), file=sys.stderr)
        return 2
    mutants = [m for m in MUTANTS if not wanted or m[0] in wanted]

    work = os.environ.get("ROCKLAB_MUTATION_DIR") or tempfile.mkdtemp(prefix="rocklab-mutation-")
    tree = os.path.join(work, "src")
    build = os.path.join(tree, "build")
    os.makedirs(tree, exist_ok=True)
    for name in os.listdir(tree):  # the previous tree, not its build
        if name != "build":
            path = os.path.join(tree, name)
            shutil.rmtree(path) if os.path.isdir(path) and not os.path.islink(path) else os.remove(path)
    archive = subprocess.Popen(["git", "-C", repo, "archive", "HEAD"], stdout=subprocess.PIPE)
    subprocess.check_call(["tar", "-x", "-C", tree], stdin=archive.stdout)
    if archive.wait() != 0:
        raise SystemExit("git archive failed")
    # ccache keyed on paths relative to the scratch tree: the same as a
    # worktree's build/ sees, so a developer's build fills the cache.
    env = dict(os.environ, CCACHE_BASEDIR=tree, CCACHE_NOHASHDIR="1")
    print(f"rocklab mutation check of {head} in {work}")
    code, out = run(["cmake", "-S", tree, "-B", build, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=RelWithDebInfo",
                     "-DROCKLAB_WERROR=OFF", "-DCMAKE_CXX_COMPILER_LAUNCHER=ccache",
                     "-DCMAKE_C_COMPILER_LAUNCHER=ccache"], env=env)
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
        if layer in LAYER_SUITES:
            suites &= set(LAYER_SUITES[layer])
        regex[layer] = "^(" + "|".join(sorted(suites)) + ")\\."
        for name in EXTRA_TESTS.get(layer, []):
            regex[layer] += "|^" + re.escape(name) + "$"
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
                failed = re.findall(r"^\s*\d+ - (\S+) \((?:Failed|Timeout|SEGFAULT|Subprocess aborted|"
                                    r"Child aborted|Exception|Not Run)\)", out, re.M)
                shown = ", ".join(failed[:4]) + (", ..." if len(failed) > 4 else "")
                verdict = f"killed by {len(failed)} test(s): {shown}" if code != 0 else "SURVIVED"
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
    summary = (f"{len(rows) - len(survived)} of {len(rows)} mutants killed" +
               (f"; survived or stale: {', '.join(survived)}" if survived else ""))
    print()
    print(summary)
    if update_docs:
        UpdateDocs(repo, head, rows, summary, time.time() - t0)
    return 1 if survived else 0


BEGIN = "<!-- mutation-table:begin (tests/mutation/run.py --update-docs writes this) -->"
END = "<!-- mutation-table:end -->"


def UpdateDocs(repo, head, rows, summary, seconds):
    """docs/testing.md's table between BEGIN and END, from this run."""
    path = os.path.join(repo, "docs", "testing.md")
    text = open(path).read()
    if BEGIN not in text or END not in text:
        raise SystemExit(f"{path}: no mutation-table markers")
    date = time.strftime("%d %b %Y", time.gmtime())
    lines = [BEGIN, "",
             f"Last run: commit {head}, {date}, {seconds / 60:.0f} min on the shared 2-core machine:", "",
             "```sh", "nice -n 15 python3 tests/mutation/run.py --update-docs", "```", "",
             "| mutant | file | what is wrong | result |", "|---|---|---|---|"]
    for name, rel, verdict, _, why in rows:
        lines.append(f"| `{name}` | `{rel}` | {why} | {verdict} |")
    lines += ["", summary + ".", "", END]
    head_text, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    with open(path, "w") as f:
        f.write(head_text + "\n".join(lines) + tail)
    print(f"{path}: table updated")


if __name__ == "__main__":
    sys.exit(main(sys.argv))
