#!/usr/bin/env python3
"""The coverage table of docs/fit_coverage.md from the per-record CSV files
of rocklab_bench_fit_coverage (--csv), also while a run is going.

    python3 bench/fit_coverage_table.py impacts.csv free.csv forced.csv

Per method and parameter: the records that say converged, the percentage
whose truth lies within 1 and 1.96 stated standard errors (nominal 68.3 and
95.0), the binomial standard deviation of that percentage for that many
records, and the rms of error / stated error.
"""
import csv
import math
import sys


def rows(path):
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            if r["error"] or not r["alpha"]:
                yield r, None
                continue
            yield r, {k: float(r[k]) for k in r if k not in ("method", "error")}


def main(paths):
    print("| method | records | converged | refused | parameter | within 1 se (%) | within 1.96 se (%) "
          "| binomial sd (points, 68/95) | rms(error / stated) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for path in paths:
        data = list(rows(path))
        if not data:
            continue
        method = data[0][0]["method"]
        ok = [d for _, d in data if d is not None and d["converged"] == 1]
        refused = sum(1 for _, d in data if d is None)
        n = len(ok)
        for name in ("alpha", "p", "mu"):
            z = [(d[name] - d[name + "_true"]) / d[name + "_stderr"] for d in ok]
            in68 = 100.0 * sum(abs(v) <= 1.0 for v in z) / max(n, 1)
            in95 = 100.0 * sum(abs(v) <= 1.959964 for v in z) / max(n, 1)
            sd68 = 100.0 * math.sqrt(0.683 * 0.317 / max(n, 1))
            sd95 = 100.0 * math.sqrt(0.95 * 0.05 / max(n, 1))
            rms = math.sqrt(sum(v * v for v in z) / max(n, 1))
            print(f"| {method} | {len(data)} | {n} | {refused} | {name} | {in68:.1f} | {in95:.1f} "
                  f"| {sd68:.1f} / {sd95:.1f} | {rms:.3f} |")


if __name__ == "__main__":
    main(sys.argv[1:])
