// Analytic sphere shadows (compute): the spheres with analytic_shadow are left out of the shadow
// maps, and this pass multiplies every shadowed light's visibility by what they leave of the
// light, in closed form (shaders/render/sphere_shadows.comp over penumbra/sphere_shadow.glsl).
// It runs after the resolves and before the passes that read their images.

#include "passes.hpp"

namespace penumbra::render::passes {

namespace {

constexpr VkShaderStageFlags kCompute = VK_SHADER_STAGE_COMPUTE_BIT;

bool local_shadows(const FrameResources& r) {
  return r.req.spot_shadow_maps > 0 || r.req.point_shadow_cubes > 0;
}

std::vector<shader::Define> sphere_defines(const FrameResources& r) {
  return {{"PENUMBRA_SUN_SHADOWS", r.req.sun_shadows ? "1" : "0"},
          {"PENUMBRA_LOCAL_SHADOWS", local_shadows(r) ? "1" : "0"},
          {"PENUMBRA_ANALYTIC_SPHERES", std::to_string(r.req.analytic_spheres)}};
}

// Frame, depth, the spheres; the sun's block and shadow info at 3-4; the local shadows at 5.
std::vector<gpu::BindingDesc> sphere_bindings(const FrameResources& r) {
  std::vector<gpu::BindingDesc> b{{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, kCompute},
                                  {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute},
                                  {2, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, kCompute}};
  if (r.req.sun_shadows) {
    b.push_back({3, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, kCompute});
    b.push_back({4, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, kCompute});
  }
  if (local_shadows(r)) b.push_back({5, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, kCompute});
  return b;
}

}  // namespace

SphereShadowPass::SphereShadowPass(FrameResources& r, const ShadowMapPass& maps)
    : compute_(r, variant("sphere-shadows", sphere_defines(r)),
               {"render/sphere_shadows.comp", sphere_defines(r)}, sphere_bindings(r)),
      sun_(r.req.sun_shadows),
      local_(local_shadows(r)) {
  r.sphere_ubo = gpu::Buffer(r.ctx, sizeof(glm::vec4) * r.req.analytic_spheres,
                             VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
  gpu::DescriptorWriter w;
  w.buffer(0, r.frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
      .combined_image(1, r.depth.view(), r.nearest.handle())
      .buffer(2, r.sphere_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER);
  if (sun_) {
    w.buffer(3, maps.sun_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
        .storage_image(4, r.info.view());
  }
  if (local_) w.storage_image(5, r.local_info.view());
  w.update(r.ctx, compute_.set());
  r.report.passes.push_back("sphere-shadows: compute (" + std::to_string(r.req.analytic_spheres) +
                            " analytic spheres)");
}

std::vector<Step> SphereShadowPass::steps(FrameResources& r) {
  Step step{"sphere-shadows",
            {{"depth", &r.depth, Use::sampled}},
            [this, &r](VkCommandBuffer cmd) { compute_.dispatch(cmd, r); },
            "sphere-shadows"};
  if (sun_) step.images.push_back({"shadow-info", &r.info, Use::storage_modify});
  if (local_) step.images.push_back({"local-shadow", &r.local_info, Use::storage_modify});
  return {step};
}

}  // namespace penumbra::render::passes
