#!/usr/bin/env bash
# Installs the Debian packages, then configures and builds Penumbra into build/ (or $PENUMBRA_BUILD).
set -euo pipefail
cd "$(dirname "$0")/.."
.ci/install-deps.sh
build=${PENUMBRA_BUILD:-build}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@" >/dev/null
cmake --build "$build" -j"$(nproc)"
