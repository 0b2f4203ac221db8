#pragma once

// Synthetic depth/normal buffers for the contact-shadow tests, built on the host by ray casting
// analytic scenes (planes and boxes) through every pixel centre of a perspective camera: nothing
// is rendered. Also the scenes' ground truth: whether the segment from a pixel's surface point
// towards the light (max_distance long) really hits geometry.

#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>
#include <limits>
#include <penumbra/render/contact_shadows.hpp>
#include <penumbra/shadow/types.hpp>
#include <reference/contact_ref.hpp>
#include <string>
#include <vector>

namespace penumbra::render::test {

struct Plane {
  glm::dvec3 point{0.0};
  glm::dvec3 normal{0.0, 1.0, 0.0};  // unit; the visible side
};

struct Box {
  glm::dvec3 min{0.0}, max{0.0};
};

struct Scene {
  std::string name;
  std::vector<Plane> planes;
  std::vector<Box> boxes;
};

struct SceneHit {
  double t = std::numeric_limits<double>::infinity();
  glm::dvec3 normal{0.0};
};

// Nearest intersection with t in (t_min, t_max) of origin + t * dir.
inline SceneHit intersect(const Scene& s, glm::dvec3 origin, glm::dvec3 dir, double t_min,
                          double t_max) {
  SceneHit best;
  best.t = t_max;
  bool found = false;
  for (const Plane& p : s.planes) {
    const double denom = glm::dot(dir, p.normal);
    if (denom == 0.0) continue;
    const double t = glm::dot(p.point - origin, p.normal) / denom;
    if (t > t_min && t < best.t) {
      best.t = t;
      best.normal = p.normal;
      found = true;
    }
  }
  for (const Box& b : s.boxes) {
    double t0 = t_min, t1 = best.t;
    int axis = -1;
    double sign = 0.0;
    bool miss = false;
    for (int a = 0; a < 3 && !miss; ++a) {
      if (dir[a] == 0.0) {
        if (origin[a] < b.min[a] || origin[a] > b.max[a]) miss = true;
        continue;
      }
      double ta = (b.min[a] - origin[a]) / dir[a];
      double tb = (b.max[a] - origin[a]) / dir[a];
      double s_enter = -1.0;  // entering through the min face: normal -axis
      if (ta > tb) {
        std::swap(ta, tb);
        s_enter = 1.0;
      }
      if (ta > t0) {
        t0 = ta;
        axis = a;
        sign = s_enter;
      }
      t1 = std::min(t1, tb);
      if (t0 > t1) miss = true;
    }
    if (!miss && axis >= 0 && t0 > t_min && t0 < best.t) {
      best.t = t0;
      best.normal = glm::dvec3(0.0);
      best.normal[axis] = sign;
      found = true;
    }
  }
  if (!found) best.t = std::numeric_limits<double>::infinity();
  return best;
}

struct View {
  shadow::Camera camera;
  int width = 160, height = 120;
  shadow::DepthConvention depth = shadow::DepthConvention::reverse_z;
};

inline ContactCamera contact_camera(const View& v) {
  ContactCamera c = ContactCamera::from(v.camera, v.depth);
  return c;
}

// The buffers of a scene, and each pixel's world position (for the ground truth).
struct Frame {
  reference::contact::Buffers buffers;
  std::vector<glm::dvec3> world;  // surface point per pixel (undefined for sky)
  std::vector<glm::dvec3> world_normal;
  std::vector<bool> sky;
};

inline Frame render_buffers(const Scene& s, const View& v) {
  const ContactCamera cc = contact_camera(v);
  const glm::dmat3 basis = contact_view_basis(v.camera);  // view = basis * world
  const glm::dmat3 to_world = glm::transpose(basis);
  const bool reverse_z = v.depth == shadow::DepthConvention::reverse_z;
  Frame f;
  f.buffers.width = v.width;
  f.buffers.height = v.height;
  const std::size_t n = static_cast<std::size_t>(v.width) * v.height;
  f.buffers.depth.resize(n);
  f.buffers.normals.resize(n);
  f.world.resize(n);
  f.world_normal.resize(n);
  f.sky.resize(n);
  for (int y = 0; y < v.height; ++y) {
    for (int x = 0; x < v.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * v.width + x;
      const glm::dvec2 uv((x + 0.5) / v.width, (y + 0.5) / v.height);
      // A direction whose view z is -1: the hit's t is its view distance.
      const glm::dvec3 view_dir((2.0 * uv.x - 1.0) * cc.tan_half_fov_y * cc.aspect,
                                (1.0 - 2.0 * uv.y) * cc.tan_half_fov_y, -1.0);
      const glm::dvec3 dir = to_world * view_dir;
      const SceneHit h = intersect(s, v.camera.position, dir, cc.near, cc.far);
      if (!std::isfinite(h.t)) {
        f.sky[i] = true;
        f.buffers.depth[i] = reverse_z ? 0.0f : 1.0f;
        f.buffers.normals[i] = glm::vec3(0.0f);
        continue;
      }
      f.buffers.depth[i] =
          static_cast<float>(reference::contact::device_depth(h.t, cc.near, cc.far, reverse_z));
      f.buffers.normals[i] = glm::vec3(basis * h.normal);
      f.world[i] = v.camera.position + dir * h.t;
      f.world_normal[i] = h.normal;
    }
  }
  return f;
}

// Ground truth: the segment of length max_distance from pixel i's surface point towards the
// light hits geometry (nudged off the surface by 1e-6 of the distance to avoid the receiver).
inline std::vector<bool> truth_occluded(const Scene& s, const Frame& f, glm::dvec3 to_light_world,
                                        double max_distance) {
  const glm::dvec3 l = glm::normalize(to_light_world);
  std::vector<bool> out(f.world.size(), false);
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (f.sky[i] || glm::dot(f.world_normal[i], l) <= 0.0) continue;
    const glm::dvec3 p = f.world[i] + f.world_normal[i] * 1e-6;
    out[i] = std::isfinite(intersect(s, p, l, 1e-9, max_distance).t);
  }
  return out;
}

// Reference parameters from the GPU parameters the pass packed.
inline reference::contact::Params ref_params(const ContactShadowGpu& g) {
  reference::contact::Params p;
  p.to_light = glm::dvec3(g.light_dir);
  p.tan_half_fov_y = g.tan_half_fov_y;
  p.aspect = g.aspect;
  p.near = g.near_plane;
  p.far = g.far_plane > 0.0f ? double{g.far_plane} : std::numeric_limits<double>::infinity();
  p.max_distance = g.max_distance;
  p.thickness = g.thickness;
  p.depth_bias = g.depth_bias;
  p.intensity = g.intensity;
  p.step_exponent = g.step_exponent;
  p.edge_fade = g.edge_fade;
  p.step_count = g.step_count;
  p.frame = g.frame;
  p.reverse_z = g.reverse_z != 0;
  return p;
}

// A direction towards the sun at `elevation` above the horizon and `azimuth` around +Y (0: from
// +Z, pi/2: from +X), both in degrees.
inline glm::dvec3 sun(double elevation_deg, double azimuth_deg) {
  const double e = glm::radians(elevation_deg), a = glm::radians(azimuth_deg);
  return {std::cos(e) * std::sin(a), std::sin(e), std::cos(e) * std::cos(a)};
}

}  // namespace penumbra::render::test
