#!/usr/bin/env bash
# Installs what rocklab needs from Debian's packages (only what is missing),
# then configures and builds into build/ (ROCKLAB_BUILD_DIR), RelWithDebInfo
# (ROCKLAB_BUILD_TYPE). Used by tools/demo.sh (Release, build-release/) and
# tools/test.sh; safe to run again.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${ROCKLAB_BUILD_DIR:-$here/build}

packages=(
  build-essential cmake ninja-build pkg-config
  liblcm-dev liblcm-bin liblcm-java default-jdk-headless libjchart2d-java
  libsundials-dev libeigen3-dev libspdlog-dev libfmt-dev
  libcli11-dev libtomlplusplus-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev
  iproute2 util-linux
  libcpp-httplib-dev libmicrohttpd-dev gnuplot-nox
  libexpat1-dev
  libopenmpi-dev openmpi-bin
  libmatio-dev libhdf5-dev
  python3-dev python3-numpy pybind11-dev python3-pytest python3-scipy
  libopencv-dev libopencv-contrib-dev libavcodec-dev libavformat-dev libavutil-dev libswscale-dev
)
# Node.js and npm fetch the monitor's charting library at build time; a
# machine that already has a Node.js with npm (nodesource, say) keeps it.
command -v npm >/dev/null 2>&1 || packages+=(nodejs npm)
# The browser tests drive Debian's headless Chromium, the lcm-spy test runs
# under Xvfb, the export read-back test reads with h5py (and scipy, above),
# the posterior test samples with emcee as an independent sampler, the
# README test (tests/docs/run_day_in_the_lab.py) plots with matplotlib,
# the citation test reads CITATION.cff with python3-yaml, the stub test
# type-checks with python3-mypy, the pip install test (ROCKLAB_SOAK_TESTS)
# builds through python3-skbuild in a python3-venv venv,
# the sanitizer and fuzz pass (tools/test.sh, build-asan/) needs clang with
# its sanitizer and libFuzzer runtimes, and the package test runs lintian on
# the .debs; only tools/test.sh asks.
if [ "${ROCKLAB_TEST_TOOLS:-}" = "1" ]; then
  packages+=(chromium chromium-driver fonts-dejavu-core clang libclang-rt-dev xvfb python3-h5py python3-emcee python3-matplotlib python3-yaml python3-mypy python3-skbuild python3-venv lintian)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "rocklab setup: installing ${missing[*]}"
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo=sudo
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

werror=OFF
[ "${CI:-}" = "true" ] && werror=ON
cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE="${ROCKLAB_BUILD_TYPE:-RelWithDebInfo}" \
  -DROCKLAB_WERROR=$werror ${ROCKLAB_CMAKE_ARGS:-}
cmake --build "$build" -j "$(nproc)"
