#pragma once

// Independent C++ references for shaders/penumbra/cascade.glsl, written from the definitions in
// its header comment (not from its code), in double precision. Inputs are the float values the
// GPU sees, widened exactly to double.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <limits>

namespace penumbra::ref {

inline constexpr int kMaxCascades = 8;

// ShadowGpu.splits: far split of cascade i at [i / 4][i % 4].
using Splits = std::array<glm::vec4, 2>;

inline double split_far(const Splits& splits, int i) {
  return static_cast<double>(splits[static_cast<std::size_t>(i / 4)][i % 4]);
}

inline int clamp_count(int32_t count, int max = kMaxCascades) {
  return std::clamp(count, 0, max);
}

// The first cascade whose far split is >= depth (binary search over the non-decreasing splits);
// count when beyond the last split or NaN.
inline int32_t select_cascade_by_depth(float depth, const Splits& splits, int32_t count) {
  const int n = clamp_count(count);
  if (std::isnan(depth)) return n;
  std::array<double, kMaxCascades> far{};
  for (int i = 0; i < n; ++i) far[static_cast<std::size_t>(i)] = split_far(splits, i);
  const auto* first = far.data();
  return static_cast<int32_t>(std::lower_bound(first, first + n, static_cast<double>(depth)) -
                              first);
}

// The 1..4-cascade form: splits.x .. splits.w.
inline int32_t select_cascade_by_depth4(float depth, const glm::vec4& splits, int32_t count) {
  return select_cascade_by_depth(depth, Splits{splits, glm::vec4(0.0f)}, clamp_count(count, 4));
}

// The ramp shared by the blend and the fade: linear from 0 at end - width to 1 at end, clamped;
// a step (1 only beyond end) for a width below FLT_MIN (no band) or a non-finite width or end.
inline double end_ramp(double x, double end, double width) {
  constexpr double kMinWidth = std::numeric_limits<float>::min();
  if (!(width >= kMinWidth) || !std::isfinite(width) || !std::isfinite(end)) {
    return x > end ? 1.0 : 0.0;
  }
  // 1 at the end, falling with slope 1 / width (not (x - start) / width: end - width rounds away
  // a width far below an ULP of end, even in double).
  if (x >= end) return 1.0;
  return std::clamp(1.0 - (end - x) / width, 0.0, 1.0);
}

inline double clamp_fraction(float f) {
  return f > 0.0f ? std::min(static_cast<double>(f), 1.0) : 0.0;
}

// Weight of the next cascade: the band is the last `fraction` of [near, far].
inline double cascade_blend_weight(float depth, float near, float far, float band_fraction) {
  if (std::isnan(depth)) return 0.0;
  const double width = clamp_fraction(band_fraction) * (static_cast<double>(far) - near);
  return end_ramp(depth, far, width);
}

inline double cascade_blend_to_next(float depth, const Splits& splits, int32_t cascade,
                                    int32_t count, float camera_near, float band_fraction) {
  const int n = clamp_count(count);
  if (cascade < 0 || cascade >= n - 1) return 0.0;
  const double near = cascade == 0 ? camera_near : split_far(splits, cascade - 1);
  const double far = split_far(splits, cascade);
  if (std::isnan(depth)) return 0.0;
  return end_ramp(depth, far, clamp_fraction(band_fraction) * (far - near));
}

// Fade to lit over the last fade_fraction of [0, max_distance]; NaN is lit.
inline double shadow_distance_fade(float depth, float max_distance, float fade_fraction) {
  if (std::isnan(depth)) return 1.0;
  return end_ramp(depth, max_distance, clamp_fraction(fade_fraction) * max_distance);
}

struct ShadowCoord {
  bool outside = true;     // w < FLT_MIN, or a non-finite (in float) result
  glm::dvec3 coord{-1.0};  // (u, v, depth); (-1, -1, -1) when outside
  glm::dvec4 clip{0.0};
};

inline ShadowCoord world_to_shadow_coord(const glm::mat4& view_proj, const glm::vec3& position) {
  ShadowCoord r;
  const glm::dmat4 m(view_proj);
  r.clip = m * glm::dvec4(glm::dvec3(position), 1.0);
  const double w = r.clip.w;
  if (!(w >= static_cast<double>(std::numeric_limits<float>::min())) || !std::isfinite(w)) return r;
  const glm::dvec3 ndc = glm::dvec3(r.clip) / w;
  const glm::dvec3 coord(ndc.x * 0.5 + 0.5, ndc.y * 0.5 + 0.5, ndc.z);
  // Outside when a float would overflow: the NDC itself, or the coordinate.
  constexpr double kFloatMax = std::numeric_limits<float>::max();
  for (int c = 0; c < 3; ++c) {
    if (!(std::abs(ndc[c]) <= kFloatMax) || !(std::abs(coord[c]) <= kFloatMax)) return r;
  }
  r.outside = false;
  r.coord = coord;
  return r;
}

// uv at least border texels inside the map on each side, depth in [0, 1]; exact in double for
// float inputs.
inline bool shadow_coord_in_bounds(const glm::dvec3& coord, float border_texels, float resolution) {
  for (int c = 0; c < 3; ++c) {
    if (!std::isfinite(coord[c])) return false;
  }
  const double res = resolution, border = border_texels;
  for (int c = 0; c < 2; ++c) {
    if (!(coord[c] * res >= border) || !((1.0 - coord[c]) * res >= border)) return false;
  }
  return coord.z >= 0.0 && coord.z <= 1.0;
}

inline int32_t select_cascade_by_containment(const std::array<glm::vec3, 8>& coords, int32_t count,
                                             float border_texels, float resolution) {
  const int n = clamp_count(count);
  for (int i = 0; i < n; ++i) {
    if (shadow_coord_in_bounds(glm::dvec3(coords[static_cast<std::size_t>(i)]), border_texels,
                               resolution)) {
      return i;
    }
  }
  return n;
}

inline int32_t select_cascade_by_position(const glm::vec3& position,
                                          const std::array<glm::mat4, 8>& view_proj, int32_t count,
                                          float border_texels, float resolution) {
  const int n = clamp_count(count);
  for (int i = 0; i < n; ++i) {
    const ShadowCoord c = world_to_shadow_coord(view_proj[static_cast<std::size_t>(i)], position);
    if (!c.outside && shadow_coord_in_bounds(c.coord, border_texels, resolution)) return i;
  }
  return n;
}

}  // namespace penumbra::ref
