#!/usr/bin/env python3
"""The scipy peer of `rocklab simulate` (bench/run.sh): the same rocking
models, regime logic and tolerances, integrated with scipy's solve_ivp and
its event location, so the CPU of the two can be compared on the same motion.

  scipy_peer.py --model housner|complex [--alpha A --p P --mu M --l L]
                [--amp U --freq F --duration T --rate R] [--method DOP853]
                [--events FILE.csv] [--out FILE.csv]

Prints one JSON line: cpu_solve_s (process CPU of the integration alone),
impacts, first/last impact time, peak |theta| at the outputs. --events writes
time,kind,value rows like `rocklab simulate --events`; --out the outputs as
`rocklab simulate --out` does (time,theta,theta_dot; s, rad, rad/s; each
number the shortest text that reads back as the same double, Python's repr),
so that the two can be compared as whole processes (bench/figures.py).

The physics follows model/housner.cpp and model/complex.cpp (docs/errata.md items
3-6): Housner's piecewise equation in physical time; the complex
formulation as the planar motion of (x, y) = chi (cos psi, sin psi) under
eq. (10)'s radial force, seeded at uplift at chi0 = max(chi_m, sqrt(l)) on
psi = 0 or pi; uplift from rest when |u_g''| > g tan(alpha); return to rest
when two impacts come closer than 2 ms (complex: also at a crossing below
2 V_min); overturn at |theta| = pi/2. Tolerances: rtol 1e-10, atol 1e-12
(Housner); complex atol min(1e-7 l, 1e-12 / alpha) on x, y and
min(1e-7 l p, 1e-12 / alpha) on x', y', as rocklab uses.
"""
import argparse
import json
import math
import time

import numpy as np
from scipy.integrate import solve_ivp

