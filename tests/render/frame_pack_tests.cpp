// pack_frame without a GPU: what a scene's keys become in the frame block, the draws and the
// shadow structs (include/penumbra/render/frame_pack.hpp).

#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <penumbra/render/frame_pack.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <string>

namespace penumbra::render {
namespace {

const std::string kScene = R"(
[camera]
position = [0, 2, 6]
target = [0, 0, 0]
[sun]
direction = [0.3, -1, 0.2]
intensity = 2.5
[[spot]]
position = [0, 3, 0]
direction = [0, -1, 0]
outer_angle = 40
inner_angle = 30
[[spot]]
position = [1, 3, 0]
direction = [0, -1, 0]
shadows = false
[[point]]
position = [0, 2, 1]
range = 7
[[material]]
name = "grid"
mask = "checker"
[[object]]
mesh = "plane"
size = [20, 20]
[[object]]
mesh = "box"
position = [0, 0.5, 0]
material = "grid"
casts_shadows = false
)";

scene::Scene parse(const std::string& text) {
  return scene::parse_scene(text, "pack.toml", ".");
}

FrameCaps caps_of(const scene::Scene& s) {
  const auto r = s.requirements();
  FrameCaps c;
  c.sun_shadows = r.sun_shadows;
  c.spot_shadow_maps = r.spot_shadow_maps;
  c.point_shadow_cubes = r.point_shadow_cubes;
  c.contact_pass = true;
  return c;
}

TEST(PackFrame, TheCameraIsTheOriginAndModelsAreRelativeToIt) {
  scene::Scene s = parse(kScene);
  const PackedFrame f = pack_frame(s, 640, 360, caps_of(s), 7);
  EXPECT_EQ(f.origin, glm::dvec3(0, 2, 6));
  EXPECT_EQ(f.frame.camera_position, glm::vec4(0, 0, 0, 1));
  ASSERT_EQ(f.draws.size(), 2u);
  // The box at (0, 0.5, 0) is at (0, -1.5, -6) from the camera.
  EXPECT_EQ(glm::vec3(f.draws[1].push.model[3]), glm::vec3(0.0f, -1.5f, -6.0f));
  EXPECT_TRUE(f.draws[1].masked);
  EXPECT_FALSE(f.draws[1].casts);
  EXPECT_EQ(f.draws[1].push.albedo.w, 0.0f);
  EXPECT_EQ(f.draws[1].push.mask.x, float(int(scene::MaskPattern::checker)));
  EXPECT_EQ(f.frame.viewport, glm::vec4(640, 360, 1.0f / 640, 1.0f / 360));
  EXPECT_EQ(f.frame.mode.x, 7u);
}

TEST(PackFrame, FarFromTheOriginTheRelativeMatricesKeepTheirPrecision) {
  // The same scene 1e5 m away: the camera-relative model matrix is unchanged (to float
  // precision of the offset, which is exact here), not rounded at 1e5.
  scene::Scene s = parse(kScene);
  scene::Scene far = s;
  const glm::vec3 shift(1e5f, 0.0f, -1e5f);
  far.camera.position += shift;
  far.camera.target += shift;
  for (auto& i : far.instances) i.transform = glm::translate(glm::mat4(1.0f), shift) * i.transform;
  const PackedFrame a = pack_frame(s, 640, 360, caps_of(s), 0);
  const PackedFrame b = pack_frame(far, 640, 360, caps_of(far), 0);
  EXPECT_EQ(a.draws[1].push.model, b.draws[1].push.model);
  EXPECT_EQ(a.frame.view, b.frame.view);
}

TEST(PackFrame, ReverseZMapsNearToOneAndFarToZero) {
  for (bool reverse : {true, false}) {
    scene::Scene s = parse(kScene);
    s.shadows.reverse_z = reverse;
    const PackedFrame f = pack_frame(s, 640, 360, caps_of(s), 0);
    const auto depth_at = [&](float d) {
      const glm::vec4 clip = f.frame.proj * glm::vec4(0.0f, 0.0f, -d, 1.0f);
      return clip.z / clip.w;
    };
    EXPECT_NEAR(depth_at(s.camera.near), reverse ? 1.0f : 0.0f, 1e-6f);
    EXPECT_NEAR(depth_at(s.camera.far), reverse ? 0.0f : 1.0f, 1e-6f);
    EXPECT_EQ(f.frame.mode.y, reverse ? 1u : 0u);
  }
}

TEST(PackFrame, ShadowKeysReachTheFrameBlock) {
  scene::Scene s = parse(kScene);
  scene::set_param(s, "shadows.filter", "poisson");
  scene::set_param(s, "shadows.pcf_radius", "3");
  scene::set_param(s, "shadows.pcss_quality", "high");
  scene::set_param(s, "shadows.poisson_taps", "24");
  scene::set_param(s, "shadows.pcss_confidence", "0.25");
  scene::set_param(s, "shadows.normal_offset_texels", "0.75");
  scene::set_param(s, "shadows.slope_bias", "3");
  scene::set_param(s, "shadows.constant_bias", "0.001");
  scene::set_param(s, "shadows.max_slope_bias", "6");
  scene::set_param(s, "shadows.constant_filter_width", "true");
  scene::set_param(s, "shadows.pcss_search_texels", "20");
  scene::set_param(s, "shadows.pcss_min_filter_texels", "0.75");
  scene::set_param(s, "shadows.pcss_max_filter_texels", "24");
  scene::set_param(s, "render.view", "penumbra");
  scene::set_param(s, "render.exposure", "2");
  const PackedFrame f = pack_frame(s, 640, 360, caps_of(s), 0);
  EXPECT_EQ(f.frame.mode.z, scene::filter_index(scene::Filter::poisson));
  EXPECT_EQ(f.frame.mode.w, uint32_t(scene::DebugView::penumbra));
  EXPECT_EQ(f.frame.filter_params, glm::vec4(3.0f, 2.0f, 24.0f, 3.5f));
  EXPECT_EQ(f.frame.pcss, glm::vec4(0.25f, 20.0f, 0.75f, 24.0f));
  EXPECT_EQ(f.frame.bias.x, 0.75f);
  EXPECT_EQ(f.frame.bias.y, 3.0f);
  EXPECT_EQ(f.frame.bias.z, 0.001f);
  EXPECT_EQ(f.frame.bias.w, 6.0f);
  EXPECT_EQ(f.frame.filter_world.x, 1.0f);
  EXPECT_EQ(f.frame.ambient.w, 2.0f);
  EXPECT_EQ(f.frame.sun_color.w, 1.0f);
  EXPECT_FLOAT_EQ(f.frame.sun_direction.w, 2.5f);
  const glm::vec3 to_sun = -glm::normalize(glm::vec3(0.3f, -1.0f, 0.2f));
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(f.frame.sun_direction[i], to_sun[i], 1e-6f);
}

TEST(PackFrame, PcssClampsAndCascadeKeysReachTheShadowBlock) {
  scene::Scene s = parse(kScene);
  scene::set_param(s, "shadows.pcss_search_texels", "24");
  scene::set_param(s, "shadows.pcss_min_filter_texels", "2");
  scene::set_param(s, "shadows.pcss_max_filter_texels", "12");
  scene::set_param(s, "shadows.max_distance", "35");
  scene::set_param(s, "shadows.snap_to_texels", "false");
  s.shadows.cascades = 3;
  const PackedFrame f = pack_frame(s, 640, 360, caps_of(s), 0);
  EXPECT_EQ(f.shadow.pcss.y, 24.0f);
  EXPECT_EQ(f.shadow.pcss.z, 2.0f);
  EXPECT_EQ(f.shadow.pcss.w, 12.0f);
  EXPECT_EQ(f.shadow.counts.x, 3u);
  EXPECT_EQ(f.shadow.selection.z, 35.0f);
  EXPECT_EQ(f.cascades.cascades.size(), 3u);
  // snap_to_texels reaches the cascade fit: snapped and unsnapped matrices differ.
  scene::Scene snapped = s;
  snapped.shadows.snap_to_texels = true;
  const PackedFrame g = pack_frame(snapped, 640, 360, caps_of(snapped), 0);
  EXPECT_NE(f.cascades.cascades[0].view_proj, g.cascades.cascades[0].view_proj);
  // Without sun shadows there are no cascades.
  FrameCaps no_sun = caps_of(s);
  no_sun.sun_shadows = false;
  EXPECT_TRUE(pack_frame(s, 640, 360, no_sun, 0).cascades.cascades.empty());
}

TEST(PackFrame, LocalLightsGetMapsInOrderAndUnshadowedOnesNone) {
  scene::Scene s = parse(kScene);
  s.spots[0].radius = 0.125f;
  s.points[0].radius = 0.25f;
  s.points[0].filter = scene::Filter::pcss;
  // A scene file holds at most kMaxSpotLights spots; one built in code may hold more: the third
  // (shadowed) is neither packed nor given a map.
  scene::SpotLight third = s.spots[0];
  third.position = glm::dvec3(2, 3, 0);
  s.spots.push_back(third);
  EXPECT_EQ(s.requirements().spot_shadow_maps, 1u);
  const PackedFrame f = pack_frame(s, 640, 360, caps_of(s), 0);
  // The sphere lights' radii reach the local resolve's PCSS.
  EXPECT_EQ(f.frame.spots[0].params.z, 0.125f);
  EXPECT_EQ(f.frame.points[0].params.z, 0.25f);
  // A light's own filter reaches its params.w; -1 means the scene's.
  EXPECT_EQ(f.frame.points[0].params.w, float(scene::filter_index(scene::Filter::pcss)));
  EXPECT_EQ(f.frame.spots[0].params.w, -1.0f);
  // Three spots declared, kMaxSpotLights (2) packed; the second casts no shadow.
  EXPECT_EQ(f.frame.counts.x, uint32_t(kMaxSpotLights));
  EXPECT_EQ(f.frame.counts.y, 1u);
  EXPECT_EQ(f.frame.counts.z, 1u);
  EXPECT_EQ(f.frame.spots[0].params.y, 0.0f);
  EXPECT_EQ(f.frame.spots[1].params.y, -1.0f);
  EXPECT_EQ(f.spot_shadows.size(), 1u);
  EXPECT_FLOAT_EQ(f.frame.spots[0].direction_cos.w, std::cos(glm::radians(40.0f)));
  EXPECT_FLOAT_EQ(f.frame.spots[0].params.x, std::cos(glm::radians(30.0f)));
  EXPECT_EQ(glm::vec3(f.frame.spots[0].position_range), glm::vec3(0, 1, -6));
  EXPECT_EQ(f.frame.points[0].position_range, glm::vec4(0, 0, -5, 7));
  EXPECT_EQ(f.frame.points[0].params.y, 0.0f);
  EXPECT_EQ(f.point_shadows.size(), 1u);
  ASSERT_EQ(f.spot_gpu.size(), size_t(kMaxSpotLights));
  ASSERT_EQ(f.point_gpu.size(), size_t(kMaxPointLights));
  // No maps allocated: every light is unshadowed.
  FrameCaps none = caps_of(s);
  none.spot_shadow_maps = 0;
  none.point_shadow_cubes = 0;
  const PackedFrame g = pack_frame(s, 640, 360, none, 0);
  EXPECT_EQ(g.frame.spots[0].params.y, -1.0f);
  EXPECT_EQ(g.frame.points[0].params.y, -1.0f);
  EXPECT_TRUE(g.spot_shadows.empty());
}

// A point light fitted to the camera (fit_to_camera, shadow::fit_point_shadow): in the space
// scene looking out of the belt, away from the star, the faces behind the camera are not drawn;
// looking at the star every face sees something; an unfitted light draws all six.
// vogel takes 2D maps only (the filter table): the sun and a spot light inheriting it use it; a
// point light inheriting it resolves as its fallback, poisson (a Vogel disk on cubes).
TEST(PackFrame, APointLightInheritingVogelUsesItsFallback) {
  scene::Scene s = parse(kScene);
  s.shadows.filter = scene::Filter::vogel;
  const PackedFrame f = pack_frame(s, 640, 360, caps_of(s), 0);
  EXPECT_EQ(f.frame.mode.z, scene::filter_index(scene::Filter::vogel));
  EXPECT_EQ(f.frame.spots[0].params.w, -1.0f);  // the scene's: vogel
  EXPECT_EQ(f.frame.points[0].params.w, float(scene::filter_index(scene::Filter::poisson)));
  EXPECT_EQ(local_filter_index(s, std::nullopt, scene::LightKind::point, false, false),
            scene::filter_index(scene::Filter::poisson));
  EXPECT_EQ(local_filter_index(s, std::nullopt, scene::LightKind::spot, false, false),
            scene::filter_index(scene::Filter::vogel));
}

TEST(PackFrame, AFittedPointLightDrawsOnlyTheFacesTheCameraSees) {
  scene::Scene s = scene::load_scene(scene::find_scene("space"));
  ASSERT_FALSE(s.points.empty());
  EXPECT_TRUE(s.points[0].fit_to_camera) << "the space scene's star is fitted (space.toml)";
  auto faces = [](const PackedFrame& f) {
    int n = 0;
    for (int b = 0; b < 6; ++b) n += (f.point_shadows.at(0).face_mask >> b) & 1u;
    return n;
  };
  s.points[0].fit_to_camera = false;
  EXPECT_EQ(faces(pack_frame(s, 640, 360, caps_of(s), 0)), 6);
  s.points[0].fit_to_camera = true;
  EXPECT_EQ(faces(pack_frame(s, 640, 360, caps_of(s), 0)), 6) << "the shipped view sees the star";
  scene::set_param(s, "camera.position", "[0, 2, 20]");
  scene::set_param(s, "camera.target", "[0, 0, 40]");
  const PackedFrame away = pack_frame(s, 640, 360, caps_of(s), 0);
  EXPECT_GE(faces(away), 1);
  EXPECT_LE(faces(away), 3) << "looking away from the star, the faces behind the camera";
  // The fitted depth range spans what the camera may see, not the light's whole range.
  const auto& p = away.point_shadows.at(0);
  EXPECT_LT(p.depth_far - p.depth_near, double(s.points[0].range));
}

}  // namespace
}  // namespace penumbra::render
