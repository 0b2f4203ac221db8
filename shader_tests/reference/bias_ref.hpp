#pragma once

// Independent C++ references for shaders/penumbra/bias.glsl, written from the definitions in its
// header comment (not from its code), in double precision with the textbook formulas
// (sin(acos(c)), tan(acos(c)), a 2x2 matrix inverse). Inputs are the float values the GPU sees,
// widened exactly to double.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <limits>

namespace penumbra::ref {

inline constexpr double kFloatMin = std::numeric_limits<float>::min();
inline constexpr double kFloatMax = std::numeric_limits<float>::max();

// A vector is degenerate when a component is not finite, or when every component is below
// FLT_MIN in magnitude (zero or denormal). Any other length is usable.
inline bool degenerate(const glm::vec3& v) {
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(v[i])) return true;
  const double m = std::max({std::abs(double(v.x)), std::abs(double(v.y)), std::abs(double(v.z))});
  return !(m >= kFloatMin);
}

// sin(theta) for N.L > 0, else 1; 1 for a degenerate normal or light.
inline double normal_offset_scale(const glm::vec3& normal, const glm::vec3& to_light) {
  if (degenerate(normal) || degenerate(to_light)) return 1.0;
  const glm::dvec3 n = glm::normalize(glm::dvec3(normal));
  const glm::dvec3 l = glm::normalize(glm::dvec3(to_light));
  const double c = glm::dot(n, l);
  if (!(c > 0.0)) return 1.0;
  return std::sin(std::acos(std::min(c, 1.0)));
}

inline glm::dvec3 normal_offset(const glm::vec3& normal, const glm::vec3& to_light,
                                float texel_world_size, float offset_texels) {
  if (degenerate(normal)) return glm::dvec3(0.0);
  const double distance =
      static_cast<double>(offset_texels) * texel_world_size * normal_offset_scale(normal, to_light);
  return glm::normalize(glm::dvec3(normal)) * distance;
}

inline double slope_scaled_bias(float n_dot_l, float constant_bias, float slope_scale,
                                float max_bias) {
  if (std::isnan(n_dot_l) || !(n_dot_l >= kFloatMin)) return max_bias;
  const double theta = std::acos(std::min(static_cast<double>(n_dot_l), 1.0));
  return std::min(constant_bias + static_cast<double>(slope_scale) * std::tan(theta),
                  static_cast<double>(max_bias));
}

// The relative size of the uv Jacobian's determinant: |det| / (|du/dx dv/dy| + |du/dy dv/dx|)
// (0 when both products are 0).
inline double relative_determinant(const glm::vec3& ddx, const glm::vec3& ddy) {
  const double ad = static_cast<double>(ddx.x) * ddy.y;
  const double bc = static_cast<double>(ddy.x) * ddx.y;
  const double scale = std::abs(ad) + std::abs(bc);
  return scale > 0.0 ? std::abs(ad - bc) / scale : 0.0;
}

inline constexpr double kReceiverPlaneMinDet = 1.0e-4;

// (dz/du, dz/dv) = (dz/dx, dz/dy) J^-1 with J the uv Jacobian; zero when J is singular (relative
// determinant <= 1e-4), when its products or its determinant leave the normal float range, for
// non-finite inputs, or when the gradient does not fit a float.
inline glm::dvec2 receiver_plane_depth_gradient(const glm::vec3& ddx, const glm::vec3& ddy) {
  for (int c = 0; c < 3; ++c) {
    if (!std::isfinite(ddx[c]) || !std::isfinite(ddy[c])) return glm::dvec2(0.0);
  }
  // Products below the normal float range or above it: no usable determinant in float.
  const double size =
      std::abs(static_cast<double>(ddx.x) * ddy.y) + std::abs(static_cast<double>(ddy.x) * ddx.y);
  if (!(size >= kFloatMin) || !(size <= kFloatMax)) return glm::dvec2(0.0);
  if (!(relative_determinant(ddx, ddy) > kReceiverPlaneMinDet)) return glm::dvec2(0.0);
  const double det = static_cast<double>(ddx.x) * ddy.y - static_cast<double>(ddy.x) * ddx.y;
  if (!(std::abs(det) >= kFloatMin)) return glm::dvec2(0.0);
  // Columns of J: the uv change along screen x, then along screen y.
  const glm::dmat2 jacobian(glm::dvec2(ddx.x, ddx.y), glm::dvec2(ddy.x, ddy.y));
  // (dz/dx, dz/dy) = (dz/du, dz/dv) J as a row vector, so the gradient is the row vector times
  // J^-1.
  const glm::dvec2 gradient = glm::dvec2(ddx.z, ddy.z) * glm::inverse(jacobian);
  if (!(std::abs(gradient.x) <= kFloatMax) || !(std::abs(gradient.y) <= kFloatMax)) {
    return glm::dvec2(0.0);
  }
  return gradient;
}

// Moves depth towards the light: up under reverse-Z, down under standard depth; the exact result
// rounded once to float (a float sum or difference rounded through double is correctly rounded).
inline float apply_depth_bias(float depth, float bias, bool reverse_z) {
  const double d = depth, b = bias;
  return static_cast<float>(reverse_z ? d + b : d - b);
}

}  // namespace penumbra::ref
