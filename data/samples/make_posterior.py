#!/usr/bin/env python3
"""Writes fig7_block1.posterior.csv: illustrative posterior draws for the demo.

Not a fit: independent Gaussian draws around Table 2's block 1 values
(alpha 0.235 rad, p 3.884 rad/s, mu 0.937), with standard deviations chosen
to make a visible band (alpha 0.002 rad, p 0.02 rad/s, mu 0.005), plus a
noise sigma column (rad) and log_posterior (the log density of the
generating Gaussian, up to a constant), in the layout `rocklab fit
--posterior --samples` writes (one row per draw, a column per parameter).
Seeded: the same file every time. Run from this folder:

    python3 make_posterior.py > fig7_block1.posterior.csv
"""
import math
import random

MEAN = {"alpha": 0.235, "p": 3.884, "mu": 0.937, "sigma": 2.0e-4}
SD = {"alpha": 0.002, "p": 0.02, "mu": 0.005, "sigma": 1.0e-5}
ROWS = 400
SEED = 20051


def main():
    rng = random.Random(SEED)
    names = ["alpha", "p", "mu", "sigma"]
    print(",".join(names + ["log_posterior"]))
    for _ in range(ROWS):
        row = {k: rng.gauss(MEAN[k], SD[k]) for k in names}
        row["mu"] = min(row["mu"], 1.0)
        logp = -0.5 * sum(((row[k] - MEAN[k]) / SD[k]) ** 2 for k in names)
        print(",".join("%.9g" % row[k] for k in names) + ",%.6f" % logp)


if __name__ == "__main__":
    main()
