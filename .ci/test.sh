#!/usr/bin/env bash
# Builds with AddressSanitizer + UndefinedBehaviorSanitizer and runs every test, with the Khronos
# validation layer on in every GPU test. Extra arguments go to both ctest runs (e.g. -R Pcf).
set -euo pipefail
cd "$(dirname "$0")/.."
export PENUMBRA_BUILD=${PENUMBRA_BUILD:-build-asan}
# The library and tools at -O1 -g1 (line tables for the sanitizers' stack traces, as
# AddressSanitizer's docs advise -O1): half the compile time of RelWithDebInfo's -O2 -g
# (scene_objects.cpp: 13.9 -> 7.4 s). The test sources at -O0 -g1: they are two thirds of the
# build's compile time (gtest and harness templates) and little of any test's run time, which is
# the library, the driver and the tools (vsm_tests.cpp: 21.6 -> 12.4 s). About three minutes of
# this script on 2 cores. The dev build (.ci/build.sh) and a plain Release build keep their own
# flags.
# GLSL coverage of shaders/penumbra/ by shader_tests/: each shader test process writes its
# tracefile there (this run's only: the last run's are removed). The floors: docs/coverage.md.
coverage=$(realpath -m "$PENUMBRA_BUILD/shader-coverage")
# The test sources share a precompiled header (PENUMBRA_TEST_PCH, cmake/PenumbraWarnings.cmake):
# their compile 505 -> 331 s.
.ci/build.sh -DPENUMBRA_SANITIZE=ON "-DPENUMBRA_TEST_COMPILE_OPTIONS=-O0;-g1" -DPENUMBRA_TEST_PCH=ON \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" \
  "-DPENUMBRA_SHADER_COVERAGE_DIR=$coverage"
rm -rf "$coverage" "$PENUMBRA_BUILD/shader-coverage-html"
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# The fuzzer's random parts get 8 s each here (45 s by default): its seeded corpus runs whole
# either way, and the 15-minute budget of this script holds the frontier replays of issue 33 and
# the shadow-map cache's identity tests (issue 37; 12 s each before them).
export PENUMBRA_FUZZ_SECONDS=${PENUMBRA_FUZZ_SECONDS:-8}
# CPU-only tests run with leak detection. Tests that load a Vulkan driver run without it: Mesa's
# lavapipe and the validation layer leave a few hundred bytes behind in modules that are already
# unloaded at exit, which LeakSanitizer cannot attribute or suppress by name.
status=0
ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1} \
  ctest --test-dir "$PENUMBRA_BUILD" --output-on-failure -j2 -L cpu "$@" || status=1
ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0} \
  ctest --test-dir "$PENUMBRA_BUILD" --output-on-failure -j2 -LE cpu "$@" || status=1
