// The shadow-map pass: every caster into every light's depth views. The sun's cascades, the
// spot maps and the point cubes are one list of views (an image, its layers, the caster
// pipelines and the push index of each layer), recorded the same way.
//
// A view is drawn relative to anchors of its own (the sun's: the camera's cell of a grid as
// coarse as the shadows reach; a spot or point light's: its position), never the camera, so a
// map's texels depend only on its light, its casters and its matrices. The cache
// (shadows.cache) keys each layer on exactly those: its matrices, every caster whose bounds
// reach the layer's volume with its transform and material, the depth convention and the
// pipelines' generation. A layer whose key is unchanged is not drawn. With moving casters
// (Instance::motion) each view keeps a copy of its still casters: a layer whose moving casters
// changed is restored from it and only the moving ones are drawn over. Depth-only draws keep
// the nearest depth whatever their order, so this is the same bit for bit as drawing all.

#include <algorithm>
#include <cmath>
#include <cstring>
#include <penumbra/shadow/pack.hpp>

#include "passes.hpp"

namespace penumbra::render::passes {

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

  // The maps' own matrices: the draw UBO's bytes rebased on this frame's anchors (one anchor
  // per slot: the sun's one, a spot or point light's own), the slot and UBO bytes of a layer,
  // and whether bounds b reach a layer's volume (conservatively: a caster outside it cannot
  // touch a texel of the layer).
  gpu::Buffer draw_ubo;
  std::function<std::vector<std::byte>(const PackedFrame&, std::vector<glm::dvec3>&)> pack;
  std::function<uint32_t(uint32_t)> slot;
  std::function<std::pair<size_t, size_t>(uint32_t)> span;
  std::function<bool(const PackedFrame&, uint32_t, const scene::Bounds&)> touches;

