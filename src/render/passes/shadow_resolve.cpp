// The shadow resolves (compute). The sun's: per pixel, cascade selection and blending, distance
// fade, the world-unit biases and the configured filter (shaders/render/shadow_resolve.comp),
// into the shadow-info image the forward and tonemap passes read. The local lights': the same
// biases and filters for every shadowed spot and point light (shaders/render/
// local_shadow_resolve.comp), into the local-shadow image (one channel per light).

#include "passes.hpp"

namespace penumbra::render::passes {

ShadowResolvePass::ShadowResolvePass(FrameResources& r, const ShadowMapPass& maps) {
  r.info = r.make_image("shadow-info", gpu::ImageKind::image_2d, kInfoFormat, r.width, r.height, 1,
                        VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
  const VkShaderStageFlags cs = VK_SHADER_STAGE_COMPUTE_BIT;
  layout_ = std::make_unique<gpu::PipelineLayout>(
      r.ctx, std::vector<std::vector<gpu::BindingDesc>>{
                 {{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, cs},
                  {1, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, cs},
                  {2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs},
                  {3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs},
                  {4, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs},
                  {5, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs},
                  {6, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, cs}}});
  r.add_pipeline("shadow-resolve", {{"render/shadow_resolve.comp", {}}},
                 [this, &r](const shader::Spirvs& spirv) {
                   pipeline_ = std::make_unique<gpu::ComputePipeline>(r.ctx, spirv[0], *layout_);
                 });
  set_ = r.pool.allocate(layout_->set_layout(0));
  gpu::DescriptorWriter()
      .buffer(0, r.frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
      .buffer(1, maps.sun_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
      .combined_image(2, r.depth.view(), r.nearest.handle())
      .combined_image(3, r.normal.view(), r.nearest.handle())
      .combined_image(4, maps.sun_map.view(), r.shadow_compare.handle())
      .combined_image(5, maps.sun_map.view(), r.raw_depth.handle())
      .storage_image(6, r.info.view())
      .update(r.ctx, set_);
  r.report.passes.push_back("shadow-resolve: compute");
}

PassIo ShadowResolvePass::io() const {
  return {{"frame", "depth", "normal", "sun-shadow-map"}, {"shadow-info"}};
}

void ShadowResolvePass::record(VkCommandBuffer cmd, FrameResources& r, const Mark& mark) {
  r.info.transition(cmd, VK_IMAGE_LAYOUT_GENERAL);
  dispatch_per_pixel(cmd, r, *layout_, *pipeline_, set_);
  r.info.transition(cmd, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  mark("shadow-resolve");
}

LocalShadowResolvePass::LocalShadowResolvePass(FrameResources& r, const ShadowMapPass& maps) {
  r.local_info = r.make_image("local-shadow", gpu::ImageKind::image_2d, kInfoFormat, r.width,
                              r.height, 1, VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
  r.local_debug =
      r.make_image("local-shadow-debug", gpu::ImageKind::image_2d, kInfoFormat, r.width, r.height,
                   1, VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
  const VkShaderStageFlags cs = VK_SHADER_STAGE_COMPUTE_BIT;
  const auto& req = r.req;
  std::vector<gpu::BindingDesc> b{{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, cs},
                                  {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs},
                                  {2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs},
                                  {9, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, cs},
                                  {10, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, cs}};
  for (uint32_t first : {3u, 6u}) {
    if ((first == 3u ? req.spot_shadow_maps : req.point_shadow_cubes) == 0) continue;
    b.push_back({first, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, cs});
    b.push_back({first + 1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs});
    b.push_back({first + 2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs});
  }
  layout_ =
      std::make_unique<gpu::PipelineLayout>(r.ctx, std::vector<std::vector<gpu::BindingDesc>>{b});
  const auto all = light_defines(r);
  const std::vector<shader::Define> defines{all[2], all[3]};
  r.add_pipeline(variant("local-shadow-resolve", defines),
                 {{"render/local_shadow_resolve.comp", defines}},
                 [this, &r](const shader::Spirvs& spirv) {
                   pipeline_ = std::make_unique<gpu::ComputePipeline>(r.ctx, spirv[0], *layout_);
                 });
  set_ = r.pool.allocate(layout_->set_layout(0));
  gpu::DescriptorWriter w;
  w.buffer(0, r.frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
      .combined_image(1, r.depth.view(), r.nearest.handle())
      .combined_image(2, r.normal.view(), r.nearest.handle())
      .storage_image(9, r.local_info.view())
      .storage_image(10, r.local_debug.view());
  if (req.spot_shadow_maps) {
    w.buffer(3, maps.spot_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
        .combined_image(4, maps.spot_maps.view(), r.shadow_compare.handle())
        .combined_image(5, maps.spot_maps.view(), r.raw_depth.handle());
  }
  if (req.point_shadow_cubes) {
    w.buffer(6, maps.point_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
        .combined_image(7, maps.point_cubes.view(), r.shadow_compare.handle())
        .combined_image(8, maps.point_cubes.view(), r.raw_depth.handle());
  }
  w.update(r.ctx, set_);
  r.report.passes.push_back("local-shadow-resolve: compute");
}

PassIo LocalShadowResolvePass::io() const {
  return {{"frame", "depth", "normal", "spot-shadow-map", "point-shadow-map"},
          {"local-shadow", "local-shadow-debug"}};
}

void LocalShadowResolvePass::record(VkCommandBuffer cmd, FrameResources& r, const Mark& mark) {
  r.local_info.transition(cmd, VK_IMAGE_LAYOUT_GENERAL);
  r.local_debug.transition(cmd, VK_IMAGE_LAYOUT_GENERAL);
  dispatch_per_pixel(cmd, r, *layout_, *pipeline_, set_);
  r.local_info.transition(cmd, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  r.local_debug.transition(cmd, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  mark("local-shadow-resolve");
}

}  // namespace penumbra::render::passes
