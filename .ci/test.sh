#!/usr/bin/env bash
# Builds with AddressSanitizer + UndefinedBehaviorSanitizer and runs every test (validation layer
# on in every GPU test). Extra arguments go to ctest (e.g. -L shader).
set -euo pipefail
cd "$(dirname "$0")/.."
export PENUMBRA_BUILD=${PENUMBRA_BUILD:-build-asan}
.ci/build.sh -DPENUMBRA_SANITIZE=ON
# Mesa's and the loader's own allocations are not ours to police; leaks in project code are
# caught by the CPU-only tests, which run with leak detection on.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0:abort_on_error=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
ctest --test-dir "$PENUMBRA_BUILD" --output-on-failure -j2 "$@"
