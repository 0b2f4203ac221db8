// The shadow resolves (compute). The sun's: per pixel, cascade selection and blending, distance
// fade, the world-unit biases and the configured filter (shaders/render/shadow_resolve.comp),
// into the shadow-info image the forward and tonemap passes read. The local lights': the same
// biases and filters for every shadowed spot and point light (shaders/render/
// local_shadow_resolve.comp), into the local-shadow image (one channel per light).

#include "passes.hpp"

namespace penumbra::render::passes {

namespace {

constexpr VkShaderStageFlags kCompute = VK_SHADER_STAGE_COMPUTE_BIT;

// Frame, cascades, depth, normals, the cascades' compare and raw views, the output; with
// filter = evsm2 the moments at 7.
std::vector<gpu::BindingDesc> sun_resolve_bindings(const FrameResources& r) {
  std::vector<gpu::BindingDesc> b{{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, kCompute},
                                  {1, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, kCompute},
                                  {2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute},
                                  {3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute},
                                  {4, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute},
                                  {5, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute},
                                  {6, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, kCompute}};
  if (r.req.sun_moments) b.push_back({7, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute});
  return b;
}

// The sun resolve's program: with the moments it is a variant of its own.
std::string sun_resolve_name(const FrameResources& r) {
  return r.req.sun_moments ? variant("shadow-resolve", {{"PENUMBRA_SUN_MOMENTS", "1"}})
                           : std::string("shadow-resolve");
}
std::vector<shader::Define> sun_resolve_defines(const FrameResources& r) {
  if (!r.req.sun_moments) return {};
  return {{"PENUMBRA_SUN_MOMENTS", "1"}};
}

// Frame, depth, normals and the two outputs, then per light type present its block, its compare
// view and its raw view (spots at 3-5, points at 6-8); the point cubes' moments at 11, the spot
// maps' at 12.
std::vector<gpu::BindingDesc> local_resolve_bindings(const FrameResources& r) {
  std::vector<gpu::BindingDesc> b{{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, kCompute},
                                  {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute},
                                  {2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute},
                                  {9, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, kCompute},
                                  {10, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, kCompute}};
  for (uint32_t first : {3u, 6u}) {
    if ((first == 3u ? r.req.spot_shadow_maps : r.req.point_shadow_cubes) == 0) continue;
    b.push_back({first, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, kCompute});
    b.push_back({first + 1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute});
    b.push_back({first + 2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute});
  }
  if (r.req.point_moments)
    b.push_back({11, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute});
  if (r.req.spot_moments) b.push_back({12, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, kCompute});
  return b;
}

std::vector<shader::Define> local_defines(const FrameResources& r) {
  const auto all = light_defines(r);
  std::vector<shader::Define> d{all[2], all[3]};
  if (r.req.point_moments) d.push_back({"PENUMBRA_POINT_MOMENTS", "1"});
  if (r.req.spot_moments) d.push_back({"PENUMBRA_SPOT_MOMENTS", "1"});
  return d;
}

// The sun resolve's specialization (shadow_resolve.comp): the frame's filter, whether the
// penumbra view needs the PCSS estimate, how the cascade is chosen and whether the redrawn view
// is on. Specialized, the driver compiles one filter, not all five: on llvmpipe the default
// scene's resolve went from ~1.1 s of LLVM per new version to ~0.3 s, and its frame time from
// 77 to 18 ms at 640x360; without the selection by containment and the redrawn view that the
// default scene does not use, a new version compiles in about 70 ms less (docs/hot-reload.md).
// kSelection's values, as shadow_resolve.comp names them.
constexpr uint32_t kByDepth = 0, kByContainment = 1, kClipmap = 2;
uint32_t sun_selection(const FrameResources& r) {
  const auto& sh = r.scene.shadows;
  return sh.layout == scene::ShadowLayout::clipmap              ? kClipmap
         : sh.selection == scene::CascadeSelection::containment ? kByContainment
                                                                : kByDepth;
}
bool view_is(const FrameResources& r, scene::DebugView v) {
  return r.scene.render.view == v;
}
SpecValues sun_resolve_specialization(const FrameResources& r) {
  return {{0, "kSunFilter", sun_filter_index(r.scene, r.req.sun_moments)},
          {1, "kPenumbraView", view_is(r, scene::DebugView::penumbra) ? 1u : 0u},
          {2, "kSelection", sun_selection(r)},
          {3, "kRedrawnView", view_is(r, scene::DebugView::redrawn) ? 1u : 0u}};
}

// The filters the sun resolve compiles: the frame's filter, and with PCF the Poisson disk that
// constant width (shadows.constant_filter_width) turns it into, only while that is on. Its
// sun_filters() allows the disk with PCF either way; compiling it when the frame cannot reach
// it cost llvmpipe about 180 ms of every new version of a PCF resolve (LLVM: 324-328 ms with
// the disk, 132-149 without; docs/hot-reload.md).
uint32_t sun_filter_set(const FrameResources& r) {
  const uint32_t f = sun_filter_index(r.scene, r.req.sun_moments);
  const uint32_t pcf = scene::filter_index(scene::Filter::pcf);
  const bool disk = f == pcf && r.scene.shadows.constant_filter_width;
  return disk ? (1u << pcf) | (1u << scene::filter_index(scene::Filter::poisson)) : 1u << f;
}

// The filters the scene's spot lights and point lights may use (a bit per filter, over every
// light of the scene: a superset of those shadowed this frame).
std::pair<uint32_t, uint32_t> local_filter_sets(const FrameResources& r) {
  uint32_t spots = 0, points = 0;
  for (const auto& s : r.scene.spots)
    spots |= 1u << local_filter_index(r.scene, s.filter, scene::LightKind::spot, r.req.spot_moments,
                                    r.req.sun_moments);
  for (const auto& p : r.scene.points)
    points |= 1u << local_filter_index(r.scene, p.filter, scene::LightKind::point, r.req.point_moments,
                                     r.req.sun_moments);
  return {spots, points};
}

// The resolves' programs hold only those filters' code (shadow_filter.glsl's
// PENUMBRA_FILTERS_2D and _CUBE): a variant per set, compiled when a frame first needs it
// (PerPixelCompute). Unspecialized, every filter (the choice read from the frame).
// On llvmpipe the sun resolve's pipeline creation for the default scene (hard) went from about
// 65 to 20 ms and the local resolve's for indoor from about 115 to 50 (docs/hot-reload.md).
// The sun resolve's variant also leaves out the code of the debug views and of the selection by
// containment when the frame does not use them (PENUMBRA_PENUMBRA_VIEW, PENUMBRA_REDRAWN_VIEW,
// PENUMBRA_SUN_CONTAINMENT), which its specialization constants already switch off: the default
// scene's SPIR-V 75 -> 49 KB, and an edit of pcss.glsl there (the penumbra view's estimate)
// changes no SPIR-V.
std::vector<shader::Define> sun_resolve_variant(const FrameResources& r) {
  if (!r.specialize) return {};
  auto flag = [](bool on) { return std::string(on ? "1" : "0"); };
  return {{"PENUMBRA_FILTERS_2D", std::to_string(sun_filter_set(r))},
          {"PENUMBRA_PENUMBRA_VIEW", flag(view_is(r, scene::DebugView::penumbra))},
          {"PENUMBRA_SUN_CONTAINMENT", flag(sun_selection(r) != kByDepth)},
          {"PENUMBRA_REDRAWN_VIEW", flag(view_is(r, scene::DebugView::redrawn))}};
}
std::vector<shader::Define> local_resolve_variant(const FrameResources& r) {
  if (!r.specialize) return {};
  const auto [spots, points] = local_filter_sets(r);
  return {{"PENUMBRA_FILTERS_2D", std::to_string(spots)},
          {"PENUMBRA_FILTERS_CUBE", std::to_string(points)},
          {"PENUMBRA_PENUMBRA_VIEW", view_is(r, scene::DebugView::penumbra) ? "1" : "0"}};
}

// The local resolve's specialization (local_shadow_resolve.comp): the filters the scene's spot
// lights and point lights may use, and whether the penumbra view is on. The driver compiles only
// those filters (indoor: hard and pcf of five).
SpecValues local_resolve_specialization(const FrameResources& r) {
  const auto [spots, points] = local_filter_sets(r);
  return {{0, "kSpotFilters", spots},
          {1, "kPointFilters", points},
          {2, "kPenumbraView", view_is(r, scene::DebugView::penumbra) ? 1u : 0u}};
}

}  // namespace

ShadowResolvePass::ShadowResolvePass(FrameResources& r, ShadowMapPass& maps)
    : compute_(r, sun_resolve_name(r), {"render/shadow_resolve.comp", sun_resolve_defines(r)},
               sun_resolve_bindings(r), sun_resolve_specialization, sun_resolve_variant),
      maps_(maps) {
  r.info = r.make_image("shadow-info", gpu::ImageKind::image_2d, kInfoFormat, r.width, r.height, 1,
                        VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
  gpu::DescriptorWriter()
      .buffer(0, r.frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
      .buffer(1, maps.sun_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
      .combined_image(2, r.depth.view(), r.nearest.handle())
      .combined_image(3, r.normal.view(), r.nearest.handle())
      .combined_image(4, maps.sun_map.view(), maps.sun_compare)
      .combined_image(5, maps.sun_map.view(), maps.sun_raw)
      .storage_image(6, r.info.view())
      .update(r.ctx, compute_.set());
  if (r.req.sun_moments) {
    gpu::DescriptorWriter()
        .combined_image(7, r.sun_moments.view(), r.linear_clamp.handle())
        .update(r.ctx, compute_.set());
  }
  moments_ = r.req.sun_moments;
  r.report.passes.push_back("shadow-resolve: compute");
}

std::vector<Step> ShadowResolvePass::steps(FrameResources& r) {
  Step step{"shadow-resolve",
            {{"depth", &r.depth, Use::sampled},
             {"normal", &r.normal, Use::sampled},
             {"sun-shadow-map", &maps_.sun_map, Use::sampled},
             {"shadow-info", &r.info, Use::storage_write}},
            [this, &r](VkCommandBuffer cmd) { compute_.dispatch(cmd, r); },
            "shadow-resolve"};
  if (moments_) step.images.push_back({"sun-moments", &r.sun_moments, Use::sampled});
  return {step};
}

LocalShadowResolvePass::LocalShadowResolvePass(FrameResources& r, ShadowMapPass& maps)
    : compute_(r, variant("local-shadow-resolve", local_defines(r)),
               {"render/local_shadow_resolve.comp", local_defines(r)}, local_resolve_bindings(r),
               local_resolve_specialization, local_resolve_variant),
      maps_(maps) {
  r.local_info = r.make_image("local-shadow", gpu::ImageKind::image_2d, kInfoFormat, r.width,
                              r.height, 1, VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
  r.local_debug =
      r.make_image("local-shadow-debug", gpu::ImageKind::image_2d, kInfoFormat, r.width, r.height,
                   1, VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
  const auto& req = r.req;
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
  if (r.req.point_moments) w.combined_image(11, r.point_moments.view(), r.linear_clamp.handle());
  if (r.req.spot_moments) w.combined_image(12, r.spot_moments.view(), r.linear_clamp.handle());
  w.update(r.ctx, compute_.set());
  point_moments_ = r.req.point_moments;
  spot_moments_ = r.req.spot_moments;
  r.report.passes.push_back("local-shadow-resolve: compute");
}

std::vector<Step> LocalShadowResolvePass::steps(FrameResources& r) {
  Step step{"local-shadow-resolve",
            {{"depth", &r.depth, Use::sampled},
             {"normal", &r.normal, Use::sampled},
             {"local-shadow", &r.local_info, Use::storage_write},
             {"local-shadow-debug", &r.local_debug, Use::storage_write}},
            [this, &r](VkCommandBuffer cmd) { compute_.dispatch(cmd, r); },
            "local-shadow-resolve"};
  if (r.req.spot_shadow_maps)
    step.images.push_back({"spot-shadow-maps", &maps_.spot_maps, Use::sampled});
  if (r.req.point_shadow_cubes)
    step.images.push_back({"point-shadow-cubes", &maps_.point_cubes, Use::sampled});
  if (point_moments_) step.images.push_back({"point-moments", &r.point_moments, Use::sampled});
  if (spot_moments_) step.images.push_back({"spot-moments", &r.spot_moments, Use::sampled});
  return {step};
}

}  // namespace penumbra::render::passes
