// The forward pass: every light with its shadows (the sun's from the shadow-info image, spots
// and points from the local-shadow image, the contact mask), into the HDR image; with
// visibility_output it also writes each light's visibility as the lighting used it (what the
// reference compares).

#include "passes.hpp"

namespace penumbra::render::passes {

ForwardPass::ForwardPass(FrameResources& r) {
  const VkShaderStageFlags all = VK_SHADER_STAGE_ALL;
  const auto& req = r.req;
  std::vector<gpu::BindingDesc> b{{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, all}};
  if (req.sun_shadows) b.push_back({1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, all});
  if (r.contact_mask) b.push_back({2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, all});
  const bool local = req.spot_shadow_maps > 0 || req.point_shadow_cubes > 0;
  if (local) b.push_back({3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, all});
  layout_ = std::make_unique<gpu::PipelineLayout>(r.ctx, draw_sets(r, b),
                                                  uint32_t(sizeof(DrawPush)), all);
  auto defines = light_defines(r);
  if (!r.mask_textures.empty())
    for (auto& d : mask_defines(r)) defines.push_back(d);
  if (r.visibility_output) defines.push_back({"PENUMBRA_VISIBILITY_OUTPUT", "1"});
  for (bool masked : {false, true}) {
    if (masked && !req.masked_materials) continue;
    // The opaque pipeline has no alpha test (its draws have no mask): no discard.
    auto fragment = defines;
    if (!masked) fragment.push_back({"PENUMBRA_ALPHA_TEST", "0"});
    r.add_pipeline(variant(std::string("forward-") + (masked ? "masked" : "opaque"), defines),
                   {{"render/geometry.vert", {}}, {"render/forward.frag", fragment}},
                   masked ? masked_ : opaque_, [&r, masked, this](const shader::Spirvs& spirv) {
                     gpu::GraphicsPipelineDesc d;
                     d.vertex_spirv = spirv[0];
                     d.fragment_spirv = spirv[1];
                     d.vertex_input = vertex_input();
                     d.color_formats = {kHdrFormat};
                     if (r.visibility_output)
                       d.color_formats.insert(d.color_formats.end(), 2, kVisibilityFormat);
                     d.depth_format = kDepthFormat;
                     d.depth_write = false;
                     // The prepass wrote the nearest surface; "not behind it" rather than EQUAL
                     // tolerates last-bit differences between two pipelines.
                     d.depth_compare = r.depth_test(false);
                     d.cull = masked ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT;
                     return std::make_unique<gpu::GraphicsPipeline>(r.ctx, d, *layout_);
                   });
  }
  set_ = r.pool.allocate(layout_->set_layout(0));
  gpu::DescriptorWriter w;
  w.buffer(0, r.frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER);
  // With shadows.temporal the accumulated visibility (temporal-aux .r for the sun).
  const bool temporal = temporal_ = req.temporal;
  if (req.sun_shadows)
    w.combined_image(1, (temporal ? r.temporal_aux : r.info).view(), r.nearest.handle());
  if (r.contact_mask) w.combined_image(2, r.contact_mask->view(), r.nearest.handle());
  if (local)
    w.combined_image(3, (temporal ? r.temporal_local : r.local_info).view(), r.nearest.handle());
  w.update(r.ctx, set_);
  r.report.passes.push_back("forward: lighting");
}

std::vector<Step> ForwardPass::steps(FrameResources& r) {
  const auto& req = r.req;
  Step step{"forward",
            {{"depth", &r.depth, Use::depth_test}, {"hdr", &r.hdr, Use::color_target}},
            {},
            "forward"};
  if (req.sun_shadows)
    step.images.push_back(temporal_ ? ImageUse{"temporal-aux", &r.temporal_aux, Use::sampled}
                                    : ImageUse{"shadow-info", &r.info, Use::sampled});
  if (r.contact_mask) step.images.push_back({"contact-mask", r.contact_mask, Use::sampled});
  if (req.spot_shadow_maps > 0 || req.point_shadow_cubes > 0)
    step.images.push_back(temporal_ ? ImageUse{"temporal-local", &r.temporal_local, Use::sampled}
                                    : ImageUse{"local-shadow", &r.local_info, Use::sampled});
  if (r.visibility_output)
    for (int i = 0; i < 2; ++i)
      step.images.push_back(
          {"visibility" + std::to_string(i), &r.visibility[i], Use::color_target});
  step.record = [this, &r](VkCommandBuffer cmd) {
    std::vector<VkImageView> visibility_views;
    if (r.visibility_output)
      for (auto& v : r.visibility) visibility_views.push_back(v.view());
    const glm::vec3 sky =
        r.scene.sun ? glm::vec3(0.45f, 0.6f, 0.85f) : glm::vec3(0.01f, 0.01f, 0.02f);
    begin_rendering(cmd, r, r.width, r.height, r.hdr.view(), {{sky.r, sky.g, sky.b, 1.0f}},
                    r.depth.view(), VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, false,
                    visibility_views);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout_->handle(), 0, 1, &set_, 0,
                            nullptr);
    draw_meshes(cmd, r, *layout_, opaque_->handle(), masked_ ? masked_->handle() : VK_NULL_HANDLE,
                false, glm::uvec4(0));
    vkCmdEndRendering(cmd);
  };
  return {step};
}

}  // namespace penumbra::render::passes
