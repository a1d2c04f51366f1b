#!/bin/bash
# CPU of `rocklab model` (four variants) and `rocklab compare` while a DAQ
# publishes a record at real time over udpm, with RL_RAW on the main group
# and on its own (docs/performance.md, "Raw frames on their own group").
# Runs inside a private network namespace (unshare -n, lo only, ttl=0:
# DESIGN.md, "Networking in tests"); `rocklab record` records both buses as
# in the lab, so the machine has joined the raw group.
#
#   bash bench/raw_group.sh [B] [SECONDS] [REPEATS]
#
# B: the rocklab binary (default build/tools/rocklab); SECONDS: the record's
# length (default 20); REPEATS: runs of each mode, interleaved (default 2).
# Prints one line per run: mode, model CPU s, compare CPU s (user + sys from
# /proc/PID/stat when the DAQ has finished, start-up included), the UDP
# datagrams the namespace's sockets received while the DAQ ran (each
# datagram once per socket it reaches: /proc/net/snmp), and the events the
# recorder wrote.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
B=${1:-$ROOT/build/tools/rocklab}
SECONDS_LONG=${2:-20}
REPEATS=${3:-2}
RIG=$ROOT/data/rigs/block1_rig.toml
WORK=$(mktemp -d /tmp/rocklab_raw_group.XXXXXX)
F=alpha=0.235,p=3.884,mu=0.937
"$B" synth --rig "$RIG" --model complex --alpha 0.235 --p 3.884 --mu 0.937 \
  --excitation "sine:amp=0.010,freq=3.3,duration=$((SECONDS_LONG - 1)),start=0.5" \
  --duration "$SECONDS_LONG" --rate 1000 --seed 2 --out "$WORK/rec.csv" --truth "$WORK/rec.truth.csv" \
  > /dev/null 2>&1

cat > "$WORK/one.sh" <<'EOF'
set -eu
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
B="$1"; RIG="$2"; REC="$3"; OUT="$4"; RAW="$5"; F="$6"
URL='udpm://239.255.76.67:7667?ttl=0'
export SPDLOG_LEVEL=warn
cpu() { awk '{printf "%.2f", ($14 + $15) / 100}' "/proc/$1/stat"; }  # user + sys, s (CLK_TCK 100)
# UDP datagrams the namespace's sockets received (one per socket a datagram reaches).
udp_in() { awk '$1 == "Udp:" && $2 ~ /^[0-9]+$/ {print $2}' /proc/net/snmp; }
"$B" record "$OUT.lcm" --force --lcm-url "$URL" ${RAW:+--raw-url "$RAW"} > "$OUT.rec.out" 2>&1 &
rec=$!
"$B" model --rig "$RIG" --lcm-url "$URL" --variant fc:complex:$F --variant fh:housner:$F \
  --variant tc:complex:theoretical --variant th:housner:theoretical > "$OUT.model.out" 2>&1 &
model=$!
"$B" compare --lcm-url "$URL" > "$OUT.compare.out" 2>&1 &
cmp=$!
sleep 1
in0=$(udp_in)
"$B" daq --rig "$RIG" --input "$REC" --speed 1 --lcm-url "$URL" ${RAW:+--raw-url "$RAW"} > "$OUT.daq.out" 2>&1
sleep 1
echo "$(cpu $model) $(cpu $cmp) $(($(udp_in) - in0))"
kill -INT $model $cmp
wait $model $cmp || true
kill -INT $rec
wait $rec || true
EOF

for ((i = 1; i <= REPEATS; i++)); do
  # same: RL_RAW on the main group (before); own: the default, its own
  # group and port. (A group of its own on the main port, a third mode of
  # a first version, is now refused: docs/performance.md.)
  for mode in same own; do
    case $mode in
      same) raw=same ;;
      own) raw= ;;
    esac
    cpus=$(unshare -n bash "$WORK/one.sh" "$B" "$RIG" "$WORK/rec.csv" "$WORK/$mode$i" "$raw" "$F")
    events=$(grep -o '^rocklab record: [0-9]* events written' "$WORK/$mode$i.rec.out" | grep -o '[0-9]*' || echo '?')
    printf '%-6s model %6s s  compare %6s s  %s datagrams received  recorded %s events  load %s\n' "$mode" ${cpus} "$events" \
      "$(cut -d' ' -f1 /proc/loadavg)"
  done
done
rm -rf "$WORK"
