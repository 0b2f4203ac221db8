// Input validation of penumbra::shadow: every message names the field and its value.

#include <numbers>
#include <penumbra/shadow/cascades.hpp>
#include <penumbra/shadow/local_lights.hpp>
#include <string>

#include "detail.hpp"

namespace penumbra::shadow {

namespace {

constexpr std::uint32_t kMinResolution = 16;
constexpr std::uint32_t kMaxResolution = 16384;

void check_depth(const char* field, DepthConvention depth) {
  if (depth != DepthConvention::standard && depth != DepthConvention::reverse_z) {
    detail::fail(field, std::to_string(static_cast<std::uint32_t>(depth)),
                 "must be standard (0) or reverse_z (1)");
  }
}

void check_pcss(const std::string& prefix, const PcssOptions& pcss) {
  detail::check_positive((prefix + ".blocker_search_texels").c_str(), pcss.blocker_search_texels);
  if (!(pcss.min_filter_texels >= 0.0) || !std::isfinite(pcss.min_filter_texels)) {
    detail::fail(prefix + ".min_filter_texels", detail::format(pcss.min_filter_texels),
                 "must be finite and >= 0");
  }
  if (!(pcss.max_filter_texels >= pcss.min_filter_texels) ||
      !std::isfinite(pcss.max_filter_texels)) {
    detail::fail(prefix + ".max_filter_texels", detail::format(pcss.max_filter_texels),
                 "must be finite and >= " + prefix + ".min_filter_texels (" +
                     detail::format(pcss.min_filter_texels) + ")");
  }
}

}  // namespace

void validate(const ShadowConfig& config) {
  detail::check_range("ShadowConfig.cascade_count", config.cascade_count, 1u, kMaxCascades);
  detail::check_range("ShadowConfig.split_lambda", config.split_lambda, 0.0, 1.0);
  detail::check_positive("ShadowConfig.max_distance", config.max_distance);
  detail::check_range("ShadowConfig.resolution", config.resolution, kMinResolution, kMaxResolution);
  if (config.fit != CascadeFit::box && config.fit != CascadeFit::camera_sphere &&
      config.fit != CascadeFit::slice_sphere) {
    detail::fail("ShadowConfig.fit", std::to_string(static_cast<std::uint32_t>(config.fit)),
                 "must be box (0), camera_sphere (1) or slice_sphere (2)");
  }
  check_depth("ShadowConfig.depth", config.depth);
  detail::check_range("ShadowConfig.guard_texels", config.guard_texels, 0u, config.resolution / 8);
  detail::check_range("ShadowConfig.blend_fraction", config.blend_fraction, 0.0, 0.5);
  detail::check_range("ShadowConfig.fade_fraction", config.fade_fraction, 0.0, 1.0);
  check_pcss("ShadowConfig.pcss", config.pcss);
}

void validate(const ClipmapConfig& config) {
  detail::check_range("ClipmapConfig.level_count", config.level_count, 1u, kMaxCascades);
  detail::check_positive("ClipmapConfig.base_extent", config.base_extent);
  detail::check_range("ClipmapConfig.resolution", config.resolution, kMinResolution,
                      kMaxResolution);
  check_depth("ClipmapConfig.depth", config.depth);
  check_pcss("ClipmapConfig.pcss", config.pcss);
}

void validate(const Camera& camera) {
  detail::check_finite("Camera.position", camera.position);
  const glm::dvec3 f = normalize_direction(camera.forward, "Camera.forward");
  const glm::dvec3 u = normalize_direction(camera.up, "Camera.up");
  if (!(glm::length(glm::cross(f, u)) > 1e-9)) {
    detail::fail("Camera.up", detail::format(camera.up),
                 "must not be parallel to Camera.forward " + detail::format(camera.forward));
  }
  if (!(camera.fov_y > 0.0 && camera.fov_y < std::numbers::pi)) {
    detail::fail("Camera.fov_y", detail::format(camera.fov_y), "must be in (0, pi) radians");
  }
  detail::check_positive("Camera.aspect", camera.aspect);
  detail::check_positive("Camera.near", camera.near);
  if (!(camera.far > camera.near)) {
    detail::fail("Camera.far", detail::format(camera.far),
                 "must be > Camera.near (" + detail::format(camera.near) + ")");
  }
}

void validate(const DirectionalLight& light) {
  normalize_direction(light.direction, "DirectionalLight.direction");
  if (!(light.angular_diameter >= 0.0 && light.angular_diameter < std::numbers::pi / 2)) {
    detail::fail("DirectionalLight.angular_diameter", detail::format(light.angular_diameter),
                 "must be in [0, pi/2) radians");
  }
}

void validate_scene_bounds(const Aabb& bounds) {
  detail::check_finite("scene_bounds.min", bounds.min);
  detail::check_finite("scene_bounds.max", bounds.max);
  const std::string text =
      "{min " + detail::format(bounds.min) + ", max " + detail::format(bounds.max) + "}";
  if (!(bounds.min.x <= bounds.max.x && bounds.min.y <= bounds.max.y &&
        bounds.min.z <= bounds.max.z)) {
    detail::fail("scene_bounds", text, "min must be <= max on every axis");
  }
  const glm::dvec3 size = bounds.max - bounds.min;
  if (!(size.x > 0.0 || size.y > 0.0 || size.z > 0.0)) {
    detail::fail("scene_bounds", text, "must have a positive size on at least one axis");
  }
}

void validate(const SpotLight& light, const SpotShadowConfig& config) {
  detail::check_finite("SpotLight.position", light.position);
  normalize_direction(light.direction, "SpotLight.direction");
  if (!(light.outer_angle > 0.0 && light.outer_angle <= 1.55)) {
    detail::fail("SpotLight.outer_angle", detail::format(light.outer_angle),
                 "must be in (0, 1.55] radians (a half-angle below 90 degrees)");
  }
  detail::check_positive("SpotLight.range", light.range);
  detail::check_range("SpotShadowConfig.resolution", config.resolution, kMinResolution,
                      kMaxResolution);
  detail::check_positive("SpotShadowConfig.near", config.near);
  if (!(config.near < light.range)) {
    detail::fail("SpotShadowConfig.near", detail::format(config.near),
                 "must be < SpotLight.range (" + detail::format(light.range) + ")");
  }
  check_depth("SpotShadowConfig.depth", config.depth);
}

void validate(const PointLight& light, const PointShadowConfig& config) {
  detail::check_finite("PointLight.position", light.position);
  detail::check_positive("PointLight.range", light.range);
  detail::check_range("PointShadowConfig.resolution", config.resolution, kMinResolution,
                      kMaxResolution);
  detail::check_positive("PointShadowConfig.near", config.near);
  if (!(config.near < light.range)) {
    detail::fail("PointShadowConfig.near", detail::format(config.near),
                 "must be < PointLight.range (" + detail::format(light.range) + ")");
  }
  check_depth("PointShadowConfig.depth", config.depth);
}

}  // namespace penumbra::shadow