if (($# == 0)); then  # a filtered run (-R ...) covers only part of the library
  tools/penumbra-coverage "$coverage" --include /shaders/penumbra/ --uncovered \
    --min-lines 99 --min-branches 97 --html "$PENUMBRA_BUILD/shader-coverage-html" || status=1
  # Mutation testing's quick mode: 8 mutants of the library, each run against the test binaries
  # whose coverage reached its line. The full score is in docs/coverage.md; this checks that the
  # tests still kill most of a sample (a tool that no longer applies its mutants kills none).
  rm -f "$PENUMBRA_BUILD/mutate-quick.jsonl"
  ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0} tools/penumbra-mutate --build "$PENUMBRA_BUILD" \
    --coverage "$coverage" --quick 8 --min-score 50 \
    --results "$PENUMBRA_BUILD/mutate-quick.jsonl" || status=1
fi
# The package as a user gets it: install into a fresh prefix, then configure, build and run the
# example project (examples/shader-tests, the tutorial) against it, outside this tree.
example=$(mktemp -d)
trap 'rm -rf "$example"' EXIT
if cmake --install "$PENUMBRA_BUILD" --prefix "$example/prefix" > "$example/install.log" &&
   cmake -S examples/shader-tests -B "$example/build" -G Ninja \
     -DCMAKE_PREFIX_PATH="$example/prefix" -DTUTORIAL_COVERAGE="$example/coverage" \
     > "$example/configure.log" &&
   cmake --build "$example/build" > "$example/build.log"; then
  ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0} \
    ctest --test-dir "$example/build" --output-on-failure || status=1
  # The project's GLSL coverage, with the installed report tool.
  if ! "$example/prefix/bin/penumbra-coverage" "$example/coverage" --include examples/shader-tests/glsl \
       > "$example/coverage.log" 2>&1 || ! grep -q "my_shading.glsl" "$example/coverage.log"; then
    cat "$example/coverage.log"
    echo "the example's GLSL coverage was not written or not read" >&2
    status=1
  fi
  # And run directly, as a user runs one test binary: from another directory, without CTest's
  # PENUMBRA_SHADER_DIR / PENUMBRA_SHADER_PATH, the package's GLSL and the project's SHADER_DIRS
  # are still found (compiled in from where find_package found the prefix).
  if ! (cd / && env -u PENUMBRA_SHADER_DIR -u PENUMBRA_SHADER_PATH PENUMBRA_VALIDATION=1 \
          ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0} "$example/build/tutorial_tests" \
          > "$example/direct.log" 2>&1); then
    cat "$example/direct.log"
    echo "the example's test binary fails when run outside CTest" >&2
    status=1
  fi
  # The installed viewer from a moved prefix (issue 36): it finds its scenes and shaders beside
  # its bin/ and watches a user's overlay holding only penumbra/pcf.glsl (--shader-dir: the rest
  # from the installed library); an edit there is reloaded.
  mv "$example/prefix" "$example/moved"
  mkdir -p "$example/overlay/penumbra"
  cp "$example/moved/share/penumbra/shaders/penumbra/pcf.glsl" "$example/overlay/penumbra/"
  (cd / && exec env -u PENUMBRA_SHADER_DIR -u PENUMBRA_SHADER_PATH PENUMBRA_VALIDATION=1 \
     ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0} "$example/moved/bin/penumbra-view" \
     --headless --watch --scene default --set shadows.filter=pcf --frames 1 --size 96x54 \
     --view lit --shader-dir "$example/overlay" --out "$example/view") > "$example/view.log" 2>&1 &
  viewer=$!
  seen() {  # waits up to 120 s for a line of the viewer's log
    for _ in $(seq 600); do
      grep -q -- "$1" "$example/view.log" && return 0
      kill -0 "$viewer" 2>/dev/null || return 1
      sleep 0.2
    done
    return 1
  }
  reloaded=0
  if seen "^\[watch\] watching $example/overlay over $example/moved/share/penumbra/shaders"; then
    sed -i 's/return clamp(radius, 0, kPcfMaxRadius);/return clamp(radius + 1, 0, kPcfMaxRadius);/' \
      "$example/overlay/penumbra/pcf.glsl"
    seen "^\[reload\] rebuilt: shadow-resolve" && reloaded=1
  fi
  kill -INT "$viewer" 2>/dev/null
  wait "$viewer" || reloaded=0
  if ((reloaded == 0)) ||
     ! grep -q "$example/moved/share/penumbra/scenes/default.toml" "$example/view.log" ||
     ! grep -q "validation:  0 messages" "$example/view.log" || [[ ! -s "$example/view/lit.png" ]]; then
    cat "$example/view.log"
    echo "the installed penumbra-view did not render and reload an overlay from a moved prefix" >&2
    status=1
  fi
  # And the installed bench and tuner, from a folder outside the tree: they find their Python
  # package, the tools beside them and the scenes from their own path, and write under the
  # working directory (a tiny scene at 64x36, 4 points and 1: about 8 s under ASan).
  mkdir "$example/work"
  cp tests/data/scene/tiny-sun.toml "$example/work/tiny.toml"
  if ! (cd "$example/work" && unset PENUMBRA_BUILD PENUMBRA_SHADER_DIR PENUMBRA_SHADER_PATH &&
        export PENUMBRA_REFERENCE_CACHE="$example/reference-cache" \
          ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0} &&
        "$example/moved/bin/penumbra-bench" --quick --scene tiny.toml --size 64x36 --frames 1 &&
        "$example/moved/bin/penumbra-tune" --scene tiny.toml --trials 1 --size 64x36 \
          --frames 1 --path-frames 2) > "$example/tools.log" 2>&1 ||
     [[ ! -s "$example/work/out/bench/bench.csv" ||
        ! -s "$example/work/out/tune/tiny/points.csv" ]]; then
    cat "$example/tools.log"
    echo "the installed penumbra-bench or penumbra-tune did not run from a moved prefix" >&2
    status=1
  fi
else
  cat "$example"/*.log
  echo "the example project did not build against the installed package" >&2
  status=1
fi
exit $status
