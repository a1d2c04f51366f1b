"""The response's sensitivity to the block's parameters (docs/identification.md).

The paper's conclusion: "the responses are significantly more sensitive to
alpha and mu than to p". Measured here on Housner's model as the rms change
of theta(t), relative to the rms of theta, for a 1 % change of alpha, of p,
of mu, and of 1 - mu (the energy lost per impact), on figure 7's forced test
(block 1 of Table 2, a Hanning sine of 6 mm at 3.3 Hz, 7 s) and on a free
decay from 0.14 rad (8 s).

    PYTHONPATH=build/python python3 bench/sensitivity.py
"""
import numpy as np, rocklab
base = dict(alpha=0.235, p=3.884, mu=0.937)
def run(kind, **kw):
    prm = dict(base); prm.update(kw)
    if kind == "forced":
        r = rocklab.simulate(model="housner", excitation="hanning:amp=0.006,freq=3.3,duration=4,start=0.5", duration=7.0, rate=1000.0, **prm)
    else:
        r = rocklab.simulate(model="housner", theta0=0.14, duration=8.0, rate=1000.0, **prm)
    return r.theta
for kind in ("forced", "free"):
    th0 = run(kind)
    scale = np.sqrt(np.mean(th0**2))
    out = []
    for name, val in (("alpha", base["alpha"]*1.01), ("p", base["p"]*1.01), ("mu", base["mu"]*1.01 if base["mu"]*1.01 <= 1 else 1.0), ("mu (1-mu)", 1 - (1-base["mu"])*0.99)):
        key = name.split()[0]
        th = run(kind, **{key: val})
        out.append(f"{name}: rms dtheta {np.sqrt(np.mean((th-th0)**2)):.3e} rad ({np.sqrt(np.mean((th-th0)**2))/scale:.3f} of rms theta)")
    print(kind, f"rms theta {scale:.4f} rad;", "; ".join(out))
