// The shadow-map pass: every caster into every light's depth views. The sun's cascades, the
// spot maps and the point cubes are one list of views (an image, its layers, the caster
// pipelines and the push index of each layer), recorded the same way.
//
// A view is drawn relative to anchors of its own (the sun's: the camera's cell of a grid as
// coarse as the shadows reach; a spot or point light's: its position), never the camera, so a
// map's texels depend only on its light, its casters and its matrices.
//
// The sun's cascades are drawn into a grid image first (sun-shadow-grid): grid texel g of a
// cascade lives at texel g mod N of its layer (toroidal), always drawn at the same window
// position (CascadeDrawGpu), and each frame the cascade's window [w, w + N) is copied out of it
// into the map the resolves sample (in window order). A cascade that moved by whole texels keeps
// what it held and is drawn only where it newly reaches.
//
// The cache (shadows.cache) keys each layer on what its texels depend on: its grid or matrices,
// every still caster with its transform and material, the depth convention and the pipelines'
// generation; a layer whose key is unchanged is not drawn. Moving casters (Instance::motion)
// are drawn over the map each time they or it changed, after it is restored from the still
// casters (the grid, or a still copy of a spot or point map). Depth-only draws keep the nearest
// depth whatever their order, so this is the same bit for bit as drawing every layer every
// frame (shadows.cache = false, which takes the same route without keeping anything).

#include <algorithm>
#include <cmath>
#include <cstring>
#include <penumbra/shadow/pack.hpp>

#include "passes.hpp"

namespace penumbra::render::passes {

// A view's draw block for a frame: its bytes, an anchor per light, a grid window per layer.
struct ViewDraw {
  std::vector<std::byte> bytes;
  std::vector<glm::dvec3> anchors;
  std::vector<glm::ivec2> windows;
};

struct ShadowMapPass::View {
  std::string name;   // the timestamp ("sun-shadow")
  std::string image;  // the target's name in the build report ("sun-shadow-map")
  gpu::Image* target = nullptr;
  std::function<uint32_t(const PackedFrame&)> layers;
  std::function<glm::uvec4(uint32_t)> index;
  // Whether layer l is drawn this frame (a fitted point light draws only the faces that see
  // what the camera sees; the others are cleared to the far depth: lit). Unset: every layer.
  std::function<bool(const PackedFrame&, uint32_t)> draws;
  std::unique_ptr<gpu::PipelineLayout> layout;
  std::unique_ptr<gpu::GraphicsPipeline> opaque, masked;
  VkDescriptorSet set = VK_NULL_HANDLE;
  bool caster_bias = true;  // dynamic depth bias on the casters (not the point cubes)

  // The maps' own matrices: the draw UBO's bytes for this frame's anchors (one per slot: the
  // sun's one, a spot or point light's own) and each layer's window on its grid (the sun's
  // cascades; the others 0); a layer's slot, the UBO bytes its texels depend on, and whether
  // bounds b reach a texel rectangle [lo, hi) of it (conservatively: a caster outside cannot
  // touch those texels; the sun's rectangle in grid texels, the others' ignored).
  using Packed = ViewDraw;
  gpu::Buffer draw_ubo;
  std::function<Packed(const PackedFrame&)> pack;
  std::function<uint32_t(uint32_t)> slot;
  std::function<std::pair<size_t, size_t>(uint32_t)> span;
  std::function<bool(const PackedFrame&, uint32_t, glm::ivec2, glm::ivec2, const scene::Bounds&)>
      touches;
  uint32_t viewport = 0;  // the sun: the grid draws' viewport side P; 0: the map's side
  bool scroll = false;    // the sun: cascades scroll through the grid image (Scroll)
  // The sun: each cascade's grid start, kept while the rest of its grid (texel size, depth
  // range, light, anchor) stays as it was, so a full draw after such a change starts the grid
  // at the cascade's first texel (one rectangle, not four).
  std::vector<glm::dvec2> starts;
  std::vector<uint64_t> grid_key;
  // The sun: the map drawn from the grid, a triangle per layer writing each texel's depth (on a
  // GPU; a CPU device copies: there a copy is a memcpy and a draw runs a shader per texel).
  bool window_by_draw = false;
  std::unique_ptr<gpu::PipelineLayout> window_layout;
  std::unique_ptr<gpu::GraphicsPipeline> window_pipeline;
  VkDescriptorSet window_set = VK_NULL_HANDLE;

  // The base image holds the still casters: the sun's grid, a spot or point view's still copy
  // (the cache with moving casters), else the map itself.
  gpu::Image base_image;
  std::string base_name;
  bool grid() const { return viewport != 0; }
  bool has_base() const { return base_image.handle() != VK_NULL_HANDLE; }
  gpu::Image& base() { return has_base() ? base_image : *target; }
  std::string base_label() const { return has_base() ? base_name : image; }
  bool moving = false;  // the scene has moving casters: drawn over the map, not into the base