G = 9.81
REST_INTERVAL_S = 2e-3


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--model", required=True, choices=["housner", "complex"])
    ap.add_argument("--alpha", type=float, default=0.168)  # figure 8, block 2 (Table 2)
    ap.add_argument("--p", type=float, default=3.767)
    ap.add_argument("--mu", type=float, default=0.942)
    ap.add_argument("--l", type=float, default=1e-10)
    ap.add_argument("--amp", type=float, default=0.006)  # m
    ap.add_argument("--freq", type=float, default=5.0)  # Hz
    ap.add_argument("--duration", type=float, default=20.0)  # s
    ap.add_argument("--rate", type=float, default=200.0)  # Hz
    ap.add_argument("--rtol", type=float, default=1e-10)
    ap.add_argument("--atol", type=float, default=1e-12)
    ap.add_argument("--method", default="DOP853")
    ap.add_argument("--events")
    ap.add_argument("--out")
    a = ap.parse_args()

    alpha, p, mu, l = a.alpha, a.p, a.mu, a.l
    w = 2 * math.pi * a.freq
    T = a.duration

    def ug(t):  # table acceleration of sine:amp,freq,duration,start=0; zero outside
        return -a.amp * w * w * math.sin(w * t) if 0.0 <= t <= T else 0.0

    thr = G * math.tan(alpha)
    damping = 2 * math.log(mu) / math.pi
    chi_m = (l * l * alpha / math.sin(alpha)) ** (1 / 3)

    def potential(chi):
        return (math.cos(alpha - alpha * chi) - math.cos(alpha)) / (alpha * alpha)

    v_min = potential(chi_m) + 0.5 * l * l / (chi_m * chi_m)

    def energy(y):  # complex: regularised energy, normalised
        return 0.5 * (y[2] ** 2 + y[3] ** 2) / (p * p) + potential(math.hypot(y[0], y[1]))

    if a.model == "housner":
        atol = a.atol
    else:
        pos = min(1e-7 * l, a.atol / alpha)
        vel = min(1e-7 * l * p, a.atol / alpha)
        atol = np.array([pos, pos, vel, vel])

    n_out = int(math.floor(T * a.rate + 1e-9)) + 1
    t_out = np.arange(n_out) / a.rate
    theta_out = np.zeros(n_out)
    theta_dot_out = np.zeros(n_out)
    events = []

    # --- the regime machine ---------------------------------------------------
    def rest_until_uplift(t0):
        """Earliest t > t0 (or = t0) with |u_g''| above the threshold, analytically
        on the sine: |U w^2 sin(w t)| > thr."""
        if abs(ug(t0)) > thr:
            return t0
        s = thr / (a.amp * w * w)
        if s >= 1:
            return math.inf
        base = math.asin(s) / w
        period = math.pi / w  # |sin| has period pi/w; crossings at base + k pi/w
        k = math.floor((t0 - base) / period) + 1
        t = base + k * period
        while t <= t0:
            t += period
        return t if t <= T else math.inf

    def housner_segment(t0, y0, side):
        def rhs(t, y):
            phi = alpha * side - y[0]
            return [y[1], -p * p * (math.sin(phi) + ug(t) / G * math.cos(phi))]

        def impact(t, y):
            return y[0]
        impact.terminal = True
        impact.direction = -side

        def overturn(t, y):
            return side * y[0] - math.pi / 2
        overturn.terminal = True
        overturn.direction = 1
        return rhs, [impact, overturn]

    def complex_segment(t0, y0, side):
        def rhs(t, y):
            chi = math.hypot(y[0], y[1])
            forcing = -ug(t) / (G * alpha)
            chi_dot = (y[0] * y[2] + y[1] * y[3]) / (chi * p)
            d = damping  # symmetric block: both pivots the same
            force = (-math.sin(alpha - alpha * chi) / alpha + d * l * chi_dot / (chi * chi)
                     + forcing * math.cos(alpha - alpha * chi) * (y[0] / chi))
            return [y[2], y[3], p * p * force * y[0] / chi, p * p * force * y[1] / chi]

        def impact(t, y):
            return y[0]
        impact.terminal = False  # the crossing is in the ODE: counted, not restarted
        impact.direction = 0

        def overturn(t, y):
            return alpha * math.hypot(y[0], y[1]) - math.pi / 2
        overturn.terminal = True
        overturn.direction = 1
        return rhs, [impact, overturn]

    t = 0.0
    state = "rest"
    y = None
    side = 1
    impacts = 0
    last_impact = -math.inf
    cpu0 = time.process_time()
    while t < T:
        if state == "rest":
            tu = rest_until_uplift(t)
            if tu == math.inf:
                break
            t = tu
            events.append((t, "uplift", ug(t)))
            side = -1 if ug(t) > 0 else 1
            if a.model == "housner":
                y = [0.0, 0.0]
            else:
                chi0 = max(chi_m, math.sqrt(l))
                y = [side * chi0, 0.0, 0.0, side * p * l / chi0]
            state = "rocking"
            continue
        make = housner_segment if a.model == "housner" else complex_segment
        rhs, evs = make(t, y, side)
        sel = (t_out > t) & (t_out <= T)
        sol = solve_ivp(rhs, (t, T), y, method=a.method, rtol=a.rtol, atol=atol, events=evs,
                        t_eval=t_out[sel], dense_output=False)
        if sol.status < 0:
            raise SystemExit("solve_ivp failed at t = %.9f: %s" % (t, sol.message))
        t_end = sol.t_events[1][0] if len(sol.t_events[1]) else T
        # Impacts in order; the first that sends the block to rest ends the
        # segment (Housner: every impact does, its state jumps).
        cut = None
        rest = False
        for k, ti in enumerate(sol.t_events[0]):
            if ti <= t:
                continue  # the start itself
            if ti > t_end:
                break
            yi = sol.y_events[0][k]
            v = yi[1] if a.model == "housner" else alpha * yi[2]
            impacts += 1
            events.append((ti, "impact", v))
            rest = ti - last_impact < REST_INTERVAL_S or (a.model == "complex" and energy(yi) < 2 * v_min)
            last_impact = ti
            if rest:
                cut = ti
                break
            if a.model == "housner":
                cut = ti
                side = -side
                y = [0.0, yi[1] * mu]
                break
        t_stop = cut if cut is not None else t_end
        keep = sol.t <= t_stop
        idx = np.searchsorted(t_out, sol.t[keep])
        theta_out[idx] = sol.y[0][keep] * (1.0 if a.model == "housner" else alpha)
        theta_dot_out[idx] = sol.y[1 if a.model == "housner" else 2][keep] * (1.0 if a.model == "housner" else alpha)
        if cut is not None:
            if rest:
                events.append((cut, "rest", 0.0))
                state = "rest"
                last_impact = -math.inf
            t = cut
            continue
        if len(sol.t_events[1]):
            events.append((t_end, "overturn", 0.0))
            break
        t = T
    cpu = time.process_time() - cpu0

    imp = [e[0] for e in events if e[1] == "impact"]
    out = {"model": a.model, "method": a.method, "cpu_solve_s": cpu, "impacts": impacts,
           "first_impact_s": imp[0] if imp else None, "last_impact_s": imp[-1] if imp else None,
           "peak_abs_theta": float(np.max(np.abs(theta_out)))}
    print(json.dumps(out))
    if a.out:
        with open(a.out, "w") as f:
            f.write("time,theta,theta_dot\n")
            f.write("".join("%r,%r,%r\n" % row for row in
                            zip(t_out.tolist(), theta_out.tolist(), theta_dot_out.tolist())))
    if a.events:
        with open(a.events, "w") as f:
            f.write("time,kind,value\n")
            for e in events:
                f.write("%.9f,%s,%.9g\n" % e)


if __name__ == "__main__":
    main()
