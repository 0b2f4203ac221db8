// The prepass: depth and view-space normals of every draw (the receivers of every later pass).

#include "passes.hpp"

namespace penumbra::render::passes {

PrepassPass::PrepassPass(FrameResources& r) {
  const VkShaderStageFlags all = VK_SHADER_STAGE_ALL;
  // Geometry: prepass + forward share the vertex stage and the frame block.
  layout_ = std::make_unique<gpu::PipelineLayout>(
      r.ctx, draw_sets(r, {{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, all}}),
      uint32_t(sizeof(DrawPush)), all);
  for (bool masked : {false, true}) {
    if (masked && !r.req.masked_materials) continue;
    // The opaque pipeline has no alpha test (its draws have no mask): no discard.
    auto fragment = mask_defines(r);
    if (!masked) fragment.push_back({"PENUMBRA_ALPHA_TEST", "0"});
    r.add_pipeline(std::string("prepass-") + (masked ? "masked" : "opaque"),
                   {{"render/geometry.vert", {}}, {"render/prepass.frag", fragment}},
                   masked ? masked_ : opaque_, [&r, masked, this](const shader::Spirvs& spirv) {
                     gpu::GraphicsPipelineDesc d;
                     d.vertex_spirv = spirv[0];
                     d.fragment_spirv = spirv[1];
                     d.vertex_input = vertex_input();
                     d.color_formats = {kNormalFormat};
                     d.depth_format = kDepthFormat;
                     d.depth_compare = r.depth_test(true);
                     d.cull = masked ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT;
                     return std::make_unique<gpu::GraphicsPipeline>(r.ctx, d, *layout_);
                   });
  }
  set_ = r.pool.allocate(layout_->set_layout(0));
  gpu::DescriptorWriter()
      .buffer(0, r.frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
      .update(r.ctx, set_);
  r.report.passes.push_back("prepass: depth + normals");
}

std::vector<Step> PrepassPass::steps(FrameResources& r) {
  Step step{"prepass",
            {{"depth", &r.depth, Use::depth_target}, {"normal", &r.normal, Use::color_target}},
            {},
            "prepass"};
  step.record = [this, &r](VkCommandBuffer cmd) {
    begin_rendering(cmd, r, r.width, r.height, r.normal.view(), {{0, 0, 0, 0}}, r.depth.view(),
                    VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, true);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout_->handle(), 0, 1, &set_, 0,
                            nullptr);
    draw_meshes(cmd, r, *layout_, opaque_->handle(), masked_ ? masked_->handle() : VK_NULL_HANDLE,
                false, glm::uvec4(0));
    vkCmdEndRendering(cmd);
  };
  return {step};
}

}  // namespace penumbra::render::passes
