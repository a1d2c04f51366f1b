#!/usr/bin/env bash
# One command for the demo on a fresh Debian machine: installs what is
# missing, builds, and runs the demo scenario.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${ROCKLAB_BUILD_DIR:-$here/build}
bash "$here/tools/setup.sh" >/dev/null
"$build/tools/rocklab" demo --out-dir "${ROCKLAB_DEMO_DIR:-$build/demo}"
