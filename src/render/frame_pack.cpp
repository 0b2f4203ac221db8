// pack_frame: a scene becomes one frame's GPU structs (include/penumbra/render/frame_pack.hpp).
// Pure: no device, no allocation of GPU objects; every position is made relative to the render
// origin (the camera) in double before it is rounded to float.

#include <algorithm>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <penumbra/render/frame_pack.hpp>
#include <penumbra/shadow/pack.hpp>

namespace penumbra::render {
namespace {

glm::dvec3 to_d(glm::vec3 v) {
  return glm::dvec3(v);
}

shadow::DepthConvention depth_of(bool reverse_z) {
  return reverse_z ? shadow::DepthConvention::reverse_z : shadow::DepthConvention::standard;
}

std::vector<Draw> pack_draws(const scene::Scene& scene, const glm::dvec3& origin) {
  std::vector<Draw> draws;
  draws.reserve(scene.instances.size());
  const auto mask_images = scene.mask_images();
  std::vector<std::uint32_t> mask_slot(scene.materials.size(), 0);
  for (std::uint32_t m = 0; m < scene.materials.size(); ++m)
    mask_slot[m] = std::uint32_t(std::max(0, scene.mask_image_index(m, mask_images)));
  for (const auto& inst : scene.instances) {
    const auto& mat = scene.materials.at(inst.material);
    Draw d{};
    d.mesh = inst.mesh;
    // Camera-relative: translate by -origin in double before rounding to float.
    glm::dmat4 model = glm::dmat4(inst.transform);
    d.world = model;
    d.moves = inst.motion && inst.motion->moves();
    model[3] -= glm::dvec4(origin, 0.0);
    d.push.model = glm::mat4(model);
    d.masked = mat.alpha == scene::AlphaMode::masked;
    d.push.albedo = glm::vec4(mat.albedo, d.masked ? 0.0f : 1.0f);
    d.push.mask = glm::vec4(d.masked ? float(int(mat.mask)) : 0.0f, mat.alpha_cutoff,
                            mat.mask_scale.x, mat.mask_scale.y);
    d.casts = inst.casts_shadows;
    d.in_maps = inst.in_shadow_maps();
    d.mask_texture = mask_slot.at(inst.material);
    draws.push_back(d);
  }
  return draws;
}

// A filter as a light of `kind` resolves it (the filter table's rows): itself, or its fallback
// when it needs moments the light does not have (`moments`: they were built for it) or takes no
// maps of the light's kind.
scene::Filter usable_filter(scene::Filter f, scene::LightKind kind, bool moments) {
  const scene::FilterSpec& spec = scene::filter_spec(f);
  if ((spec.moments && !moments) || !scene::filter_accepts(f, kind))
    return spec.fallback.value_or(scene::Filter::pcf);
  return f;
}

// LightGpu.params.w: a local light's own filter, else -1 (the scene's as the frame carries it).
// Moments are built for the sun and for the spot and point lights whose own filter needs them,
// so a light that inherits such a filter, or one its maps cannot take, uses the fallback.
float local_filter_slot(const scene::Scene& scene, std::optional<scene::Filter> own,
                        scene::LightKind kind, bool moments = false) {
  if (own) return float(scene::filter_index(usable_filter(*own, kind, moments)));
  const scene::Filter inherited = usable_filter(scene.shadows.filter, kind, false);
  return inherited == scene.shadows.filter ? -1.0f : float(scene::filter_index(inherited));
}

void pack_local_lights(const scene::Scene& scene, uint32_t width, uint32_t height,
                       const FrameCaps& caps, uint32_t frame_index, PackedFrame& out) {
  const bool reverse_z = scene.shadows.reverse_z;
  const glm::dvec3& origin = out.origin;
  out.spot_gpu.assign(kMaxSpotLights, shadow::SpotShadowGpu{});
  out.point_gpu.assign(kMaxPointLights, shadow::PointShadowGpu{});
  uint32_t spots = 0, spot_maps_used = 0;
  for (const auto& s : scene.spots) {
    if (spots == kMaxSpotLights) break;
    LightGpu& l = out.frame.spots[spots++];
    l.position_range = glm::vec4(glm::vec3(to_d(s.position) - origin), s.range);
    l.direction_cos =
        glm::vec4(glm::normalize(s.direction), std::cos(glm::radians(s.outer_degrees)));
    l.color_intensity = glm::vec4(s.color, s.intensity);
    l.params = glm::vec4(std::cos(glm::radians(s.inner_degrees)), -1.0f, s.radius,
                         local_filter_slot(scene, s.filter, scene::LightKind::spot, caps.spot_moments));
    if (s.shadows && spot_maps_used < caps.spot_shadow_maps) {
      shadow::SpotLight sl;
      sl.position = to_d(s.position);
      sl.direction = to_d(s.direction);
      sl.outer_angle = glm::radians(double(s.outer_degrees));
      sl.range = s.range;
      shadow::SpotShadowConfig cfg;
      cfg.resolution = s.resolution;
      cfg.depth = depth_of(reverse_z);
      out.spot_shadows.push_back(shadow::compute_spot_shadow(sl, cfg));
      out.spot_gpu[spot_maps_used] = shadow::pack_spot_shadow(out.spot_shadows.back(), origin);
      l.params.y = float(spot_maps_used++);
    }
  }
  uint32_t points = 0, point_maps_used = 0;
  for (const auto& p : scene.points) {
    if (points == kMaxPointLights) break;
    LightGpu& l = out.frame.points[points++];
    l.position_range = glm::vec4(glm::vec3(to_d(p.position) - origin), p.range);
    l.color_intensity = glm::vec4(p.color, p.intensity);
    l.params = glm::vec4(0, -1.0f, p.radius, local_filter_slot(scene, p.filter, scene::LightKind::point, caps.point_moments));
    if (p.shadows && point_maps_used < caps.point_shadow_cubes) {
      shadow::PointLight pl;
      pl.position = to_d(p.position);
      pl.range = p.range;
      shadow::PointShadowConfig cfg;
      cfg.resolution = p.resolution;
      cfg.depth = depth_of(reverse_z);
      if (p.fit_to_camera) {
        // The objects the camera may see, and everything that may shadow them.
        std::vector<shadow::Aabb> objects;
        for (const scene::Bounds& b : scene.instance_world_bounds()) {
          if (b.empty()) continue;
          shadow::Aabb a;
          a.min = to_d(b.min);
          a.max = to_d(b.max);
          objects.push_back(a);
        }
        out.point_shadows.push_back(shadow::fit_point_shadow(
            pl.position, frame_camera(scene, width, height, frame_index), scene.shadows.max_distance, objects,
            cfg));
      } else {
        out.point_shadows.push_back(shadow::compute_point_shadow(pl, cfg));
      }
      out.point_gpu[point_maps_used] = shadow::pack_point_shadow(out.point_shadows.back(), origin);
      l.params.y = float(point_maps_used++);
    }
  }
  const int primary = primary_light_slot(scene);
  out.frame.counts = glm::uvec4(spots, points, caps.contact_pass && primary >= 0 ? 1u : 0u,
                                uint32_t(std::max(primary, 0)));
}

void pack_sun(const scene::Scene& scene, uint32_t width, uint32_t height, const FrameCaps& caps,
              uint32_t frame_index, PackedFrame& out) {
  const auto& sh = scene.shadows;
  shadow::ShadowConfig cfg;
  cfg.cascade_count = sh.cascades;
  cfg.split_lambda = sh.split_lambda;
  cfg.max_distance = sh.max_distance;
  cfg.resolution = sh.resolution;
  cfg.fit = sh.fit;
  cfg.selection = sh.selection;
  cfg.depth = depth_of(sh.reverse_z);
  cfg.depth_clamp = caps.depth_clamp;
  cfg.snap_to_texels = sh.snap_to_texels;
  cfg.blend_fraction = sh.blend_band;
  cfg.fade_fraction = sh.fade_band;
  cfg.pcss.blocker_search_texels = sh.pcss_search_texels;
  cfg.pcss.min_filter_texels = sh.pcss_min_filter_texels;
  cfg.pcss.max_filter_texels = sh.pcss_max_filter_texels;
  shadow::DirectionalLight light;
  light.direction = to_d(scene.sun->direction);
  light.angular_diameter = glm::radians(double(scene.sun->angular_diameter_degrees));
  const scene::Bounds b = scene.world_bounds();
  shadow::Aabb bounds;
  bounds.min = to_d(b.min);
  bounds.max = to_d(b.max);
  if (sh.layout == scene::ShadowLayout::clipmap) {
    shadow::ClipmapConfig clip;
    clip.level_count = std::min(sh.clipmap_levels, caps.sun_layers);
    clip.base_extent = sh.clipmap_extent;
    clip.resolution = sh.resolution;
    clip.depth = cfg.depth;
    clip.snap_to_texels = sh.snap_to_texels;
    clip.pcss = cfg.pcss;
    out.cascades = shadow::compute_clipmap(clip, to_d(scene.camera.position_at(frame_index)), light,
                                            bounds);
    out.cascades.fade_fraction = sh.fade_band;
    out.cascades.camera_forward = frame_camera(scene, width, height, frame_index).forward;
  } else {
    cfg.cascade_count = std::min(sh.cascades, caps.sun_layers);
    out.cascades =
        shadow::compute_cascades(cfg, frame_camera(scene, width, height, frame_index), light, bounds);
  }
  out.shadow = shadow::pack_shadow(out.cascades, out.origin);
}

}  // namespace

glm::mat4 camera_projection(const scene::Camera& c, double aspect, bool reverse_z) {
  const double t = std::tan(glm::radians(double(c.fov_y_degrees)) * 0.5);
  const double n = c.near, f = c.far;
  glm::dmat4 p(0.0);
  p[0][0] = 1.0 / (aspect * t);
  p[1][1] = -1.0 / t;  // Vulkan framebuffer y grows downward: flip so world up is screen up
  if (reverse_z) {
    p[2][2] = n / (f - n);
    p[3][2] = f * n / (f - n);
  } else {
    p[2][2] = f / (n - f);
    p[3][2] = f * n / (n - f);
  }
  p[2][3] = -1.0;
  return glm::mat4(p);
}

std::uint32_t sun_filter_index(const scene::Scene& scene, bool sun_moments) {
  return scene::filter_index(usable_filter(scene.shadows.filter, scene::LightKind::sun, sun_moments));
}

std::uint32_t local_filter_index(const scene::Scene& scene, std::optional<scene::Filter> own,
                                 scene::LightKind kind, bool moments, bool sun_moments) {
  const float slot = local_filter_slot(scene, own, kind, moments);
  return slot >= 0.0f ? std::uint32_t(slot) : sun_filter_index(scene, sun_moments);
}

shadow::Camera frame_camera(const scene::Scene& scene, std::uint32_t width, std::uint32_t height,
                            std::uint32_t frame) {
  const scene::Camera c = scene.camera.at(frame);
  shadow::Camera sc;
  sc.position = to_d(c.position);
  sc.forward = to_d(c.target - c.position);
  sc.up = to_d(c.up);
  sc.fov_y = glm::radians(double(c.fov_y_degrees));
  sc.aspect = double(width) / double(height);
  sc.near = c.near;
  sc.far = c.far;
  return sc;
}

int primary_light_slot(const scene::Scene& scene) {
  if (scene.sun) return 0;
  if (!scene.spots.empty()) return 1;
  if (!scene.points.empty()) return 1 + int(kMaxSpotLights);
  return -1;
}

PackedFrame pack_frame(const scene::Scene& scene, std::uint32_t width, std::uint32_t height,
                       const FrameCaps& caps, std::uint32_t frame_index) {
  PackedFrame out;
  const scene::Camera c = scene.camera.at(frame_index);
  const bool reverse_z = scene.shadows.reverse_z;
  out.origin = to_d(c.position);
  out.draws = pack_draws(scene, out.origin);
  for (const glm::vec4& sphere : scene.analytic_spheres()) {
    const glm::dvec3 centre = glm::dvec3(glm::vec3(sphere)) - out.origin;
    out.analytic_spheres.emplace_back(glm::vec3(centre), sphere.w);
  }
  const double aspect = double(width) / double(height);
  const glm::mat4 view = glm::lookAt(glm::vec3(0.0f), c.target - c.position, c.up);
  const glm::mat4 proj = camera_projection(c, aspect, reverse_z);
  FrameGpu& frame = out.frame;
  frame.view = view;
  frame.proj = proj;
  frame.view_proj = proj * view;
  frame.inv_view_proj = glm::inverse(frame.view_proj);
  frame.camera_position = glm::vec4(0, 0, 0, 1);
  frame.camera_forward = glm::vec4(glm::normalize(c.target - c.position), 0);
  frame.viewport =
      glm::vec4(float(width), float(height), 1.0f / float(width), 1.0f / float(height));
  frame.projection =
      glm::vec4(c.near, c.far, std::tan(glm::radians(c.fov_y_degrees) * 0.5f), float(aspect));
  const auto& sh = scene.shadows;
  // World-unit biases (bias.glsl): x normal offset, texels; y slope bias, texels; z constant
  // bias, metres along the light; w the slope term's bound, texels.
  frame.bias =
      glm::vec4(sh.normal_offset_texels, sh.slope_bias, sh.constant_bias, sh.max_slope_bias);
  frame.filter_params =
      scene::filter_params(sh);
  frame.filter_world = glm::vec4(sh.constant_filter_width ? 1.0f : 0.0f,
                                 float(std::clamp(sh.evsm_blur, 0, 8)),
                                 sh.evsm_mips ? 1.0f : 0.0f, 0.0f);
  frame.pcss = glm::vec4(sh.pcss_confidence, sh.pcss_search_texels, sh.pcss_min_filter_texels,
                         sh.pcss_max_filter_texels);
  frame.mode = glm::uvec4(frame_index, reverse_z ? 1u : 0u,
                          sun_filter_index(scene, caps.sun_moments), uint32_t(scene.render.view));
  const float max_exponent = sh.evsm_fp16 ? kEvsmMaxExponentFp16 : kEvsmMaxExponentFp32;
  frame.evsm = glm::vec4(std::clamp(sh.evsm_exponent, 0.0f, max_exponent), sh.evsm_min_variance,
                         sh.evsm_bleed_reduction, sh.evsm_fp16 ? 1.0f : 0.0f);
  frame.ambient = glm::vec4(0.18f, 0.2f, 0.24f, scene.render.exposure);
  if (scene.sun) {
    frame.sun_direction = glm::vec4(-glm::normalize(scene.sun->direction), scene.sun->intensity);
    frame.sun_color = glm::vec4(scene.sun->color, scene.sun->shadows ? 1.0f : 0.0f);
  }
  pack_local_lights(scene, width, height, caps, frame_index, out);
  if (caps.sun_shadows && scene.sun) pack_sun(scene, width, height, caps, frame_index, out);
  return out;
}

}  // namespace penumbra::render
