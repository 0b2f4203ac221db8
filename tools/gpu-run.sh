#!/usr/bin/env bash
# Runs every test binary of .gpu-bundle on PENUMBRA_DEVICE (default gpu) with the validation
# layer, then the benchmarks and penumbra-view on each shipped scene; logs go to ${OUT:-out/gpu}.
# Expects /work/main to be (or link to) this repository, as the binaries were built there.
set -uo pipefail
out=${OUT:-out/gpu}
mkdir -p "$out"
export PENUMBRA_DEVICE=${PENUMBRA_DEVICE:-gpu} PENUMBRA_VALIDATION=1
tar -xJf .gpu-bundle/bin.tar.xz
export MESA_SHADER_CACHE_DIR=/tmp/mesa-cache
fail=0
summary="$out/tests.txt"
: > "$summary"
for t in $(find build -type f -executable \( -path "*/tests/*" -o -path "*/shader_tests/*" \) | sort); do
  name=$(basename "$t")
  if "$t" > "$out/$name.log" 2>&1; then
    echo "PASS $name $(grep -E '^\[  PASSED  \]' "$out/$name.log")" >> "$summary"
  else
    echo "FAIL $name" >> "$summary"; fail=1
    grep -E "Failure|FAILED|error" "$out/$name.log" | head -20 >> "$summary"
  fi
done
cat "$summary"
exit $fail
