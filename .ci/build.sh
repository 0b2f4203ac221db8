#!/usr/bin/env bash
# Installs the Debian packages, then configures and builds Penumbra into build/ (or
# $PENUMBRA_BUILD). Arguments go to the configure step; PENUMBRA_TARGETS limits what is built.
set -euo pipefail
cd "$(dirname "$0")/.."
.ci/install-deps.sh
build=${PENUMBRA_BUILD:-build}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPENUMBRA_WERROR=ON -DPENUMBRA_LLD=ON "$@" >/dev/null
targets=()
for t in ${PENUMBRA_TARGETS:-}; do targets+=(--target "$t"); done
cmake --build "$build" -j"$(nproc)" "${targets[@]}"
