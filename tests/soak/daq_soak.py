#!/usr/bin/env python3
"""Soak of the DAQ daemon on a tcp:// source with faults (issue 34, point 7).

A TCP server on 127.0.0.1 (this script) feeds the lab rig's raw rows at
1 kHz, as an acquisition PC would (docs/daq-inputs.md: a header line, then
`time,<channels>` on the sample clock, which counts on while disconnected).
`rocklab daq` reads it over tcp:// and publishes on udpm; `rocklab model`,
`rocklab compare` and `rocklab record` run beside it. Faults, at stated
fractions of the run: a torn row mid-stream (a row cut short, then its line
end), two disconnects (a row torn off, the server closes its connection and
its listener, and listens again after a pause: the daq's connects are
refused and it backs off), and a reset (TCP RST once every byte sent is
acknowledged, accepted again after a pause).

Everything runs in a private network namespace on loopback, udpm with
ttl=0 (DESIGN.md "Networking in tests"): the script re-executes itself under
`unshare -n` (or `unshare -rn` without root).

Checks, each a non-zero exit with the reason:
- counts: frames read by the daq == rows sent whole; the daq's missing
  samples == rows torn + rows skipped while disconnected; so frames read +
  missing == every row of the sample clock; 3 input restarts;
- the recorder: nothing dropped, every channel the daq alone publishes
  recorded as often as the daq's own --log says it published it, RL_RAW as
  many as frames read, no sequence number missing on any channel beyond the
  daq's own gaps (RL_RAW, RL_TABLE, RL_THETA carry them);
- flat RSS and fds of every daemon (the rule in RULE below);
- every daemon exits 0 on SIGINT.

    python3 tests/soak/daq_soak.py --rocklab build/tools/rocklab --seconds 600

The figures of the last run: docs/reliability.md "Soak".
"""
import argparse
import fcntl
import json
import os
import re
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
URL = "udpm://239.255.76.67:7667?ttl=0"
RAW_URL = "udpm://239.255.76.68:7668?ttl=0"  # RL_RAW's own group: the daq's default for URL, written out
NETNS_ENV = "ROCKLAB_SOAK_IN_NETNS"
SIOCOUTQ = 0x5411  # TIOCOUTQ: bytes sent and not yet acknowledged by the peer

# Flat RSS and fds: after a warm-up (the first WARMUP_FRACTION of the run),
# the samples are cut in thirds; the last third's maximum must not pass the
# first third's maximum by more than RSS_MARGIN (the larger of the two
# terms) for RSS, and not at all for open fds.
RULE = {"warmup_fraction": 0.2, "rss_margin_kib": 2048, "rss_margin_fraction": 0.05}


def fail(msg):
    print("daq_soak: FAIL: " + msg, file=sys.stderr, flush=True)
    sys.exit(1)


def reexec_in_netns(argv):
    """Runs this script again in a private network namespace with lo up
    and a multicast route on it; returns its exit code."""
    env = dict(os.environ, **{NETNS_ENV: "1"})
    cmd = [sys.executable, os.path.abspath(__file__)] + argv
    for flags in (["-n"], ["-rn"]):
        if subprocess.run(["unshare"] + flags + ["true"], stderr=subprocess.DEVNULL).returncode == 0:
            return subprocess.run(["unshare"] + flags + cmd, env=env).returncode
    print("daq_soak: cannot make a private network namespace (unshare -n / -rn)", file=sys.stderr)
    return 1


def setup_loopback():
    for cmd in (["ip", "link", "set", "lo", "up"], ["ip", "link", "set", "lo", "multicast", "on"],
                ["ip", "route", "add", "224.0.0.0/4", "dev", "lo"]):
        subprocess.run(cmd, check=True)


