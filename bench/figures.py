#!/usr/bin/env python3
"""Every performance figure of docs/performance.md beside its target, in one
run. Called by bench/run.sh (which installs scipy and builds the binaries);
see that script for the options. CPU is user + sys of the measured process
(os.wait4), wall is the host clock; the machine's load average is printed
with each figure because the machine is shared.
"""
import argparse
import json
import math
import os
import re
import signal
import statistics
import struct
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The user's build (tools/demo.sh's Release, -O3 with LTO) where it is
# configured, else the test build (tools/test.sh's RelWithDebInfo).
DEFAULT_BUILD = next((os.path.join(ROOT, d) for d in ("build-release", "build")
                      if os.path.exists(os.path.join(ROOT, d, "build.ninja"))), os.path.join(ROOT, "build"))
F = "alpha=0.235,p=3.884,mu=0.937"
VARIANTS = ["--variant", "fitted_complex:complex:" + F, "--variant", "fitted_housner:housner:" + F,
            "--variant", "theory_complex:complex:theoretical", "--variant", "theory_housner:housner:theoretical"]
RIG = os.path.join(ROOT, "data/rigs/block1_rig.toml")
# The Debian python, which python3-scipy installs into (a pyenv one may come first on PATH).
PY = "/usr/bin/python3"
UDPM = "udpm://239.255.76.67:7667?ttl=0"  # DESIGN.md: loopback only, ttl=0


def load():
    return os.getloadavg()[0]


