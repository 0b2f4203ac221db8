#pragma once

// Independent C++ references for shaders/penumbra/temporal.glsl, in double: the octahedral
// map written from its definition (the unit vector scaled onto the L1 sphere, the lower half
// folded over the diagonals), the projection to pixel-centre coordinates, the same-surface test
// and the clamped blend.

#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>

namespace penumbra::reference {

// The octahedron |x| + |y| + |z| = 1 unfolded onto the square: a point of the upper half keeps
// its (x, y); one of the lower half moves to the mirror image of (y, x) across the square's
// edge on its side. Zero and non-finite vectors: (0, 0).
inline glm::dvec2 oct_encode(glm::dvec3 n) {
  const double l1 = std::abs(n.x) + std::abs(n.y) + std::abs(n.z);
  if (!(l1 > 0.0) || !std::isfinite(l1)) return {0.0, 0.0};
  const glm::dvec3 p = n / l1;
  if (p.z >= 0.0) return {p.x, p.y};
  const double sx = p.x >= 0.0 ? 1.0 : -1.0, sy = p.y >= 0.0 ? 1.0 : -1.0;
  return {(1.0 - std::abs(p.y)) * sx, (1.0 - std::abs(p.x)) * sy};
}

// Pixel-centre coordinates of view-space point v under proj in an image of size pixels, and
// whether it lies in front of the camera (clip w > 0).
struct Reprojected {
  glm::dvec2 pixel{0.0};
  bool in_front = false;
};
inline Reprojected reproject(const glm::dmat4& proj, glm::dvec3 v, glm::dvec2 size) {
  const glm::dvec4 c = proj * glm::dvec4(v, 1.0);
  if (!(c.w > 0.0)) return {};
  return {(glm::dvec2(c.x, c.y) / c.w * 0.5 + 0.5) * size - 0.5, true};
}

// Signed margin of the same-surface test: > 0 inside (the distance within tolerance and the
// normals within the cosine), < 0 outside; the smaller of the two margins.
inline double same_surface_margin(double stored_distance, glm::dvec3 stored_normal,
                                  double expected_distance, glm::dvec3 expected_normal,
                                  double fraction, double constant, double min_cos) {
  if (!(stored_distance > 0.0)) return -1.0;
  const double tolerance = fraction * expected_distance + constant;
  const double distance_margin = tolerance - std::abs(stored_distance - expected_distance);
  const double normal_margin = glm::dot(stored_normal, expected_normal) - min_cos;
  return std::min(distance_margin, normal_margin);
}

// history clamped to [lo, hi] (hi when lo > hi), then moved towards current by weight.
inline double temporal_blend(double history, double current, double lo, double hi,
                             double weight) {
  if (!std::isfinite(history) || !(weight > 0.0 && weight <= 1.0)) return current;
  const double clamped = std::min(std::max(history, lo), hi);
  return clamped + weight * (current - clamped);
}

}  // namespace penumbra::reference
