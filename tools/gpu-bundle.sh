#!/usr/bin/env bash
# Packs the built test binaries, benchmarks and penumbra-view (stripped) into .gpu-bundle/ so the
# same binaries can run on another machine with a real GPU. On that machine, in a copy of this
# repository: tools/gpu-run.sh (it links the bundle where the binaries expect the build tree).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${PENUMBRA_BUILD:-build}
rm -rf .gpu-bundle && mkdir -p .gpu-bundle
list=$(find "$build" -type f -executable \( -path "*/tests/*" -o -path "*/shader_tests/*" -o -path "*/tools/*" -o -path "*/runtime/*" \) ! -path "*/CMakeFiles/*" ! -name "*.so" ! -name "*.sh")
tar -cf - $list | (cd .gpu-bundle && tar -xf -)
find .gpu-bundle -type f -executable -exec strip --strip-unneeded {} +
[[ "$build" == build ]] || mv ".gpu-bundle/$build" .gpu-bundle/build
tar -C .gpu-bundle -cJf .gpu-bundle/bin.tar.xz build && rm -rf .gpu-bundle/build
du -sh .gpu-bundle
