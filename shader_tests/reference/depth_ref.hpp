#pragma once

// Independent C++ references for shaders/penumbra/depth.glsl, written from the projection's
// definition and evaluated in long double (64-bit significand on x86-64), in forms that do not
// cancel, so their own error (~2^-62 relative) is negligible next to the float bounds tested.
//
// Conventions (as depth.glsl): view space right-handed, camera looking down -Z; z = -view.z > 0
// is the view distance; Vulkan depth d in [0, 1]; reverse-Z maps near -> 1 and far -> 0; NDC
// y = -1 is the top of the image and uv = ndc * 0.5 + 0.5.

#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>
#include <limits>

#include "reference/noise_ref.hpp"  // the Vulkan float model (kRoundingRel)

namespace penumbra::reference {

static_assert(std::numeric_limits<long double>::digits >= 64,
              "the depth references need an 80-bit (or wider) long double");

using Real = long double;

// Depth of view distance z for a perspective projection with planes near < far (finite): the
// ratio of the projection's clip z to clip w, in factored form (no cancellation near d = 0, where
// the projection-matrix form (A * view.z + B) / z, A and B as in perspective() below, would lose
// reverse-Z's small depths to the rounding of A and B).
inline Real depth_from_view_distance(Real z, Real near, Real far, bool reverse_z) {
  return reverse_z ? near * (far - z) / (z * (far - near)) : far * (z - near) / (z * (far - near));
}

// Its inverse, the view distance of depth d: for reverse-Z, solving d = near (far - z) / (z (far -
// near)) gives z = near far / (near + d (far - near)), a sum of non-negative terms. Standard-Z's
// depth is 1 - reverse-Z's (the same projection with the depth axis flipped), and 1 - d is exact
// in long double for a float d, so it reuses the reverse form; the textbook standard form near far
// / (far - d (far - near)) cancels towards d = 1 by far / near, beyond even long double at 1e40.
inline Real view_distance_from_depth(Real d, Real near, Real far, bool reverse_z) {
  const Real e = reverse_z ? d : 1.0L - d;  // the reverse-Z depth
  return near * far / (near + e * (far - near));
}

// What linearize_depth(d, near, far, reverse_z) may return, with its bound (relative error `rel`
// of the shader's evaluation): a denormal d may be flushed to 0 (see kFlushFloor), so for one the
// bound reaches the answer for depth 0 too.
struct BoundedValue {
  double value;
  double bound;
};
inline BoundedValue linearize_expectation(float d, float near, float far, bool reverse_z,
                                          double rel) {
  const auto z = static_cast<double>(view_distance_from_depth(d, near, far, reverse_z));
  BoundedValue out{z, rel * z};
  if (is_denormal(d)) {
    const auto z0 = static_cast<double>(view_distance_from_depth(0.0L, near, far, reverse_z));
    out.bound = std::max(out.bound, std::fabs(z0 - z) + rel * z0);
  }
  return out;
}

// Infinite far plane: the limits far -> infinity of the above.
inline Real depth_from_view_distance_infinite(Real z, Real near, bool reverse_z) {
  return reverse_z ? near / z : 1.0L - near / z;
}
inline Real view_distance_from_depth_infinite(Real d, Real near, bool reverse_z) {
  if (reverse_z) return d == 0.0L ? std::numeric_limits<Real>::infinity() : near / d;
  return d == 1.0L ? std::numeric_limits<Real>::infinity() : near / (1.0L - d);
}

// A Vulkan perspective projection (column-major, y flipped so view +Y is the top of the image,
// NDC -Y), symmetric, with vertical half-angle tangent t and aspect = width / height.
// far = +infinity gives the infinite-far projection.
inline glm::dmat4 perspective(double t, double aspect, double near, double far, bool reverse_z) {
  glm::dmat4 p(0.0);
  p[0][0] = 1.0 / (aspect * t);
  p[1][1] = -1.0 / t;  // the Vulkan y flip
  p[2][3] = -1.0;      // clip.w = -view.z
  if (std::isinf(far)) {
    p[2][2] = reverse_z ? 0.0 : -1.0;
    p[3][2] = reverse_z ? near : -near;
  } else {
    p[2][2] = reverse_z ? near / (far - near) : far / (near - far);
    p[3][2] = reverse_z ? near * far / (far - near) : near * far / (near - far);
  }
  return p;
}

// Texture coordinate and depth of a view-space point under projection p.
struct Projected {
  glm::dvec2 uv;
  double depth;
};
inline Projected project(const glm::dmat4& p, const glm::dvec3& view) {
  const glm::dvec4 clip = p * glm::dvec4(view, 1.0);
  const glm::dvec3 ndc = glm::dvec3(clip) / clip.w;
  return {glm::dvec2(ndc) * 0.5 + 0.5, ndc.z};
}

// The view position at texture coordinate uv and view distance z, from the frustum's geometry
// (a ray through the pixel, scaled to z): ((2u - 1) aspect t z, -(2v - 1) t z, -z).
inline glm::dvec3 view_position(glm::dvec2 uv, double z, double t, double aspect) {
  const glm::dvec2 ndc = uv * 2.0 - 1.0;
  return {ndc.x * aspect * t * z, -ndc.y * t * z, -z};
}

// What view_position_from_depth(uv, d, m) computes, (m * (uv * 2 - 1, d, 1)).xyz / w, evaluated
// in double from the same float inputs (so the matrix's own rounding is an input, not an error),
// and the bound on the shader's error per component:
//   ndc = uv * 2 - 1: within 2^-23 |ndc| each (the doubling is exact, the subtraction rounded);
//   h_i = sum_j m_ij n_j: three products and three sums in any association: within 4 * 2^-23
//         sum_j |m_ij n_j| (E_i), plus sum_j |m_ij| times the ndc errors;
//   x_i = h_i / w: |(h_i + e_i) / (w + e_w) - h_i / w| <= (E_i + |x_i| E_w) / (|w| - E_w) (no
//         bound where E_w >= |w|), plus the division's 2.5 ULP; 1.001 for second-order terms.
// Standard-Z's w = (1 - d (far - near) / far) / near cancels towards the far plane, so the bound
// (and the real error) grows as z / near there; reverse-Z's w sums non-negative terms.
struct BoundedPosition {
  glm::dvec3 value;
  glm::dvec3 bound;
};
inline BoundedPosition inverse_projection_reconstruction(glm::vec2 uv, float d,
                                                         const glm::mat4& m) {
  const glm::dvec4 n(glm::dvec2(uv) * 2.0 - 1.0, d, 1.0);
  const glm::dvec4 n_error(kRoundingRel * std::fabs(n.x), kRoundingRel * std::fabs(n.y), 0, 0);
  glm::dvec4 h(0.0), e(0.0);
  for (int j = 0; j < 4; ++j) {
    for (int r = 0; r < 4; ++r) {
      const double t = double{m[j][r]} * n[j];
      h[r] += t;
      e[r] += 4.0 * kRoundingRel * std::fabs(t) + std::fabs(double{m[j][r]}) * n_error[j];
    }
  }
  BoundedPosition out;
  for (int r = 0; r < 3; ++r) {
    const double x = h[r] / h.w;
    const double quotient = e.w < std::fabs(h.w)
                                ? (e[r] + std::fabs(x) * e.w) / (std::fabs(h.w) - e.w)
                                : std::numeric_limits<double>::infinity();
    out.value[r] = x;
    out.bound[r] = 1.001 * (quotient + kDivisionUlps * kRoundingRel * (std::fabs(x) + quotient));
  }
  return out;
}

}  // namespace penumbra::reference
