// Spot and point light shadow matrices.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <penumbra/shadow/cascades.hpp>
#include <penumbra/shadow/local_lights.hpp>
#include <string>
#include <utility>
#include <vector>

#include "detail.hpp"

namespace penumbra::shadow {

namespace {

// Rows (sc, tc, ma) of the Vulkan cube-map face selection table ("Cube map face selection and
// transformations"): for direction r and face +X, sc = -rz, tc = -ry, ma = rx; and so on.
Basis cube_face_rows(CubeFace face) {
  switch (face) {
    case CubeFace::positive_x:
      return {{0, 0, -1}, {0, -1, 0}, {1, 0, 0}};
    case CubeFace::negative_x:
      return {{0, 0, 1}, {0, -1, 0}, {-1, 0, 0}};
    case CubeFace::positive_y:
      return {{1, 0, 0}, {0, 0, 1}, {0, 1, 0}};
    case CubeFace::negative_y:
      return {{1, 0, 0}, {0, 0, -1}, {0, -1, 0}};
    case CubeFace::positive_z:
      return {{1, 0, 0}, {0, -1, 0}, {0, 0, 1}};
    case CubeFace::negative_z:
      return {{-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
  }
  detail::fail("CubeFace", std::to_string(static_cast<std::uint32_t>(face)), "must be 0..5");
}

void fill_faces(PointShadow& shadow, double projection_far) {
  shadow.projection =
      perspective_projection(1.0, 1.0, shadow.clip_near, projection_far, shadow.depth);
  for (std::uint32_t f = 0; f < 6; ++f) {
    shadow.face_view[f] = cube_face_view(static_cast<CubeFace>(f), shadow.position);
    shadow.face_view_proj[f] = shadow.projection * shadow.face_view[f];
  }
}

bool box_outside_plane(const std::array<glm::dvec3, 8>& corners, const glm::dvec3& normal,
                       double offset) {
  for (const glm::dvec3& c : corners) {
    if (glm::dot(normal, c) + offset >= 0.0) return false;
  }
  return true;
}

std::array<glm::dvec3, 8> corners_relative(const Aabb& box, const glm::dvec3& origin) {
  std::array<glm::dvec3, 8> corners;
  for (int i = 0; i < 8; ++i) {
    corners[i] = glm::dvec3((i & 1) ? box.max.x : box.min.x, (i & 2) ? box.max.y : box.min.y,
                            (i & 4) ? box.max.z : box.min.z) -
                 origin;
  }
  return corners;
}

}  // namespace

glm::dmat4 cube_face_view(CubeFace face, const glm::dvec3& position) {
  return view_matrix(cube_face_rows(face), position);
}

CubeFace cube_face_for_direction(const glm::dvec3& d) {
  const glm::dvec3 a = glm::abs(d);
  if (a.z >= a.x && a.z >= a.y) return d.z < 0.0 ? CubeFace::negative_z : CubeFace::positive_z;
  if (a.y >= a.x) return d.y < 0.0 ? CubeFace::negative_y : CubeFace::positive_y;
  return d.x < 0.0 ? CubeFace::negative_x : CubeFace::positive_x;
}

SpotShadow compute_spot_shadow(const SpotLight& light, const SpotShadowConfig& config) {
  validate(light, config);
  SpotShadow s;
  s.basis = orthonormal_basis(light.direction);
  s.position = light.position;
  s.near = config.near;
  s.far = light.range;
  s.tan_half_angle = std::tan(light.outer_angle);
  s.resolution = config.resolution;
  s.depth = config.depth;
  s.view = view_matrix(s.basis, light.position);
  s.projection = perspective_projection(s.tan_half_angle, s.tan_half_angle, s.near, s.far, s.depth);
  s.view_proj = s.projection * s.view;
  if (!is_finite(s.view_proj)) {
    throw Error("compute_spot_shadow: non-finite matrix for SpotLight.position = " +
                detail::format(light.position));
  }
  return s;
}

PointShadow compute_point_shadow(const PointLight& light, const PointShadowConfig& config) {
  validate(light, config);
  PointShadow s;
  s.position = light.position;
  s.depth_near = 0.0;
  s.depth_far = light.range;
  s.clip_near = config.near;
  s.face_mask = 0x3fu;
  s.resolution = config.resolution;
  s.depth = config.depth;
  fill_faces(s, light.range);
  return s;
}

PointShadow fit_point_shadow(const glm::dvec3& light_position, const Camera& camera,
                             double max_distance, std::span<const Aabb> objects,
                             const PointShadowConfig& config) {
  detail::check_finite("light_position", light_position);
  validate(camera);
  detail::check_positive("max_distance", max_distance);
  if (!(max_distance > camera.near)) {
    detail::fail("max_distance", detail::format(max_distance),
                 "must be > Camera.near (" + detail::format(camera.near) + ")");
  }
  validate(PointLight{light_position, std::numeric_limits<double>::max()}, config);
  for (std::size_t i = 0; i < objects.size(); ++i) {
    const std::string field = "objects[" + std::to_string(i) + "]";
    detail::check_finite((field + ".min").c_str(), objects[i].min);
    detail::check_finite((field + ".max").c_str(), objects[i].max);
    if (!(objects[i].min.x <= objects[i].max.x && objects[i].min.y <= objects[i].max.y &&
          objects[i].min.z <= objects[i].max.z)) {
      detail::fail(field,
                   "{min " + detail::format(objects[i].min) + ", max " +
                       detail::format(objects[i].max) + "}",
                   "min must be <= max on every axis");
    }
  }

  // Camera frustum planes (camera-relative, inside when dot(n, x) + o >= 0).
  const glm::dvec3 f = normalize_direction(camera.forward, "Camera.forward");
  const glm::dvec3 r = glm::normalize(glm::cross(f, normalize_direction(camera.up, "Camera.up")));
  const glm::dvec3 u = glm::cross(r, f);
  const double tan_y = std::tan(camera.fov_y * 0.5);
  const double tan_x = tan_y * camera.aspect;
  const double view_far = std::min(camera.far, max_distance);
  const std::array<std::pair<glm::dvec3, double>, 6> planes = {{
      {f, -camera.near},
      {-f, view_far},
      {tan_x * f - r, 0.0},
      {tan_x * f + r, 0.0},
      {tan_y * f - u, 0.0},
      {tan_y * f + u, 0.0},
  }};

  PointShadow s;
  s.position = light_position;
  s.resolution = config.resolution;
  s.depth = config.depth;
  s.face_mask = 0;

  // The world box of the view frustum (up to view_far): a visible receiver lies in it and in its
  // object's box, so each object is clipped to it first. A ground plane under the light then
  // marks only the faces that see its part in view, not every face its whole box touches.
  Aabb frustum_box{glm::dvec3(std::numeric_limits<double>::max()),
                   glm::dvec3(std::numeric_limits<double>::lowest())};
  for (const double d : {camera.near, view_far}) {
    for (const double sx : {-1.0, 1.0}) {
      for (const double sy : {-1.0, 1.0}) {
        const glm::dvec3 c = camera.position + d * (f + sx * tan_x * r + sy * tan_y * u);
        frustum_box.min = glm::min(frustum_box.min, c);
        frustum_box.max = glm::max(frustum_box.max, c);
      }
    }
  }

  double far = 0.0;
  std::vector<bool> visible(objects.size(), false);
  for (std::size_t i = 0; i < objects.size(); ++i) {
    const auto corners = corners_relative(objects[i], camera.position);
    bool outside = false;
    for (const auto& [normal, offset] : planes) {
      if (box_outside_plane(corners, normal, offset)) {
        outside = true;
        break;
      }
    }
    const Aabb clipped{glm::max(objects[i].min, frustum_box.min),
                       glm::min(objects[i].max, frustum_box.max)};
    if (outside || glm::any(glm::greaterThan(clipped.min, clipped.max))) continue;
    visible[i] = true;
    const auto light_corners = corners_relative(clipped, light_position);
    for (const glm::dvec3& c : light_corners) far = std::max(far, glm::length(c));
    for (std::uint32_t face = 0; face < 6; ++face) {
      const Basis rows = cube_face_rows(static_cast<CubeFace>(face));
      std::array<glm::dvec3, 8> fc;
      for (int k = 0; k < 8; ++k) {
        fc[k] = glm::dvec3(glm::dot(rows.x, light_corners[k]), glm::dot(rows.y, light_corners[k]),
                           glm::dot(rows.z, light_corners[k]));
      }
      // The face pyramid is |x| <= z, |y| <= z: four planes through the light.
      const bool culled =
          box_outside_plane(fc, {-1, 0, 1}, 0.0) || box_outside_plane(fc, {1, 0, 1}, 0.0) ||
          box_outside_plane(fc, {0, -1, 1}, 0.0) || box_outside_plane(fc, {0, 1, 1}, 0.0);
      if (!culled) s.face_mask |= 1u << face;
    }
  }

  if (s.face_mask == 0) {
    // Nothing visible: no face is rendered; keep the data finite and harmless.
    s.depth_near = 0.0;
    s.depth_far = 2.0 * config.near;
    s.clip_near = config.near;
    fill_faces(s, s.depth_far);
    return s;
  }

  // Casters: any object nearer to the light than the farthest receiver point may shadow one.
  double near = far;
  for (const Aabb& box : objects) {
    const glm::dvec3 closest = glm::clamp(light_position, box.min, box.max);
    const double d = glm::length(closest - light_position);
    if (d < far) near = std::min(near, d);
  }
  s.depth_near = near;
  s.depth_far = std::max(far, near + std::max(near * 1e-9, 1e-9));
  // A point at distance depth_near can sit at view z = depth_near / sqrt(3) (a face corner).
  s.clip_near = std::max(near / std::sqrt(3.0), config.near);
  fill_faces(s, std::max(s.depth_far, 2.0 * s.clip_near));
  for (const glm::dmat4& m : s.face_view_proj) {
    if (!is_finite(m)) {
      throw Error("fit_point_shadow: non-finite matrix for light_position = " +
                  detail::format(light_position));
    }
  }
  return s;
}

double point_shadow_depth(const PointShadow& shadow, const glm::dvec3& p) {
  const double distance = glm::length(p - shadow.position);
  const double t =
      std::clamp((distance - shadow.depth_near) / (shadow.depth_far - shadow.depth_near), 0.0, 1.0);
  return shadow.depth == DepthConvention::reverse_z ? 1.0 - t : t;
}

}  // namespace penumbra::shadow
