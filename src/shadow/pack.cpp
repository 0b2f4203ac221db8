// Double results -> float GPU structs, rebased on the render origin in double first.

#include <algorithm>
#include <cmath>
#include <limits>
#include <penumbra/shadow/pack.hpp>

namespace penumbra::shadow {

namespace {

glm::vec4 to_vec4(const glm::dvec3& v, double w) {
  return glm::vec4(static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z),
                   static_cast<float>(w));
}

glm::vec4 to_vec4(double x, double y, double z, double w) {
  return glm::vec4(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z),
                   static_cast<float>(w));
}

glm::mat4 to_mat4(const glm::dmat4& m) {
  return glm::mat4(m);
}

}  // namespace

glm::dmat4 rebase(const glm::dmat4& m, const glm::dvec3& origin) {
  glm::dmat4 r = m;
  r[3] = m * glm::dvec4(origin, 1.0);
  return r;
}

ShadowGpu pack_shadow(const CascadeSet& set, const glm::dvec3& render_origin) {
  ShadowGpu gpu{};
  const glm::dvec3& dir = set.light_basis.z;
  const double origin_z = glm::dot(dir, render_origin);
  const std::size_t count = std::min<std::size_t>(set.cascades.size(), kMaxCascades);
  for (std::size_t i = 0; i < count; ++i) {
    const Cascade& c = set.cascades[i];
    gpu.cascades[i].view_proj = to_mat4(rebase(c.view_proj, render_origin));
    gpu.cascades[i].params = to_vec4(c.texel_world_size, c.box_min.z - origin_z,
                                     c.box_max.z - origin_z, c.box_max.x - c.box_min.x);
  }
  for (std::size_t i = 0; i < kMaxCascades; ++i) {
    const std::size_t s = std::min(i + 1, set.splits.size() - 1);
    gpu.splits[i / 4][static_cast<int>(i % 4)] = static_cast<float>(set.splits[s]);
  }
  gpu.light_dir_angular = to_vec4(-dir, set.angular_diameter);
  gpu.pcss = to_vec4(std::tan(0.5 * set.angular_diameter), set.pcss.blocker_search_texels,
                     set.pcss.min_filter_texels, set.pcss.max_filter_texels);
  gpu.selection =
      to_vec4(set.splits.front(), set.blend_fraction, set.splits.back(), set.fade_fraction);
  gpu.camera_position = to_vec4(set.camera_position - render_origin, 1.0);
  gpu.camera_forward = to_vec4(set.camera_forward, 0.0);
  gpu.counts = glm::uvec4(static_cast<std::uint32_t>(count), static_cast<std::uint32_t>(set.depth),
                          set.resolution, static_cast<std::uint32_t>(set.layout));
  gpu.modes = glm::uvec4(static_cast<std::uint32_t>(set.selection), 0u, 0u, 0u);
  return gpu;
}

ShadowDraw pack_shadow_draw(const CascadeSet& set, const glm::dvec3& anchor,
                            const std::vector<glm::dvec2>& starts) {
  ShadowDraw out;
  const glm::dvec3& bx = set.light_basis.x;
  const glm::dvec3& by = set.light_basis.y;
  const glm::dvec3& bz = set.light_basis.z;
  std::uint32_t p = 1;
  while (p < set.resolution) p *= 2;
  const std::size_t count = std::min<std::size_t>(set.cascades.size(), kMaxCascades);
  for (std::size_t i = 0; i < count; ++i) {
    const Cascade& c = set.cascades[i];
    const double texel = c.texel_world_size;
    // The grid's first texel (in texels of the light's axes) and the cascade's on it.
    glm::dvec2 grid(c.box_min.x / texel, c.box_min.y / texel);
    glm::ivec2 window(0);
    out.start[i] = glm::dvec2(std::numeric_limits<double>::quiet_NaN());
    const glm::dvec2 whole = glm::round(grid);
    if (glm::all(glm::lessThan(glm::abs(grid - whole), glm::dvec2(1e-6)))) {
      // A new grid puts the window a whole number of maps (at least kGridMargin texels) in,
      // so the window starts at texel 0 of the toroidal layer and may move either way.
      const double margin = double(set.resolution) *
                            std::max(1.0, std::ceil(kGridMargin / double(set.resolution)));
      glm::dvec2 start = i < starts.size() ? starts[i] : glm::dvec2(out.start[i]);
      const glm::dvec2 w = whole - start;
      if (!(w.x >= 0.0 && w.y >= 0.0 && w.x < 2.0 * margin && w.y < 2.0 * margin))
        start = whole - margin;
      window = glm::ivec2(whole - start);
      grid = start;
      out.start[i] = start;
    }
    glm::dmat4 m(0.0);
    for (int k = 0; k < 3; ++k) {
      m[k][0] = bx[k] / texel;
      m[k][1] = by[k] / texel;
    }
    m[3][0] = glm::dot(bx, anchor) / texel - grid.x;
    m[3][1] = glm::dot(by, anchor) / texel - grid.y;
    const double depth = c.box_max.z - c.box_min.z;
    const double s = glm::dot(bz, anchor);
    const bool reverse = set.depth == DepthConvention::reverse_z;
    for (int k = 0; k < 3; ++k) m[k][2] = (reverse ? -bz[k] : bz[k]) / depth;
    m[3][2] = reverse ? (c.box_max.z - s) / depth : (s - c.box_min.z) / depth;
    m[3][3] = 1.0;
    out.gpu.cascades[i].to_texels = glm::mat4(m);
    out.gpu.cascades[i].scale = glm::vec4(2.0f / float(p), 0.0f, 0.0f, 0.0f);
    out.window[i] = window;
  }
  out.viewport = p;
  return out;
}

SpotShadowGpu pack_spot_shadow(const SpotShadow& shadow, const glm::dvec3& render_origin) {
  SpotShadowGpu gpu{};
  gpu.view_proj = to_mat4(rebase(shadow.view_proj, render_origin));
  gpu.position_near = to_vec4(shadow.position - render_origin, shadow.near);
  gpu.direction_far = to_vec4(shadow.basis.z, shadow.far);
  const double cos_outer = 1.0 / std::sqrt(1.0 + shadow.tan_half_angle * shadow.tan_half_angle);
  gpu.params = to_vec4(cos_outer, shadow.tan_half_angle,
                       2.0 * shadow.tan_half_angle / static_cast<double>(shadow.resolution), 0.0);
  gpu.info = glm::uvec4(shadow.resolution, static_cast<std::uint32_t>(shadow.depth), 0u, 0u);
  return gpu;
}

PointShadowGpu pack_point_shadow(const PointShadow& shadow, const glm::dvec3& render_origin) {
  PointShadowGpu gpu{};
  for (std::size_t f = 0; f < 6; ++f) {
    gpu.face_view_proj[f] = to_mat4(rebase(shadow.face_view_proj[f], render_origin));
  }
  gpu.position = to_vec4(shadow.position - render_origin, 1.0);
  gpu.depth_range = to_vec4(shadow.depth_near, shadow.depth_far,
                            1.0 / (shadow.depth_far - shadow.depth_near), shadow.clip_near);
  gpu.info =
      glm::uvec4(shadow.face_mask, static_cast<std::uint32_t>(shadow.depth), shadow.resolution, 0u);
  return gpu;
}

}  // namespace penumbra::shadow
