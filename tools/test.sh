#!/usr/bin/env bash
# One command for the whole test suite on a fresh Debian machine: installs
# what is missing, builds, runs ctest.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${ROCKLAB_BUILD_DIR:-$here/build}
ROCKLAB_TEST_TOOLS=1 bash "$here/tools/setup.sh"
cd "$build"
ctest --output-on-failure -j "$(nproc)" "$@"
