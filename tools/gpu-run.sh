#!/usr/bin/env bash
# Runs the binaries of .gpu-bundle (tools/gpu-bundle.sh) on another machine with a GPU, from a
# copy of this repository: every test binary with the validation layer on, the benchmarks, and
# penumbra-view on each shipped scene. Prints a summary; logs go to ${OUT:-out/gpu}/logs.tar.gz.
# The binaries were built in /work/main: link the copy there first if it lives elsewhere.
set -uo pipefail
out=${OUT:-out/gpu}
logs=$(mktemp -d)
mkdir -p "$out"
tar -xJf .gpu-bundle/bin.tar.xz
export LD_LIBRARY_PATH=$PWD/build/lib:${LD_LIBRARY_PATH:-}
if [[ ! -d /usr/share/glmark2/models ]]; then
  mkdir -p /usr/share/glmark2 && cp -r build/models /usr/share/glmark2/models
fi
export PENUMBRA_DEVICE=${PENUMBRA_DEVICE:-gpu}
export MESA_SHADER_CACHE_DIR=${MESA_SHADER_CACHE_DIR:-/tmp/mesa-cache}
build/runtime/penumbra-view --list-devices
fail=0
for t in $(find build -type f -executable \( -path "*/tests/*" -o -path "*/shader_tests/*" \) | sort | grep -E "${PENUMBRA_GPU_TESTS:-.}"); do
  n=$(basename "$t")
  PENUMBRA_VALIDATION=1 timeout 300 "$t" > "$logs/$n.log" 2>&1
  rc=$?
  [[ $rc == 0 ]] || fail=1
  echo "$n rc=$rc $(grep -E '^\[  (PASSED|FAILED)  \]' "$logs/$n.log" | head -1)"
done
{
  PENUMBRA_VALIDATION=0 build/tools/penumbra-startup-bench
  PENUMBRA_VALIDATION=0 build/tools/penumbra-harness-bench --same-functions
  PENUMBRA_VALIDATION=0 build/tools/penumbra-harness-bench --same-functions
} > "$out/bench.txt" 2>&1
for s in default grazing space indoor; do
  PENUMBRA_VALIDATION=1 build/runtime/penumbra-view --headless --scene "$s" --frames 10 \
    --size 1280x720 --out "$logs/view-$s" > "$logs/view-$s.txt" 2>&1 || fail=1
  cat "$logs/view-$s.txt" >> "$out/view.txt"
done
cp "$logs/view-default/lit.png" "$out/default-lit.png" 2>/dev/null
# The ray-traced reference of each shipped scene at its defaults, against this GPU's frames (the
# tracing runs on this machine's CPU).
for s in default grazing indoor space; do
  PENUMBRA_VALIDATION=1 build/tools/penumbra-reference --scene "$s" --no-cache \
    --out "$logs/reference-$s" >> "$out/reference.txt" 2>&1 || fail=1
done
PENUMBRA_VALIDATION=0 build/tools/penumbra-reference-bench --repeat 3 >> "$out/bench.txt" 2>&1
tar -czf "$out/logs.tar.gz" -C "$logs" .
exit $fail
