#!/usr/bin/env bash
# Installs every Debian package Penumbra needs. Idempotent; run as root on Debian 12.
set -euo pipefail
packages=(
  build-essential cmake ninja-build pkg-config git clang-format lld
  glslang-dev glslang-tools libspirv-cross-c-shared-dev spirv-tools
  mesa-vulkan-drivers libvulkan-dev vulkan-validationlayers vulkan-tools
  libglm-dev libglfw3-dev libgtest-dev libgmock-dev xvfb libstb-dev
  libtomlplusplus-dev libtinyobjloader-dev glmark2-data libimgui-dev libembree-dev libpng-dev
  libmeshoptimizer-dev
  libcli11-dev
  python3 python3-matplotlib python3-pil python3-optuna python3-distributed lcov
  chromium chromium-driver python3-selenium cmark-gfm
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update
  apt-get install -y --no-install-recommends "${missing[@]}"
fi
echo "penumbra: all ${#packages[@]} Debian packages present"
