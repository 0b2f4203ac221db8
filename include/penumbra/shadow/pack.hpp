#pragma once

// Double-precision results -> the float GPU structs of gpu_types.hpp.
//
// render_origin: the point the renderer subtracts from world positions before they reach the
// GPU (camera-relative rendering). Every matrix is rebased in double (view_proj * T(origin))
// and only then rounded to float, so a shadow lookup 10 km from the world origin keeps ~1e-4
// texel precision when the origin is near the camera. Pass the zero vector for absolute world
// coordinates (fine near the origin; at 10 km float positions alone are ~1 mm apart).

#include <glm/glm.hpp>
#include <penumbra/shadow/cascades.hpp>
#include <penumbra/shadow/gpu_types.hpp>
#include <penumbra/shadow/local_lights.hpp>
#include <vector>

namespace penumbra::shadow {

// clip = m * (p_world, 1) rewritten as clip = result * (p_world - origin, 1), in double.
glm::dmat4 rebase(const glm::dmat4& m, const glm::dvec3& origin);

ShadowGpu pack_shadow(const CascadeSet& set, const glm::dvec3& render_origin);
// The sun's depth-pass block (CascadeDrawGpu, gpu_types.hpp) for positions relative to
// `anchor`. A cascade placed on whole texels (snap_to_texels) keeps the grid that starts at
// starts[i] (whole texels along the light's x and y axes) while its window, its first texel on
// the grid, stays within [0, 2 m) of it, m the least multiple of the resolution that is at
// least kGridMargin; otherwise (or when starts[i] is NaN, or absent) it gets a grid starting m
// texels before its window. Grid coordinates then stay below 2^16 (exact in 1/256-texel steps).
// A cascade that is not on whole texels gets a grid at its own first texel (start NaN).
// `start` says which grid each got; `viewport`: P, the least power of two >= the resolution.
inline constexpr double kGridMargin = 2048.0;
struct ShadowDraw {
  ShadowDrawGpu gpu{};
  glm::ivec2 window[kMaxCascades]{};
  glm::dvec2 start[kMaxCascades]{};
  std::uint32_t viewport = 1;
};
ShadowDraw pack_shadow_draw(const CascadeSet& set, const glm::dvec3& anchor,
                            const std::vector<glm::dvec2>& starts = {});
SpotShadowGpu pack_spot_shadow(const SpotShadow& shadow, const glm::dvec3& render_origin);
PointShadowGpu pack_point_shadow(const PointShadow& shadow, const glm::dvec3& render_origin);

}  // namespace penumbra::shadow
