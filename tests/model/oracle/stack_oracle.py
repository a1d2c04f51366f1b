#!/usr/bin/env python3
"""An independent integration of a stack of rigid rectangular blocks rocking
on a moving table (Housner-type: no sliding, no bounce, no flight), written
apart from rocklab's own code and in another formulation: every body keeps
its three coordinates (x, z, theta of its centre of mass) and each contact
is a set of constraints, solved with its multipliers at every right-hand side
(Newton-Euler with Lagrange multipliers) and at every impact (an impulse
that brings the bodies into the post-impact contacts: angular momentum
conserved about every new contact, the inelastic impact of Housner's rule).

Conventions: table frame, x to the right, z up, angles counter-clockwise.
Bodies bottom-up, interface k under body k (0: the table). A contact is
closed (0), or a pivot on the left corner of the face (+1: the body above
turns counter-clockwise relative to the one below) or on the right corner
(-1). The table's acceleration u_g'' (m/s^2) acts as -m u_g'' on every body.

`--check` runs the oracles that hold this file to closed forms and to an
integration of the single block's own equation written here (docs/models.md,
"Assemblies"); it is ctest's External.stack_oracle.
"""

import argparse
import itertools
import math
import sys

import numpy as np
from scipy.integrate import solve_ivp

G = 9.81  # m/s^2
# Largest step while nothing moves (the state is constant, so the step size
# would grow past the table's push): events are looked for at step ends.
REST_STEP_S = 1e-3
# Largest step while rocking: an event is missed when it is crossed twice in
# one step (rocking of a small amplitude has impacts ~5 ms apart).
MOVING_STEP_S = 2e-3


