#!/usr/bin/env python3
"""Start-up and memory of the rocklab command (docs/performance.md, "Start-up").

    python3 bench/startup.py [--build build] [--work DIR] [--run-seconds 600] [--daq-speed 20] [--only startup]

(bench/run.sh runs it after figures.py with the same arguments; it runs
when --only is not given or names `startup`.) What it measures, each
beside its target of issue 33:
- `rocklab --version` and `rocklab simulate --help`: CPU (user + sys) and
  peak RSS from /usr/bin/time -v, the median of 21 runs, and perf stat's
  task-clock over 50 runs when perf is there; the shared objects the
  dynamic linker loaded (LD_DEBUG=files), as tests/tools/startup_test.cpp
  counts them.
- `rocklab run --max` on figures.py's 600 s, 1 kHz record with the
  README's four variants: peak RSS.
- the daemons on the same record in a private network namespace
  (unshare -n, loopback, ttl=0; DESIGN.md): record, model (four
  variants), compare and monitor as processes, their peak RSS (VmHWM read
  from /proc just before each is stopped), and daq (no video input) paced
  at --speed N, by /usr/bin/time -v. Needs root for the namespace; without
  it the daemons' line says so.
"""

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import figures  # noqa: E402  (synth, RIG, VARIANTS, UDPM, Table, load)


def time_v(cmd, env=None):
    """(cpu_s, max_rss_mb) of cmd by GNU time -v."""
    r = subprocess.run(["/usr/bin/time", "-v"] + cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                       text=True, env=env)
    if r.returncode != 0:
        sys.exit("startup bench: %s failed: %s" % (" ".join(cmd), r.stderr[-2000:]))
    user = float(re.search(r"User time \(seconds\): ([\d.]+)", r.stderr).group(1))
    system = float(re.search(r"System time \(seconds\): ([\d.]+)", r.stderr).group(1))
    rss_kb = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", r.stderr).group(1))
    return user + system, rss_kb / 1024.0


def perf_task_clock_ms(cmd, runs=50):
    """perf stat's task-clock (ms) per run, mean of `runs`; None without perf."""
    try:
        r = subprocess.run(["perf", "stat", "-r", str(runs), "-x", ","] + cmd, stdout=subprocess.DEVNULL,
                           stderr=subprocess.PIPE, text=True)
    except FileNotFoundError:
        return None
    for line in r.stderr.splitlines():
        f = line.split(",")
        if len(f) > 2 and f[2].startswith("task-clock"):
            return float(f[0])
    return None


def loaded_objects(cmd):
    with tempfile.TemporaryDirectory() as d:
        env = dict(os.environ, LD_DEBUG="files", LD_DEBUG_OUTPUT=os.path.join(d, "ld"))
        subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, check=True)
        names = set()
        for f in os.listdir(d):
            with open(os.path.join(d, f)) as fh:
                names.update(re.findall(r"file=(\S+) \[\d+\];\s+generating link map", fh.read()))
    return names


def bench_commands(b, t):
    for args in (["--version"], ["simulate", "--help"]):
        cmd = [b] + args
        runs = [time_v(cmd) for _ in range(21)]
        cpu = statistics.median(r[0] for r in runs)
        rss = statistics.median(r[1] for r in runs)
        clock = perf_task_clock_ms(cmd)
        n = len(loaded_objects(cmd))
        name = "rocklab " + " ".join(args)
        note = "%d shared objects loaded; load %.1f" % (n, figures.load())
        if clock is not None:
            t.add(name + " CPU (perf task-clock)", "%.2f" % clock, "ms", "<= 5", 5 / clock, note)
        t.add(name + " CPU (time -v, median of 21)", "%.3f" % cpu, "s", "<= 0.005", 0.005 / max(cpu, 1e-3),
              "time -v counts in 10 ms ticks")
        t.add(name + " peak RSS", "%.1f" % rss, "MB", "<= 15", 15 / rss, "median of 21")


DAEMONS = r"""
set -e
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
B="$1"; RIG="$2"; REC="$3"; WORK="$4"; URL="$5"; SPEED="$6"; shift 6
export SPDLOG_LEVEL=warn
"$B" record "$WORK/daemons.lcm" --force --lcm-url "$URL" > "$WORK/record.out" 2>&1 &
rec=$!
"$B" model --rig "$RIG" --lcm-url "$URL" "$@" > "$WORK/model.out" 2>&1 &
model=$!
"$B" compare --lcm-url "$URL" > "$WORK/compare.out" 2>&1 &
cmp=$!
"$B" monitor --lcm-url "$URL" --http 127.0.0.1:0 > "$WORK/monitor.out" 2>&1 &
mon=$!
sleep 1
/usr/bin/time -v "$B" daq --rig "$RIG" --input "$REC" --speed "$SPEED" --lcm-url "$URL" > "$WORK/daq.out" 2> "$WORK/daq.time"
sleep 1
for p in model:$model compare:$cmp monitor:$mon record:$rec; do
  echo "${p%%:*} $(awk '/VmHWM/ {print $2}' /proc/${p##*:}/status)"
done
kill -INT $model $cmp $mon
wait $model $cmp $mon || true
kill -INT $rec
wait $rec || true
echo "daq $(awk -F': ' '/Maximum resident/ {print $2}' "$WORK/daq.time")"
"""


def bench_daemons(b, work, t, rec, seconds, speed):
    script = os.path.join(work, "daemons.sh")
    with open(script, "w") as f:
        f.write(DAEMONS)
    la = figures.load()
    r = subprocess.run(["unshare", "-n", "bash", script, b, figures.RIG, rec, work, figures.UDPM, str(speed)]
                       + figures.VARIANTS, capture_output=True, text=True)
    if r.returncode != 0:
        t.add("daemons' peak RSS", "n/a", "", "<= 24 MB", 0.0,
              "no private network namespace (%s)" % r.stderr.strip()[-200:])
        return
    for line in r.stdout.splitlines():
        name, kb = line.split()
        mb = int(kb) / 1024.0
        t.add("%s peak RSS (%d s test, daq --speed %g)" % (name, seconds, speed), "%.1f" % mb, "MB", "<= 24",
              24 / mb, "udpm in a private namespace; load %.1f" % la)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=figures.DEFAULT_BUILD)
    ap.add_argument("--work", default=None)
    ap.add_argument("--run-seconds", dest="seconds", type=int, default=600)
    ap.add_argument("--daq-speed", dest="speed", type=float, default=20)
    ap.add_argument("--only", default="startup")  # bench/run.sh's --only: runs when it names startup
    a, _ = ap.parse_known_args()
    if "startup" not in a.only.split(","):
        return
    b = os.path.join(a.build, "tools/rocklab")
    work = a.work or tempfile.mkdtemp(prefix="rocklab-startup-")
    os.makedirs(work, exist_ok=True)
    t = figures.Table()
    bench_commands(b, t)
    rec = os.path.join(work, "run%d.csv" % a.seconds)
    figures.synth(b, rec, a.seconds)
    _, _, rss, _ = figures.measure([b, "run", "--rig", figures.RIG, "--input", rec, "--max"] + figures.VARIANTS,
                                   env=dict(os.environ, SPDLOG_LEVEL="warn"))
    t.add("run --max peak RSS (%d s test)" % a.seconds, "%.1f" % rss, "MB", "<= 24", 24 / rss, "load %.1f" %
          figures.load())
    bench_daemons(b, work, t, rec, a.seconds, a.speed)
    print()
    print(t.markdown())


if __name__ == "__main__":
    main()
