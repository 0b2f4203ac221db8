// The shadow-map pass: every caster into every light's depth views. The sun's cascades, the
// spot maps and the point cubes are one list of views (an image, its layers, the caster
// pipelines and the push index of each layer), recorded the same way.
//
// A view is drawn relative to anchors of its own (the sun's: the camera's cell of a grid as
// coarse as the shadows reach; a spot or point light's: its position), never the camera, so a
// map's texels depend only on its light, its casters and its matrices.
//
// The sun's cascades are drawn into a grid: grid texel g of a cascade lives at texel g mod N of
// its layer (toroidal), always drawn at the same window position (CascadeDrawGpu), so a cascade
// that moved by whole texels keeps what it held and is drawn only where it newly reaches. The
// resolves and EVSM2's moments read the grid in place (sun-shadow-map is the grid;
// SunWindow::in_place, the default); SunWindow::copy or draw draws it into an image of its own
// (sun-shadow-grid) and writes each cascade's window [w, w + N) into the map in window order.
//
// The cache (shadows.cache) keys each layer on what its texels depend on: its grid or matrices,
// every still caster with its transform and material, the depth convention and the pipelines'
// generation; a layer whose key is unchanged is not drawn. Moving casters (Instance::motion)
// are keyed apart: where the map is drawn as it is sampled (read in place, spot and point
// maps), the rectangle they reached last frame and reach now is drawn again with every caster
// in it; through sun-shadow-grid, they are drawn over the copied map. Depth-only draws keep the
// nearest depth whatever their order, and a texel is always rasterized at the same window
// position, so this is the same bit for bit as drawing every layer every frame
// (shadows.cache = false, which takes the same route without keeping anything).

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <penumbra/shadow/pack.hpp>

#include "shadow_view.hpp"

