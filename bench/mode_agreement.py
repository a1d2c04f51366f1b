#!/usr/bin/env python3
"""The mode agreement a perfect model gets, per rest threshold (docs/compare.md).

Usage: mode_agreement.py RAW, where RAW.truth.csv is `rocklab synth
--assembly`'s truth (the stack model's angles and its `mode` column) and
RAW.theta.csv is `rocklab reconstruct`'s output of RAW (two bodies). The
measured mode is read as compare::MeasuredMode reads it (each interface's
relative angle against the threshold); it is compared with the truth's
mode, from the reconstructed angles and from the truth's own angles.
"""
import csv
import sys


def mode(theta, rest):
    out, below = "", 0.0
    for t in theta:
        r = t - below
        out += "R" if r > rest else "L" if r < -rest else "C"
        below = t
    return out


def main():
    raw = sys.argv[1]
    rec = list(csv.DictReader(open(raw + ".theta.csv")))
    truth = list(csv.DictReader(open(raw + ".truth.csv")))
    n = min(len(rec), len(truth))
    for rest in (0.0, 5e-4, 1e-3, 2e-3, 4e-3):
        measured = exact = 0
        for i in range(n):
            m = truth[i]["mode"]
            measured += mode([float(rec[i]["theta_1"]), float(rec[i]["theta_2"])], rest) == m
            exact += mode([float(truth[i]["theta_1"]), float(truth[i]["theta_2"])], rest) == m
        print(f"rest {rest:g} rad: reconstructed {measured / n:.4f}, truth's angles {exact / n:.4f} ({n} samples)")


if __name__ == "__main__":
    main()
