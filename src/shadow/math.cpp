#include <algorithm>
#include <cmath>
#include <penumbra/shadow/math.hpp>

#include "detail.hpp"

namespace penumbra::shadow {

glm::dvec3 normalize_direction(const glm::dvec3& direction, const char* what) {
  const double m = std::max({std::abs(direction.x), std::abs(direction.y), std::abs(direction.z)});
  if (!detail::finite(direction) || !(m > 0.0)) {
    detail::fail(what, detail::format(direction), "must be a finite, non-zero direction");
  }
  const glm::dvec3 scaled = direction / m;  // largest component is exactly +-1
  return scaled / std::sqrt(glm::dot(scaled, scaled));
}

Basis orthonormal_basis(const glm::dvec3& direction) {
  const glm::dvec3 n = normalize_direction(direction, "direction");
  // Duff et al. 2017 with the pole on world +Y: permute cyclically (x, y, z) -> (z, x, y) so that
  // the formula's "z" is world y, build the basis there, permute back. A cyclic permutation is
  // a rotation, so the basis stays right-handed.
  const double px = n.z;
  const double py = n.x;
  const double pz = n.y;
  const double sign = std::copysign(1.0, pz);
  const double a = -1.0 / (sign + pz);
  const double b = px * py * a;
  const glm::dvec3 b1(1.0 + sign * px * px * a, sign * b, -sign * px);
  const glm::dvec3 b2(b, sign + py * py * a, -py);
  Basis basis;
  // Inverse permutation: (x', y', z') -> (y', z', x').
  basis.x = glm::dvec3(b1.y, b1.z, b1.x);
  basis.y = glm::dvec3(b2.y, b2.z, b2.x);
  basis.z = n;
  return basis;
}

glm::dmat4 view_matrix(const Basis& basis, const glm::dvec3& eye) {
  glm::dmat4 m(1.0);
  for (int c = 0; c < 3; ++c) {
    m[c][0] = basis.x[c];
    m[c][1] = basis.y[c];
    m[c][2] = basis.z[c];
  }
  m[3][0] = -glm::dot(basis.x, eye);
  m[3][1] = -glm::dot(basis.y, eye);
  m[3][2] = -glm::dot(basis.z, eye);
  return m;
}

glm::dmat4 orthographic_projection(const glm::dvec3& lo, const glm::dvec3& hi,
                                   DepthConvention depth) {
  glm::dmat4 m(0.0);
  const glm::dvec3 size = hi - lo;
  m[0][0] = 2.0 / size.x;
  m[3][0] = -(hi.x + lo.x) / size.x;
  m[1][1] = 2.0 / size.y;
  m[3][1] = -(hi.y + lo.y) / size.y;
  if (depth == DepthConvention::reverse_z) {
    m[2][2] = -1.0 / size.z;
    m[3][2] = hi.z / size.z;
  } else {
    m[2][2] = 1.0 / size.z;
    m[3][2] = -lo.z / size.z;
  }
  m[3][3] = 1.0;
  return m;
}

glm::dmat4 perspective_projection(double tan_half_x, double tan_half_y, double near, double far,
                                  DepthConvention depth) {
  glm::dmat4 m(0.0);
  m[0][0] = 1.0 / tan_half_x;
  m[1][1] = 1.0 / tan_half_y;
  m[2][3] = 1.0;
  const double range = far - near;
  if (depth == DepthConvention::reverse_z) {
    m[2][2] = -near / range;
    m[3][2] = far * near / range;
  } else {
    m[2][2] = far / range;
    m[3][2] = -far * near / range;
  }
  return m;
}

glm::dvec3 project_point(const glm::dmat4& m, const glm::dvec3& p) {
  const glm::dvec4 clip = m * glm::dvec4(p, 1.0);
  return glm::dvec3(clip) / clip.w;
}

bool is_finite(const glm::dmat4& m) {
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) {
      if (!std::isfinite(m[c][r])) return false;
    }
  }
  return true;
}

}  // namespace penumbra::shadow
