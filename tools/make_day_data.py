#!/usr/bin/env python3
"""Writes the bundled data of README.md's "a day in the lab" (data/README.md).

1. data/samples/free_block1.csv (+ .truth.csv): a free-rocking test of the
   paper's block 1 as the lab records it: the rig's raw channels
   (data/rigs/block1_rig.toml), the block held at 0.12 rad for 0.5 s, then
   let go, 6 s at 1 kHz, typical noise. The physics is rocklab's own:
   `rocklab synth` with Housner's model and Table 2's fitted parameters
   (alpha 0.235 rad, p 3.884 rad/s, mu 0.937).
2. data/records/cp_synthetic_{1,2,3}.csv: synthetic ground motions for
   `rocklab sweep` (`time,accel`, s and m/s^2, 100 Hz, 20 s), NOT recorded
   earthquakes: seeded Gaussian white noise through a Clough-Penzien filter
   (a Kanai-Tajimi ground filter, omega_g 15.6 rad/s and zeta_g 0.6, the
   firm-soil values of Kanai and Tajimi, then the Clough-Penzien
   high-pass, omega_f 1.5 rad/s, zeta_f 0.6), shaped by a Jennings-type
   envelope (t^2 rise to 2 s, strong phase to 8 s, exp(-0.4 (t - 8)) decay)
   and scaled to a peak of 0.3 g.

Deterministic (seeded; pure Python, no numpy): the same files every time,
which tests/docs/day_data_test.py checks. Run from the repository root:

    python3 tools/make_day_data.py --rocklab build/tools/rocklab --out .
"""
import argparse
import math
import os
import random
import subprocess

G = 9.81  # m/s^2, the g of the .AT2 reader (model/excitation.h)
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Free rocking of block 1 (Table 2 of the paper; docs/identification.md).
FREE = dict(alpha=0.235, p=3.884, mu=0.937, theta0=0.12, hold=0.5, duration=6.0, seed=36)

# Clough-Penzien ground motion.
CP = dict(omega_g=15.6, zeta_g=0.6, omega_f=1.5, zeta_f=0.6, rate=100.0, duration=20.0, pga_g=0.3,
          rise=2.0, strong_end=8.0, decay=0.4, substeps=10)
RECORD_SEEDS = (1, 2, 3)


def cp_derivative(state, w, c):
    """d/dt of (x_g, v_g, x_f, v_f) of the Clough-Penzien filter under input w.

    Kanai-Tajimi:  x_g'' + 2 zeta_g omega_g x_g' + omega_g^2 x_g = -w
    high-pass:     x_f'' + 2 zeta_f omega_f x_f' + omega_f^2 x_f = 2 zeta_g omega_g x_g' + omega_g^2 x_g
    ground accel:  a = x_f''.
    """
    xg, vg, xf, vf = state
    kt = 2 * c["zeta_g"] * c["omega_g"] * vg + c["omega_g"] ** 2 * xg  # the Kanai-Tajimi ground acceleration
    ag = -w - 2 * c["zeta_g"] * c["omega_g"] * vg - c["omega_g"] ** 2 * xg
    af = kt - 2 * c["zeta_f"] * c["omega_f"] * vf - c["omega_f"] ** 2 * xf
    return (vg, ag, vf, af)


def cp_filter(w, dt, c):
    """The ground acceleration x_f'' at the samples of the input w (held over
    each step dt), integrated by classical RK4 with c["substeps"] sub-steps."""
    state = (0.0, 0.0, 0.0, 0.0)
    h = dt / c["substeps"]
    out = []
    for wk in w:
        for _ in range(c["substeps"]):
            k1 = cp_derivative(state, wk, c)
            k2 = cp_derivative(tuple(s + 0.5 * h * k for s, k in zip(state, k1)), wk, c)
            k3 = cp_derivative(tuple(s + 0.5 * h * k for s, k in zip(state, k2)), wk, c)
            k4 = cp_derivative(tuple(s + h * k for s, k in zip(state, k3)), wk, c)
            state = tuple(s + h / 6 * (a + 2 * b + 2 * cc + d) for s, a, b, cc, d in zip(state, k1, k2, k3, k4))
        out.append(cp_derivative(state, wk, c)[3])
    return out


