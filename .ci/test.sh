#!/usr/bin/env bash
# Builds with AddressSanitizer + UndefinedBehaviorSanitizer and runs every test, with the Khronos
# validation layer on in every GPU test. Extra arguments go to both ctest runs (e.g. -R Pcf).
set -euo pipefail
cd "$(dirname "$0")/.."
export PENUMBRA_BUILD=${PENUMBRA_BUILD:-build-asan}
.ci/build.sh -DPENUMBRA_SANITIZE=ON
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# CPU-only tests run with leak detection. Tests that load a Vulkan driver run without it: Mesa's
# lavapipe and the validation layer leave a few hundred bytes behind in modules that are already
# unloaded at exit, which LeakSanitizer cannot attribute or suppress by name.
status=0
ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1} \
  ctest --test-dir "$PENUMBRA_BUILD" --output-on-failure -j2 -L cpu "$@" || status=1
ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0} \
  ctest --test-dir "$PENUMBRA_BUILD" --output-on-failure -j2 -LE cpu "$@" || status=1
exit $status
