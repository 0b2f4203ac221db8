// The sun's view of the shadow-map pass: its cascades drawn through a grid relative to an
// anchor cell of the camera (shadow_maps.cpp says how the grid scrolls and what the cache keys).
#include <algorithm>
#include <cmath>
#include <limits>
#include <penumbra/shadow/pack.hpp>

#include "shadow_view.hpp"

namespace penumbra::render::passes {

namespace {

// The sun's anchor: the camera's cell of a grid whose cells are a power of two metres, at least
// the shadows' reach (so a walk crosses a cell rarely, and positions within stay small).
glm::dvec3 sun_anchor(const glm::dvec3& camera, double reach) {
  const double cell = std::ldexp(1.0, std::clamp(int(std::ceil(std::log2(std::max(reach, 1.0)))), 4, 16));
  return glm::floor(camera / cell) * cell;
}

// The square bounds b cover across the light (its corners on the light basis' x and y).
std::pair<glm::dvec2, glm::dvec2> light_square(const PackedFrame& f, const scene::Bounds& b) {
  const shadow::Basis& basis = f.cascades.light_basis;
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-lo);
  for (int i = 0; i < 8; ++i) {
    const glm::dvec3 p((i & 1) ? b.max.x : b.min.x, (i & 2) ? b.max.y : b.min.y,
                       (i & 4) ? b.max.z : b.min.z);
    const glm::dvec2 q(glm::dot(basis.x, p), glm::dot(basis.y, p));
    lo = glm::min(lo, q);
    hi = glm::max(hi, q);
  }
  return {lo, hi};
}

}  // namespace

void configure_sun_view(FrameResources& r, ShadowMapPass::View& v, gpu::Image& map, uint32_t n,
                        uint32_t res) {
  using View = ShadowMapPass::View;
  v.name = "sun-shadow";
  v.image = "sun-shadow-map";
  v.target = &map;
  v.layers = [n](const PackedFrame&) { return n; };
  v.index = [](uint32_t c) { return glm::uvec4(c, 0, 0, 0); };
  v.layout = ubo_layout(r);
  add_caster_pipelines(r, "sun-shadow", "render/shadow_depth.vert", *v.layout, v.opaque, v.masked,
                       r.ctx.info().depth_clamp);
  v.draw_ubo =
      gpu::Buffer(r.ctx, sizeof(shadow::ShadowDrawGpu), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
  v.set = ubo_set(r, *v.layout, v.draw_ubo);
  v.viewport = 1;
  while (v.viewport < res) v.viewport *= 2;
  const scene::Scene& scene = r.scene;
  v.pack = [&scene, &v, n](const PackedFrame& f) {
    const double reach = scene.shadows.layout == scene::ShadowLayout::clipmap
                             ? std::ldexp(double(scene.shadows.clipmap_extent),
                                          int(scene.shadows.clipmap_levels))
                             : double(scene.shadows.max_distance);
    View::Packed out;
    out.anchors = {sun_anchor(f.origin, reach)};
    const shadow::CascadeSet& set = f.cascades;
    v.starts.resize(n, glm::dvec2(std::numeric_limits<double>::quiet_NaN()));
    v.grid_key.resize(n, 0);
    // Without scrolling a new grid every frame: the window sits on a whole map of it, and a
    // cascade that moved has new matrices, so it is drawn whole straight into the map.
    if (!v.scroll) std::fill(v.starts.begin(), v.starts.end(),
                             glm::dvec2(std::numeric_limits<double>::quiet_NaN()));
    for (size_t c = 0; c < set.cascades.size() && c < n; ++c) {
      Hash h;
      h.add(set.cascades[c].texel_world_size);
      h.add(set.cascades[c].box_min.z);
      h.add(set.cascades[c].box_max.z);
      h.add(set.light_basis);
      h.add(set.depth);
      h.add(out.anchors[0]);
      if (h.h != v.grid_key[c]) v.starts[c] = glm::dvec2(std::numeric_limits<double>::quiet_NaN());
      v.grid_key[c] = h.h;
    }
    const shadow::ShadowDraw draw = shadow::pack_shadow_draw(set, out.anchors[0], v.starts);
    for (size_t c = 0; c < n; ++c) v.starts[c] = draw.start[c];
    out.bytes = bytes_of(std::vector<shadow::ShadowDrawGpu>{draw.gpu});
    out.windows.assign(draw.window, draw.window + n);
    return out;
  };
  v.slot = [](uint32_t) { return 0u; };
  // A cascade's texels depend on its grid (to_texels), not on where on it its window is.
  v.span = [](uint32_t c) {
    return std::pair<size_t, size_t>(offsetof(shadow::ShadowDrawGpu, cascades) +
                                         c * sizeof(shadow::CascadeDrawGpu),
                                     sizeof(glm::mat4));
  };
  // Grid texels [lo, hi) of the cascade's square across the light, grown by two texels; every
  // depth along it (depth clamp pancakes casters in front of the near plane onto it).
  v.touches = [&v](const PackedFrame& f, uint32_t c, glm::ivec2 lo_texel, glm::ivec2 hi_texel,
                   const scene::Bounds& b) {
    if (b.empty()) return false;
    const shadow::Cascade& k = f.cascades.cascades[c];
    const auto [lo, hi] = light_square(f, b);
    // Grid texel g starts at box_min + (g - window) texels.
    const double t = k.texel_world_size;
    const glm::dvec2 w(v.window.at(c));
    const glm::dvec2 from = glm::dvec2(k.box_min) + (glm::dvec2(lo_texel) - w - 2.0) * t;
    const glm::dvec2 to = glm::dvec2(k.box_min) + (glm::dvec2(hi_texel) - w + 2.0) * t;
    return hi.x >= from.x && lo.x <= to.x && hi.y >= from.y && lo.y <= to.y;
  };
  // The grid texels (x0, y0, x1, y1) bounds b can be drawn into in cascade c: its square across
  // the light in whole texels, grown by two, within the cascade's window (empty: x0 >= x1).
  v.rect = [&v](const PackedFrame& f, uint32_t c, const scene::Bounds& b) {
    const glm::ivec2 w = v.window.at(c);
    const int side = int(v.target->desc().width);
    if (b.empty()) return glm::ivec4(w, w);
    const shadow::Cascade& k = f.cascades.cascades[c];
    const auto [lo, hi] = light_square(f, b);
    const double t = k.texel_world_size;
    const glm::dvec2 box(k.box_min);
    const glm::dvec2 limit{double(side)};
    // Texels of the window, as doubles first: a caster far outside does not overflow an int.
    const glm::dvec2 from = glm::clamp(glm::floor((lo - box) / t) - 2.0, glm::dvec2(0.0), limit);
    const glm::dvec2 to = glm::clamp(glm::floor((hi - box) / t) + 3.0, glm::dvec2(0.0), limit);
    const glm::ivec2 a = w + glm::ivec2(from), z = w + glm::ivec2(to);
    return glm::ivec4(a, glm::max(z, a));
  };
}

}  // namespace penumbra::render::passes