def cp_gain(omega, c):
    """|H(i omega)| of w -> ground acceleration, closed form:
    Kanai-Tajimi (omega_g^2 + 2 i zeta_g omega_g omega) / (omega_g^2 - omega^2 + 2 i zeta_g omega_g omega)
    times the high-pass omega^2 / (omega_f^2 - omega^2 + 2 i zeta_f omega_f omega), with the sign of -w."""
    s = 1j * omega
    kt = (c["omega_g"] ** 2 + 2 * c["zeta_g"] * c["omega_g"] * s) / (
        c["omega_g"] ** 2 + 2 * c["zeta_g"] * c["omega_g"] * s + s * s)
    hp = -s * s / (c["omega_f"] ** 2 + 2 * c["zeta_f"] * c["omega_f"] * s + s * s)
    return abs(kt * hp)


def envelope(t, c):
    if t < c["rise"]:
        return (t / c["rise"]) ** 2
    if t <= c["strong_end"]:
        return 1.0
    return math.exp(-c["decay"] * (t - c["strong_end"]))


def ground_motion(seed, c=CP):
    """(times s, acceleration m/s^2) of one seeded record."""
    rng = random.Random(seed)
    dt = 1.0 / c["rate"]
    n = int(round(c["duration"] * c["rate"])) + 1
    w = [rng.gauss(0.0, 1.0) for _ in range(n)]
    a = cp_filter(w, dt, c)
    a = [ak * envelope(k * dt, c) for k, ak in enumerate(a)]
    peak = max(abs(x) for x in a)
    scale = c["pga_g"] * G / peak
    return [k * dt for k in range(n)], [x * scale for x in a]


def write_record(path, seed):
    t, a = ground_motion(seed)
    with open(path + ".tmp", "w") as f:
        f.write("# rocklab synthetic ground motion (NOT a recorded earthquake): Clough-Penzien filtered white noise,\n")
        f.write("# seed %d, peak %.2f g; made by tools/make_day_data.py (data/README.md)\n" % (seed, CP["pga_g"]))
        f.write("time,accel\n")
        for tk, ak in zip(t, a):
            f.write("%.2f,%.6f\n" % (tk, ak))
    os.replace(path + ".tmp", path)


def write_free_rocking(rocklab, out):
    samples = os.path.join(out, "data", "samples")
    f = FREE
    subprocess.run(
        [rocklab, "synth", "--rig", os.path.join(REPO, "data", "rigs", "block1_rig.toml"), "--model", "housner",
         "--alpha", str(f["alpha"]), "--p", str(f["p"]), "--mu", str(f["mu"]), "--theta0", str(f["theta0"]),
         "--hold", str(f["hold"]), "--duration", str(f["duration"]), "--rate", "1000", "--seed", str(f["seed"]),
         "--out", os.path.join(samples, "free_block1.csv"),
         "--truth", os.path.join(samples, "free_block1.truth.csv")],
        check=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rocklab", help="the rocklab binary (for the free-rocking test); leave out to skip it")
    ap.add_argument("--out", default=".", help="repository root to write data/ under (default .)")
    ap.add_argument("--records-only", action="store_true", help="only the ground motions")
    args = ap.parse_args()
    os.makedirs(os.path.join(args.out, "data", "records"), exist_ok=True)
    for seed in RECORD_SEEDS:
        write_record(os.path.join(args.out, "data", "records", "cp_synthetic_%d.csv" % seed), seed)
    if not args.records_only:
        if not args.rocklab:
            ap.error("--rocklab is needed for the free-rocking test (or --records-only)")
        os.makedirs(os.path.join(args.out, "data", "samples"), exist_ok=True)
        write_free_rocking(args.rocklab, args.out)


if __name__ == "__main__":
    main()
