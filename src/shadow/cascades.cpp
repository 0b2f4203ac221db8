// PSSM cascades and clipmap levels. See docs/cascades.md for the algorithms.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <penumbra/shadow/cascades.hpp>
#include <string>

#include "detail.hpp"

namespace penumbra::shadow {

namespace {

// The camera's orthonormal frame and frustum slopes.
struct CameraFrame {
  glm::dvec3 forward;
  glm::dvec3 right;
  glm::dvec3 up;
  double tan_x = 0.0;
  double tan_y = 0.0;
};

CameraFrame camera_frame(const Camera& camera) {
  CameraFrame frame;
  frame.forward = normalize_direction(camera.forward, "Camera.forward");
  frame.right =
      glm::normalize(glm::cross(frame.forward, normalize_direction(camera.up, "Camera.up")));
  frame.up = glm::cross(frame.right, frame.forward);
  frame.tan_y = std::tan(camera.fov_y * 0.5);
  frame.tan_x = frame.tan_y * camera.aspect;
  return frame;
}

// Rotation into light space (no translation: light space shares the world origin).
glm::dvec3 to_light(const Basis& basis, const glm::dvec3& v) {
  return glm::dvec3(glm::dot(basis.x, v), glm::dot(basis.y, v), glm::dot(basis.z, v));
}

// Light-space z range of the scene bounds (exact extremes over the 8 corners).
void scene_depth_range(const Basis& basis, const Aabb& bounds, double& z_min, double& z_max) {
  z_min = std::numeric_limits<double>::infinity();
  z_max = -std::numeric_limits<double>::infinity();
  for (int i = 0; i < 8; ++i) {
    const glm::dvec3 corner((i & 1) ? bounds.max.x : bounds.min.x,
                            (i & 2) ? bounds.max.y : bounds.min.y,
                            (i & 4) ? bounds.max.z : bounds.min.z);
    const double z = glm::dot(basis.z, corner);
    z_min = std::min(z_min, z);
    z_max = std::max(z_max, z);
  }
}

// Places a square of `extent` metres (plus guard texels) over [lo, lo + extent] on both axes of
// light space. With snapping, the left/bottom edge is a whole multiple of the texel size, so a
// translation of the camera moves the map by whole texels. The texel size depends on extent,
// resolution and guard only, which the callers compute from translation-invariant quantities.
struct Placement {
  glm::dvec2 lo;
  double texel = 0.0;
  double width = 0.0;
};

Placement place(const glm::dvec2& lo, double extent, std::uint32_t resolution, std::uint32_t guard,
                bool snap) {
  const double res = static_cast<double>(resolution);
  const double g = static_cast<double>(guard);
  Placement p;
  if (snap) {
    // floor() may move the edge down by up to one texel: reserve it.
    p.texel = extent / (res - 2.0 * g - 1.0);
    p.lo = (glm::floor(lo / p.texel) - g) * p.texel;
  } else {
    p.texel = extent / (res - 2.0 * g);
    p.lo = lo - g * p.texel;
  }
  p.width = res * p.texel;
  return p;
}

Cascade make_cascade(const Basis& basis, const Placement& placement, double z_near, double z_far,
                     DepthConvention depth) {
  // A small margin so that points exactly on the fitted bounds stay strictly inside [0, 1]
  // after rounding.
  const double pad = (z_far - z_near) * 1e-4;
  Cascade c;
  c.texel_world_size = placement.texel;
  c.box_min = glm::dvec3(placement.lo, z_near - pad);
  c.box_max = glm::dvec3(placement.lo + placement.width, z_far + pad);
  c.view = view_matrix(basis);
  c.projection = orthographic_projection(c.box_min, c.box_max, depth);
  c.view_proj = c.projection * c.view;
  return c;
}

void check_finite_result(const CascadeSet& set, const char* what) {
  for (std::size_t i = 0; i < set.cascades.size(); ++i) {
    if (!is_finite(set.cascades[i].view_proj) || !(set.cascades[i].texel_world_size > 0.0)) {
      throw Error(std::string(what) + ": cascade " + std::to_string(i) +
                  " has a non-finite matrix (inputs too large for double precision?)");
    }
  }
}

}  // namespace

std::vector<double> pssm_splits(double near, double far, std::uint32_t count, double lambda) {
  detail::check_positive("pssm_splits.near", near);
  if (!(far > near) || !std::isfinite(far)) {
    detail::fail("pssm_splits.far", detail::format(far),
                 "must be finite and > near (" + detail::format(near) + ")");
  }
  detail::check_range("pssm_splits.count", count, 1u, kMaxCascades);
  detail::check_range("pssm_splits.lambda", lambda, 0.0, 1.0);
  std::vector<double> splits(count + 1);
  splits[0] = near;
  const double ratio = far / near;
  for (std::uint32_t i = 1; i < count; ++i) {
    const double t = static_cast<double>(i) / static_cast<double>(count);
    const double log_split = near * std::pow(ratio, t);
    const double uniform_split = near + (far - near) * t;
    double s = lambda * log_split + (1.0 - lambda) * uniform_split;
    // Mathematically strictly increasing; keep it so under rounding, too.
    s = std::max(s, std::nextafter(splits[i - 1], far));
    splits[i] = s;
  }
  splits[count] = far;
  return splits;
}

CascadeSet compute_cascades(const ShadowConfig& config, const Camera& camera,
                            const DirectionalLight& light, const Aabb& scene_bounds) {
  validate(config);
  validate(camera);
  validate(light);
  validate_scene_bounds(scene_bounds);
  if (!(config.max_distance > camera.near)) {
    detail::fail("ShadowConfig.max_distance", detail::format(config.max_distance),
                 "must be > Camera.near (" + detail::format(camera.near) + ")");
  }

  CascadeSet set;
  set.layout = ShadowLayout::cascades;
  set.fit = config.fit;
  set.depth = config.depth;
  set.resolution = config.resolution;
  set.light_basis = orthonormal_basis(light.direction);
  set.angular_diameter = light.angular_diameter;
  set.blend_fraction = config.blend_fraction;
  set.fade_fraction = config.fade_fraction;
  set.pcss = config.pcss;
  set.selection = config.selection;
  set.camera_position = camera.position;

  const CameraFrame frame = camera_frame(camera);
  set.camera_forward = frame.forward;
  const double far = std::min(camera.far, config.max_distance);
  set.splits = pssm_splits(camera.near, far, config.cascade_count, config.split_lambda);

  const Basis& basis = set.light_basis;
  const glm::dvec3 camera_ls = to_light(basis, camera.position);
  double scene_z_min = 0.0;
  double scene_z_max = 0.0;
  scene_depth_range(basis, scene_bounds, scene_z_min, scene_z_max);
  // Squared slope of the frustum's corner rays: a slice cross-section at distance d has
  // half-diagonal d * sqrt(k2).
  const double k2 = frame.tan_x * frame.tan_x + frame.tan_y * frame.tan_y;

  for (std::uint32_t i = 0; i < config.cascade_count; ++i) {
    const double a =
        i == 0 ? set.splits[0]
               : set.splits[i] - config.blend_fraction * (set.splits[i] - set.splits[i - 1]);
    const double b = set.splits[i + 1];

    // Every quantity below that determines the texel size (extent) is computed camera-relative
    // and is therefore bit-identical under camera translation; camera_sphere's is also
    // independent of the camera's orientation.
    glm::dvec2 lo_rel(0.0);
    double extent = 0.0;
    double z_rel_min = 0.0;
    double z_rel_max = 0.0;
    glm::dvec3 sphere_center_rel(0.0);
    double radius = 0.0;
    switch (config.fit) {
      case CascadeFit::box: {
        glm::dvec3 lo(std::numeric_limits<double>::infinity());
        glm::dvec3 hi(-std::numeric_limits<double>::infinity());
        for (const double d : {a, b}) {
          for (const double sx : {-1.0, 1.0}) {
            for (const double sy : {-1.0, 1.0}) {
              const glm::dvec3 corner = frame.forward * d + frame.right * (sx * d * frame.tan_x) +
                                        frame.up * (sy * d * frame.tan_y);
              const glm::dvec3 ls = to_light(basis, corner);
              lo = glm::min(lo, ls);
              hi = glm::max(hi, ls);
            }
          }
        }
        lo_rel = glm::dvec2(lo);
        extent = std::max(hi.x - lo.x, hi.y - lo.y);
        z_rel_min = lo.z;
        z_rel_max = hi.z;
        break;
      }
      case CascadeFit::camera_sphere: {
        // Centred on the camera; the slice's farthest points are its far corners.
        radius = b * std::sqrt(1.0 + k2);
        lo_rel = glm::dvec2(-radius);
        extent = 2.0 * radius;
        z_rel_min = -radius;
        z_rel_max = radius;
        break;
      }
      case CascadeFit::slice_sphere: {
        // Smallest sphere through the corner circles (distance a, radius a*sqrt(k2)) and
        // (b, b*sqrt(k2)): its centre c on the axis equalizes both distances unless that lies
        // beyond the far cap, where the far circle alone decides.
        const double c = std::min(0.5 * (a + b) * (1.0 + k2), b);
        radius = std::max(std::sqrt((c - a) * (c - a) + k2 * a * a),
                          std::sqrt((c - b) * (c - b) + k2 * b * b));
        sphere_center_rel = frame.forward * c;
        const glm::dvec3 center_ls = to_light(basis, sphere_center_rel);
        lo_rel = glm::dvec2(center_ls) - radius;
        extent = 2.0 * radius;
        z_rel_min = center_ls.z - radius;
        z_rel_max = center_ls.z + radius;
        break;
      }
    }

    const Placement placement = place(glm::dvec2(camera_ls) + lo_rel, extent, config.resolution,
                                      config.guard_texels, config.snap_to_texels);
    // Receivers span [camera z + z_rel_min, camera z + z_rel_max]; casters anywhere in the
    // scene bounds. Depth clamp: the near plane stays at the receivers.
    double z_near = camera_ls.z + z_rel_min;
    double z_far = std::max(camera_ls.z + z_rel_max, scene_z_max);
    if (!config.depth_clamp) z_near = std::min(z_near, scene_z_min);
    if (config.snap_to_texels) {
      // The depth range in whole steps of 64 texels, like the placement in whole texels: a
      // walking camera leaves the cascade's matrix exactly as it was until it has moved a texel
      // across the light or 64 along it, so the map's texels stay the same (the renderer's
      // cache keeps them). A coarser step cost the grazing scene's sun accuracy (mean |dV|
      // 0.0018 -> 0.0019 at a quarter of the cascade's width).
      const double step = 64.0 * placement.texel;
      z_near = std::floor(z_near / step) * step;
      z_far = std::ceil(z_far / step) * step;
    }

    Cascade cascade = make_cascade(basis, placement, z_near, z_far, config.depth);
    cascade.fit_near = a;
    cascade.fit_far = b;
    if (radius > 0.0) {
      cascade.sphere_center = camera.position + sphere_center_rel;
      cascade.sphere_radius = radius;
    }
    set.cascades.push_back(cascade);
  }
  check_finite_result(set, "compute_cascades");
  return set;
}

CascadeSet compute_clipmap(const ClipmapConfig& config, const glm::dvec3& camera_position,
                           const DirectionalLight& light, const Aabb& scene_bounds) {
  validate(config);
  detail::check_finite("camera_position", camera_position);
  validate(light);
  validate_scene_bounds(scene_bounds);

  CascadeSet set;
  set.layout = ShadowLayout::clipmap;
  set.fit = CascadeFit::box;
  set.depth = config.depth;
  set.resolution = config.resolution;
  set.light_basis = orthonormal_basis(light.direction);
  set.angular_diameter = light.angular_diameter;
  set.pcss = config.pcss;
  set.camera_position = camera_position;
  set.splits.push_back(0.0);

  const Basis& basis = set.light_basis;
  const glm::dvec2 camera_ls(to_light(basis, camera_position));
  double z_near = 0.0;
  double z_far = 0.0;
  scene_depth_range(basis, scene_bounds, z_near, z_far);
  if (!(z_far > z_near)) {
    // A flat scene seen edge-on by the light: give the depth range a little thickness.
    const double thickness = std::max(1e-3, std::abs(z_near) * 1e-9);
    z_near -= thickness;
    z_far += thickness;
  }
  const double res = static_cast<double>(config.resolution);

  for (std::uint32_t i = 0; i < config.level_count; ++i) {
    // Exact powers of two: extent and texel size of level i are exactly 2^i those of level 0.
    const double extent = std::ldexp(config.base_extent, static_cast<int>(i));
    Placement placement;
    placement.texel = extent / res;
    placement.width = extent;
    placement.lo = camera_ls - 0.5 * extent;
    if (config.snap_to_texels) {
      // Round to the nearest texel: the camera stays within half a texel of the centre.
      placement.lo = glm::floor(placement.lo / placement.texel + 0.5) * placement.texel;
    }
    Cascade cascade = make_cascade(basis, placement, z_near, z_far, config.depth);
    cascade.fit_near = 0.0;
    cascade.fit_far = 0.5 * extent - placement.texel;  // guaranteed radius around the camera
    set.splits.push_back(cascade.fit_far);
    set.cascades.push_back(cascade);
  }
  check_finite_result(set, "compute_clipmap");
  return set;
}

}  // namespace penumbra::shadow