  // This frame's plan, per layer.
  enum class Base : uint8_t { keep, draw, strips };
  std::vector<Base> base_plan;
  std::vector<std::vector<glm::ivec4>> strips;  // grid rectangles (x0, y0, x1, y1) newly reached
  std::vector<uint8_t> restore;  // the map copied from the base (and the moving drawn over)
  // The sun without moving casters: a cascade drawn whole while its window starts on a whole
  // map of the grid (w mod N = 0, as after every new grid) is drawn straight into the map, whose
  // layout is then the grid's (`direct`); the grid layer is left stale (`in_map`) until the
  // cascade scrolls, when the map is first copied back into it (`sync`). A still camera never
  // copies.
  std::vector<uint8_t> direct, sync, in_map;
  std::vector<uint64_t> base_key, map_key;
  std::vector<glm::ivec2> base_window, window;
  std::vector<std::vector<glm::mat4>> models;  // per slot, per draw
  std::vector<scene::Bounds> bounds;           // per draw, this frame
};

namespace {

std::unique_ptr<gpu::PipelineLayout> ubo_layout(FrameResources& r) {
  return std::make_unique<gpu::PipelineLayout>(
      r.ctx, draw_sets(r, {{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_ALL}}),
      uint32_t(sizeof(DrawPush)), VK_SHADER_STAGE_ALL);
}

VkDescriptorSet ubo_set(FrameResources& r, const gpu::PipelineLayout& layout,
                        const gpu::Buffer& ubo) {
  VkDescriptorSet set = r.pool.allocate(layout.set_layout(0));
  gpu::DescriptorWriter()
      .buffer(0, ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
      .update(r.ctx, set);
  return set;
}

// The depth-only caster pipelines of a light: opaque casters with no fragment stage, and (when
// the scene has masked materials) alpha-tested casters. Dynamic depth bias on both.
void add_caster_pipelines(FrameResources& r, const std::string& name, const std::string& vertex,
                          const gpu::PipelineLayout& layout,
                          std::unique_ptr<gpu::GraphicsPipeline>& opaque,
                          std::unique_ptr<gpu::GraphicsPipeline>& masked_out, bool depth_clamp) {
  for (bool masked : {false, true}) {
    if (masked && !r.req.masked_materials) continue;
    std::vector<shader::ProgramSource> sources{{vertex, {}}};
    if (masked) sources.push_back({"render/shadow_masked.frag", mask_defines(r)});
    auto& target = masked ? masked_out : opaque;
    r.add_pipeline(name + (masked ? "-masked" : "-opaque (no fragment stage)"), sources, target,
                   [&r, masked, depth_clamp, &layout](const shader::Spirvs& spirv) {
                     gpu::GraphicsPipelineDesc d;
                     d.vertex_spirv = spirv[0];
                     if (masked) d.fragment_spirv = spirv[1];
                     d.vertex_input = vertex_input();
                     d.depth_format = kDepthFormat;
                     d.depth_compare = r.depth_test(false);
                     d.depth_bias = true;
                     d.depth_clamp = depth_clamp;
                     d.cull = VK_CULL_MODE_NONE;
                     return std::make_unique<gpu::GraphicsPipeline>(r.ctx, d, layout);
                   });
  }
}

constexpr VkImageUsageFlags kMapUsage =
    VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;

// FNV-1a over bytes.
struct Hash {
  uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
  }
  template <class T>
  void add(const T& v) {
    bytes(&v, sizeof(v));
  }
};

template <class T>
std::vector<std::byte> bytes_of(const std::vector<T>& v) {
  const auto b = std::as_bytes(std::span(v));
  return {b.begin(), b.end()};
}

// Whether bounds b reach the sphere (centre, radius).
bool reaches_sphere(const scene::Bounds& b, const glm::dvec3& centre, double radius) {
  if (b.empty()) return false;
  const glm::dvec3 nearest = glm::clamp(centre, glm::dvec3(b.min), glm::dvec3(b.max));
  return glm::length(nearest - centre) <= radius;
}

// The sun's anchor: the camera's cell of a grid whose cells are a power of two metres, at least
// the shadows' reach (so a walk crosses a cell rarely, and positions within stay small).
glm::dvec3 sun_anchor(const glm::dvec3& camera, double reach) {
  const double cell = std::ldexp(1.0, std::clamp(int(std::ceil(std::log2(std::max(reach, 1.0)))), 4, 16));
  return glm::floor(camera / cell) * cell;
}

// A spot or point view's draw block: each light's matrices rebased on its own position (its
// anchor), `layers` layers a light, no grid window.
template <class Gpu, class Shadow, class Pack>
ViewDraw pack_lights(const std::vector<Shadow>& shadows, size_t max, size_t layers, Pack pack) {
  std::vector<Gpu> gpu(max);
  ViewDraw out;
  for (size_t i = 0; i < shadows.size(); ++i) {
    out.anchors.push_back(shadows[i].position);
    gpu[i] = pack(shadows[i], out.anchors.back());
  }
  out.bytes = bytes_of(gpu);
  out.windows.assign(layers * shadows.size(), glm::ivec2(0));
  return out;
}

}  // namespace

ShadowMapPass::ShadowMapPass(FrameResources& r) {
  views_.reserve(3);  // the pipelines' create callbacks hold references into the views
  if (r.req.sun_shadows) {
    const uint32_t res = r.scene.shadows.resolution, n = r.req.cascades;
    sun_map = r.make_image("sun-shadow-map", gpu::ImageKind::image_2d_array, kDepthFormat, res, res,
                           n, kMapUsage, 1, "shadows.resolution = " + std::to_string(res));
    sun_ubo = gpu::Buffer(r.ctx, sizeof(shadow::ShadowGpu), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    View& v = views_.emplace_back();
    v.name = "sun-shadow";
    v.image = "sun-shadow-map";
    v.target = &sun_map;
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
      const shadow::Basis& basis = f.cascades.light_basis;
      glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-lo);
      for (int i = 0; i < 8; ++i) {
        const glm::dvec3 p((i & 1) ? b.max.x : b.min.x, (i & 2) ? b.max.y : b.min.y,
                           (i & 4) ? b.max.z : b.min.z);
        const glm::dvec2 q(glm::dot(basis.x, p), glm::dot(basis.y, p));
        lo = glm::min(lo, q);
        hi = glm::max(hi, q);
      }
      // Grid texel g starts at box_min + (g - window) texels.
      const double t = k.texel_world_size;
      const glm::dvec2 w(v.window.at(c));
      const glm::dvec2 from = glm::dvec2(k.box_min) + (glm::dvec2(lo_texel) - w - 2.0) * t;
      const glm::dvec2 to = glm::dvec2(k.box_min) + (glm::dvec2(hi_texel) - w + 2.0) * t;
      return hi.x >= from.x && lo.x <= to.x && hi.y >= from.y && lo.y <= to.y;
    };
    r.report.passes.push_back("sun-shadow: " + std::to_string(n) + " cascade(s) " +
                              std::to_string(res) + "^2");
  }
  if (r.req.spot_shadow_maps > 0) {
    const uint32_t n = r.req.spot_shadow_maps;
    uint32_t res = 16;
    for (const auto& s : r.scene.spots)
      if (s.shadows) res = std::max(res, s.resolution);
    spot_maps = r.make_image("spot-shadow-maps", gpu::ImageKind::image_2d_array, kDepthFormat, res,
                             res, n, kMapUsage, 1,
                             "[[spot]] resolution = " + std::to_string(res) + " (" +
                                 std::to_string(n) + " shadowed spot light(s))");
    spot_ubo = gpu::Buffer(r.ctx, sizeof(shadow::SpotShadowGpu) * kMaxSpotLights,
                           VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    View& v = views_.emplace_back();
    v.name = "spot-shadow";
    v.image = "spot-shadow-maps";
    v.target = &spot_maps;
    v.layers = [](const PackedFrame& f) { return uint32_t(f.spot_shadows.size()); };
    v.index = [](uint32_t i) { return glm::uvec4(i, 0, 0, 0); };
    v.layout = ubo_layout(r);
    add_caster_pipelines(r, "spot-shadow", "render/spot_depth.vert", *v.layout, v.opaque, v.masked,
                         false);
    v.draw_ubo = gpu::Buffer(r.ctx, sizeof(shadow::SpotShadowGpu) * kMaxSpotLights,
                             VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    v.set = ubo_set(r, *v.layout, v.draw_ubo);
    v.pack = [](const PackedFrame& f) {
      return pack_lights<shadow::SpotShadowGpu>(f.spot_shadows, kMaxSpotLights, 1,
                                                shadow::pack_spot_shadow);
    };
    v.slot = [](uint32_t i) { return i; };
    v.span = [](uint32_t i) {
      return std::pair<size_t, size_t>(i * sizeof(shadow::SpotShadowGpu),
                                       sizeof(shadow::SpotShadowGpu));
    };
    // The frustum's bounding sphere: its far corners are far·sqrt(1 + 2 tan²) from the light.
    v.touches = [](const PackedFrame& f, uint32_t i, glm::ivec2, glm::ivec2,
                   const scene::Bounds& b) {
      const shadow::SpotShadow& s = f.spot_shadows[i];
      const double t = s.tan_half_angle;
      return reaches_sphere(b, s.position, s.far * std::sqrt(1.0 + 2.0 * t * t) * 1.001);
    };
    r.report.passes.push_back("spot-shadow: " + std::to_string(n) + " map(s) " +
                              std::to_string(res) + "^2");
  }
  if (r.req.point_shadow_cubes > 0) {
    const uint32_t n = r.req.point_shadow_cubes;
    uint32_t res = 16;
    for (const auto& p : r.scene.points)
      if (p.shadows) res = std::max(res, p.resolution);
    // One cube array: the forward pass indexes it by layer, not by descriptor.
    point_cubes = r.make_image("point-shadow-cubes", gpu::ImageKind::cube_array, kDepthFormat, res,
                               res, 6 * n, kMapUsage, 1,
                               "[[point]] resolution = " + std::to_string(res) + " (" +
                                   std::to_string(n) + " shadowed point light(s))");
    point_ubo = gpu::Buffer(r.ctx, sizeof(shadow::PointShadowGpu) * kMaxPointLights,
                            VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    View& v = views_.emplace_back();
    v.name = "point-shadow";
    v.image = "point-shadow-cubes";
    v.target = &point_cubes;
    // Layer 6·i + f is face f of light i. One pipeline draws opaque and masked casters: its
    // fragment stage writes the linear distance and alpha-tests.
    v.layers = [](const PackedFrame& f) { return 6 * uint32_t(f.point_shadows.size()); };
    v.draws = [](const PackedFrame& f, uint32_t l) {
      return (f.point_shadows[l / 6].face_mask >> (l % 6) & 1u) != 0;
    };
    v.index = [](uint32_t l) { return glm::uvec4(l % 6, l / 6, 0, 0); };
    v.caster_bias = false;
    v.layout = ubo_layout(r);
    v.draw_ubo = gpu::Buffer(r.ctx, sizeof(shadow::PointShadowGpu) * kMaxPointLights,
                             VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    v.pack = [](const PackedFrame& f) {
      return pack_lights<shadow::PointShadowGpu>(f.point_shadows, kMaxPointLights, 6,
                                                 shadow::pack_point_shadow);
    };
    v.slot = [](uint32_t l) { return l / 6; };
    v.span = [](uint32_t l) {
      return std::pair<size_t, size_t>((l / 6) * sizeof(shadow::PointShadowGpu),
                                       sizeof(shadow::PointShadowGpu));
    };
    // A face's frustum reaches depth_far along its axis: corners at depth_far·sqrt(3).
    v.touches = [](const PackedFrame& f, uint32_t l, glm::ivec2, glm::ivec2,
                   const scene::Bounds& b) {
      const shadow::PointShadow& p = f.point_shadows[l / 6];
      return reaches_sphere(b, p.position, p.depth_far * std::sqrt(3.0) * 1.001);
    };
    const gpu::PipelineLayout& layout = *v.layout;
    auto& pipe = v.opaque;
    r.add_pipeline("point-shadow-cube (linear distance)",
                   {{"render/point_depth.vert", {}}, {"render/point_depth.frag", mask_defines(r)}},
                   pipe, [&r, &layout](const shader::Spirvs& spirv) {
                     gpu::GraphicsPipelineDesc d;
                     d.vertex_spirv = spirv[0];
                     d.fragment_spirv = spirv[1];
                     d.vertex_input = vertex_input();
                     d.depth_format = kDepthFormat;
                     d.depth_compare = r.depth_test(false);
                     d.cull = VK_CULL_MODE_NONE;  // cube face views are mirrored
                     return std::make_unique<gpu::GraphicsPipeline>(r.ctx, d, layout);
                   });
    v.set = ubo_set(r, *v.layout, v.draw_ubo);
    const bool fitted =
        std::any_of(r.scene.points.begin(), r.scene.points.end(),
                    [](const scene::PointLight& p) { return p.shadows && p.fit_to_camera; });
    r.report.passes.push_back("point-shadow: " + std::to_string(n) + " cube(s) x 6 faces" +
                              (fitted ? " (fitted to the camera: the faces it sees)" : ""));
  }
  // The base images: the sun's grid (always: shadows.cache = false takes the same route), and a
  // spot or point view's still copy when the cache keeps one for moving casters.
  cache_ = r.scene.shadows.cache;
  const bool moving = std::any_of(r.scene.instances.begin(), r.scene.instances.end(),
                                  [](const scene::Instance& i) {
                                    return i.in_shadow_maps() && i.motion && i.motion->moves();
                                  });
  for (View& v : views_) {
    const gpu::ImageDesc& d = v.target->desc();
    const uint64_t before = r.image_bytes;
    using Scroll = RendererOptions::Scroll;
    v.scroll = v.grid() && (r.scroll_cascades == Scroll::on ||
                            (r.scroll_cascades == Scroll::automatic && r.ctx.info().is_cpu));
    // Moving casters over the still ones: the sun's grid holds those when it scrolls; without it
    // the sun draws every caster whole when any changed.
    v.moving = moving && (v.grid() ? v.scroll : cache_);
    if (v.scroll) {
      v.base_name = "sun-shadow-grid";
      v.base_image = r.make_image(v.base_name, d.kind, kDepthFormat, d.width, d.height, d.layers,
                                  kMapUsage, 1,
                                  "shadows.resolution = " + std::to_string(d.width) +
                                      " (the cascades' grid, drawn into sun-shadow-map)");
    }
    using SunWindow = RendererOptions::SunWindow;
    v.window_by_draw = v.scroll && (r.sun_window == SunWindow::draw ||
                                    (r.sun_window == SunWindow::automatic && !r.ctx.info().is_cpu));
    if (v.window_by_draw) {
      v.window_layout = std::make_unique<gpu::PipelineLayout>(
          r.ctx,
          std::vector<std::vector<gpu::BindingDesc>>{
              {{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT}}},
          uint32_t(sizeof(glm::ivec4)), VK_SHADER_STAGE_FRAGMENT_BIT);
      const gpu::PipelineLayout& layout = *v.window_layout;
      r.add_pipeline("sun-shadow-window (the map from the grid)",
                     {{"render/shadow_window.vert", {}}, {"render/shadow_window.frag", {}}},
                     v.window_pipeline, [&r, &layout](const shader::Spirvs& spirv) {
                       gpu::GraphicsPipelineDesc p;
                       p.vertex_spirv = spirv[0];
                       p.fragment_spirv = spirv[1];
                       p.depth_format = kDepthFormat;
                       p.depth_compare = VK_COMPARE_OP_ALWAYS;
                       p.cull = VK_CULL_MODE_NONE;
                       return std::make_unique<gpu::GraphicsPipeline>(r.ctx, p, layout);
                     });
      v.window_set = r.pool.allocate(v.window_layout->set_layout(0));
      gpu::DescriptorWriter()
          .combined_image(0, v.base_image.view(), r.raw_depth.handle())
          .update(r.ctx, v.window_set);
    }
    if (!v.grid() && v.moving) {
      v.base_name = v.image + "-still";
      v.base_image = r.make_image(v.base_name, d.kind, kDepthFormat, d.width, d.height, d.layers,
                                  kMapUsage, 1,
                                  "shadows.cache = true (" + v.image +
                                      "'s still casters, kept for the moving ones)");
    }
    cache_bytes += r.image_bytes - before;
  }
  if (!views_.empty()) {
    const std::string mib = std::to_string((cache_bytes + (1u << 20) - 1) >> 20) + " MiB";
    r.report.passes.push_back(
        std::string("shadow-map cache: ") +
        (cache_ ? std::string("on: a layer is drawn where its key changed") +
                      (std::any_of(views_.begin(), views_.end(), [](const View& v) {
                         return v.scroll;
                       })
                           ? ", cascades only where they newly reach"
                           : "")
                : std::string("off (shadows.cache = false): every layer drawn every frame")) +
        (moving ? "; moving casters drawn over the still ones" : "") + " (" + mib +
        " beside the maps)");
  }
}

ShadowMapPass::~ShadowMapPass() = default;

void ShadowMapPass::invalidate() {
  ++generation_;
}

namespace {

// The grid rectangles (x0, y0, x1, y1) a window [to, to + n) covers that [from, from + n) did not.
std::vector<glm::ivec4> newly_covered(glm::ivec2 from, glm::ivec2 to, int n) {
  std::vector<glm::ivec4> out;
  const glm::ivec2 m = to - from;
  if (m.x > 0) out.emplace_back(from.x + n, to.y, to.x + n, to.y + n);
  if (m.x < 0) out.emplace_back(to.x, to.y, from.x, to.y + n);
  if (m.y > 0) out.emplace_back(to.x, from.y + n, to.x + n, to.y + n);
  if (m.y < 0) out.emplace_back(to.x, to.y, to.x + n, from.y);
  return out;
}

}  // namespace

void ShadowMapPass::prepare(FrameResources& r) {
  const PackedFrame& f = r.packed;
  if (sun_ubo.handle() != VK_NULL_HANDLE) sun_ubo.write(std::as_bytes(std::span(&f.shadow, 1)));
  if (spot_ubo.handle() != VK_NULL_HANDLE) spot_ubo.write(std::as_bytes(std::span(f.spot_gpu)));
  if (point_ubo.handle() != VK_NULL_HANDLE) point_ubo.write(std::as_bytes(std::span(f.point_gpu)));
  stats_ = {};
  // Each caster's bounds this frame (the draws are the scene's instances, in order).
  const std::vector<scene::Bounds> bounds = r.scene.instance_world_bounds();
  for (View& v : views_) {
    View::Packed packed = v.pack(f);
    v.draw_ubo.write(std::span(packed.bytes));
    v.window = std::move(packed.windows);
    v.bounds = bounds;
    v.models.assign(packed.anchors.size(), {});
    for (size_t s = 0; s < packed.anchors.size(); ++s) {
      v.models[s].resize(f.draws.size());
      for (size_t i = 0; i < f.draws.size(); ++i) {
        glm::dmat4 m = f.draws[i].world;
        m[3] -= glm::dvec4(packed.anchors[s], 0.0);
        v.models[s][i] = glm::mat4(m);
      }
    }
    const uint32_t layers = v.layers(f);
    const int side = int(v.target->desc().width);
    const uint64_t texels = uint64_t(side) * uint64_t(side);
    v.base_key.resize(layers, 0);
    v.map_key.resize(layers, 0);
    v.base_window.resize(layers, glm::ivec2(0));
    v.base_plan.assign(layers, View::Base::draw);
    v.strips.assign(layers, {});
    v.restore.assign(layers, v.has_base() ? 1 : 0);
    v.direct.assign(layers, 0);
    v.sync.assign(layers, 0);
    v.in_map.resize(layers, 0);
    stats_.layers += layers;
    for (uint32_t l = 0; l < layers; ++l) {
      // The base's key: what its texels depend on besides the window: the grid or matrices, the
      // still casters with their transforms (as drawn) and materials, the pipelines.
      Hash common;
      common.add(generation_);
      common.add(r.reverse_z);
      const auto [offset, size] = v.span(l);
      common.bytes(packed.bytes.data() + offset, size);
      common.add(!v.draws || v.draws(f, l));
      Hash base = common, moving = common;
      moving.add(v.window[l]);
      bool any_moving = false;
      const std::vector<glm::mat4>& models = v.models[v.slot(l)];
      for (size_t i = 0; i < f.draws.size(); ++i) {
        const Draw& d = f.draws[i];
        if (!d.in_maps) continue;
        const bool moves = v.moving && d.moves;
        // A moving caster counts where its bounds reach the layer this frame.
        if (moves &&
            !v.touches(f, l, v.window[l], v.window[l] + glm::ivec2(side), bounds[i]))
          continue;
        any_moving = any_moving || moves;
        Hash& h = moves ? moving : base;
        h.add(i);
        h.add(models[i]);
        h.add(d.mesh);
        h.add(d.masked);
        h.add(d.push.mask);
        h.add(d.mask_texture);
      }
      View::Base plan = View::Base::draw;
      const glm::ivec2 move = v.window[l] - v.base_window[l];
      if (cache_ && base.h == v.base_key[l]) {
        const bool near = std::abs(move.x) < side && std::abs(move.y) < side;
        plan = move == glm::ivec2(0) ? View::Base::keep
               : near && v.scroll    ? View::Base::strips
                                     : View::Base::draw;
      }
      v.base_plan[l] = plan;
      if (plan == View::Base::strips) v.strips[l] = newly_covered(v.base_window[l], v.window[l], side);
      v.base_key[l] = base.h;
      v.base_window[l] = v.window[l];
      if (plan == View::Base::draw) {
        ++stats_.drawn;
        stats_.texels_drawn += texels;
      } else if (plan == View::Base::strips) {
        ++stats_.scrolled;
        stats_.texels_drawn +=
            texels - uint64_t(side - std::abs(move.x)) * uint64_t(side - std::abs(move.y));
      }
      if (v.scroll && !v.moving) {
        const bool aligned = v.window[l].x % side == 0 && v.window[l].y % side == 0;
        if (plan == View::Base::draw && aligned) {
          v.direct[l] = 1;
          v.in_map[l] = 1;
          v.base_plan[l] = View::Base::keep;
          v.restore[l] = 0;
          v.map_key[l] = 0;
          continue;
        }
        if (plan == View::Base::strips && v.in_map[l]) v.sync[l] = 1;
        if (plan != View::Base::keep) v.in_map[l] = 0;
        if (v.in_map[l]) {  // kept, and the map holds it
          v.restore[l] = 0;
          continue;
        }
      }
      if (!v.has_base()) continue;
      Hash full = moving;
      full.add(base.h);
      const bool changed = full.h != v.map_key[l] || plan != View::Base::keep;
      v.map_key[l] = full.h;
      v.restore[l] = !cache_ || changed ? 1 : 0;
      if (v.restore[l] && any_moving) {
        ++stats_.moving_drawn;
        stats_.texels_drawn += texels;
      }
    }
  }
}

std::vector<Step> ShadowMapPass::steps(FrameResources& r) {
  std::vector<Step> out;
  for (View& v : views_) {
    // Draws `which` casters into layer l of `target`: the whole layer (cleared first when
    // `clear`), or, with `rects` (layer texels, each with the grid offset of its draw), only
    // those rectangles, cleared first; the rest of the layer is kept. A caster whose bounds
    // cannot reach a rectangle is skipped.
    struct Area {
      VkRect2D rect;
      glm::ivec2 offset;           // the grid texel at layer texel 0 of the draw
      glm::ivec2 grid_lo, grid_hi;  // the rectangle in grid texels
    };
    const auto draw = [&r, &v](VkCommandBuffer cmd, gpu::Image& target, uint32_t l,
                                     Casters which, const std::vector<Area>& areas, bool clear) {
      const gpu::GraphicsPipeline* masked = v.caster_bias ? v.masked.get() : v.opaque.get();
      const uint32_t side = target.desc().width;
      // Depth only, stored; loaded unless the whole layer is cleared.
      VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
      depth.imageView = target.layer_view(l);
      depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
      depth.loadOp = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
      depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
      depth.clearValue.depthStencil = {r.reverse_z ? 0.0f : 1.0f, 0};
      VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
      info.renderArea = {{0, 0}, {side, side}};
      info.layerCount = 1;
      info.pDepthAttachment = &depth;
      vkCmdBeginRendering(cmd, &info);
      const float vp_side = float(v.grid() ? v.viewport : side);
      const VkViewport vp{0, 0, vp_side, vp_side, 0, 1};
      vkCmdSetViewport(cmd, 0, 1, &vp);
      if (!clear) {
        std::vector<VkClearRect> clears;
        for (const Area& a : areas) clears.push_back({a.rect, 0, 1});
        VkClearAttachment wipe{VK_IMAGE_ASPECT_DEPTH_BIT, 0, {}};
        wipe.clearValue.depthStencil = {r.reverse_z ? 0.0f : 1.0f, 0};
        if (!clears.empty() && which != Casters::moving)
          vkCmdClearAttachments(cmd, 1, &wipe, uint32_t(clears.size()), clears.data());
      }
      if (!v.draws || v.draws(r.packed, l)) {
        if (v.caster_bias) vkCmdSetDepthBias(cmd, 0.0f, 0.0f, (r.reverse_z ? -1.0f : 1.0f) * 1.0f);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, v.layout->handle(), 0, 1,
                                &v.set, 0, nullptr);
        const std::vector<glm::mat4>& models = v.models[v.slot(l)];
        std::vector<uint8_t> take(models.size(), 1);
        for (const Area& a : areas) {
          vkCmdSetScissor(cmd, 0, 1, &a.rect);
          for (size_t i = 0; i < take.size(); ++i)
              take[i] = v.touches(r.packed, l, a.grid_lo, a.grid_hi, v.bounds[i]) ? 1 : 0;
          glm::uvec4 index = v.index(l);
          if (v.grid()) index.y = uint32_t(a.offset.x) | (uint32_t(a.offset.y) << 16);
          draw_casters(cmd, r, *v.layout, v.opaque->handle(),
                       masked ? masked->handle() : VK_NULL_HANDLE, index, models, which, &take);
        }
      }
      vkCmdEndRendering(cmd);
    };
    // A grid rectangle [lo, hi) as the areas of the grid image it lies in: split where it wraps
    // (grid texel g at layer texel g mod n), each drawn with the offset that puts it there.
    const auto wrapped = [&v](glm::ivec2 lo, glm::ivec2 hi) {
      const int n = int(v.target->desc().width);
      std::vector<Area> areas;
      for (int ky = lo.y / n; ky * n < hi.y; ++ky)
        for (int kx = lo.x / n; kx * n < hi.x; ++kx) {
          const glm::ivec2 k0(kx * n, ky * n);
          const glm::ivec2 a = glm::max(lo, k0), b = glm::min(hi, k0 + n);
          if (a.x >= b.x || a.y >= b.y) continue;
          areas.push_back({{{a.x - k0.x, a.y - k0.y}, {uint32_t(b.x - a.x), uint32_t(b.y - a.y)}},
                           k0, a, b});
        }
      return areas;
    };
    // The whole layer of the map itself (its own window) or of a spot or point base.
    const auto whole = [&v](uint32_t l) {
      const uint32_t n = v.target->desc().width;
      const glm::ivec2 w = v.window.empty() ? glm::ivec2(0) : v.window[l];
      return std::vector<Area>{{{{0, 0}, {n, n}}, w, w, w + glm::ivec2(int(n))}};
    };
    gpu::Image& base = v.base();
    const std::string base_label = v.base_label();
    const bool separate = v.has_base();
    if (v.scroll) {
      // A cascade drawn straight into the map and now scrolling: the map (last frame's, laid
      // out as the grid) copied back into the grid first.
      out.push_back({v.name + "-sync",
                     {{v.image, v.target, Use::copy_source, true},
                      {base_label, &base, Use::copy_target}},
                     [&v, &base](VkCommandBuffer cmd) {
                       std::vector<VkImageCopy> regions;
                       const gpu::ImageDesc& d = v.target->desc();
                       for (uint32_t l = 0; l < v.sync.size(); ++l) {
                         if (!v.sync[l]) continue;
                         VkImageCopy c{};
                         c.srcSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, l, 1};
                         c.dstSubresource = c.srcSubresource;
                         c.extent = {d.width, d.height, 1};
                         regions.push_back(c);
                       }
                       if (!regions.empty())
                         vkCmdCopyImage(cmd, v.target->handle(),
                                        VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, base.handle(),
                                        VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                        uint32_t(regions.size()), regions.data());
                     },
                     {}});
    }
    // The base: layers drawn whole, and the strips a cascade newly reaches.
    Step base_step{separate ? v.name + (v.scroll ? "-grid" : "-still") : v.name,
                   {{base_label, &base, v.scroll ? Use::depth_modify : Use::depth_target}},
                   {},
                   separate ? std::string() : v.name};
    base_step.record = [&v, &base, draw, wrapped, whole](VkCommandBuffer cmd) {
      const Casters which = v.moving ? Casters::still : Casters::all;
      const int n = int(v.target->desc().width);
      for (uint32_t l = 0; l < v.base_plan.size(); ++l) {
        if (v.base_plan[l] == View::Base::draw)
          draw(cmd, base, l, which,
               v.grid() ? wrapped(v.window[l], v.window[l] + glm::ivec2(n)) : whole(l), true);
        if (v.base_plan[l] != View::Base::strips) continue;
        std::vector<Area> areas;
        for (const glm::ivec4& s : v.strips[l])
          for (const Area& a : wrapped(glm::ivec2(s.x, s.y), glm::ivec2(s.z, s.w)))
            areas.push_back(a);
        draw(cmd, base, l, which, areas, false);
      }
    };
    out.push_back(std::move(base_step));
    if (!separate) continue;
    // The map: the sun's window drawn out of its grid (a triangle per layer writing each
    // texel's stored depth: a depth-image copy costs several times more on some GPUs), a spot
    // or point map copied from its still copy; then the moving casters drawn over it.
    if (v.window_by_draw) {
      out.push_back({v.name + "-window",
                     {{base_label, &base, Use::sampled}, {v.image, v.target, Use::depth_target}},
                     [&v](VkCommandBuffer cmd) {
                       const int n = int(v.target->desc().width);
                       for (uint32_t l = 0; l < v.restore.size(); ++l) {
                         if (!v.restore[l]) continue;
                         VkRenderingAttachmentInfo depth{
                             VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
                         depth.imageView = v.target->layer_view(l);
                         depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
                         depth.loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
                         depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
                         VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
                         info.renderArea = {{0, 0}, {uint32_t(n), uint32_t(n)}};
                         info.layerCount = 1;
                         info.pDepthAttachment = &depth;
                         vkCmdBeginRendering(cmd, &info);
                         const VkViewport vp{0, 0, float(n), float(n), 0, 1};
                         vkCmdSetViewport(cmd, 0, 1, &vp);
                         vkCmdSetScissor(cmd, 0, 1, &info.renderArea);
                         vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS,
                                           v.window_pipeline->handle());
                         vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS,
                                                 v.window_layout->handle(), 0, 1, &v.window_set,
                                                 0, nullptr);
                         const glm::ivec4 push(int(l), v.window[l].x % n, v.window[l].y % n, n);
                         vkCmdPushConstants(cmd, v.window_layout->handle(),
                                            VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push), &push);
                         vkCmdDraw(cmd, 3, 1, 0, 0);
                         vkCmdEndRendering(cmd);
                       }
                     },
                     {}});
    } else {
      // A copy: the grid's window in up to four parts (it wraps), a still copy whole.
      out.push_back({v.name + "-copy",
                     {{base_label, &base, Use::copy_source}, {v.image, v.target, Use::copy_target}},
                     [&v, &base, wrapped](VkCommandBuffer cmd) {
                       std::vector<VkImageCopy> regions;
                       const int n = int(v.target->desc().width);
                       for (uint32_t l = 0; l < v.restore.size(); ++l) {
                         if (!v.restore[l]) continue;
                         const glm::ivec2 w = v.grid() ? v.window[l] : glm::ivec2(0);
                         for (const Area& a : wrapped(w, w + glm::ivec2(n))) {
                           VkImageCopy c{};
                           c.srcSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, l, 1};
                           c.dstSubresource = c.srcSubresource;
                           c.srcOffset = {a.rect.offset.x, a.rect.offset.y, 0};
                           c.dstOffset = {a.grid_lo.x - w.x, a.grid_lo.y - w.y, 0};
                           c.extent = {a.rect.extent.width, a.rect.extent.height, 1};
                           regions.push_back(c);
                         }
                       }
                       if (!regions.empty())
                         vkCmdCopyImage(cmd, base.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                                        v.target->handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                        uint32_t(regions.size()), regions.data());
                     },
                     v.moving || v.grid() ? std::string() : v.name});
    }
    if (v.scroll && !v.moving) {
      // Cascades drawn whole straight into the map (their window on a whole map of the grid).
      Step direct{v.name, {{v.image, v.target, Use::depth_modify}}, {}, v.name};
      direct.record = [&v, draw, whole](VkCommandBuffer cmd) {
        for (uint32_t l = 0; l < v.direct.size(); ++l)
          if (v.direct[l]) draw(cmd, *v.target, l, Casters::all, whole(l), true);
      };
      out.push_back(std::move(direct));
    }
    if (!v.moving) continue;
    Step step{v.name, {{v.image, v.target, Use::depth_modify}}, {}, v.name};
    step.record = [&v, draw, whole](VkCommandBuffer cmd) {
      for (uint32_t l = 0; l < v.restore.size(); ++l)
        if (v.restore[l]) draw(cmd, *v.target, l, Casters::moving, whole(l), false);
    };
    out.push_back(std::move(step));
  }
  return out;
}

}  // namespace penumbra::render::passes
