#!/usr/bin/env bash
# Every performance figure of docs/performance.md beside its target, in one
# run (2-core machine: about 10 minutes, most of it the live test at real
# time and the scipy peer):
#
#   bash bench/run.sh [--work DIR] [--repeats N] [--only run,band,simulate,node,reconstruct,replay,live,startup]
#                     [--run-seconds 600] [--simulate-seconds 20,200] [--live-seconds 20] [--build build-release]
#
# Installs the bench-only dependency python3-scipy (the peer of `simulate`,
# bench/scipy_peer.py) the way tools/setup.sh installs packages, builds the
# targets it runs (rocklab, rocklab_bench_log_read, rocklab_bench_node_sample) in the configured
# build folder, then runs bench/figures.py. The live figure needs root for
# a private network namespace (unshare -n; DESIGN.md: loopback, ttl=0);
# without one it says so and the other figures stand.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
# The user's build (tools/demo.sh's Release) where it is configured, else
# the test build; figures.py and startup.py take the same default.
build="$here/build"
[ -f "$here/build-release/build.ninja" ] && build="$here/build-release"
for ((i = 1; i <= $#; i++)); do
  if [ "${!i}" = "--build" ]; then j=$((i + 1)); build="${!j}"; fi
done
sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
if ! /usr/bin/python3 -c "import scipy" 2>/dev/null; then
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends python3-scipy
fi
if [ ! -f "$build/build.ninja" ]; then
  echo "bench: no configured build in $build: run tools/setup.sh first" >&2
  exit 2
fi
cmake --build "$build" -j "$(nproc)" --target rocklab rocklab_bench_log_read rocklab_bench_node_sample
/usr/bin/python3 "$here/bench/figures.py" "$@"
# Start-up and peak RSS of the command and the daemons (--only startup).
exec /usr/bin/python3 "$here/bench/startup.py" "$@"