class Feed:
    """The acquisition PC: a TCP server paced on the sample clock.

    Row k is due at t0 + k / rate (t0: the first connection). Every row is
    accounted exactly once: sent whole, torn (cut short: at a disconnect
    with no line end, or mid-stream with its line end) or skipped (its
    time passed while no connection was open)."""

    def __init__(self, header, rows, rate_hz, faults):
        self.header = header
        self.rows = rows  # value fields of the synthetic test, repeated; times are the feed's
        self.rate = rate_hz
        self.faults = sorted(faults)  # (row index, kind)
        self.sent_whole = 0
        self.torn = 0
        self.skipped = 0
        self.next_k = 0
        self.log = []  # what happened, for the report
        self.stop_flag = threading.Event()
        self.done = threading.Event()
        self.error = None
        self.listener = None
        self.conn = None
        self.port = 0
        self.t0 = None
        self._listen()

    def _listen(self):
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind(("127.0.0.1", self.port))
        s.listen(1)
        self.port = s.getsockname()[1]
        self.listener = s

    def line(self, k):
        return "%.3f,%s\n" % (k / self.rate, self.rows[k % len(self.rows)])

    def due(self):
        return int((time.monotonic() - self.t0) * self.rate) + 1

    def _accept(self):
        self.listener.settimeout(0.05)
        while not self.stop_flag.is_set():
            try:
                c, _ = self.listener.accept()
                break
            except socket.timeout:
                if self.t0 is not None:
                    self._skip_to(self.due())
        else:
            return False
        c.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.conn = c
        if self.t0 is None:
            self.t0 = time.monotonic()
        else:
            self._skip_to(self.due())  # the rows of the pause and of the daq's reconnect
        c.sendall((self.header + "\n").encode())
        return True

    def _skip_to(self, k):
        if k > self.next_k:
            self.skipped += k - self.next_k
            self.next_k = k

    def _wait_acked(self):
        """Until the daq's kernel holds every byte sent (a reset discards
        what the sender still holds)."""
        buf = bytearray(4)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            fcntl.ioctl(self.conn.fileno(), SIOCOUTQ, buf)
            if struct.unpack("i", buf)[0] == 0:
                return
            time.sleep(0.002)
        raise RuntimeError("the daq did not acknowledge what was sent within 30 s")

    def _fault(self, kind):
        k = self.next_k
        whole = self.line(k)
        if kind == "torn":  # a row cut short mid-stream, then its line end: fewer fields
            fields = whole.rstrip("\n").split(",")
            self.conn.sendall((",".join(fields[: len(fields) // 2]) + "\n").encode())
        else:  # the connection breaks in the middle of row k
            self.conn.sendall(whole[: len(whole) // 2].encode())
        self.torn += 1
        self.next_k += 1
        self.log.append("%s at row %d (t = %.3f s)" % (kind, k, k / self.rate))
        if kind == "torn":
            return
        pause_s = {"disconnect": 1.5, "disconnect-long": 3.0, "reset": 0.5}[kind]
        if kind == "reset":
            self._wait_acked()
            self.conn.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
            self.conn.close()  # RST; the listener stays: the daq's reconnect waits in its backlog
        else:
            self.conn.close()  # FIN, and no listener: the daq's connects are refused
            self.listener.close()
        self.conn = None
        end = time.monotonic() + pause_s
        while time.monotonic() < end and not self.stop_flag.is_set():
            time.sleep(0.01)
            self._skip_to(self.due())
        if kind != "reset":
            self._listen()

    def run(self, seconds):
        try:
            if not self._accept():
                return
            end_k = int(seconds * self.rate)
            fi = 0
            while self.next_k < end_k and not self.stop_flag.is_set():
                if self.conn is None and not self._accept():
                    break
                upto = min(self.due(), end_k)
                if fi < len(self.faults) and self.faults[fi][0] < upto:
                    upto = max(self.faults[fi][0], self.next_k)
                if upto > self.next_k:
                    chunk = "".join(self.line(k) for k in range(self.next_k, upto))
                    self.conn.sendall(chunk.encode())
                    self.sent_whole += upto - self.next_k
                    self.next_k = upto
                if fi < len(self.faults) and self.next_k >= self.faults[fi][0]:
                    self._fault(self.faults[fi][1])
                    fi += 1
                    continue
                time.sleep(0.005)
            if self.conn is not None:
                self._wait_acked()
        except Exception as e:  # reported by the main thread
            self.error = "%s: %s" % (type(e).__name__, e)
        finally:
            self.done.set()

    def close(self):
        for s in (self.conn, self.listener):
            if s is not None:
                s.close()


def rx_queue_empty(port):
    """True when no TCP socket in this namespace connected to `port` holds
    unread bytes (the daq has read everything the feed sent)."""
    with open("/proc/net/tcp") as f:
        next(f)
        for line in f:
            parts = line.split()
            remote_port = int(parts[2].split(":")[1], 16)
            rx = int(parts[4].split(":")[1], 16)
            if remote_port == port and rx > 0:
                return False
    return True


def sample(pid):
    """(VmRSS in KiB, open fds) of a process, or None once it is gone."""
    try:
        with open("/proc/%d/status" % pid) as f:
            rss = next(int(l.split()[1]) for l in f if l.startswith("VmRSS:"))
        return rss, len(os.listdir("/proc/%d/fd" % pid))
    except (FileNotFoundError, ProcessLookupError, StopIteration):
        return None


def flat(samples, seconds):
    """The RULE applied to [(t, rss_kib, fds)]: (ok, first-third maxima, last-third maxima)."""
    kept = [s for s in samples if s[0] >= RULE["warmup_fraction"] * seconds]
    if len(kept) < 6:
        return False, None, None, "only %d samples after the warm-up" % len(kept)
    third = len(kept) // 3
    first, last = kept[:third], kept[-third:]
    a = (max(s[1] for s in first), max(s[2] for s in first))
    b = (max(s[1] for s in last), max(s[2] for s in last))
    margin = max(RULE["rss_margin_kib"], RULE["rss_margin_fraction"] * a[0])
    why = []
    if b[0] > a[0] + margin:
        why.append("RSS grew from %d to %d KiB (margin %d KiB)" % (a[0], b[0], margin))
    if b[1] > a[1]:
        why.append("open fds grew from %d to %d" % (a[1], b[1]))
    return not why, a, b, "; ".join(why)


def wait_for(cond, seconds, what):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if cond():
            return
        time.sleep(0.05)
    fail("timed out after %g s waiting for %s" % (seconds, what))


def parse_daq_summary(text):
    """Figures of the daq's last lines (pipeline.cpp: 'daq: N frames read, ...')."""
    m = re.search(r"daq: (\d+) frames read, (\d+) messages published \((\d+) failed\), (\d+) gaps "
                  r"\((\d+) samples missing\), (\d+) bad samples", text)
    if not m:
        fail("no summary line in the daq's stderr:\n" + text[-2000:])
    out = dict(zip(["frames_read", "published", "publish_failed", "gaps", "missing", "bad_samples"],
                   map(int, m.groups())))
    r = re.search(r"daq: (\d+) input restarts \((\d+) samples lost across them\)", text)
    out["restarts"], out["restart_lost"] = (int(r.group(1)), int(r.group(2))) if r else (0, 0)
    return out


def info(rocklab, log):
    out = subprocess.run([rocklab, "info", "--json", log], capture_output=True, text=True)
    if out.returncode != 0:
        fail("rocklab info %s: %s" % (log, out.stderr.strip()))
    return {c["name"]: c for c in json.loads(out.stdout)["channels"]}


def soak(a):
    setup_loopback()
    rocklab = os.path.abspath(a.rocklab)
    work = a.work or tempfile.mkdtemp(prefix="rocklab_soak_")
    os.makedirs(work, exist_ok=True)
    rig = os.path.join(REPO, "data", "rigs", "lab_rig.toml")
    env = dict(os.environ, SPDLOG_LEVEL="warn")
    env.pop("LCM_DEFAULT_URL", None)

    # One free-rocking test of the lab rig (a pulse, 60 impacts, back to
    # rest by 20 s), repeated by the feed with its time counting on.
    raw = os.path.join(work, "test.csv")
    synth = subprocess.run([rocklab, "synth", "--rig", rig, "--alpha", "0.245", "--p", "3.78", "--mu", "0.91",
                            "--excitation", "hanning:amp=0.03,freq=2,duration=1,start=0.5", "--duration", "20",
                            "--rate", str(a.rate), "--drop", "0", "--seed", "7", "--out", raw,
                            "--truth", os.path.join(work, "truth.csv")], env=env, capture_output=True, text=True)
    if synth.returncode != 0:
        fail("rocklab synth: " + synth.stderr.strip())
    with open(raw) as f:
        header = f.readline().rstrip("\n")
        rows = [l.rstrip("\n").split(",", 1)[1] for l in f if l.strip()]

    n = int(a.seconds * a.rate)
    faults = [(int(0.20 * n), "torn"), (int(0.35 * n), "disconnect"), (int(0.55 * n), "reset"),
              (int(0.70 * n), "disconnect-long")]
    feed = Feed(header, rows, a.rate, faults)

    def start(name, args):
        err = open(os.path.join(work, name + ".err"), "w")
        return subprocess.Popen([rocklab] + args, stdout=err, stderr=subprocess.STDOUT, env=env), err

    procs = {}
    procs["record"] = start("record", ["record", os.path.join(work, "record.lcm"), "--force",
                                       "--summary", os.path.join(work, "record.json"),
                                       "--lcm-url", URL, "--raw-url", RAW_URL])
    wait_for(lambda: "recording" in open(os.path.join(work, "record.err")).read(), 60, "the recorder")
    if not a.no_model:
        procs["model"] = start("model", ["model", "--rig", rig, "--variant", "housner:housner:theoretical",
                                         "--lcm-url", URL])
        procs["compare"] = start("compare", ["compare", "--lcm-url", URL])
    daq_log = os.path.join(work, "daq.lcm")
    procs["daq"] = start("daq", ["daq", "--rig", rig, "--input", "tcp://127.0.0.1:%d" % feed.port,
                                 "--lcm-url", URL, "--raw-url", RAW_URL, "--log", daq_log])

    thread = threading.Thread(target=feed.run, args=(a.seconds,), daemon=True)
    thread.start()
    samples = {name: [] for name in procs}
    t_start = time.monotonic()
    next_sample = 0.0
    while not feed.done.is_set():
        for name, (p, _) in procs.items():
            if p.poll() is not None:
                feed.stop_flag.set()
                fail("%s exited early (%d); see %s" % (name, p.returncode, os.path.join(work, name + ".err")))
        t = time.monotonic() - t_start
        if t >= next_sample:
            for name, (p, _) in procs.items():
                s = sample(p.pid)
                if s:
                    samples[name].append((t, s[0], s[1]))
            next_sample += a.sample_every
        time.sleep(0.1)
    if feed.error:
        fail("the feed: " + feed.error)
    wait_for(lambda: rx_queue_empty(feed.port), 60, "the daq to read every byte sent")

    # Stop in the order of the data flow; each drains what it was given.
    codes = {}
    for group in (["daq"], ["model", "compare"], ["record"]):
        for name in group:
            if name in procs:
                procs[name][0].send_signal(signal.SIGINT)
        for name in group:
            if name in procs:
                try:
                    codes[name] = procs[name][0].wait(timeout=60)
                except subprocess.TimeoutExpired:
                    procs[name][0].kill()
                    fail("%s did not stop within 60 s of SIGINT" % name)
                procs[name][1].close()
    feed.close()

    problems = []
    for name, code in codes.items():
        if code != 0:
            problems.append("%s exited %d (see %s.err)" % (name, code, name))

    total = feed.next_k
    d = parse_daq_summary(open(os.path.join(work, "daq.err")).read())
    rec = json.load(open(os.path.join(work, "record.json")))
    rec_ch = {c["name"]: c for c in rec["channels"]}
    pub = info(rocklab, daq_log)
    logged = info(rocklab, os.path.join(work, "record.lcm"))

    lost = feed.torn + feed.skipped
    if feed.sent_whole + lost != total:
        problems.append("the feed's own accounting: %d + %d + %d != %d" % (feed.sent_whole, feed.torn, feed.skipped, total))
    if d["frames_read"] != feed.sent_whole:
        problems.append("daq read %d frames, the feed sent %d rows whole" % (d["frames_read"], feed.sent_whole))
    if d["missing"] != lost:
        problems.append("daq counted %d samples missing, the feed tore %d and skipped %d" % (d["missing"], feed.torn, feed.skipped))
    if d["frames_read"] + d["missing"] != total:
        problems.append("frames read + missing = %d, rows of the sample clock %d" % (d["frames_read"] + d["missing"], total))
    if d["restarts"] != 3:
        problems.append("daq counted %d input restarts, the feed made 3" % d["restarts"])
    if d["publish_failed"] != 0:
        problems.append("daq: %d publishes failed" % d["publish_failed"])
    if rec["dropped"] != 0 or rec["write_error"]:
        problems.append("record dropped %d (write error %r)" % (rec["dropped"], rec["write_error"]))
    daq_only = [c for c in pub if c not in ("RL_EVENT", "RL_HEALTH")] if not a.no_model else list(pub)
    for c in daq_only:
        got = rec_ch.get(c, {}).get("count", 0)
        if got != pub[c]["count"]:
            problems.append("%s: the daq published %d, record recorded %d" % (c, pub[c]["count"], got))
        if logged.get(c, {}).get("count", 0) != got:
            problems.append("%s: record says %d, its log holds %d" % (c, got, logged.get(c, {}).get("count", 0)))
    if pub.get("RL_RAW", {}).get("count") != d["frames_read"]:
        problems.append("RL_RAW published %s, frames read %d" % (pub.get("RL_RAW", {}).get("count"), d["frames_read"]))
    for c, ch in rec_ch.items():
        expected = pub[c]["seq_missing"] if c in pub and c in daq_only else 0
        if ch["seq_missing"] != expected:
            problems.append("%s: record counts %d missing by seq, the daq's own stream %d" % (c, ch["seq_missing"], expected))

    flatness = {}
    for name, s in samples.items():
        ok, first, last, why = flat(s, a.seconds)
        flatness[name] = {"first_third_max": first, "last_third_max": last,
                          "first": s[0][1:] if s else None, "last": s[-1][1:] if s else None, "samples": len(s),
                          "series_t_s_rss_kib_fds": s}
        if not ok:
            problems.append("%s: not flat: %s" % (name, why))

    result = {
        "date_utc": time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
        "seconds": a.seconds, "rate_hz": a.rate, "rule": RULE, "faults": feed.log,
        "feed": {"rows": total, "sent_whole": feed.sent_whole, "torn": feed.torn, "skipped": feed.skipped},
        "daq": d, "record": {"events": rec["events"], "dropped": rec["dropped"], "seq_missing": rec["seq_missing"],
                             "queue_high_water_bytes": rec.get("queue_high_water_bytes"),
                             "channels": {c: ch["count"] for c, ch in rec_ch.items()}},
        "published_by_daq": {c: pub[c]["count"] for c in pub},
        "exit_codes": codes, "rss_kib_fds": flatness, "problems": problems,
    }
    with open(os.path.join(work, "result.json"), "w") as f:
        json.dump(result, f, indent=2)
    brief = dict(result, rss_kib_fds={k: {kk: vv for kk, vv in v.items() if kk != "series_t_s_rss_kib_fds"}
                                      for k, v in flatness.items()})
    print(json.dumps(brief, indent=1))
    if problems:
        fail("%d problem(s):\n  " % len(problems) + "\n  ".join(problems) + "\n(files in %s)" % work)
    print("daq_soak: PASS (%g s, %d rows, files in %s)" % (a.seconds, total, work))
    if not a.keep:  # the logs are about 0.8 MB per second of run; result.json stays in --work
        if a.work:
            for name in ("daq.lcm", "record.lcm", "test.csv", "truth.csv"):
                os.remove(os.path.join(work, name))
        else:
            shutil.rmtree(work, ignore_errors=True)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--rocklab", default=os.path.join(REPO, "build", "tools", "rocklab"))
    p.add_argument("--seconds", type=float, default=600.0, help="run time of the feed, s (faults at 20/35/55/70 %%)")
    p.add_argument("--rate", type=float, default=1000.0, help="sample rate of the feed, Hz (the rig's)")
    p.add_argument("--sample-every", type=float, default=2.0, help="RSS/fd sampling period, s")
    p.add_argument("--work", help="folder for the logs and result.json (default: a temporary one, removed after a pass)")
    p.add_argument("--keep", action="store_true", help="keep the logs after a pass (they are kept after a failure)")
    p.add_argument("--no-model", action="store_true", help="daq and record only")
    a = p.parse_args()
    if a.seconds < 30:
        p.error("--seconds must be at least 30 (the faults need room)")
    if os.environ.get(NETNS_ENV) != "1":
        sys.exit(reexec_in_netns(sys.argv[1:]))
    soak(a)


if __name__ == "__main__":
    main()
