#!/usr/bin/env python3
"""`import rocklab` against the command line (docs/python.md, "Speed").

    PYTHONPATH=build/python /usr/bin/python3 bench/python.py [--build build]
        [--work DIR] [--seconds 600] [--repeats 3] [--only simulate,read_log]

- simulate: figure 8 (block 2, 6 mm at 5 Hz, 20 s, 200 Hz outputs), each
  model: rocklab.simulate's CPU (time.process_time around the call: the
  solve, the arrays, the events and the summary) against `rocklab simulate
  --json --out /dev/null`'s CPU (os.wait4: the whole process) and its
  `cpu_time` (the solve alone). Target: the call within 1.1x the
  command's CPU.
- read_log: the log of bench/figures.py's `run` figure (synth of N s at
  1 kHz, `rocklab run --max --log` with its four variants), read whole by
  rocklab.read_log: messages per CPU second into numpy, beside `rocklab
  export --out X.h5` and the raw LogReader floor (rocklab_bench_log_read).
  Target: >= 1 M messages/s.

Best of --repeats (the machine is shared; the load average is printed).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench"))
from figures import RIG, VARIANTS, measure, synth  # noqa: E402  the same inputs as the other figures

import rocklab  # noqa: E402

FIG8 = dict(alpha=0.168, p=3.767, mu=0.942)
SINE = "sine:amp=0.006,freq=5,duration=20,start=0"


def load():
    return os.getloadavg()[0]


def bench_simulate(b, repeats):
    for model in ("housner", "complex"):
        cmd = [b, "simulate", "--model", model, "--alpha", str(FIG8["alpha"]), "--p", str(FIG8["p"]), "--mu",
               str(FIG8["mu"]), "--excitation", SINE, "--duration", "20", "--rate", "200", "--json", "--out",
               os.devnull]
        cli = min(measure(cmd, stdout=subprocess.PIPE) for _ in range(repeats))
        cli_solve = json.loads(cli[3])["cpu_time"]
        calls = []
        for _ in range(repeats):
            c0 = time.process_time()
            r = rocklab.simulate(model, **FIG8, excitation=SINE, duration=20, rate=200)
            calls.append((time.process_time() - c0, r.summary["cpu_time"]))
        call, solve = min(calls)
        print("simulate fig 8 %-8s rocklab.simulate %.4f s CPU (solve %.4f s) | rocklab simulate %.4f s CPU "
              "(solve %.4f s): call / command %.2fx, call / command's solve %.2fx; %d samples, %d impacts; "
              "load %.1f" % (model, call, solve, cli[0], cli_solve, call / cli[0], call / cli_solve,
                             r.summary["samples"], r.summary["impacts"], load()), flush=True)


def bench_read_log(b, build, work, seconds, repeats):
    rec = os.path.join(work, "run%d.csv" % seconds)
    synth(b, rec, seconds)
    log = os.path.join(work, "run%d.lcm" % seconds)
    if not os.path.exists(log):
        subprocess.run([b, "run", "--rig", RIG, "--input", rec, "--max", "--log", log] + VARIANTS, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                       env=dict(os.environ, SPDLOG_LEVEL="warn"))
    size_mb = os.path.getsize(log) / 1e6
    best = None
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.monotonic()
        tables = rocklab.read_log(log)
        cpu, wall = time.process_time() - c0, time.monotonic() - w0
        messages = tables.summary["rows"]
        del tables
        if best is None or cpu < best[0]:
            best = (cpu, wall, messages)
    cpu, wall, messages = best
    h5 = os.path.join(work, "bench_export.h5")
    export = min(measure([b, "export", log, "--out", h5, "--quiet"]) for _ in range(repeats))
    os.remove(h5)
    reader = os.path.join(build, "bench/rocklab_bench_log_read")
    floor = min(measure([reader, log], stdout=subprocess.PIPE) for _ in range(repeats)) if os.path.exists(reader) \
        else None
    print("read_log %d s log (%.0f MB, %d messages): %.2f M messages/s on CPU (%.2f s CPU, %.2f s wall) | "
          "rocklab export --out .h5 %.2f s CPU (%.2f M/s)%s; load %.1f" %
          (seconds, size_mb, messages, messages / cpu / 1e6, cpu, wall, export[0], messages / export[0] / 1e6,
           "" if floor is None else " | raw LogReader %.2f s CPU" % floor[0], load()), flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--work", help="folder for the generated inputs (kept; default: a temporary one)")
    ap.add_argument("--seconds", type=int, default=600)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--only", default="simulate,read_log")
    a = ap.parse_args()
    b = os.path.join(a.build, "tools/rocklab")
    work = a.work or tempfile.mkdtemp(prefix="rocklab-bench-python-")
    os.makedirs(work, exist_ok=True)
    only = set(a.only.split(","))
    print("bench/python.py: %s, rocklab from %s, %d cores, load %.1f; inputs in %s" %
          (time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), os.path.dirname(rocklab.__file__),
           os.cpu_count(), load(), work), flush=True)
    if "simulate" in only:
        bench_simulate(b, a.repeats)
    if "read_log" in only:
        bench_read_log(b, a.build, work, a.seconds, a.repeats)


if __name__ == "__main__":
    main()
