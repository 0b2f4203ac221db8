// Tonemapping (compute): exposure and the tone curve of the HDR image, or one of the debug views
// (shadow factor, cascades, contact mask, texel density, penumbra), into the output image.

#include "passes.hpp"

namespace penumbra::render::passes {

TonemapPass::TonemapPass(FrameResources& r) {
  const VkShaderStageFlags cs = VK_SHADER_STAGE_COMPUTE_BIT;
  std::vector<gpu::BindingDesc> b{{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, cs},
                                  {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs},
                                  {4, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, cs}};
  if (r.req.sun_shadows) b.push_back({2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs});
  if (r.contact_mask) b.push_back({3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs});
  const bool local = r.req.spot_shadow_maps > 0 || r.req.point_shadow_cubes > 0;
  if (local) {
    b.push_back({5, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs});
    b.push_back({6, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs});
  }
  layout_ =
      std::make_unique<gpu::PipelineLayout>(r.ctx, std::vector<std::vector<gpu::BindingDesc>>{b});
  const auto defines = light_defines(r);
  r.add_pipeline(variant("tonemap", defines), {{"render/tonemap.comp", defines}},
                 [this, &r](const shader::Spirvs& spirv) {
                   pipeline_ = std::make_unique<gpu::ComputePipeline>(r.ctx, spirv[0], *layout_);
                 });
  set_ = r.pool.allocate(layout_->set_layout(0));
  gpu::DescriptorWriter w;
  w.buffer(0, r.frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
      .combined_image(1, r.hdr.view(), r.nearest.handle())
      .storage_image(4, r.ldr.view());
  if (r.req.sun_shadows) w.combined_image(2, r.info.view(), r.nearest.handle());
  if (r.contact_mask) w.combined_image(3, r.contact_mask->view(), r.nearest.handle());
  if (local) {
    w.combined_image(5, r.local_info.view(), r.nearest.handle());
    w.combined_image(6, r.local_debug.view(), r.nearest.handle());
  }
  w.update(r.ctx, set_);
  r.report.passes.push_back("tonemap: compute");
}

PassIo TonemapPass::io() const {
  return {{"frame", "hdr", "shadow-info", "local-shadow", "local-shadow-debug", "contact-mask"},
          {"ldr"}};
}

void TonemapPass::record(VkCommandBuffer cmd, FrameResources& r, const Mark& mark) {
  r.ldr.transition(cmd, VK_IMAGE_LAYOUT_GENERAL);
  dispatch_per_pixel(cmd, r, *layout_, *pipeline_, set_);
  mark("tonemap");
}

}  // namespace penumbra::render::passes
