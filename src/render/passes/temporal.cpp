// The shadow-temporal pass (shaders/render/shadow_temporal.comp): every light's visibility
// accumulated over frames, reprojected through the depth buffer and clamped to the frame's
// neighbourhood. The renderer fills the temporal block each frame (the last frame's camera and
// whether the history is usable).

#include "passes.hpp"

namespace penumbra::render::passes {

namespace {

constexpr VkShaderStageFlags kCompute = VK_SHADER_STAGE_COMPUTE_BIT;
constexpr VkFormat kTemporalAuxFormat = VK_FORMAT_R32G32B32A32_SFLOAT;

bool has_local(const FrameResources& r) {
  return r.req.spot_shadow_maps > 0 || r.req.point_shadow_cubes > 0;
}

std::vector<shader::Define> temporal_defines(const FrameResources& r) {
  return {{"PENUMBRA_SUN_SHADOWS", r.req.sun_shadows ? "1" : "0"},
          {"PENUMBRA_LOCAL_SHADOWS", has_local(r) ? "1" : "0"}};
}

std::vector<gpu::BindingDesc> temporal_bindings(const FrameResources& r) {
  std::vector<gpu::BindingDesc> b{{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, kCompute},
                                  {1, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, kCompute},
                                  {2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute},
                                  {3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute},
                                  {6, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute},
                                  {7, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute},
                                  {8, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, kCompute},
                                  {9, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, kCompute}};
  if (r.req.sun_shadows) b.push_back({4, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute});
  if (has_local(r)) b.push_back({5, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute});
  return b;
}

void copy_image(VkCommandBuffer cmd, gpu::Image& from, gpu::Image& to, uint32_t w, uint32_t h) {
  VkImageCopy region{};
  region.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.extent = {w, h, 1};
  vkCmdCopyImage(cmd, from.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, to.handle(),
                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
}

}  // namespace

TemporalShadowPass::TemporalShadowPass(FrameResources& r)
    : compute_(r, variant("shadow-temporal", temporal_defines(r)),
               {"render/shadow_temporal.comp", temporal_defines(r)}, temporal_bindings(r)) {
  const VkImageUsageFlags out_usage =
      VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  const VkImageUsageFlags history_usage =
      VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  r.temporal_local = r.make_image("temporal-local", gpu::ImageKind::image_2d, kInfoFormat, r.width,
                                  r.height, 1, out_usage);
  r.temporal_aux = r.make_image("temporal-aux", gpu::ImageKind::image_2d, kTemporalAuxFormat,
                                r.width, r.height, 1, out_usage);
  r.history_local = r.make_image("history-local", gpu::ImageKind::image_2d, kInfoFormat, r.width,
                                 r.height, 1, history_usage);
  r.history_aux = r.make_image("history-aux", gpu::ImageKind::image_2d, kTemporalAuxFormat, r.width,
                               r.height, 1, history_usage);
  r.temporal_ubo = gpu::Buffer(r.ctx, sizeof(TemporalGpu), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
  gpu::DescriptorWriter w;
  w.buffer(0, r.frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
      .buffer(1, r.temporal_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
      .combined_image(2, r.depth.view(), r.nearest.handle())
      .combined_image(3, r.normal.view(), r.nearest.handle())
      .combined_image(6, r.history_local.view(), r.nearest.handle())
      .combined_image(7, r.history_aux.view(), r.nearest.handle())
      .storage_image(8, r.temporal_local.view())
      .storage_image(9, r.temporal_aux.view());
  if (r.req.sun_shadows) w.combined_image(4, r.info.view(), r.nearest.handle());
  if (has_local(r)) w.combined_image(5, r.local_info.view(), r.nearest.handle());
  w.update(r.ctx, compute_.set());
  r.report.passes.push_back("shadow-temporal: compute");
}

std::vector<Step> TemporalShadowPass::steps(FrameResources& r) {
  Step blend{"shadow-temporal",
             {{"depth", &r.depth, Use::sampled},
              {"normal", &r.normal, Use::sampled},
              {"history-local", &r.history_local, Use::sampled, true},
              {"history-aux", &r.history_aux, Use::sampled, true},
              {"temporal-local", &r.temporal_local, Use::storage_write},
              {"temporal-aux", &r.temporal_aux, Use::storage_write}},
             [this, &r](VkCommandBuffer cmd) { compute_.dispatch(cmd, r); },
             {}};
  if (r.req.sun_shadows) blend.images.push_back({"shadow-info", &r.info, Use::sampled});
  if (has_local(r)) blend.images.push_back({"local-shadow", &r.local_info, Use::sampled});
  // This frame's accumulation becomes the next frame's history.
  Step keep{"shadow-temporal-history",
            {{"temporal-local", &r.temporal_local, Use::copy_source},
             {"temporal-aux", &r.temporal_aux, Use::copy_source},
             {"history-local", &r.history_local, Use::copy_target},
             {"history-aux", &r.history_aux, Use::copy_target}},
            [&r](VkCommandBuffer cmd) {
              copy_image(cmd, r.temporal_local, r.history_local, r.width, r.height);
              copy_image(cmd, r.temporal_aux, r.history_aux, r.width, r.height);
            },
            "shadow-temporal"};
  return {blend, keep};
}

}  // namespace penumbra::render::passes
