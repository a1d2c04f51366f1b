#!/usr/bin/env bash
# One command for the demo on a fresh Debian machine: installs what is
# missing, builds, and runs the whole pipeline (daq -> model -> compare) on
# the bundled figure-7 test of block 1, printing the comparison summary.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# A user's build: Release, without the tests, in its own folder
# (tools/test.sh's build/ stays RelWithDebInfo; docs/layout.md).
build=${ROCKLAB_BUILD_DIR:-$here/build-release}
out=${ROCKLAB_DEMO_DIR:-$build/demo}
ROCKLAB_BUILD_DIR="$build" ROCKLAB_BUILD_TYPE=${ROCKLAB_BUILD_TYPE:-Release} \
  ROCKLAB_CMAKE_ARGS="-DROCKLAB_BUILD_TESTS=OFF ${ROCKLAB_CMAKE_ARGS:-}" bash "$here/tools/setup.sh" >/dev/null
mkdir -p "$out"
# Table 2's fitted parameters of block 1 with both models, and Table 1's
# theoretical ones (from the rig's 0.247 x 1.0 m block).
fitted=alpha=0.235,p=3.884,mu=0.937
SPDLOG_LEVEL=${SPDLOG_LEVEL:-warn} "$build/tools/rocklab" run \
  --rig "$here/data/rigs/block1_rig.toml" --input "$here/data/samples/fig7_block1.csv" --max \
  --variant fitted_complex:complex:$fitted --variant fitted_housner:housner:$fitted \
  --variant theory_complex:complex:theoretical --variant theory_housner:housner:theoretical \
  --log "$out/fig7_block1.lcm" --summary "$out/summary.json"
# The write-up: the monitor's page for the whole test, and the figure.
"$build/tools/rocklab" report "$out/fig7_block1.lcm" --out "$out/report.html" --svg "$out/fig7_block1.svg"
echo "summary: $out/summary.json; every message: $out/fig7_block1.lcm (lcm-logplayer, rocklab replay)"
