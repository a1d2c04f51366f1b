#!/usr/bin/env python3
"""The bundled data of "a day in the lab" (data/README.md).

1. The Clough-Penzien filter of tools/make_day_data.py. Oracle: the closed
   form |H(i omega)| of the Kanai-Tajimi filter times the Clough-Penzien
   high-pass, at 0.5, 2.5 (omega_g) and 8 Hz: the filter driven by a sine
   in the steady state (after 30 s, the slowest pole's e-folding time
   1 / (zeta_f omega_f) = 1.1 s) has that amplitude within 1e-3 (RK4 at
   h = 0.1 ms: truncation ~ (omega h)^4, 1e-9; the amplitude read as the
   largest sample of 1 ms samples: cos(omega 0.5 ms) >= 1 - 3.2e-4 at 8 Hz).
2. The committed files are what the generator makes (same bytes).
3. `reconstruct` then `fit` on samples/free_block1.csv give the paper's
   Table 2 values for block 1 (alpha 0.235 rad, p 3.884 rad/s, mu 0.937),
   which made the file, within 3 standard errors of the fit, from 10 or
   more impacts.

Usage: day_data_test.py --repo DIR --rocklab BIN --scratch DIR
"""
import argparse
import filecmp
import json
import math
import os
import shutil
import subprocess
import sys

TABLE2 = {"alpha": 0.235, "p": 3.884, "mu": 0.937}


def check_filter(gen):
    bad = []
    c = dict(gen.CP)
    c["substeps"] = 10
    dt = 0.001
    for f_hz in (0.5, 2.5, 8.0):
        omega = 2 * math.pi * f_hz
        n = int(40 / dt)
        w = [math.sin(omega * k * dt) for k in range(n)]
        a = gen.cp_filter(w, dt, c)
        amp = max(abs(x) for x in a[int(30 / dt):])
        want = gen.cp_gain(omega, gen.CP)
        rel = abs(amp / want - 1)
        print("filter gain at %.1f Hz: %.6f, closed form %.6f (%.1e)" % (f_hz, amp, want, rel))
        if rel > 1e-3:
            bad.append("filter gain at %.1f Hz off by %.1e" % (f_hz, rel))
    return bad


def check_regenerated(repo, rocklab, scratch):
    out = os.path.join(scratch, "regenerated")
    shutil.rmtree(out, ignore_errors=True)
    subprocess.run([sys.executable, os.path.join(repo, "tools", "make_day_data.py"), "--rocklab", rocklab,
                    "--out", out], check=True)
    bad = []
    for rel in ["data/records/cp_synthetic_%d.csv" % s for s in (1, 2, 3)] + [
            "data/samples/free_block1.csv", "data/samples/free_block1.truth.csv"]:
        if not filecmp.cmp(os.path.join(repo, rel), os.path.join(out, rel), shallow=False):
            bad.append("%s differs from what tools/make_day_data.py makes" % rel)
    return bad


def check_fit(repo, rocklab, scratch):
    rig = os.path.join(repo, "data", "rigs", "block1_rig.toml")
    theta = os.path.join(scratch, "free_theta.csv")
    subprocess.run([rocklab, "reconstruct", "--rig", rig, "--input",
                    os.path.join(repo, "data", "samples", "free_block1.csv"), "--out", theta], check=True)
    r = subprocess.run([rocklab, "fit", "--input", theta, "--rig", rig, "--json", "--quiet"], check=True,
                       capture_output=True, text=True)
    fit = json.loads(r.stdout)
    impacts = sum(1 for row in fit["impacts"] if row["n"] >= 1)
    print("fit: alpha %.4f +- %.4f, p %.4f +- %.4f, mu %.4f +- %.4f, %d impacts" % (
        fit["alpha"], fit["alpha_stderr"], fit["p"], fit["p_stderr"], fit["mu"], fit["mu_stderr"], impacts))
    bad = []
    if impacts < 10:
        bad.append("only %d impacts (10 or more wanted)" % impacts)
    for k, v in TABLE2.items():
        err = fit[k + "_stderr"]
        if err is None or not (abs(fit[k] - v) <= 3 * err):
            bad.append("%s %.5f is not within 3 standard errors (%s) of Table 2's %.3f" % (k, fit[k], err, v))
    return bad


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--rocklab", required=True)
    ap.add_argument("--scratch", required=True)
    args = ap.parse_args()
    os.makedirs(args.scratch, exist_ok=True)
    sys.path.insert(0, os.path.join(args.repo, "tools"))
    import make_day_data as gen

    bad = check_filter(gen) + check_regenerated(args.repo, args.rocklab, args.scratch) + check_fit(
        args.repo, args.rocklab, args.scratch)
    for b in bad:
        print("FAILED: " + b)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
