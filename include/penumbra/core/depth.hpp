#pragma once

// The depth-buffer convention, a concept of every layer (the shadow math, the renderer, the
// test harness's depth generators), so it lives here rather than in any one of them.

#include <cstdint>

namespace penumbra {

// How a [near, far] range maps to Vulkan's [0, 1] depth.
//   reverse_z (default): near -> 1, far -> 0; depth test GREATER(_OR_EQUAL); clear to 0.
//   standard:            near -> 0, far -> 1; depth test LESS(_OR_EQUAL);    clear to 1.
enum class DepthConvention : std::uint32_t { standard = 0, reverse_z = 1 };

}  // namespace penumbra
