// The sun's shadow resolve (compute): per pixel, cascade selection and blending, distance fade,
// normal-offset and slope-scaled bias and the configured filter (shaders/render/
// shadow_resolve.comp), into the shadow-info image the forward and tonemap passes read.

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
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_->handle());
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_->handle(), 0, 1, &set_, 0,
                          nullptr);
  vkCmdDispatch(cmd, (r.width + 7) / 8, (r.height + 7) / 8, 1);
  r.info.transition(cmd, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  mark("shadow-resolve");
}

}  // namespace penumbra::render::passes
