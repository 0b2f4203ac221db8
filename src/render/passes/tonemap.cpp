// Tonemapping (compute): exposure and the tone curve of the HDR image, or one of the debug views
// (shadow factor, cascades, contact mask, texel density, penumbra), into the output image.

#include "passes.hpp"

namespace penumbra::render::passes {

namespace {

// Frame, HDR and output, then what the scene built: the sun's shadow info, the contact mask, the
// local lights' visibility and debug data.
std::vector<gpu::BindingDesc> tonemap_bindings(const FrameResources& r) {
  const VkShaderStageFlags cs = VK_SHADER_STAGE_COMPUTE_BIT;
  std::vector<gpu::BindingDesc> b{{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, cs},
                                  {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs},
                                  {4, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, cs}};
  if (r.req.sun_shadows) b.push_back({2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs});
  if (r.contact_mask) b.push_back({3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs});
  if (r.req.spot_shadow_maps > 0 || r.req.point_shadow_cubes > 0) {
    b.push_back({5, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs});
    b.push_back({6, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs});
  }
  return b;
}

}  // namespace

TonemapPass::TonemapPass(FrameResources& r)
    : compute_(r, variant("tonemap", light_defines(r)), {"render/tonemap.comp", light_defines(r)},
               tonemap_bindings(r)) {
  const bool local = r.req.spot_shadow_maps > 0 || r.req.point_shadow_cubes > 0;
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
  w.update(r.ctx, compute_.set());
  r.report.passes.push_back("tonemap: compute");
}

std::vector<Step> TonemapPass::steps(FrameResources& r) {
  Step step{"tonemap",
            {{"hdr", &r.hdr, Use::sampled}, {"ldr", &r.ldr, Use::storage_write}},
            [this, &r](VkCommandBuffer cmd) { compute_.dispatch(cmd, r); },
            "tonemap"};
  if (r.req.sun_shadows) step.images.push_back({"shadow-info", &r.info, Use::sampled});
  if (r.contact_mask) step.images.push_back({"contact-mask", r.contact_mask, Use::sampled});
  if (r.req.spot_shadow_maps > 0 || r.req.point_shadow_cubes > 0) {
    step.images.push_back({"local-shadow", &r.local_info, Use::sampled});
    step.images.push_back({"local-shadow-debug", &r.local_debug, Use::sampled});
  }
  return {step};
}

}  // namespace penumbra::render::passes
