#!/usr/bin/env bash
# The main job: build penumbra-view, then run it headless with the validation layer on.
set -euo pipefail
cd "$(dirname "$0")/.."
PENUMBRA_TARGETS=penumbra-view .ci/build.sh
PENUMBRA_VALIDATION=${PENUMBRA_VALIDATION:-1} build/runtime/penumbra-view --headless "$@"
