#!/usr/bin/env bash
# The paper's Table 2 with intervals, from a synthetic lab campaign
# (docs/identification.md): for each of the four blocks, a rig file with its
# geometry (Table 1; block 4 with errata item 9's 4.2 cm chamfer), a free
# rocking test made by `rocklab synth` (Housner's model at Table 2's
# parameters, released from 0.6 alpha, 8 s at 1 kHz, the rig simulator's
# typical noise, LED occlusions and dropped samples), reconstructed by
# `rocklab reconstruct`, then `rocklab fit --posterior` (impacts likelihood)
# on the reconstructed theta. Prints a markdown table and leaves the files
# in OUT_DIR.
#
#   bench/table2_campaign.sh [BUILD_DIR [OUT_DIR [SEED]]]
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-$here/build}
out=${2:-$(mktemp -d)}
seed=${3:-1}
B=$build/tools/rocklab
mkdir -p "$out"

# block  2b(m)  2h(m)  chamfer(m)  alpha  p(rad/s)  mu   (Table 1 geometry, Table 2 parameters)
blocks=(
  "1 0.247 1.000 0.000 0.235 3.884 0.937"
  "2 0.168 1.000 0.000 0.168 3.767 0.942"
  "3 0.120 1.000 0.000 0.112 4.716 0.986"
  "4 0.246 0.500 0.042 0.311 4.633 0.926"
)

echo "| block | alpha truth | alpha median [95 %] | p truth | p median [95 %] | mu truth | mu median [95 %] | converged |"
echo "|---|---|---|---|---|---|---|---|"
for row in "${blocks[@]}"; do
  read -r n w h c a p mu <<<"$row"
  rig=$out/block$n.toml
  # The lab rig with this block: its geometry, the LEDs inside its face.
  sed -e "s/^width_m = .*/width_m = $w/" -e "s/^height_m = .*/height_m = $h/" \
      -e "s/^chamfer_m = .*/chamfer_m = $c/" -e "s/x_m = -0.10/x_m = -0.04/g" -e "s/x_m = 0.10/x_m = 0.04/g" \
      -e "s/z_m = 0.85/z_m = $(python3 -c "print(0.85 * $h)")/g" \
      "$here/data/rigs/lab_rig.toml" >"$rig"
  theta0=$(python3 -c "print(0.6 * $a)")
  "$B" synth --rig "$rig" --model housner --alpha "$a" --p "$p" --mu "$mu" --theta0 "$theta0" \
    --duration 8 --rate 1000 --seed "$seed" --out "$out/block$n.raw.csv" --truth "$out/block$n.truth.csv" 2>/dev/null
  "$B" reconstruct --rig "$rig" --input "$out/block$n.raw.csv" --out "$out/block$n.theta.csv" >/dev/null 2>&1
  status=0
  "$B" fit --input "$out/block$n.theta.csv" --rig "$rig" --posterior --seed "$seed" --quiet --json \
    --samples "$out/block$n.draws.csv" --plot "$out/block$n.corner.svg" >"$out/block$n.fit.json" || status=$?
  python3 - "$out/block$n.fit.json" "$n" "$a" "$p" "$mu" "$status" <<'EOF'
import json, sys
j = json.load(open(sys.argv[1]))["posterior"]
n, a, p, mu, status = sys.argv[2], *map(float, sys.argv[3:6]), sys.argv[6]
def cell(name, fmt):
    s = j[name]
    return f"{s['median']:{fmt}} [{s['ci95'][0]:{fmt}}, {s['ci95'][1]:{fmt}}]"
print(f"| {n} | {a:.3f} | {cell('alpha', '.4f')} | {p:.3f} | {cell('p', '.3f')} | {mu:.3f} | {cell('mu', '.4f')} | "
      f"{'yes' if j['converged'] else 'no (exit ' + status + ')'} |")
EOF
done
echo
echo "files in $out"