def rot(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


def perp(v):
    """v turned by +90 degrees (d/dtheta of R(theta) r is perp(R(theta) r))."""
    return np.array([-v[1], v[0]])


class Stack:
    """Rectangles bottom-up: widths and heights (m), masses (kg). `glued`:
    interfaces that never open (a stack glued there is one body)."""

    def __init__(self, widths, heights, masses, glued=()):
        self.n = len(widths)
        self.b = [w / 2 for w in widths]
        self.h = [hh / 2 for hh in heights]
        self.m = list(masses)
        self.inertia = [m * (b * b + h * h) / 3 for m, b, h in zip(self.m, self.b, self.h)]
        self.c = [self.b[0]] + [min(self.b[k - 1], self.b[k]) for k in range(1, self.n)]
        self.glued = set(glued)
        mass = np.repeat(self.m, 3).astype(float)
        mass[2::3] = self.inertia
        self.M = np.diag(mass)

    def rest(self):
        """Coordinates of the stack at rest, centred on x = 0."""
        q = np.zeros(3 * self.n)
        z = 0.0
        for i in range(self.n):
            q[3 * i + 1] = z + self.h[i]
            z += 2 * self.h[i]
        return q

    def angle_below(self, q, k):
        return 0.0 if k == 0 else q[3 * (k - 1) + 2]

    def relative_angle(self, q, k):
        return q[3 * k + 2] - self.angle_below(q, k)

    def _points(self, k, s):
        """The contact point of interface k in the upper body's frame and in
        the lower body's frame (the table's: its own)."""
        e = -s * self.c[k]
        upper = np.array([e, -self.h[k]])
        lower = np.array([e, self.h[k - 1]]) if k > 0 else np.array([e, 0.0])
        return upper, lower

    def constraints(self, q, v, mode):
        """Rows of the constraint Jacobian C, the right-hand side gamma of
        C a = gamma, and for each interface its rows (point, [rotation])."""
        rows, gamma, where = [], [], []
        for k, s in enumerate(mode):
            ru, rl = self._points(k, s)
            iu = 3 * k
            tu, wu = q[iu + 2], v[iu + 2]
            au = rot(tu) @ ru
            first = len(rows)
            for d in range(2):
                row = np.zeros(3 * self.n)
                row[iu + d] = 1.0
                row[iu + 2] = perp(au)[d]
                g = au[d] * wu * wu
                if k > 0:
                    il = 3 * (k - 1)
                    tl, wl = q[il + 2], v[il + 2]
                    al = rot(tl) @ rl
                    row[il + d] = -1.0
                    row[il + 2] = -perp(al)[d]
                    g -= al[d] * wl * wl
                rows.append(row)
                gamma.append(g)
            if s == 0:
                row = np.zeros(3 * self.n)
                row[iu + 2] = 1.0
                if k > 0:
                    row[3 * (k - 1) + 2] = -1.0
                rows.append(row)
                gamma.append(0.0)
            where.append((first, len(rows)))
        return np.array(rows), np.array(gamma), where

    def contact(self, q, k, lam, rows):
        """Normal force (N, along the lower face's normal) and moment about
        the contact point (N m, counter-clockwise) on the body above
        interface k, from the multipliers (or impulses) of its rows."""
        first, last = rows
        force = -lam[first:first + 2]
        moment = -lam[first + 2] if last - first == 3 else 0.0
        normal = rot(self.angle_below(q, k)) @ np.array([0.0, 1.0])
        return float(force @ normal), float(moment)

    def solve(self, q, v, mode, accel):
        C, gamma, where = self.constraints(q, v, mode)
        f = np.zeros(3 * self.n)
        for i in range(self.n):
            f[3 * i] = -self.m[i] * accel
            f[3 * i + 1] = -self.m[i] * G
        x = np.linalg.solve(self._kkt(C), np.concatenate([f, gamma]))
        return x[:3 * self.n], x[3 * self.n:], where

    def _kkt(self, C):
        n3, nc = 3 * self.n, C.shape[0]
        kkt = np.zeros((n3 + nc, n3 + nc))
        kkt[:n3, :n3] = self.M
        kkt[:n3, n3:] = C.T
        kkt[n3:, :n3] = C
        return kkt

    def energy(self, q, v):
        kinetic = 0.5 * v @ self.M @ v
        potential = sum(self.m[i] * G * q[3 * i + 1] for i in range(self.n))
        return kinetic + potential

    def impact(self, q, v, mode, k):
        """Post-impact velocities and mode after the pivot of interface k
        closes. Candidates in order of fewest changes: k on its other corner
        or closed; closed interfaces kept closed or opened. The first whose
        impulses push (normal >= 0, a closed face's moment within its width)
        and whose opened interfaces move apart is taken."""
        closed = [j for j, s in enumerate(mode) if s == 0 and j != k and j not in self.glued]
        candidates = []
        for sk in (-mode[k], 0):
            for opened in itertools.product((0, 1, -1), repeat=len(closed)):
                new = list(mode)
                new[k] = sk
                for j, s in zip(closed, opened):
                    new[j] = s
                changes = sum(1 for j in closed if new[j] != 0) + (sk == 0)
                candidates.append((changes, new))
        candidates.sort(key=lambda c: c[0])
        for _, new in candidates:
            C, _, where = self.constraints(q, v, new)
            x = np.linalg.solve(self._kkt(C), np.concatenate([self.M @ v, np.zeros(C.shape[0])]))
            vp, imp = x[:3 * self.n], x[3 * self.n:]
            ok = True
            for j, s in enumerate(new):
                pn, pm = self.contact(q, j, imp, where[j])
                if pn < -1e-12 * (1 + abs(pm)):
                    ok = False
                if s == 0 and abs(pm) > self.c[j] * pn * (1 + 1e-12) + 1e-15:
                    ok = False
                opening = s != 0 and (j == k or mode[j] == 0)
                if opening:
                    rel = vp[3 * j + 2] - (vp[3 * (j - 1) + 2] if j > 0 else 0.0)
                    if rel * s < 0:
                        ok = False
            if ok:
                return vp, new
        raise RuntimeError("no consistent post-impact contact at t, interface %d" % k)

    def place(self, theta, omega, mode):
        """Coordinates and velocities (three per body) of the stack whose
        bodies have the absolute angles theta (rad) and rates omega (rad/s),
        each standing on the one below (the table at x = 0 for the bottom)
        at the contact point of its interface's state in `mode`: a pivot's
        corner, or a closed face's centre. No slide: a contact point moves
        with both bodies."""
        q = np.zeros(3 * self.n)
        v = np.zeros(3 * self.n)
        for k, s in enumerate(mode):
            ru, rl = self._points(k, s)
            if k == 0:
                p, vp = rl, np.zeros(2)
            else:
                gl, tl, wl = q[3 * k - 3:3 * k - 1], theta[k - 1], omega[k - 1]
                arm = rot(tl) @ rl
                p, vp = gl + arm, v[3 * k - 3:3 * k - 1] + wl * perp(arm)
            arm = rot(theta[k]) @ ru
            q[3 * k:3 * k + 2] = p - arm
            q[3 * k + 2] = theta[k]
            v[3 * k:3 * k + 2] = vp - omega[k] * perp(arm)
            v[3 * k + 2] = omega[k]
        return q, v

    def impact_rules(self, q, v, mode, k, tau=1e-6):
        """The impact of interface k closing as rocklab's model states its
        rule (docs/models.md, "Impacts: the contact states after"), solved
        here in this file's coordinates: the first contact state, fewest
        changes first, whose impulses all push ("pushing"); failing that,
        the state of least tensile shortfall if it is within every
        interface's preload, the weight above it over tau ("preload");
        failing both, the same two with the interfaces that pivot through
        the impact held, their normal impulse unchecked ("held"). Returns
        (rule, velocities after, mode after), or ("none", None, None)."""
        n = self.n
        scale = sum(self.m[i] * (np.hypot(v[3 * i], v[3 * i + 1]) + abs(v[3 * i + 2]) * self.h[i])
                    for i in range(n))
        tol = 1e-11 * scale
        rate_k = v[3 * k + 2] - (v[3 * k - 1] if k > 0 else 0.0)
        allowance = [tau * G * sum(self.m[j:]) for j in range(n)]
        closed = [j for j, s in enumerate(mode) if s == 0 and j != k and j not in self.glued]
        candidates = []
        for sk in (-mode[k], 0, mode[k]):
            if sk != 0 and k in self.glued:
                continue
            for code in range(3 ** len(closed)):
                new = list(mode)
                new[k] = sk
                changes = (sk == 0) + (2 * n + 2 if sk == mode[k] else 0)
                for j in closed:
                    new[j] = (0, 1, -1)[code % 3]
                    code //= 3
                    changes += new[j] != 0
                candidates.append((changes, new))
        candidates.sort(key=lambda c: c[0])

        def shortfall(new, hold):
            C, _, where = self.constraints(q, v, new)
            x = np.linalg.solve(self._kkt(C), np.concatenate([self.M @ v, np.zeros(C.shape[0])]))
            vp, imp = x[:3 * n], x[3 * n:]
            worst = 0.0
            for j, s in enumerate(new):
                if s != 0 and (j == k or mode[j] == 0):
                    rel = vp[3 * j + 2] - (vp[3 * j - 1] if j > 0 else 0.0)
                    if s * rel < -1e-12 * (abs(rate_k) + 1):
                        return vp, None  # an interface it opens would not open
                pn, pm = self.contact(q, j, imp, where[j])
                if hold and s != 0 and j != k and mode[j] != 0:
                    continue
                worst = max(worst, (-pn - tol) / allowance[j])
                if s == 0:
                    worst = max(worst, (abs(pm) - self.c[j] * pn - tol * self.c[j]) / (self.c[j] * allowance[j]))
            return vp, worst

        for hold in (False, True):
            best = None
            for _, new in candidates:
                vp, worst = shortfall(new, hold)
                if worst is None:
                    continue
                if worst == 0.0:
                    return ("held" if hold else "pushing"), vp, new
                if best is None or worst < best[0]:
                    best = (worst, vp, new)
            if best is not None and best[0] <= 1.0:
                return ("held" if hold else "preload"), best[1], best[2]
        return "none", None, None


def simulate(stack, accel, duration, mode=None, q0=None, v0=None, rtol=1e-11, atol=1e-13, max_events=100000,
             rest_step_s=None):
    """Integrates; returns the events [(t, kind, interface, mode after)] and
    the final (q, v, mode). kind: 'uplift', 'impact', 'overturn'.
    rest_step_s: the largest step at rest (REST_STEP_S; a table push that
    only grows can take any)."""
    rest_step_s = REST_STEP_S if rest_step_s is None else rest_step_s
    q = stack.rest() if q0 is None else np.array(q0, float)
    v = np.zeros(3 * stack.n) if v0 is None else np.array(v0, float)
    mode = [0] * stack.n if mode is None else list(mode)
    t = 0.0
    events = []
    n3 = 3 * stack.n

    def rhs(tt, y):
        a, _, _ = stack.solve(y[:n3], y[n3:], mode, accel(tt))
        return np.concatenate([y[n3:], a])

    while t < duration and len(events) < max_events:
        fns, meta = [], []
        for k, s in enumerate(mode):
            if s == 0 and k not in stack.glued:
                for side in (1, -1):  # x_p reaches -c (pivot left, +1) or +c (right, -1)
                    def uplift(tt, y, k=k, side=side):
                        _, lam, where = stack.solve(y[:n3], y[n3:], mode, accel(tt))
                        pn, pm = stack.contact(y[:n3], k, lam, where[k])
                        return stack.c[k] * pn + side * pm
                    uplift.terminal, uplift.direction = True, -1
                    fns.append(uplift)
                    meta.append(("uplift", k, side))
            elif s != 0:
                def close(tt, y, k=k, s=s):
                    return s * stack.relative_angle(y[:n3], k)
                close.terminal, close.direction = True, -1
                fns.append(close)
                meta.append(("impact", k, s))

                def over(tt, y, k=k, s=s):
                    return math.pi / 2 - s * stack.relative_angle(y[:n3], k)
                over.terminal, over.direction = True, -1
                fns.append(over)
                meta.append(("overturn", k, s))
        resting = all(s == 0 for s in mode)  # nothing moves: the steps would pass the table's push
        sol = solve_ivp(rhs, (t, duration), np.concatenate([q, v]), method="DOP853", rtol=rtol, atol=atol,
                        events=fns or None, max_step=rest_step_s if resting else MOVING_STEP_S)
        y = sol.y[:, -1]
        t = sol.t[-1]
        q, v = y[:n3].copy(), y[n3:].copy()
        if sol.status != 1:
            break
        hit = [i for i, te in enumerate(sol.t_events) if len(te)]
        i = min(hit, key=lambda j: sol.t_events[j][0])
        t = float(sol.t_events[i][0])
        ye = sol.y_events[i][0]
        q, v = ye[:n3].copy(), ye[n3:].copy()
        kind, k, s = meta[i]
        if kind == "uplift":
            mode[k] = s
            events.append((t, "uplift", k, list(mode)))
        elif kind == "impact":
            v, mode = stack.impact(q, v, mode, k)
            events.append((t, "impact", k, list(mode)))
        else:
            events.append((t, "overturn", k, list(mode)))
            break
    return events, (q, v, mode)


def single_block(b, hc, mass, inertia_g, accel, duration, theta0=0.0, omega0=0.0, rtol=1e-11, atol=1e-13):
    """One rigid body rocking on its base corners (half-width b, centre of
    mass hc above the base), written from its own equation of motion about
    the pivot: I_O theta'' = m (-g r_x + u_g'' r_z), r = R(theta) (s b, hc),
    and Housner's rule at impacts: omega+ = (1 - 2 m b^2 / I_O) omega-.
    Returns the impact times (and the uplift time)."""
    i_o = inertia_g + mass * (b * b + hc * hc)
    mu = 1 - 2 * mass * b * b / i_o
    t, th, om = 0.0, theta0, omega0
    s = 0 if th == 0 and om == 0 else (1 if th > 0 or (th == 0 and om > 0) else -1)
    times = []

    if s == 0:  # at rest until the table's push passes the restoring moment about a corner
        def up(tt, y, side):
            return G * b - side * accel(tt) * hc
        while True:
            ev = [lambda tt, y: up(tt, y, 1), lambda tt, y: up(tt, y, -1)]
            for e in ev:
                e.terminal, e.direction = True, -1
            sol = solve_ivp(lambda tt, y: [0.0], (t, duration), [0.0], events=ev, rtol=rtol, atol=atol,
                            method="DOP853", max_step=REST_STEP_S)
            if sol.status != 1:
                return times
            i = 0 if len(sol.t_events[0]) else 1
            t = float(sol.t_events[i][0])
            s = 1 if i == 0 else -1  # the table pushed to +x: the block turns counter-clockwise on its left corner
            times.append(("uplift", t))
            break

    def rhs(tt, y, s):
        r = rot(y[0]) @ np.array([s * b, hc])
        return [y[1], mass * (-G * r[0] + accel(tt) * r[1]) / i_o]

    while t < duration:
        def close(tt, y, s=s):
            return s * y[0]
        close.terminal, close.direction = True, -1

        def over(tt, y, s=s):
            return math.pi / 2 - s * y[0]
        over.terminal, over.direction = True, -1
        sol = solve_ivp(lambda tt, y: rhs(tt, y, s), (t, duration), [th, om], events=[close, over], rtol=rtol,
                        atol=atol, method="DOP853", max_step=MOVING_STEP_S)
        if sol.status != 1:
            break
        if len(sol.t_events[1]):
            times.append(("overturn", float(sol.t_events[1][0])))
            break
        t = float(sol.t_events[0][0])
        th, om = 0.0, mu * sol.y_events[0][0][1]
        s = -s
        times.append(("impact", t))
    return times


def check():
    failures = []

    def expect(ok, what):
        print(("ok   " if ok else "FAIL ") + what)
        if not ok:
            failures.append(what)

    sine = lambda amp, f: (lambda t: -amp * (2 * math.pi * f) ** 2 * math.sin(2 * math.pi * f * t))

    # 1. One block: the constrained formulation against the block's own
    #    equation about its pivot and Housner's coefficient. Impact times to
    #    1e-6 s (both integrations at rtol 1e-11: their own error ~1e-9 s).
    w, hgt, m = 0.25, 1.0, 100.0
    one = Stack([w], [hgt], [m])
    acc = sine(0.02, 2.0)
    ev, _ = simulate(one, acc, 3.0)
    ref = single_block(w / 2, hgt / 2, m, one.inertia[0], acc, 3.0)
    mine = [(kind, t) for t, kind, _, _ in ev]
    same = len(mine) == len(ref) and all(a[0] == b[0] and abs(a[1] - b[1]) < 1e-6 for a, b in zip(mine, ref))
    expect(same and len(ref) > 5, "one block = its own equation (%d events, largest time difference %.2e s)" %
           (len(ref), max((abs(a[1] - b[1]) for a, b in zip(mine, ref)), default=float("nan"))))

    # 2. Uplift of a two-block stack from rest under a ramp u_g'' = k t:
    #    a/g = min(b2/h2, (m1 + m2) b1 / (m1 h1 + m2 (2 h1 + h2))) (half
    #    sizes, bottom block 1), the first term the upper block alone, the
    #    second the stack as one body. Time to 1e-9 s.
    ramp = 0.5  # m/s^3
    for widths, heights, masses, who in (([0.4, 0.2], [0.6, 0.8], [300.0, 50.0], 1),
                                         ([0.3, 0.4], [1.2, 0.5], [200.0, 150.0], 0)):
        st = Stack(widths, heights, masses)
        b1, b2 = widths[0] / 2, widths[1] / 2
        h1, h2 = heights[0] / 2, heights[1] / 2
        m1, m2 = masses
        upper = min(b1, b2) / h2
        whole = (m1 + m2) * b1 / (m1 * h1 + m2 * (2 * h1 + h2))
        t_star = min(upper, whole) * G / ramp
        ev, _ = simulate(st, lambda t: ramp * t, t_star + 0.01, max_events=1, rest_step_s=np.inf)
        ok = len(ev) == 1 and abs(ev[0][0] - t_star) < 1e-9 and ev[0][2] == who
        expect(ok, "two-block uplift at a/g = %.6f, interface %d (got %s)" %
               (min(upper, whole), who, ev[:1]))

    # 3. A stack glued at its interface = one body of the combined section.
    widths, heights, masses = [0.3, 0.3], [0.7, 0.5], [210.0, 150.0]
    glued = Stack(widths, heights, masses, glued={1})
    m_all = sum(masses)
    z1, z2 = heights[0] / 2, heights[0] + heights[1] / 2
    hc = (masses[0] * z1 + masses[1] * z2) / m_all
    i_g = sum(glued.inertia) + masses[0] * (z1 - hc) ** 2 + masses[1] * (z2 - hc) ** 2
    acc = sine(0.02, 2.0)
    ev, _ = simulate(glued, acc, 3.0)
    ref = single_block(widths[0] / 2, hc, m_all, i_g, acc, 3.0)
    mine = [(kind, t) for t, kind, _, _ in ev]
    same = len(mine) == len(ref) and all(a[0] == b[0] and abs(a[1] - b[1]) < 1e-6 for a, b in zip(mine, ref))
    expect(same and len(ref) > 3, "glued stack = the combined block (%d events)" % len(ref))

    # 4. A massless upper block: the lower block moves as if alone (its
    #    impacts to 1e-6 s), while the upper one rocks on it.
    light = Stack([0.3, 0.12], [1.0, 0.6], [200.0, 200.0 * 1e-10])
    acc = sine(0.015, 2.5)
    ev, _ = simulate(light, acc, 3.0)
    ref = single_block(0.15, 0.5, 200.0, light.inertia[0], acc, 3.0)
    # (the run ends when the light block falls off: compared up to then)
    base = [(kind, t) for t, kind, k, _ in ev if k == 0]
    ref = [r for r in ref if r[1] < ev[-1][0]]
    same = len(base) == len(ref) and all(a[0] == b[0] and abs(a[1] - b[1]) < 1e-6 for a, b in zip(base, ref))
    expect(same and len(base) >= 4 and any(k == 1 for _, _, k, _ in ev),
           "massless upper block: the lower alone (%d base events, %d of the upper)" %
           (len(base), sum(1 for e in ev if e[2] == 1)))

    # 5. Energy between impacts: a two-block stack released tilted with both
    #    interfaces open, no table motion; T + V constant to 1e-9 relative
    #    along each flight, lost at impacts only.
    st = Stack([0.4, 0.25], [1.0, 0.8], [250.0, 120.0])
    q = st.rest()
    mode = [1, 1]
    # tilt: body 0 by 0.05 rad about its left corner, body 1 by 0.05 more on
    # body 0's top left corner
    th0, th1 = 0.05, 0.10
    p0 = np.array([-st.b[0], 0.0])
    g0 = p0 + rot(th0) @ np.array([st.b[0], st.h[0]])
    corner = g0 + rot(th0) @ np.array([-st.c[1], st.h[0]])
    g1 = corner + rot(th1) @ np.array([st.c[1], st.h[1]])
    q[0:3] = [g0[0], g0[1], th0]
    q[3:6] = [g1[0], g1[1], th1]
    drift = []
    t0, y0 = 0.0, None

    def still(t):
        return 0.0

    ev, _ = simulate(st, still, 3.0, mode=mode, q0=q, max_events=6)
    # integrate each flight again and watch the energy along it
    qq, vv, md, tt = q, np.zeros(6), list(mode), 0.0
    for (te, kind, k, after) in ev:
        n3 = 6
        sol = solve_ivp(lambda t, y: np.concatenate([y[n3:], st.solve(y[:n3], y[n3:], md, 0.0)[0]]), (tt, te),
                        np.concatenate([qq, vv]), method="DOP853", rtol=1e-11, atol=1e-13, dense_output=True)
        e = [st.energy(sol.y[:n3, i], sol.y[n3:, i]) for i in range(sol.y.shape[1])]
        drift.append((max(e) - min(e)) / abs(e[0]))
        qq, vv = sol.y[:n3, -1], sol.y[n3:, -1]
        if kind == "impact":
            vv, md = st.impact(qq, vv, md, k)
        else:
            md = list(after)
        tt = te
    expect(len(ev) >= 3 and max(drift) < 1e-9, "energy of a free two-block stack between %d events: largest "
           "relative drift %.1e" % (len(ev), max(drift) if drift else float("nan")))

    # 6. The impact map against a hand computation: one block, Housner's
    #    coefficient 1 - 1.5 sin^2(alpha) on the angular velocity.
    blk = Stack([0.3], [1.2], [80.0])
    alpha = math.atan(0.15 / 0.6)
    q = blk.rest()
    v = np.zeros(3)
    omega = -0.7  # turning clockwise back onto the table on its left... (mode +1 closing)
    v[2] = omega
    r = blk.rest()[0:2] - np.array([-0.15, 0.0])
    v[0:2] = omega * perp(r)
    vp, new = blk.impact(q, v, [1], 0)
    expect(new == [-1] and abs(vp[2] / omega - (1 - 1.5 * math.sin(alpha) ** 2)) < 1e-12,
           "impact map: omega+/omega- = %.12f, Housner %.12f" % (vp[2] / omega, 1 - 1.5 * math.sin(alpha) ** 2))

    return 1 if failures else 0


MODE_LETTER = {0: "C", 1: "L", -1: "R"}


def compare(a):
    """Integrates the stack and sine the arguments give and compares its
    events with the CSV `time,kind,interface,mode` another integration wrote
    (rocklab's StackRun test): the same kinds, interfaces and modes in the
    same order, times within --tolerance s. Exit 0 when they agree."""
    floats = lambda text: [float(x) for x in text.split(",")]
    st = Stack(floats(a.widths), floats(a.heights), floats(a.masses))
    amp, freq = floats(a.sine)
    accel = lambda t: -amp * (2 * math.pi * freq) ** 2 * math.sin(2 * math.pi * freq * t)
    ev, _ = simulate(st, accel, a.duration)
    mine = [(t, kind, k, "".join(MODE_LETTER[x] for x in mode)) for t, kind, k, mode in ev]
    theirs = []
    with open(a.compare) as f:
        header = f.readline().strip()
        if header != "time,kind,interface,mode":
            print("%s: header %r, not time,kind,interface,mode" % (a.compare, header))
            return 2
        for line in f:
            t, kind, k, mode = line.strip().split(",")
            theirs.append((float(t), kind, int(k), mode))
    worst = 0.0
    for i, (m, o) in enumerate(zip(mine, theirs)):
        if m[1:] != o[1:]:
            print("event %d differs: reference %s, compared %s" % (i, m, o))
            return 1
        worst = max(worst, abs(m[0] - o[0]))
    if len(mine) != len(theirs):
        print("%d events in the reference, %d compared" % (len(mine), len(theirs)))
        return 1
    print("%d events agree; largest time difference %.3g s" % (len(mine), worst))
    return 0 if worst <= a.tolerance else 1


def compare_impacts(a):
    """Solves the impacts the CSV lists (another code's pre-impact states
    and its answers: rocklab's StackImpact test) with impact_rules and
    compares: the same rule and contact state after, every body's rate
    after within --rate-tolerance rad/s. Columns: k, mode_1..n (0, 1, -1),
    theta_1..n (rad), omega_1..n (rad/s), rule (pushing, preload, held or
    none), mode_after_1..n, omega_after_1..n. Exit 0 when every row agrees."""
    floats = lambda text: [float(x) for x in text.split(",")]
    st = Stack(floats(a.widths), floats(a.heights), floats(a.masses))
    n = st.n
    counts, worst, rows = {}, 0.0, 0
    with open(a.impacts) as f:
        f.readline()
        for line_no, line in enumerate(f, start=2):
            cells = line.strip().split(",")
            if len(cells) != 2 + 5 * n:
                print("%s:%d: %d cells, not %d" % (a.impacts, line_no, len(cells), 2 + 5 * n))
                return 2
            k = int(cells[0])
            mode = [int(x) for x in cells[1:1 + n]]
            theta = [float(x) for x in cells[1 + n:1 + 2 * n]]
            omega = [float(x) for x in cells[1 + 2 * n:1 + 3 * n]]
            rule = cells[1 + 3 * n]
            mode_after = [int(x) for x in cells[2 + 3 * n:2 + 4 * n]]
            omega_after = [float(x) for x in cells[2 + 4 * n:2 + 5 * n]]
            q, v = st.place(theta, omega, mode)
            mine, vp, new = st.impact_rules(q, v, mode, k)
            rows += 1
            counts[mine] = counts.get(mine, 0) + 1
            if mine != rule:
                print("%s:%d: interface %d of %s: rule %s here, %s compared" % (a.impacts, line_no, k, mode, mine, rule))
                return 1
            if mine == "none":
                continue
            if new != mode_after:
                print("%s:%d: interface %d of %s: state after %s here, %s compared" % (a.impacts, line_no, k, mode,
                                                                                       new, mode_after))
                return 1
            diff = max(abs(vp[3 * i + 2] - omega_after[i]) for i in range(n))
            worst = max(worst, diff)
            if diff > a.rate_tolerance:
                print("%s:%d: interface %d of %s: rates after differ by %.3g rad/s" % (a.impacts, line_no, k, mode, diff))
                return 1
    print("%d impacts agree (%s); largest rate difference %.3g rad/s" %
          (rows, ", ".join("%s %d" % kv for kv in sorted(counts.items())), worst))
    return 0 if rows > 0 else 1


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="run the oracles (ctest External.stack_oracle)")
    ap.add_argument("--compare", metavar="EVENTS.csv", help="compare another integration's events (time,kind,"
                    "interface,mode) with this one's for the stack and sine below")
    ap.add_argument("--widths", help="m, bottom-up, comma-separated")
    ap.add_argument("--heights", help="m")
    ap.add_argument("--masses", help="kg")
    ap.add_argument("--sine", help="AMP,FREQ: the table's displacement AMP sin(2 pi FREQ t), m and Hz")
    ap.add_argument("--duration", type=float, help="s")
    ap.add_argument("--tolerance", type=float, default=1e-6, help="largest time difference, s")
    ap.add_argument("--impacts", metavar="IMPACTS.csv", help="compare another code's impacts (compare_impacts: "
                    "the columns) with impact_rules for the stack above")
    ap.add_argument("--rate-tolerance", type=float, default=1e-9, help="largest rate difference after, rad/s")
    a = ap.parse_args()
    if a.check:
        sys.exit(check())
    if a.compare:
        sys.exit(compare(a))
    if a.impacts:
        sys.exit(compare_impacts(a))
    ap.print_help()


if __name__ == "__main__":
    main()
