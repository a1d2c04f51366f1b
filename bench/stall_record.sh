#!/usr/bin/env bash
# What `rocklab record` loses when its disk stalls, and
# how much of it the sequence numbers show. A synthetic test (synth, four
# model variants: every channel) is run once into a log; then, in a private
# network namespace on loopback (DESIGN.md: ttl=0, nothing leaves the
# machine), `rocklab replay LOG --max` sends it over udpm while `rocklab
# record` is paused (SIGSTOP, as a writer stuck on a stalled disk holds the
# LCM thread's buffers) for 0.5 s. Per channel: messages sent (the log),
# recorded, lost, and lost as counted by the recorder's seq_missing (less
# what the log itself already misses), now and before every type had a seq.
# Needs root (unshare -n).
#
#   bash bench/stall_record.sh [--build build] [--work DIR] [--seconds 120] [--pause 0.5]
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="$here/build"; work=""; seconds=120; pause=0.5
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build="$2"; shift 2 ;;
    --work) work="$2"; shift 2 ;;
    --seconds) seconds="$2"; shift 2 ;;
    --pause) pause="$2"; shift 2 ;;
    *) echo "stall_record: unknown option $1" >&2; exit 2 ;;
  esac
done
[ -n "$work" ] || work="$build/bench_stall"
mkdir -p "$work"
B="$build/tools/rocklab"
RIG="$here/data/rigs/block1_rig.toml"
F="alpha=0.235,p=3.884,mu=0.937"
rec="$work/synth$seconds.csv"; log="$work/synth$seconds.lcm"
export SPDLOG_LEVEL=warn
if [ ! -f "$log" ]; then
  "$B" synth --rig "$RIG" --model complex --alpha 0.235 --p 3.884 --mu 0.937 \
    --excitation "sine:amp=0.010,freq=3.3,duration=$((seconds - 1)),start=0.5" --duration "$seconds" \
    --rate 1000 --seed 1 --out "$rec" --truth "$rec.truth.csv" > /dev/null 2>&1
  "$B" run --rig "$RIG" --input "$rec" --max --log "$log" \
    --variant "fitted_complex:complex:$F" --variant "fitted_housner:housner:$F" \
    --variant theory_complex:complex:theoretical --variant theory_housner:housner:theoretical > /dev/null 2>&1
fi
"$B" info "$log" --json > "$work/sent.json"
out="$work/stalled.lcm"; summary="$work/stalled.json"
unshare -n bash -s "$B" "$log" "$out" "$summary" "$pause" <<'SCRIPT'
set -e
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
B="$1"; LOG="$2"; OUT="$3"; SUMMARY="$4"; PAUSE="$5"
URL='udpm://239.255.76.67:7667?ttl=0'
"$B" record "$OUT" --force --channels 'RL_.*' --summary "$SUMMARY" --lcm-url "$URL" > "$OUT.out" 2> "$OUT.err" &
rec=$!
for _ in $(seq 100); do grep -q "recording" "$OUT.err" && break; sleep 0.1; done
"$B" replay "$LOG" --max --lcm-url "$URL" > "$OUT.replay.out" 2>&1 &
rp=$!
sleep 0.2
kill -STOP $rec; sleep "$PAUSE"; kill -CONT $rec
wait $rp
sleep 1
kill -INT $rec
wait $rec || true
SCRIPT
/usr/bin/python3 - "$work/sent.json" "$summary" <<'PY'
import json, sys
sent = {c["name"]: c for c in json.load(open(sys.argv[1]))["channels"]}
got = {c["name"]: c for c in json.load(open(sys.argv[2]))["channels"]}
# Types that carried a seq before the successor types: only these losses were counted.
before = {"RL_RAW", "RL_THETA", "RL_TABLE"}
kinds = {}
for name, c in sent.items():
    kind = name if not name.startswith(("RL_MODEL_", "RL_COMPARE_")) else name.split("_")[0] + "_" + name.split("_")[1] + "_*"
    g = got.get(name, {"count": 0, "seq_missing": None, "dropped": 0})
    k = kinds.setdefault(kind, [0, 0, 0, 0, 0])
    k[0] += c["count"]; k[1] += g["count"]; k[2] += c["count"] - g["count"]
    # Less the numbers already missing in the log itself (source gaps the DAQ counted).
    k[3] += (g["seq_missing"] or 0) - (c["seq_missing"] or 0)
    k[4] += g["dropped"]
print("| channel | sent | recorded | lost | counted by seq now | counted before | dropped (recorder queue) |")
print("|---|---|---|---|---|---|---|")
tot = [0] * 6
for kind in sorted(kinds):
    s, r, lost, seq, dropped = kinds[kind]
    old = seq if kind in before else 0
    print("| `%s` | %d | %d | %d | %d | %d | %d |" % (kind, s, r, lost, seq, old, dropped))
    for i, v in enumerate((s, r, lost, seq, old, dropped)):
        tot[i] += v
print("| all | %d | %d | %d | %d | %d | %d |" % tuple(tot))
PY
