// Double-precision reference for shaders/penumbra/sphere_shadow.glsl, written from the geometry
// rather than from the GLSL's closed forms: the hidden fraction of a light cap is integrated
// numerically over the cap, ring by ring, with the arc of each ring inside the occluder cap from
// the spherical law of cosines.
#pragma once

#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>
#include <numbers>

namespace penumbra::sphere_ref {

// Fraction of a light cap of half-angle a hidden by an occluder cap of half-angle b whose centre
// is g away. The cap is uniform in solid angle: with s = sin^2(theta / 2) (1 - cos theta = 2 s),
// solid angle is uniform in s, so the midpoint rule in s over `steps` rings averages the rings'
// hidden arc fractions.
inline double cap_occlusion(double a, double b, double g, int steps = 4000) {
  if (a <= 0.0) return g < b ? 1.0 : 0.0;
  const double s_max = std::pow(std::sin(0.5 * a), 2.0);
  const double cb = std::cos(b), cg = std::cos(g), sg = std::sin(g);
  double sum = 0.0;
  for (int i = 0; i < steps; ++i) {
    const double s = s_max * (i + 0.5) / steps;
    const double theta = 2.0 * std::asin(std::sqrt(s));
    const double ct = std::cos(theta), st = std::sin(theta);
    // A point of the ring at azimuth phi (from the occluder's side) is inside the occluder when
    // ct cg + st sg cos(phi) >= cos b.
    const double den = st * sg;
    double arc;
    if (den <= 0.0) {
      arc = ct * cg >= cb ? 1.0 : 0.0;
    } else {
      const double k = (cb - ct * cg) / den;
      arc = k <= -1.0 ? 1.0 : k >= 1.0 ? 0.0 : std::acos(k) / std::numbers::pi;
    }
    sum += arc;
  }
  return sum / steps;
}

inline double angle(glm::dvec3 u, glm::dvec3 v) {
  const glm::dvec3 un = glm::normalize(u), vn = glm::normalize(v);
  return 2.0 * std::atan2(glm::length(un - vn), glm::length(un + vn));
}

// The occluder's half-angle: pi/2 on or inside the sphere.
inline double occluder_half_angle(double r, double d) {
  return d > r ? std::asin(r / d) : 0.5 * std::numbers::pi;
}

// A sphere light (centre c, radius R) and a sphere occluder (centre o, radius r) seen from p.
inline double sphere_light_occlusion(glm::dvec3 p, glm::dvec3 c, double R, glm::dvec3 o,
                                     double r) {
  const double dl = glm::length(c - p), d = glm::length(o - p);
  if (d - r >= dl) return 0.0;  // wholly beyond the light's centre
  return cap_occlusion(std::asin(std::min(R / dl, 1.0)), occluder_half_angle(r, d),
                       angle(c - p, o - p));
}

inline double sun_sphere_occlusion(glm::dvec3 p, glm::dvec3 to_sun, double angular_radius,
                                   glm::dvec3 o, double r) {
  return cap_occlusion(angular_radius, occluder_half_angle(r, glm::length(o - p)),
                       angle(to_sun, o - p));
}

}  // namespace penumbra::sphere_ref
