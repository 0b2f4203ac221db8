#pragma once

// Shared helpers of the shadow tests: scenes, cameras, random sampling, texel coordinates.

#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <penumbra/shadow/shadow.hpp>
#include <random>

namespace penumbra::shadow::test {

inline Camera default_camera(const glm::dvec3& position = glm::dvec3(0.0, 2.0, 0.0)) {
  Camera camera;
  camera.position = position;
  camera.forward = glm::dvec3(0.6, -0.2, -0.77);
  camera.up = glm::dvec3(0.0, 1.0, 0.0);
  camera.fov_y = 1.0;
  camera.aspect = 16.0 / 9.0;
  camera.near = 0.1;
  camera.far = 1000.0;
  return camera;
}

inline DirectionalLight default_light() {
  DirectionalLight light;
  light.direction = glm::dvec3(0.35, -1.0, 0.25);
  return light;
}

// A 400 m square of terrain, 60 m of height, around `center`.
inline Aabb default_scene(const glm::dvec3& center = glm::dvec3(0.0)) {
  return Aabb{center + glm::dvec3(-200.0, -10.0, -200.0), center + glm::dvec3(200.0, 50.0, 200.0)};
}

struct Frame {
  glm::dvec3 forward;
  glm::dvec3 right;
  glm::dvec3 up;
  double tan_x;
  double tan_y;
};

inline Frame frame_of(const Camera& camera) {
  Frame f;
  f.forward = glm::normalize(camera.forward);
  f.right = glm::normalize(glm::cross(f.forward, camera.up));
  f.up = glm::cross(f.right, f.forward);
  f.tan_y = std::tan(camera.fov_y * 0.5);
  f.tan_x = f.tan_y * camera.aspect;
  return f;
}

// The world point at view distance d and normalized frustum position (sx, sy) in [-1, 1]^2.
inline glm::dvec3 frustum_point(const Camera& camera, double d, double sx, double sy) {
  const Frame f = frame_of(camera);
  return camera.position + f.forward * d + f.right * (sx * d * f.tan_x) + f.up * (sy * d * f.tan_y);
}

inline glm::dvec3 random_direction(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  for (;;) {
    const glm::dvec3 v(n(rng), n(rng), n(rng));
    const double l = glm::length(v);
    if (l > 1e-6) return v / l;
  }
}

inline double uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

inline glm::dvec3 uniform3(std::mt19937_64& rng, double lo, double hi) {
  return glm::dvec3(uniform(rng, lo, hi), uniform(rng, lo, hi), uniform(rng, lo, hi));
}

// Shadow-map texel coordinate of p (uv * resolution).
inline glm::dvec2 texel_coord(const glm::dmat4& view_proj, const glm::dvec3& p,
                              std::uint32_t resolution) {
  const glm::dvec3 ndc = project_point(view_proj, p);
  return ndc_to_uv(glm::dvec2(ndc)) * static_cast<double>(resolution);
}

// The same in float, as a shader computes it: p relative to the render origin, float matrix.
inline glm::dvec2 texel_coord_gpu(const glm::mat4& view_proj, const glm::dvec3& p_world,
                                  const glm::dvec3& render_origin, std::uint32_t resolution) {
  const glm::vec4 rel(glm::vec3(p_world - render_origin), 1.0f);
  const glm::vec4 clip = view_proj * rel;
  const glm::vec2 uv = glm::vec2(clip) / clip.w * 0.5f + 0.5f;
  return glm::dvec2(uv * static_cast<float>(resolution));
}

// Distance between the fractional parts of a and b, on the circle (in [0, 0.5]).
inline double fractional_distance(double a, double b) {
  const double d = a - b;
  return std::abs(d - std::round(d));
}

}  // namespace penumbra::shadow::test
