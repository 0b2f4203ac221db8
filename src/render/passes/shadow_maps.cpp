// The shadow-map pass: every caster into every light's depth views. The sun's cascades, the
// spot maps and the point cubes are one list of views (an image, its layers, the caster
// pipelines and the push index of each layer), recorded the same way.

#include <algorithm>

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
    v.set = ubo_set(r, *v.layout, sun_ubo);
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
    v.set = ubo_set(r, *v.layout, spot_ubo);
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
    v.set = ubo_set(r, *v.layout, point_ubo);
    const bool fitted =
        std::any_of(r.scene.points.begin(), r.scene.points.end(),
                    [](const scene::PointLight& p) { return p.shadows && p.fit_to_camera; });
    r.report.passes.push_back("point-shadow: " + std::to_string(n) + " cube(s) x 6 faces" +
                              (fitted ? " (fitted to the camera: the faces it sees)" : ""));
  }
}

ShadowMapPass::~ShadowMapPass() = default;

void ShadowMapPass::upload(const PackedFrame& f) {
  if (sun_ubo.handle() != VK_NULL_HANDLE) sun_ubo.write(std::as_bytes(std::span(&f.shadow, 1)));
  if (spot_ubo.handle() != VK_NULL_HANDLE) spot_ubo.write(std::as_bytes(std::span(f.spot_gpu)));
  if (point_ubo.handle() != VK_NULL_HANDLE) point_ubo.write(std::as_bytes(std::span(f.point_gpu)));
}

std::vector<Step> ShadowMapPass::steps(FrameResources& r) {
  std::vector<Step> out;
  for (View& v : views_) {
    Step step{v.name, {{v.image, v.target, Use::depth_target}}, {}, v.name};
    step.record = [&r, &v](VkCommandBuffer cmd) {
      // Caster-side depth bias pushes caster depth away from the light: negative under
      // reverse-Z.
      const float bias_sign = r.reverse_z ? -1.0f : 1.0f;
      gpu::Image& target = *v.target;
      const uint32_t layers = v.layers(r.packed);
      // The point pipeline draws opaque and masked casters alike.
      const gpu::GraphicsPipeline* masked = v.caster_bias ? v.masked.get() : v.opaque.get();
      for (uint32_t l = 0; l < layers; ++l) {
        begin_rendering(cmd, r, target.desc().width, target.desc().width, VK_NULL_HANDLE, {},
                        target.layer_view(l), VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, true);
        if (!v.draws || v.draws(r.packed, l)) {
          if (v.caster_bias) vkCmdSetDepthBias(cmd, 0.0f, 0.0f, bias_sign * 1.0f);
          vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, v.layout->handle(), 0, 1,
                                  &v.set, 0, nullptr);
          draw_meshes(cmd, r, *v.layout, v.opaque->handle(),
                      masked ? masked->handle() : VK_NULL_HANDLE, true, v.index(l));
        }
        vkCmdEndRendering(cmd);
      }
    };
    out.push_back(std::move(step));
  }
  return out;
}

}  // namespace penumbra::render::passes