def measure(cmd, env=None, stdout=subprocess.DEVNULL, err_out=None):
    """Runs cmd; returns (cpu_s, wall_s, max_rss_mb, stdout text or None);
    its stderr text is appended to the list err_out when one is given."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        t0 = time.monotonic()
        p = subprocess.Popen(cmd, stdout=out if stdout == subprocess.PIPE else stdout, stderr=err, env=env)
        _, status, ru = os.wait4(p.pid, 0)  # files, not pipes: a full pipe cannot stall the child
        wall = time.monotonic() - t0
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        text = out.read().decode() if stdout == subprocess.PIPE else None
        err_text = err.read().decode(errors="replace")
        if p.returncode != 0:
            sys.exit("bench: %s failed (%d): %s" % (" ".join(cmd), p.returncode, err_text[-2000:]))
        if err_out is not None:
            err_out.append(err_text)
    return ru.ru_utime + ru.ru_stime, wall, ru.ru_maxrss / 1024.0, text


def model_failures(err_text):
    """The model failures `rocklab run` counts in its last line ("run: ...,
    N model failures, ..."); a run without that line counts as failed."""
    m = re.findall(r"(\d+) model failures", err_text)
    return int(m[-1]) if m else 1


class Table:
    def __init__(self):
        self.rows = []

    def add(self, name, value, unit, target, ratio, note=""):
        self.rows.append((name, value, unit, target, ratio, note))
        print("%-46s %12s %-10s target %-14s ratio %6.2f %s" % (name, value, unit, target, ratio, note),
              flush=True)

    def markdown(self):
        lines = ["| figure | measured | target | measured / target | note |", "|---|---|---|---|---|"]
        for name, value, unit, target, ratio, note in self.rows:
            lines.append("| %s | %s %s | %s | %.2f | %s |" % (name, value, unit, target, ratio, note))
        return "\n".join(lines)


def synth(b, out, duration, seed=1):
    if os.path.exists(out):
        return
    amp_dur = duration - 1
    subprocess.run([b, "synth", "--rig", RIG, "--model", "complex", "--alpha", "0.235", "--p", "3.884",
                    "--mu", "0.937", "--excitation", "sine:amp=0.010,freq=3.3,duration=%g,start=0.5" % amp_dur,
                    "--duration", str(duration), "--rate", "1000", "--seed", str(seed), "--out", out,
                    "--truth", out + ".truth.csv"], check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)


def bench_run(b, work, t, seconds, repeats):
    rec = os.path.join(work, "run%d.csv" % seconds)
    synth(b, rec, seconds)
    env = dict(os.environ, SPDLOG_LEVEL="warn")
    for threads in ("1", "0"):  # the default (the handler's thread), and one per variant up to the cores
        best = None
        failures = 0
        for _ in range(repeats):
            la = load()
            errs = []
            r = measure([b, "run", "--rig", RIG, "--input", rec, "--max", "--threads", threads] + VARIANTS, env=env,
                        err_out=errs)
            failures = max(failures, model_failures(errs[0]))
            if best is None or r[1] < best[0][1]:
                best = (r, la)
        (cpu, wall, rss, _), la = best
        # A variant that stopped makes the run cheaper: such a time is not
        # the figure (its ratio 0).
        stopped = "; %d model failures: a variant stopped, not the whole run" % failures if failures else ""
        t.add("run --max, %d s at 1 kHz, 4 variants, --threads %s" % (seconds, threads), "%.0f" % (seconds / wall),
              "x real time", ">= 250", 0.0 if failures else seconds / wall / 250,
              "wall %.2f s, CPU %.2f s (%.0fx on CPU), load %.1f%s" % (wall, cpu, seconds / cpu, la, stopped))
    t.add("run --max peak RSS", "%.1f" % rss, "MB", "<= 32", 32 / rss, "same run")
    return rec


def bench_band(b, t, repeats, draws=32):
    """run --max on the bundled 7 s test (tools/demo.sh's input) with one
    point variant and an ensemble of `draws` complex-model posterior draws
    (data/samples/fig7_block1.posterior.csv), one thread and all cores."""
    env = dict(os.environ, SPDLOG_LEVEL="warn")
    base = [b, "run", "--rig", RIG, "--input", os.path.join(ROOT, "data/samples/fig7_block1.csv"), "--max",
            "--quiet", "--variant", "fitted_complex:complex:" + F, "--posterior-samples",
            os.path.join(ROOT, "data/samples/fig7_block1.posterior.csv"), "--ensemble", str(draws),
            "--ensemble-model", "complex"]
    for threads in (1, 0):
        best = None
        for _ in range(repeats):
            la = load()
            r = measure(base + ["--threads", str(threads)], env=env)
            if best is None or r[1] < best[0][1]:
                best = (r, la)
        (cpu, wall, rss, _), la = best
        t.add("run --max, fig7 7 s, %d complex draws, --threads %d" % (draws, threads), "%.2f" % wall, "s wall",
              "< 5", 5 / wall, "CPU %.2f s, %.1f MB, load %.1f" % (cpu, rss, la))


def bench_simulate(b, work, t, repeats, durations):
    """`rocklab simulate` against the scipy peer as whole processes (each
    starting, integrating figure 8 and writing its CSV), beside the CPU of
    rocklab's process start (`rocklab --version`) subtracted."""
    peer = os.path.join(ROOT, "bench/scipy_peer.py")
    start = min(measure([b, "--version"])[0] for _ in range(max(repeats, 5)))
    t.add("rocklab --version CPU (process start)", "%.1f" % (start * 1e3), "ms", "(subtracted below)", 1.0,
          "best of %d" % max(repeats, 5))
    for duration in durations:
        for model in ("housner", "complex"):
            out = os.path.join(work, "simulate_%s_%d.csv" % (model, duration))
            cmd = [b, "simulate", "--model", model, "--alpha", "0.168", "--p", "3.767", "--mu", "0.942",
                   "--excitation", "sine:amp=0.006,freq=5,duration=%d,start=0" % duration,
                   "--duration", str(duration), "--rate", "200", "--json", "--out", out]
            ours = min(measure(cmd, stdout=subprocess.PIPE) for _ in range(max(repeats, 3)))
            summary = json.loads(ours[3])
            la = load()
            theirs_cpu, _, _, peer_out = measure([PY, peer, "--model", model, "--duration", str(duration),
                                                  "--out", out + ".scipy.csv"], stdout=subprocess.PIPE)
            theirs = json.loads(peer_out)
            whole = theirs_cpu / ours[0]
            own = max(ours[0] - start, 1e-6)
            t.add("simulate fig 8 %s %d s: scipy / rocklab, process CPU" % (model, duration), "%.0f" % whole, "x",
                  ">= 100", whole / 100,
                  "rocklab %.4f s (solve and CSV %.4f s, %d steps), scipy %.2f s (solve %.2f s, %s); "
                  "without rocklab's start %.0fx, with a 5 ms start %.0fx; impacts %d vs %d, peak %.7g vs %.7g rad; "
                  "load %.1f" %
                  (ours[0], summary["cpu_time"], summary["steps"], theirs_cpu, theirs["cpu_solve_s"], theirs["method"],
                   theirs_cpu / own, theirs_cpu / (own + 0.005), summary["impacts"], theirs["impacts"],
                   summary["peak_abs_theta"], theirs["peak_abs_theta"], la))


def bench_node_sample(build, b, work, t):
    """The model node's CPU per table sample beside one RK4 step per sample
    (rocklab_bench_node_sample on the 60 s record's exact acceleration plus
    an accelerometer's noise)."""
    rec = os.path.join(work, "run60.csv")
    synth(b, rec, 60)
    la = load()
    out = subprocess.run([os.path.join(build, "bench/rocklab_bench_node_sample"), rec + ".truth.csv"], check=True,
                         capture_output=True, text=True, env=dict(os.environ, SPDLOG_LEVEL="warn")).stdout
    print(out, end="")
    ns = {}
    for line in out.splitlines():
        m = re.search(r"^(floor|model alone, (\w+)|model node).*?([0-9.]+) ns/sample", line)
        if m:  # the first of each: the node's integrator (the bench prints ARKODE's RK5 after it)
            ns.setdefault(m.group(2) or m.group(1), float(m.group(3)))
    floor = ns["floor"]
    t.add("model node per sample, 4 variants", "%.0f" % ns["model node"], "ns", "(floor %.0f ns)" % floor,
          1.0, "per variant %.0f ns = %.0fx one RK4 step; Housner alone %.0f ns, complex alone %.0f ns; load %.1f" %
          (ns["model node"] / 4, ns["model node"] / 4 / floor, ns["housner"], ns["complex"], la))


def bench_reconstruct(b, work, t, rec, repeats):
    frames = sum(1 for _ in open(rec)) - 1
    out = os.path.join(work, "theta.csv")
    best = None
    for _ in range(repeats):
        la = load()
        r = measure([b, "reconstruct", "--rig", RIG, "--input", rec, "--out", out])
        if best is None or r[0] < best[0][0]:
            best = (r, la)
    (cpu, wall, rss, _), la = best
    rate = frames / cpu
    t.add("reconstruct, CSV in and out", "%.2f" % (rate / 1e6), "M frames/s", ">= 1", rate / 1e6,
          "%d frames, CPU %.2f s, %.1f MB, load %.1f" % (frames, cpu, rss, la))


def bench_replay(b, reader, work, t, repeats):
    rec = os.path.join(work, "run60.csv")
    synth(b, rec, 60)
    log = os.path.join(work, "run60.lcm")
    if not os.path.exists(log):
        subprocess.run([b, "run", "--rig", RIG, "--input", rec, "--max", "--log", log] + VARIANTS, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                       env=dict(os.environ, SPDLOG_LEVEL="warn"))
    raw = min(measure([reader, log], stdout=subprocess.PIPE) for _ in range(repeats))
    events = int(raw[3].split()[0])
    la = load()
    rep = min(measure([b, "replay", log, "--max"]) for _ in range(repeats))
    ratio = rep[0] / raw[0]
    t.add("replay --max CPU / raw LogReader CPU", "%.2f" % ratio, "x", "(no target)", 1.0,
          "%d events: replay %.2f s (%.2f M events/s), LogReader %.2f s; load %.1f" %
          (events, rep[0], events / rep[0] / 1e6, raw[0], la))


LIVE_SCRIPT = r"""
set -e
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
B="$1"; RIG="$2"; REC="$3"; LOG="$4"; URL="$5"; shift 5
export SPDLOG_LEVEL=warn
"$B" record "$LOG" --force --lcm-url "$URL" --channels 'RL_THETA|RL_COMPARE_.*|RL_MODEL_.*|RL_TABLE' > "$LOG.rec.out" 2>&1 &
rec=$!
"$B" model --rig "$RIG" --lcm-url "$URL" "$@" > "$LOG.model.out" 2>&1 &
model=$!
"$B" compare --lcm-url "$URL" > "$LOG.compare.out" 2>&1 &
cmp=$!
sleep 1
"$B" daq --rig "$RIG" --input "$REC" --speed 1 --lcm-url "$URL" > "$LOG.daq.out" 2>&1
sleep 1
kill -INT $model $cmp
wait $model $cmp || true
kill -INT $rec
wait $rec || true
"""


def read_lcm_log(path):
    """(channel, recv_utime, payload) of every event: LCM's log format."""
    with open(path, "rb") as f:
        data = f.read()
    pos = 0
    while pos + 28 <= len(data):
        sync, _num, utime, clen, dlen = struct.unpack_from(">IqqII", data, pos)
        if sync != 0xEDA1DA01:
            break
        pos += 28
        channel = data[pos:pos + clen].decode()
        pos += clen
        yield channel, utime, data[pos:pos + dlen]
        pos += dlen


def bench_live(b, work, t, seconds):
    rec = os.path.join(work, "live%d.csv" % seconds)
    synth(b, rec, seconds, seed=2)
    log = os.path.join(work, "live.lcm")
    script = os.path.join(work, "live.sh")
    with open(script, "w") as f:
        f.write(LIVE_SCRIPT)
    la = load()
    r = subprocess.run(["unshare", "-n", "bash", script, b, RIG, rec, log, UDPM] + VARIANTS,
                       capture_output=True, text=True)
    if r.returncode != 0:
        t.add("live RL_THETA -> RL_COMPARE p50", "n/a", "", "<= 2 ms", 0.0,
              "no private network namespace (%s)" % r.stderr.strip()[-200:])
        return
    theta_at = {}
    pairs = []
    for channel, recv, payload in read_lcm_log(log):
        utime = struct.unpack_from(">q", payload, 8)[0]  # every type starts with int64 utime
        if channel == "RL_THETA":
            theta_at.setdefault(utime, recv)
        elif channel.startswith("RL_COMPARE_") and utime in theta_at:
            pairs.append((channel, utime, (recv - theta_at[utime]) / 1000.0))
    # Each comparator's last RL_COMPARE per variant is Finish's, sent when it
    # is stopped (a second after the data): not a latency.
    last = {channel: utime for channel, utime, _ in pairs}
    lat = [ms for channel, utime, ms in pairs if utime != last[channel]]
    if not lat:
        t.add("live RL_THETA -> RL_COMPARE p50", "n/a", "", "<= 2 ms", 0.0, "no RL_COMPARE paired with RL_THETA")
        return
    lat.sort()
    p50 = lat[len(lat) // 2]
    p90 = lat[min(len(lat) - 1, int(0.90 * len(lat)))]
    p99 = lat[min(len(lat) - 1, int(0.99 * len(lat)))]
    t.add("live RL_THETA -> RL_COMPARE p50", "%.2f" % p50, "ms", "<= 2", 2 / max(p50, 1e-9),
          "%d pairs over udpm in a private namespace, %d s at 1 kHz real time, load %.1f" %
          (len(lat), seconds, la))
    t.add("live RL_THETA -> RL_COMPARE p99", "%.2f" % p99, "ms", "<= 10", 10 / max(p99, 1e-9),
          "same run; p90 %.2f ms" % p90)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=DEFAULT_BUILD)
    ap.add_argument("--work", help="folder for the generated inputs (kept; default: a temporary one)")
    ap.add_argument("--run-seconds", type=int, default=600)
    ap.add_argument("--live-seconds", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--simulate-seconds", default="20,200", help="figure 8's durations for simulate, s")
    ap.add_argument("--only", default="run,band,simulate,node,reconstruct,replay,live")
    a = ap.parse_args()
    b = os.path.join(a.build, "tools/rocklab")
    reader = os.path.join(a.build, "bench/rocklab_bench_log_read")
    work = a.work or tempfile.mkdtemp(prefix="rocklab-bench-")
    os.makedirs(work, exist_ok=True)
    only = set(a.only.split(","))
    print("bench: %s, %d cores, load %.1f at the start; inputs in %s" %
          (time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), os.cpu_count(), load(), work), flush=True)
    t = Table()
    rec = None
    if "run" in only:
        rec = bench_run(b, work, t, a.run_seconds, a.repeats)
    if "band" in only:
        bench_band(b, t, a.repeats)
    if "simulate" in only:
        bench_simulate(b, work, t, a.repeats, [int(d) for d in a.simulate_seconds.split(",")])
    if "node" in only:
        bench_node_sample(a.build, b, work, t)
    if "reconstruct" in only:
        if rec is None:
            rec = os.path.join(work, "run%d.csv" % a.run_seconds)
            synth(b, rec, a.run_seconds)
        bench_reconstruct(b, work, t, rec, a.repeats)
    if "replay" in only:
        bench_replay(b, reader, work, t, a.repeats)
    if "live" in only:
        bench_live(b, work, t, a.live_seconds)
    print()
    print(t.markdown())


if __name__ == "__main__":
    main()