namespace penumbra::render::passes {

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

namespace {

// The texels (x0, y0, x1, y1) of a side x side layer that bounds b can be drawn into through
// view_proj (world to clip, perspective, near plane at w = near): the square of the box's part
// in front of a plane just inside the near plane (its corners there and its edges' crossings),
// in whole texels, grown by two. A box's perspective image lies within that square; what lies
// behind the near plane is clipped anyway.
glm::ivec4 projected_rect(const glm::dmat4& view_proj, double near, const scene::Bounds& b,
                          int side) {
  if (b.empty()) return glm::ivec4(0);
  std::array<glm::dvec4, 8> corner;
  for (int i = 0; i < 8; ++i)
    corner[size_t(i)] = view_proj * glm::dvec4((i & 1) ? b.max.x : b.min.x,
                                               (i & 2) ? b.max.y : b.min.y,
                                               (i & 4) ? b.max.z : b.min.z, 1.0);
  const double plane = 0.99 * near;
  glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-lo);
  const auto add = [&](const glm::dvec4& c) {
    const glm::dvec2 t = (glm::dvec2(c) / c.w * 0.5 + 0.5) * double(side);
    lo = glm::min(lo, t);
    hi = glm::max(hi, t);
  };
  for (int i = 0; i < 8; ++i) {
    const glm::dvec4& a = corner[size_t(i)];
    if (a.w >= plane) add(a);
    for (int axis = 1; axis < 8; axis <<= 1) {  // the edges to the corners one bit up
      if (i & axis) continue;
      const glm::dvec4& c = corner[size_t(i | axis)];
      if ((a.w < plane) != (c.w < plane)) add(a + (c - a) * ((plane - a.w) / (c.w - a.w)));
    }
  }
  if (!(lo.x <= hi.x)) return glm::ivec4(0);  // wholly behind the near plane (or not finite)
  const glm::dvec2 limit{double(side)};
  const glm::ivec2 from(glm::clamp(glm::floor(lo) - 2.0, glm::dvec2(0.0), limit));
  const glm::ivec2 to(glm::clamp(glm::floor(hi) + 3.0, glm::dvec2(0.0), limit));
  return glm::ivec4(from, glm::max(to, from));
}

// Whether bounds b reach the sphere (centre, radius).
bool reaches_sphere(const scene::Bounds& b, const glm::dvec3& centre, double radius) {
  if (b.empty()) return false;
  const glm::dvec3 nearest = glm::clamp(centre, glm::dvec3(b.min), glm::dvec3(b.max));
  return glm::length(nearest - centre) <= radius;
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
  const size_t first_program = r.report.pipelines.size();
  views_.reserve(3);  // the pipelines' create callbacks hold references into the views
  if (r.req.sun_shadows) {
    const uint32_t res = r.scene.shadows.resolution, n = r.req.cascades;
    sun_map = r.make_image("sun-shadow-map", gpu::ImageKind::image_2d_array, kDepthFormat, res, res,
                           n, kMapUsage, 1, "shadows.resolution = " + std::to_string(res));
    sun_ubo = gpu::Buffer(r.ctx, sizeof(shadow::ShadowGpu), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    configure_sun_view(r, views_.emplace_back(), sun_map, n, res);
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
    const gpu::Image& maps = spot_maps;
    v.rect = [&maps](const PackedFrame& f, uint32_t i, const scene::Bounds& b) {
      const shadow::SpotShadow& s = f.spot_shadows[i];
      return projected_rect(s.view_proj, s.near, b, int(maps.desc().width));
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
    const gpu::Image& cubes = point_cubes;
    v.rect = [&cubes](const PackedFrame& f, uint32_t l, const scene::Bounds& b) {
      const shadow::PointShadow& p = f.point_shadows[l / 6];
      return projected_rect(p.face_view_proj[l % 6], p.clip_near, b, int(cubes.desc().width));
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
  // The base image: the sun's grid where the cascades scroll through it into a map (a CPU
  // device's route; shadows.cache = false takes the same route).
  cache_ = r.scene.shadows.cache;
  const bool moving = std::any_of(r.scene.instances.begin(), r.scene.instances.end(),
                                  [](const scene::Instance& i) {
                                    return i.in_shadow_maps() && i.motion && i.motion->moves();
                                  });
  for (View& v : views_) {
    const gpu::ImageDesc& d = v.target->desc();
    const uint64_t before = r.image_bytes;
    using Scroll = RendererOptions::Scroll;
    using SunWindow = RendererOptions::SunWindow;
    const bool cpu = r.ctx.info().is_cpu;
    // Read in place (EVSM2's moments too: EvsmPass reads each cascade through its window).
    v.in_place = v.grid() &&
                 (r.sun_window == SunWindow::in_place || r.sun_window == SunWindow::automatic);
    v.scroll = v.grid() && (r.scroll_cascades == Scroll::on ||
                            (r.scroll_cascades == Scroll::automatic && (cpu || v.in_place)));
    // Moving casters apart from the still ones: over the sun's grid when it is copied into the
    // map; where the map is drawn as sampled (read in place, a spot or point view), again with
    // the rest where they were and are. Without scrolling the sun draws every caster whole.
    v.moving = moving && (v.grid() ? v.scroll : cache_);
    // The grid the cascades scroll through, written into the map (read in place, the map is
    // the grid).
    if (v.scroll && !v.in_place) {
      v.base_name = "sun-shadow-grid";
      v.base_image = r.make_image(v.base_name, d.kind, kDepthFormat, d.width, d.height, d.layers,
                                  kMapUsage, 1,
                                  "shadows.resolution = " + std::to_string(d.width) +
                                      " (the cascades' grid, drawn into sun-shadow-map)");
    }
    v.window_by_draw = v.scroll && !v.in_place &&
                       (r.sun_window == SunWindow::draw ||
                        (r.sun_window == SunWindow::automatic && !cpu));
    if (v.grid()) {
      sun_in_place = v.in_place;
      sun_compare = r.shadow_compare.handle();
      sun_raw = r.raw_depth.handle();
    }
    if (v.in_place) {
      gpu::SamplerDesc cmp;
      cmp.filter = VK_FILTER_LINEAR;
      cmp.compare = true;
      cmp.compare_op = r.depth_test(false);
      cmp.address = VK_SAMPLER_ADDRESS_MODE_REPEAT;
      repeat_compare_ = gpu::Sampler(r.ctx, cmp);
      gpu::SamplerDesc raw;
      raw.address = VK_SAMPLER_ADDRESS_MODE_REPEAT;
      repeat_raw_ = gpu::Sampler(r.ctx, raw);
      sun_compare = repeat_compare_.handle();
      sun_raw = repeat_raw_.handle();
    }
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
                           : "") +
                      (sun_in_place ? ", read in place from sun-shadow-map as their toroidal grid"
                                    : "")
                : std::string("off (shadows.cache = false): every layer drawn every frame")) +
        (!moving ? ""
         : std::any_of(views_.begin(), views_.end(),
                       [](const View& v) { return v.moving && v.has_base(); })
             ? "; moving casters drawn over the still ones (the sun's grid), elsewhere again "
               "with the rest where they were and are"
             : "; moving casters drawn again with the rest where they were and are") +
        " (" + mib + " beside the maps)");
  }
  programs_.assign(r.report.pipelines.begin() + std::ptrdiff_t(first_program),
                   r.report.pipelines.end());
}

ShadowMapPass::~ShadowMapPass() = default;

void ShadowMapPass::invalidate() {
  ++generation_;
}

bool ShadowMapPass::draws_maps(const std::string& program) const {
  return std::find(programs_.begin(), programs_.end(), program) != programs_.end();
}

glm::ivec2 ShadowMapPass::sun_offset(uint32_t c) const {
  for (const View& v : views_)
    if (v.in_place && c < v.window.size()) {
      const int n = int(v.target->desc().width);
      return ((v.window[c] % n) + n) % n;
    }
  return glm::ivec2(0);
}

}  // namespace penumbra::render::passes