  // The still casters' copy (the cache with moving casters), and the per-layer keys and plans.
  gpu::Image still;
  std::string still_name;
  std::vector<uint64_t> map_key, still_key;
  enum class Plan : uint8_t { keep, draw_all, restore, restore_and_draw_moving };
  std::vector<Plan> plan;
  std::vector<uint8_t> draw_still;
  std::vector<std::vector<glm::mat4>> models;  // per slot, per draw
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
    v.draw_ubo = gpu::Buffer(r.ctx, sizeof(shadow::ShadowGpu), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    v.set = ubo_set(r, *v.layout, v.draw_ubo);
    const scene::Scene& scene = r.scene;
    v.pack = [&scene](const PackedFrame& f, std::vector<glm::dvec3>& anchors) {
      const double reach = scene.shadows.layout == scene::ShadowLayout::clipmap
                               ? std::ldexp(double(scene.shadows.clipmap_extent),
                                            int(scene.shadows.clipmap_levels))
                               : double(scene.shadows.max_distance);
      anchors = {sun_anchor(f.origin, reach)};
      return bytes_of(std::vector<shadow::ShadowGpu>{shadow::pack_shadow(f.cascades, anchors[0])});
    };
    v.slot = [](uint32_t) { return 0u; };
    v.span = [](uint32_t c) {
      return std::pair<size_t, size_t>(offsetof(shadow::ShadowGpu, cascades) +
                                           c * sizeof(shadow::CascadeGpu),
                                       sizeof(shadow::CascadeGpu));
    };
    // The cascade's square across the light, grown by a texel; every depth along it (depth
    // clamp pancakes casters in front of the near plane onto it).
    v.touches = [](const PackedFrame& f, uint32_t c, const scene::Bounds& b) {
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
      const double g = k.texel_world_size;
      return hi.x >= k.box_min.x - g && lo.x <= k.box_max.x + g && hi.y >= k.box_min.y - g &&
             lo.y <= k.box_max.y + g;
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
    v.pack = [](const PackedFrame& f, std::vector<glm::dvec3>& anchors) {
      std::vector<shadow::SpotShadowGpu> gpu(kMaxSpotLights);
      anchors.clear();
      for (size_t i = 0; i < f.spot_shadows.size(); ++i) {
        anchors.push_back(f.spot_shadows[i].position);
        gpu[i] = shadow::pack_spot_shadow(f.spot_shadows[i], anchors.back());
      }
      return bytes_of(gpu);
    };
    v.slot = [](uint32_t i) { return i; };
    v.span = [](uint32_t i) {
      return std::pair<size_t, size_t>(i * sizeof(shadow::SpotShadowGpu),
                                       sizeof(shadow::SpotShadowGpu));
    };
    // The frustum's bounding sphere: its far corners are far·sqrt(1 + 2 tan²) from the light.
    v.touches = [](const PackedFrame& f, uint32_t i, const scene::Bounds& b) {
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
    v.pack = [](const PackedFrame& f, std::vector<glm::dvec3>& anchors) {
      std::vector<shadow::PointShadowGpu> gpu(kMaxPointLights);
      anchors.clear();
      for (size_t i = 0; i < f.point_shadows.size(); ++i) {
        anchors.push_back(f.point_shadows[i].position);
        gpu[i] = shadow::pack_point_shadow(f.point_shadows[i], anchors.back());
      }
      return bytes_of(gpu);
    };
    v.slot = [](uint32_t l) { return l / 6; };
    v.span = [](uint32_t l) {
      return std::pair<size_t, size_t>((l / 6) * sizeof(shadow::PointShadowGpu),
                                       sizeof(shadow::PointShadowGpu));
    };
    // A face's frustum reaches depth_far along its axis: corners at depth_far·sqrt(3).
    v.touches = [](const PackedFrame& f, uint32_t l, const scene::Bounds& b) {
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
  // The cache: with moving casters, a copy of each map holding its still casters.
  cache_ = r.scene.shadows.cache;
  const bool moving =
      cache_ && std::any_of(r.scene.instances.begin(), r.scene.instances.end(),
                            [](const scene::Instance& i) {
                              return i.in_shadow_maps() && i.motion && i.motion->moves();
                            });
  for (View& v : views_) {
    if (!moving) continue;
    const gpu::ImageDesc& d = v.target->desc();
    v.still_name = v.image + "-still";
    const uint64_t before = r.image_bytes;
    v.still = r.make_image(v.still_name, d.kind, kDepthFormat, d.width, d.height, d.layers,
                           kMapUsage, 1,
                           "shadows.cache = true (" + v.image +
                               "'s still casters, kept for the moving ones)");
    cache_bytes += r.image_bytes - before;
  }
  if (!views_.empty()) {
    r.report.passes.push_back(
        std::string("shadow-map cache: ") +
        (!cache_  ? "off (shadows.cache = false): every layer drawn every frame"
         : moving ? "on, moving casters drawn over still copies (" +
                        std::to_string((cache_bytes + (1u << 20) - 1) >> 20) + " MiB)"
                  : "on (no moving casters: a layer is drawn when its key changes)"));
  }
}

ShadowMapPass::~ShadowMapPass() = default;

void ShadowMapPass::invalidate() {
  ++generation_;
}

void ShadowMapPass::prepare(FrameResources& r) {
  const PackedFrame& f = r.packed;
  if (sun_ubo.handle() != VK_NULL_HANDLE) sun_ubo.write(std::as_bytes(std::span(&f.shadow, 1)));
  if (spot_ubo.handle() != VK_NULL_HANDLE) spot_ubo.write(std::as_bytes(std::span(f.spot_gpu)));
  if (point_ubo.handle() != VK_NULL_HANDLE) point_ubo.write(std::as_bytes(std::span(f.point_gpu)));
  stats_ = {};
  // Each caster's bounds this frame (the draws are the scene's instances, in order).
  const std::vector<scene::Bounds> bounds = r.scene.instance_world_bounds();
  for (View& v : views_) {
    std::vector<glm::dvec3> anchors;
    const std::vector<std::byte> data = v.pack(f, anchors);
    v.draw_ubo.write(std::span(data));
    v.models.assign(anchors.size(), {});
    for (size_t s = 0; s < anchors.size(); ++s) {
      v.models[s].resize(f.draws.size());
      for (size_t i = 0; i < f.draws.size(); ++i) {
        glm::dmat4 m = f.draws[i].world;
        m[3] -= glm::dvec4(anchors[s], 0.0);
        v.models[s][i] = glm::mat4(m);
      }
    }
    const uint32_t layers = v.layers(f);
    const uint64_t texels = uint64_t(v.target->desc().width) * v.target->desc().width;
    const bool still = v.still.handle() != VK_NULL_HANDLE;
    v.map_key.resize(layers, 0);
    v.still_key.resize(layers, 0);
    v.plan.assign(layers, View::Plan::draw_all);
    v.draw_still.assign(layers, 0);
    stats_.layers += layers;
    for (uint32_t l = 0; l < layers; ++l) {
      if (!cache_) {
        ++stats_.drawn;
        stats_.texels_drawn += texels;
        continue;
      }
      // The layer's key: what its texels depend on. Casters are keyed by index, transform (as
      // drawn) and material; only those whose bounds reach the layer's volume.
      Hash common;
      common.add(generation_);
      common.add(r.reverse_z);
      const auto [offset, size] = v.span(l);
      common.bytes(data.data() + offset, size);
      common.add(!v.draws || v.draws(f, l));
      Hash still_hash = common, moving_hash = common;
      const std::vector<glm::mat4>& models = v.models[v.slot(l)];
      for (size_t i = 0; i < f.draws.size(); ++i) {
        const Draw& d = f.draws[i];
        if (!d.in_maps || !v.touches(f, l, bounds[i])) continue;
        Hash& h = still && d.moves ? moving_hash : still_hash;
        h.add(i);
        h.add(models[i]);
        h.add(d.mesh);
        h.add(d.masked);
        h.add(d.push.mask);
        h.add(d.mask_texture);
      }
      Hash full = still_hash;
      full.add(moving_hash.h);
      if (still && still_hash.h != v.still_key[l]) {
        v.draw_still[l] = 1;
        v.still_key[l] = still_hash.h;
        ++stats_.still_drawn;
      }
      if (full.h == v.map_key[l]) {
        v.plan[l] = View::Plan::keep;
        continue;
      }
      v.map_key[l] = full.h;
      if (!still) {
        ++stats_.drawn;
        stats_.texels_drawn += texels;
      } else if (moving_hash.h != common.h) {
        v.plan[l] = View::Plan::restore_and_draw_moving;
        ++stats_.moving_drawn;
        stats_.texels_drawn += texels;
      } else {
        v.plan[l] = View::Plan::restore;
      }
    }
  }
}

std::vector<Step> ShadowMapPass::steps(FrameResources& r) {
  std::vector<Step> out;
  for (View& v : views_) {
    // Caster-side depth bias pushes caster depth away from the light: negative under reverse-Z.
    // The point pipeline draws opaque and masked casters alike.
    const auto draw = [&r, &v](VkCommandBuffer cmd, gpu::Image& target, uint32_t l, bool clear,
                               Casters which) {
      const gpu::GraphicsPipeline* masked = v.caster_bias ? v.masked.get() : v.opaque.get();
      begin_rendering(cmd, r, target.desc().width, target.desc().width, VK_NULL_HANDLE, {},
                      target.layer_view(l), VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, clear);
      if (!v.draws || v.draws(r.packed, l)) {
        if (v.caster_bias) vkCmdSetDepthBias(cmd, 0.0f, 0.0f, (r.reverse_z ? -1.0f : 1.0f) * 1.0f);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, v.layout->handle(), 0, 1,
                                &v.set, 0, nullptr);
        draw_casters(cmd, r, *v.layout, v.opaque->handle(),
                     masked ? masked->handle() : VK_NULL_HANDLE, v.index(l),
                     v.models[v.slot(l)], which);
      }
      vkCmdEndRendering(cmd);
    };
    if (v.still.handle() == VK_NULL_HANDLE) {
      Step step{v.name, {{v.image, v.target, Use::depth_target}}, {}, v.name};
      step.record = [&v, draw](VkCommandBuffer cmd) {
        for (uint32_t l = 0; l < v.plan.size(); ++l)
          if (v.plan[l] == View::Plan::draw_all) draw(cmd, *v.target, l, true, Casters::all);
      };
      out.push_back(std::move(step));
      continue;
    }
    // With moving casters: the still copy's layers drawn again, the map's restored from it, the
    // moving casters drawn over.
    out.push_back({v.name + "-still",
                   {{v.still_name, &v.still, Use::depth_target}},
                   [&v, draw](VkCommandBuffer cmd) {
                     for (uint32_t l = 0; l < v.draw_still.size(); ++l)
                       if (v.draw_still[l]) draw(cmd, v.still, l, true, Casters::still);
                   },
                   {}});
    out.push_back({v.name + "-restore",
                   {{v.still_name, &v.still, Use::copy_source},
                    {v.image, v.target, Use::copy_target}},
                   [&v](VkCommandBuffer cmd) {
                     std::vector<VkImageCopy> regions;
                     const gpu::ImageDesc& d = v.target->desc();
                     for (uint32_t l = 0; l < v.plan.size(); ++l) {
                       if (v.plan[l] == View::Plan::keep) continue;
                       VkImageCopy c{};
                       c.srcSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, l, 1};
                       c.dstSubresource = c.srcSubresource;
                       c.extent = {d.width, d.height, 1};
                       regions.push_back(c);
                     }
                     if (!regions.empty())
                       vkCmdCopyImage(cmd, v.still.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                                      v.target->handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                      uint32_t(regions.size()), regions.data());
                   },
                   {}});
    Step step{v.name, {{v.image, v.target, Use::depth_modify}}, {}, v.name};
    step.record = [&v, draw](VkCommandBuffer cmd) {
      for (uint32_t l = 0; l < v.plan.size(); ++l)
        if (v.plan[l] == View::Plan::restore_and_draw_moving)
          draw(cmd, *v.target, l, false, Casters::moving);
    };
    out.push_back(std::move(step));
  }
  return out;
}

}  // namespace penumbra::render::passes
