#!/usr/bin/env bash
# The main job: build, then run penumbra-view on its default scene (headless when there is no
# display), with the validation layer on.
set -euo pipefail
cd "$(dirname "$0")/.."
.ci/build.sh
PENUMBRA_VALIDATION=${PENUMBRA_VALIDATION:-1} build/runtime/penumbra-view --headless "$@"
