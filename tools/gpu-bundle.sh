#!/usr/bin/env bash
# Packs the built test binaries, benchmarks and penumbra-view (stripped) into .gpu-bundle/ so the
# same binaries can run on another machine with a real GPU. On that machine, in a copy of this
# repository: tools/gpu-run.sh (it links the bundle where the binaries expect the build tree).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${PENUMBRA_BUILD:-build}
rm -rf .gpu-bundle && mkdir -p .gpu-bundle
# PENUMBRA_BUNDLE_FILTER (an extended regex over the paths) packs a part, for a machine that takes
# only so much at a time.
list=$(find "$build" -type f -executable \( -path "*/tests/*" -o -path "*/shader_tests/*" -o -path "*/tools/*" -o -path "*/runtime/*" \) ! -path "*/CMakeFiles/*" ! -name "*.so" ! -name "*.sh" | grep -E "${PENUMBRA_BUNDLE_FILTER:-.}")
tar -cf - $list | (cd .gpu-bundle && tar -xf -)
find .gpu-bundle -type f -executable -exec strip --strip-unneeded {} +
# Shared libraries from the project's Debian packages that a bare machine lacks (toml++,
# tinyobjloader, ...): everything ldd resolves except the C/C++ runtime and the Vulkan loader.
mkdir -p ".gpu-bundle/$build/lib"
for bin in $list; do ldd "$bin"; done | awk '/=> \//{print $3}' | sort -u |
  grep -vE '/(libc|libm|libstdc\+\+|libgcc_s|libvulkan|ld-linux|libpthread|libdl|librt)[.-]' |
  xargs -r -I{} cp -L {} ".gpu-bundle/$build/lib/" || true  # grep finds none: only system libs
[[ "$build" == build ]] || mv ".gpu-bundle/$build" .gpu-bundle/build
# The meshes the shipped scenes load (Debian's glmark2-data).
mkdir -p .gpu-bundle/build/models && cp /usr/share/glmark2/models/{bunny.obj,asteroid-low.3ds,asteroid-high.3ds,cube.3ds} .gpu-bundle/build/models/
tar -C .gpu-bundle -cJf .gpu-bundle/bin.tar.xz build && rm -rf .gpu-bundle/build
du -sh .gpu-bundle
