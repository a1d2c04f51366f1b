#!/usr/bin/env python3
"""The fragility fit's independent oracle.

Fits P(x) = Phi(ln(x / theta) / beta) to fragility_data.csv by maximum
likelihood with scipy alone: the log-likelihood from scipy.stats.norm.logcdf
(not rocklab's erfc), maximised over (ln theta, ln beta) by Nelder-Mead (no
derivatives, unlike rocklab's Newton on the probit (a, b)) and then by
Powell from Nelder-Mead's answer; the two must agree. Writes
fragility_oracle.csv beside it, with the versions used and an estimate of
the distance to the true maximiser (one Newton step |H^-1 g| from central
differences of the log-likelihood), which is what the C++ test's tolerance
rests on (tests/sweep/fragility_test.cpp, FragilityOracle.*).

Run with Debian's interpreter (python3-scipy): /usr/bin/python3 fit_lognormal.py
(writes fragility_oracle.csv); with --check it writes nothing and exits 1
unless the committed file holds what scipy computes now (to 1e-7
relative): the ctest External.fragility_oracle, so the committed oracle
cannot drift from its script.
"""

import csv
import os
import platform
import sys

try:
    import numpy as np
    import scipy
    from scipy.optimize import minimize
    from scipy.stats import norm
except ImportError as e:  # a skip (77), a failure under CI=true (tests/skip.h)
    print(f"{e} (Debian: python3-scipy)")
    sys.exit(1 if os.environ.get("CI") == "true" else 77)

here = os.path.dirname(os.path.abspath(__file__))

rows = [r for r in csv.reader(open(os.path.join(here, "fragility_data.csv"))) if r and not r[0].startswith("#")]
assert rows[0] == ["x_g", "trials", "overturned"], rows[0]
x = np.array([float(r[0]) for r in rows[1:]])
n = np.array([float(r[1]) for r in rows[1:]])
m = np.array([float(r[2]) for r in rows[1:]])


def log_likelihood(log_theta, log_beta):
    z = (np.log(x) - log_theta) / np.exp(log_beta)
    return float(np.sum(m * norm.logcdf(z) + (n - m) * norm.logcdf(-z)))


def neg(v):
    return -log_likelihood(v[0], v[1])


start = np.array([np.log(np.median(x)), np.log(0.5)])
nm = minimize(neg, start, method="Nelder-Mead",
              options={"xatol": 1e-12, "fatol": 1e-15, "maxiter": 20000, "maxfev": 40000})
pw = minimize(neg, nm.x, method="Powell", options={"xtol": 1e-12, "ftol": 1e-15, "maxiter": 20000})
assert nm.success and pw.success, (nm.message, pw.message)
best = nm.x if nm.fun <= pw.fun else pw.x
agreement = float(np.max(np.abs(nm.x - pw.x)))

# Distance to the maximiser: one Newton step from central differences
# (step 1e-4 in ln theta and ln beta; the truncation error of the
# derivatives is O(h^2) ~ 1e-8 of the step, far below the step itself).
h = 1e-4
f = lambda a, b: log_likelihood(a, b)
a0, b0 = best
g = np.array([(f(a0 + h, b0) - f(a0 - h, b0)) / (2 * h), (f(a0, b0 + h) - f(a0, b0 - h)) / (2 * h)])
haa = (f(a0 + h, b0) - 2 * f(a0, b0) + f(a0 - h, b0)) / h**2
hbb = (f(a0, b0 + h) - 2 * f(a0, b0) + f(a0, b0 - h)) / h**2
hab = (f(a0 + h, b0 + h) - f(a0 + h, b0 - h) - f(a0 - h, b0 + h) + f(a0 - h, b0 - h)) / (4 * h * h)
hess = np.array([[haa, hab], [hab, hbb]])
newton = np.linalg.solve(hess, -g)
assert np.all(np.linalg.eigvalsh(hess) < 0), "not a maximum"

lines = [
    "# Written by tests/sweep/oracle/fit_lognormal.py from fragility_data.csv\n",
    f"# python {platform.python_version()}, scipy {scipy.__version__}, numpy {np.__version__}\n",
    "# Nelder-Mead (xatol 1e-12, fatol 1e-15) then Powell (xtol 1e-12, ftol 1e-15)\n",
    f"# on (ln theta, ln beta); the two optimisers agree to {agreement:.1e} in ln units;\n",
    f"# one Newton step from the answer moves ln theta by {abs(newton[0]):.1e}, ln beta by {abs(newton[1]):.1e}\n",
    "median_g,beta,log_likelihood,optimiser_agreement_ln,newton_step_ln_theta,newton_step_ln_beta\n",
    f"{np.exp(best[0]):.15g},{np.exp(best[1]):.15g},{-neg(best):.15g},"
    f"{agreement:.3g},{abs(newton[0]):.3g},{abs(newton[1]):.3g}\n",
]
out = os.path.join(here, "fragility_oracle.csv")
if "--check" in sys.argv[1:]:
    committed = [l for l in open(out) if l and not l.startswith("#")][1].split(",")
    now = lines[-1].split(",")
    for name, a, b in zip(("median_g", "beta", "log_likelihood"), committed[:3], now[:3]):
        if abs(float(a) - float(b)) > 1e-7 * abs(float(b)):
            print(f"{out}: {name} {a}, scipy now gives {b}")
            sys.exit(1)
    sys.stdout.write("".join(lines))
    print("the committed oracle is what scipy computes")
    sys.exit(0)
with open(out, "w") as o:
    o.writelines(lines)
sys.stdout.write("".join(lines))
