// EVSM2 moments: after the maps are drawn, each layer's depths are warped into moments and
// box-blurred along x, then along y (shaders/render/evsm_moments.comp). The sun's cascades
// (shadows.filter = evsm2) go into sun-moments, which the shadow resolve samples bilinearly; the
// point lights' cubes (a point light's own filter = evsm2), face by face, into point-moments, a
// cube array the local resolve samples across faces; the spot lights' maps (a spot's own filter
// = evsm2), made linear first, into spot-moments. Built only for what the scene asks.

#include <penumbra/core/error.hpp>

#include "passes.hpp"

namespace penumbra::render::passes {

namespace {

constexpr VkShaderStageFlags kCompute = VK_SHADER_STAGE_COMPUTE_BIT;

struct EvsmPush {
  glm::uvec4 params;  // x blur radius, y resolution
  glm::ivec4 windows[4];  // the sun's layers' offsets on their grid, two a vec4
};

}  // namespace

EvsmPass::EvsmPass(FrameResources& r, ShadowMapPass& maps, MomentSource source) : source_(source) {
  const bool fp16 = r.scene.shadows.evsm_fp16;
  const bool sun = source == MomentSource::sun;
  const bool spots = source == MomentSource::spots;
  const char* const names[] = {"sun", "point", "spot"};
  const std::string kind = names[int(source)];
  if (!r.ctx.info().storage_image_extended_formats) {
    throw Error(std::string(sun ? "shadows.filter" : "a [[" + kind + "]] filter") +
                " = 'evsm2' needs shaderStorageImageExtendedFormats (rg16f / rg32f storage "
                "images), which " +
                r.ctx.info().name + " does not have");
  }
  maps_ = &maps;
  gpu::Image& depths = sun ? maps.sun_map : spots ? maps.spot_maps : maps.point_cubes;
  depths_ = &depths;
  resolution_ = depths.desc().width;
  layers_ = depths.desc().layers;
  const VkFormat format = fp16 ? VK_FORMAT_R16G16_SFLOAT : VK_FORMAT_R32G32_SFLOAT;
  const VkImageUsageFlags usage = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
  const std::string name = kind + "-moments";
  const std::string sized_by =
      (sun ? std::string("shadows.resolution") : "[[" + kind + "]] resolution") + " = " +
      std::to_string(resolution_) + " with the evsm2 filter";
  moments_x_ = r.make_image(name + "-x", gpu::ImageKind::image_2d_array, format, resolution_,
                            resolution_, layers_, usage, 1, sized_by);
  gpu::Image& out = sun ? r.sun_moments : spots ? r.spot_moments : r.point_moments;
  out_ = &out;
  const bool cubes = source == MomentSource::points;
  // shadows.evsm_mips: the sun's moments get a full chain, blitted down from level 0.
  mips_ = sun && r.scene.shadows.evsm_mips;
  if (mips_ && !gpu::mips_supported(r.ctx, format)) {
    throw Error(std::string("shadows.evsm_mips = true needs linear blits of ") +
                (fp16 ? "rg16f" : "rg32f") + " images, which " + r.ctx.info().name +
                " does not have");
  }
  out = r.make_image(name, cubes ? gpu::ImageKind::cube_array : gpu::ImageKind::image_2d_array,
                     format, resolution_, resolution_, layers_, usage,
                     mips_ ? gpu::full_mip_count(resolution_, resolution_) : 1u, sized_by);
  if (r.linear_clamp.handle() == VK_NULL_HANDLE) {  // shared by the sun's and the points' passes
    gpu::SamplerDesc linear;
    linear.filter = VK_FILTER_LINEAR;
    linear.mip = VK_SAMPLER_MIPMAP_MODE_LINEAR;  // trilinear where the moments have mips
    r.linear_clamp = gpu::Sampler(r.ctx, linear);
  }
  // The spots' first pass also reads their planes (SpotBlock at 3); both passes share the layout.
  std::vector<gpu::BindingDesc> bindings{
      {0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, kCompute},
      {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute},
      {2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, kCompute}};
  if (spots) bindings.push_back({3, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, kCompute});
  layout_ = std::make_unique<gpu::PipelineLayout>(
      r.ctx, std::vector<std::vector<gpu::BindingDesc>>{bindings}, uint32_t(sizeof(EvsmPush)),
      kCompute);
  for (int p = 0; p < 2; ++p) {
    std::vector<shader::Define> defines{{"PENUMBRA_EVSM_PASS", std::to_string(p)},
                                        {"PENUMBRA_EVSM_FORMAT", fp16 ? "rg16f" : "rg32f"}};
    if (spots) defines.push_back({"PENUMBRA_EVSM_SPOTS", "1"});
    r.add_pipeline(
        variant(std::string(sun ? "" : kind + "-") + (p == 0 ? "evsm-moments-x" : "evsm-moments-y"),
                defines),
        {{"render/evsm_moments.comp", defines}}, pass_[p], [this, &r](const shader::Spirvs& spirv) {
          return std::make_unique<gpu::ComputePipeline>(r.ctx, spirv[0], *layout_);
        });
    set_[p] = r.pool.allocate(layout_->set_layout(0));
  }
  // The cubes are read and written as plain 2D arrays, face by face.
  gpu::DescriptorWriter first;
  first.buffer(0, r.frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
      .combined_image(1, cubes ? depths.array_view() : depths.view(), r.raw_depth.handle())
      .storage_image(2, moments_x_.view());
  if (spots) first.buffer(3, maps.spot_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER);
  first.update(r.ctx, set_[0]);
  gpu::DescriptorWriter()
      .buffer(0, r.frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
      .combined_image(1, moments_x_.view(), r.nearest.handle())
      .storage_image(2, out.array_view())  // level 0 (the default view holds every mip)
      .update(r.ctx, set_[1]);
  r.report.passes.push_back(std::string(sun ? "evsm" : "evsm-" + kind) + ": moments " +
                            (fp16 ? "rg16f" : "rg32f") + ", " + std::to_string(layers_) +
                            " layer(s), separable box blur" + (mips_ ? ", mips" : ""));
}

EvsmPass::~EvsmPass() = default;

std::vector<Step> EvsmPass::steps(FrameResources& r) {
  static const char* const names[] = {"evsm", "evsm-point", "evsm-spot"};
  static const char* const maps[] = {"sun-shadow-map", "point-shadow-cubes", "spot-shadow-maps"};
  static const char* const moments[] = {"sun-moments", "point-moments", "spot-moments"};
  const std::string name = names[int(source_)];
  gpu::Image* out = out_;
  const std::string x_name = std::string(moments[int(source_)]) + "-x";
  // x: the depths warped into moments and blurred along x; y: blurred along y (and the mips).
  auto dispatch = [this, &r](VkCommandBuffer cmd, int p) {
    EvsmPush push{
        glm::uvec4(uint32_t(std::clamp(r.scene.shadows.evsm_blur, 0, 8)), resolution_, 0u, 0u),
        {}};
    if (source_ == MomentSource::sun)
      for (uint32_t l = 0; l < layers_ && l < 8; ++l) {
        const glm::ivec2 w = maps_->sun_offset(l);
        push.windows[l / 2][int(l % 2) * 2] = w.x;
        push.windows[l / 2][int(l % 2) * 2 + 1] = w.y;
      }
    const uint32_t groups = (resolution_ + 7) / 8;
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pass_[p]->handle());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_->handle(), 0, 1, &set_[p],
                            0, nullptr);
    vkCmdPushConstants(cmd, layout_->handle(), kCompute, 0, sizeof(EvsmPush), &push);
    vkCmdDispatch(cmd, groups, groups, layers_);
  };
  Step x{name + "-x",
         {{maps[int(source_)], depths_, Use::sampled}, {x_name, &moments_x_, Use::storage_write}},
         [dispatch](VkCommandBuffer cmd) { dispatch(cmd, 0); },
         {}};
  Step y{name + "-y",
         {{x_name, &moments_x_, Use::sampled}, {moments[int(source_)], out, Use::storage_write}},
         [this, dispatch, out](VkCommandBuffer cmd) {
           dispatch(cmd, 1);
           if (mips_) out->generate_mips(cmd);  // leaves every level SHADER_READ_ONLY
         },
         name};
  return {x, y};
}

}  // namespace penumbra::render::passes
