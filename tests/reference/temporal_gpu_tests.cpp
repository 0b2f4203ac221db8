// Temporal stability of the renderer's shadows along camera paths (measure_flicker): what a
// still frame comparison against the reference cannot see.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <glm/glm.hpp>

#include <penumbra/core/error.hpp>
#include <penumbra/reference/temporal.hpp>
#include <penumbra/render/frame_pack.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <string>

#include "../runtime/temp_tree.hpp"

namespace penumbra::reference {
namespace {

using testing::GpuTest;
class TemporalGpu : public GpuTest {};

render::RendererOptions small() {
  render::RendererOptions ro;
  ro.width = 320;
  ro.height = 180;
  ro.visibility_output = true;
  return ro;
}

Flicker sun_flicker(gpu::Context& ctx, const scene::Scene& s, const CameraPath& path,
                    uint32_t frames) {
  render::Renderer r(ctx, s, small());
  const auto results = measure_flicker(r, path, {frames});
  EXPECT_EQ(results.size(), 1u);
  return results.empty() ? Flicker{} : results[0];
}

// A shipped scene held still: these measure the shadows' own stability along camera and sun
// paths, not a rolling ball's (TheTruthFollowsMovingObjects gives one its motion).
scene::Scene shipped(const char* name) {
  scene::Scene s = scene::load_scene(scene::find_scene(name));
  s.hold_still();
  return s;
}

// A camera that does not move sees the same shadows: no flicker with the hard filter, exactly.
TEST_F(TemporalGpu, AStillCameraGivesNoFlickerWithAHardFilter) {
  scene::Scene s = shipped("default");
  const Flicker f = sun_flicker(ctx(), s, {"still", Motion::translate, 0.0}, 4);
  EXPECT_GT(f.edge_pixels, 300u) << "the default scene's shadow edges";
  EXPECT_EQ(f.changed, 0u);
}

// The Poisson filter turns its disk every frame (interleaved_gradient_noise_temporal): without a
// temporal filter, a still camera sees its edges crawl. The measure sees it.
TEST_F(TemporalGpu, APerFrameRotatingFilterFlickersOnAStillCamera) {
  scene::Scene s = shipped("default");
  scene::set_param(s, "shadows.filter", "poisson");
  const Flicker f = sun_flicker(ctx(), s, {"still", Motion::translate, 0.0}, 4);
  EXPECT_GT(f.fraction(), 0.05) << f.changed << " of " << f.edge_pixels;
}

// Cascades that move by whole texels keep the shadows still while the sun turns; without the
// snapping every texel of every cascade moves by a fraction each frame. Here (320x180, 4
// frames) 12 of 4711 edge pixels flicker against 126 of 4686. At 640x360 over 8 frames: sun
// 0.54% against 4.84%, and yaw 0.46% against 1.23% (too few pixels at this size to test).
TEST_F(TemporalGpu, SnappingTheCascadesToTexelsKeepsTheShadowsStill) {
  scene::Scene s = shipped("default");
  const CameraPath path = find_path("sun-0.05deg");
  const Flicker snapped = sun_flicker(ctx(), s, path, 4);
  scene::set_param(s, "shadows.snap_to_texels", "false");
  const Flicker unsnapped = sun_flicker(ctx(), s, path, 4);
  EXPECT_GT(unsnapped.fraction(), 3.0 * snapped.fraction())
      << "snapped " << snapped.changed << " of " << snapped.edge_pixels << ", unsnapped "
      << unsnapped.changed << " of " << unsnapped.edge_pixels;
}

// The truth traced at every frame: a turning sun moves the shadows themselves, in the truth as
// in the renderer; the truth's changes excuse the renderer's, so the excess is a part of what
// the renderer changed. (1280x720 on the H200, 16 frames: the renderer 0.91%, the truth 2.80%,
// the excess 0.44%.) A still camera's truth does not change at all: the shared light-sample
// pattern leaves no Monte Carlo noise between frames.
TEST_F(TemporalGpu, TheTruthAlongAPathExcusesWhatItShares) {
  scene::Scene s = shipped("default");
  render::Renderer r(ctx(), s, small());
  FlickerOptions o;
  o.frames = 3;
  o.truth = TraceOptions{};
  o.truth->samples = 64;
  const auto sun = measure_flicker(r, find_path("sun-0.05deg"), o);
  ASSERT_EQ(sun.size(), 1u);
  const Flicker& f = sun[0];
  EXPECT_TRUE(f.has_truth);
  EXPECT_GT(f.truth_edge_pixels, 300u);
  EXPECT_GT(f.truth_changed, 0u) << "the truth's shadows move with the sun";
  EXPECT_GT(f.changed, 0u);
  EXPECT_LT(f.excess_changed, f.changed) << "some of the renderer's changes are the truth's";
  const auto still = measure_flicker(r, {"still", Motion::translate, 0.0}, o);
  ASSERT_EQ(still.size(), 1u);
  EXPECT_GT(still[0].truth_edge_pixels, 300u);
  EXPECT_EQ(still[0].truth_changed, 0u);
}

// A moving caster (Instance::motion): the truth of each frame is traced where the renderer drew
// it, so the path error stays that of a still scene while its shadow crosses the ground. (A truth
// traced once, with the ball where it was at frame 0, leaves it there: 0.0038 against 0.0006.)
TEST_F(TemporalGpu, TheTruthFollowsMovingObjects) {
  scene::Scene s = shipped("default");
  scene::Instance& ball = s.instances.at(3);
  scene::Motion m;
  m.base = ball.transform;
  m.move = {0.25f, 0.0f, 0.0f};
  m.move_frames = 1;
  ball.motion = m;
  render::Renderer r(ctx(), s, small());
  FlickerOptions o;
  o.frames = 3;
  o.truth = TraceOptions{};
  o.truth->samples = 16;
  const auto moving = measure_flicker(r, {"still", Motion::translate, 0.0}, o);
  ASSERT_EQ(moving.size(), 1u);
  EXPECT_GT(moving[0].truth_changed, 0u) << "the ball's shadow moves in the truth";
  render::Renderer still_r(ctx(), shipped("default"), small());
  const auto still = measure_flicker(still_r, {"still", Motion::translate, 0.0}, o);
  ASSERT_EQ(still.size(), 1u);
  EXPECT_LT(moving[0].path_mean_abs_error, 2.0 * still[0].path_mean_abs_error + 1e-4)
      << "still " << still[0].path_mean_abs_error;
}

TEST_F(TemporalGpu, MeasuringPutsTheCameraAndTheSunBack) {
  scene::Scene s = shipped("default");
  render::Renderer r(ctx(), s, small());
  const scene::Camera before = r.scene().camera;
  const glm::vec3 sun = r.scene().sun->direction;
  // A camera path and the sun's (the other two move the camera the same way).
  for (const char* name : {"yaw-0.05deg", "sun-0.05deg"}) (void)measure_flicker(r, find_path(name), {2});
  EXPECT_EQ(r.scene().camera.position, before.position);
  EXPECT_EQ(r.scene().camera.target, before.target);
  EXPECT_EQ(r.scene().sun->direction, sun);
}

TEST_F(TemporalGpu, BadInputIsAClearError) {
  scene::Scene s = shipped("default");
  render::Renderer r(ctx(), s, small());
  EXPECT_THROW((void)measure_flicker(r, find_path("translate-1mm"), {1}), Error);
  EXPECT_THROW((void)measure_flicker(r, {"nan", Motion::yaw, std::nan("")}, {4}), Error);
  render::RendererOptions no_visibility = small();
  no_visibility.visibility_output = false;
  render::Renderer without(ctx(), s, no_visibility);
  EXPECT_THROW((void)measure_flicker(without, find_path("translate-1mm"), {2}), Error);
  // No sun: the sun path measures nothing.
  scene::Scene indoor = shipped("indoor");
  render::Renderer ri(ctx(), indoor, small());
  EXPECT_TRUE(measure_flicker(ri, find_path("sun-0.05deg"), {2}).empty());
}


// ---- shadows.temporal: the shadow-temporal pass ---------------------------------------------

class TemporalAccumulationGpu : public GpuTest {};

// One rendered frame as the flicker measure sees it: receivers, camera and one slot's
// visibility.
FrameSample sample(render::Renderer& r, uint32_t slot) {
  const render::GBuffer g = r.read_gbuffer();
  FrameSample f;
  f.receivers = receivers_from_gbuffer(g.width, g.height, g.depth, g.normal_view, g.camera.view,
                                       g.camera.proj, g.camera.origin);
  f.camera = g.camera;
  f.visibility = r.read_visibility(slot);
  return f;
}

// Moves the camera and its target sideways by `metres`.
void move_camera(scene::Scene& s, float metres) {
  const glm::vec3 right =
      glm::normalize(glm::cross(s.camera.target - s.camera.position, s.camera.up));
  s.camera.position += right * metres;
  s.camera.target += right * metres;
}

size_t count_differences(const std::vector<float>& a, const std::vector<float>& b, float tol) {
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += !(std::abs(a[i] - b[i]) <= tol);
  return n;
}

// The indoor scene without contact shadows (they multiply the primary light's visibility after
// the accumulation), with the temporal pass and weight w.
scene::Scene indoor_temporal(float weight) {
  scene::Scene s = shipped("indoor");
  s.contact.step_count = 0;
  s.shadows.temporal = true;
  s.shadows.temporal_weight = weight;
  return s;
}

// The first frame has no history: the pass hands the resolves' values through, bit for bit.
// Only scenes that ask for it build the pass.
TEST_F(TemporalAccumulationGpu, TheFirstFrameIsTheResolveAndOnlyScenesThatAskBuildIt) {
  scene::Scene with = indoor_temporal(0.2f), without = with;
  without.shadows.temporal = false;
  render::Renderer a(ctx(), with, small()), b(ctx(), without, small());
  EXPECT_TRUE(a.built().has_pass("shadow-temporal")) << a.built().to_string();
  EXPECT_FALSE(b.built().has_pass("shadow-temporal")) << b.built().to_string();
  a.render(0);
  b.render(0);
  for (uint32_t slot : {render::spot_visibility_slot(0), render::point_visibility_slot(0)})
    EXPECT_EQ(a.read_visibility(slot), b.read_visibility(slot)) << "slot " << slot;
  EXPECT_EQ(a.read_rgba8(), b.read_rgba8());
}

// The pass against its C++ model (accumulate_visibility, in double) over four frames of a
// camera moving 1 cm a frame, the lights moving 10 cm in the last (the shadows move, and the
// neighbourhood clamp holds the stale history back): each frame's accumulated visibility from
// the last frame's and the resolves' own (a renderer without the pass, same frames). The local
// lights' history is stored as fp16, so values agree within 2e-3; pixels whose taps sit on the
// same-surface bound (float against double) may take or drop the history: at most 0.1% (none
// on lavapipe).
TEST_F(TemporalAccumulationGpu, MatchesItsCppModelAlongAMovingCamera) {
  constexpr float kWeight = 0.3f;
  scene::Scene with = indoor_temporal(kWeight), without = with;
  without.shadows.temporal = false;
  render::Renderer a(ctx(), with, small()), b(ctx(), without, small());
  for (uint32_t slot : {render::spot_visibility_slot(0), render::point_visibility_slot(0)}) {
    a.reset_history();
    a.scene().camera = with.camera;
    b.scene().camera = with.camera;
    for (render::Renderer* r : {&a, &b}) {
      r->scene().spots = with.spots;
      r->scene().points = with.points;
    }
    a.render(0);
    FrameSample accumulated = sample(a, slot);
    for (uint32_t k = 1; k <= 3; ++k) {
      for (render::Renderer* r : {&a, &b}) {
        move_camera(r->scene(), 0.01f);
        if (k < 3) continue;
        r->scene().spots[0].position += glm::vec3(0.1f, 0.0f, 0.0f);
        r->scene().points[0].position += glm::vec3(0.1f, 0.0f, 0.0f);
      }
      a.render(k);
      b.render(k);
      const FrameSample raw = sample(b, slot);
      const FrameSample got = sample(a, slot);
      const std::vector<float> want = accumulate_visibility(accumulated, raw, kWeight);
      const size_t n = want.size();
      const size_t off = count_differences(want, got.visibility, 2e-3f);
      EXPECT_LE(off, n / 1000) << "slot " << slot << " frame " << k << ": " << off << " of " << n;
      // The model is not the identity: the accumulation changed what the resolve gave.
      EXPECT_GT(count_differences(raw.visibility, got.visibility, 2e-3f), n / 1000)
          << "slot " << slot << " frame " << k;
      accumulated = got;
    }
  }
}

// What resets the history: an edited parameter (the next frame equals a renderer's that never
// had one), reset_history(), a reload that gave a pipeline new code; a reload whose SPIR-V did
// not change keeps it. Poisson turns its disk every frame, so an accumulated frame differs from
// a fresh one. On a copy of the shader tree, which the fresh renderers read too.
TEST_F(TemporalAccumulationGpu, AParameterChangeAResetOrAReloadStartsAfresh) {
  scene::Scene s = indoor_temporal(0.2f);
  scene::set_param(s, "shadows.filter", "poisson");
  testing::TempTree tree(true);
  render::RendererOptions o = small();
  o.shader_dir = tree.shaders();
  render::Renderer a(ctx(), s, o);
  const uint32_t slot = render::spot_visibility_slot(0);
  auto fresh = [&](const scene::Scene& like, uint32_t frame) {
    render::Renderer f(ctx(), like, o);
    f.render(frame);
    return f.read_visibility(slot);
  };
  for (uint32_t k = 0; k < 4; ++k) a.render(k);
  EXPECT_NE(a.read_visibility(slot), fresh(s, 3)) << "four frames accumulated";
  scene::set_param(a.scene(), "shadows.constant_bias", "0.001");
  a.render(4);
  EXPECT_EQ(a.read_visibility(slot), fresh(a.scene(), 4)) << "after a parameter change";
  a.render(5);
  a.reset_history();
  a.render(6);
  EXPECT_EQ(a.read_visibility(slot), fresh(a.scene(), 6)) << "after reset_history()";
  a.render(7);
  const std::filesystem::path resolve = tree.shaders() / "render/local_shadow_resolve.comp";
  const auto same = a.reload({resolve});  // the file as it was: the same SPIR-V
  ASSERT_FALSE(same.rebuilt.empty());
  EXPECT_EQ(same.same_spirv, same.rebuilt);
  a.render(8);
  EXPECT_NE(a.read_visibility(slot), fresh(a.scene(), 8)) << "a reload without new code";
  std::string text = testing::read_text(resolve);
  const std::string from = "float rotation = 6.2831853 *";
  ASSERT_NE(text.find(from), std::string::npos);
  text.replace(text.find(from), from.size(), "float rotation = 6.28319 *");
  std::ofstream(resolve) << text;
  const auto edited = a.reload({resolve});
  ASSERT_TRUE(edited.ok());
  ASSERT_FALSE(edited.rebuilt.empty());
  EXPECT_TRUE(edited.same_spirv.empty());
  a.render(9);
  EXPECT_EQ(a.read_visibility(slot), fresh(a.scene(), 9)) << "after a reload with new code";
}

// What the pass is for: the indoor lights' flicker along 1 cm steps where the truth holds still
// (the excess; at 960x540 on lavapipe 0.65% and 0.62% without it, 0.27% and 0.02% with weight
// 0.15). Here 320x180, 4 frames; without the truth, the renderer's own flicker.
TEST_F(TemporalAccumulationGpu, ItCutsTheFlickerOfACameraMovingACentimetreAFrame) {
  auto flicker = [&](const scene::Scene& s) {
    render::Renderer r(ctx(), s, small());
    return measure_flicker(r, find_path("translate-1cm"), {4});
  };
  scene::Scene on = indoor_temporal(0.2f), off = on;
  off.shadows.temporal = false;
  const auto with = flicker(on), without = flicker(off);
  ASSERT_EQ(with.size(), 2u);
  ASSERT_EQ(without.size(), 2u);
  size_t changed_with = 0, changed_without = 0;
  for (int i = 0; i < 2; ++i) {
    changed_with += with[i].changed;
    changed_without += without[i].changed;
    EXPECT_GT(without[i].edge_pixels, 300u) << without[i].light;
  }
  EXPECT_GT(changed_without, 20u);
  EXPECT_LT(2 * changed_with, changed_without)
      << "with " << changed_with << ", without " << changed_without;
}

// ---- point lights fitted to the camera (fit_to_camera) ----------------------------------------
class FittedPointLightGpu : public GpuTest {};

// A point light over a yard, the camera behind the light's shoulder looking away from it: the
// fitted cube draws only the faces that see what the camera sees (the others stay cleared) and
// stores distances over the fitted range, and every shadow in view is the unfitted one's.
constexpr const char* kLampYard = R"(
name = "lamp-yard"
[camera]
position = [3, 2.5, 3]
target = [9, 0, 9]
fov_y = 50
[[point]]
position = [0, 3, 0]
intensity = 60
range = 40
resolution = 1024
[shadows]
filter = "hard"
[contact]
steps = 0
[[object]]
mesh = "plane"
size = [60, 60]
casts_shadows = false
[[object]]
mesh = "box"
size = [1, 1.5, 1]
position = [6, 0.75, 5]
[[object]]
mesh = "box"
size = [0.6, 2, 0.6]
position = [5, 1, 8]
[[object]]
mesh = "sphere"
radius = 0.7
position = [8, 0.7, 6]
[[object]]
mesh = "box"
size = [1, 1, 1]
position = [-5, 0.5, -4]
)";

TEST_F(FittedPointLightGpu, SkippedFacesAndTheFittedRangeChangeNoVisibleShadow) {
  scene::Scene s = scene::parse_scene(kLampYard, "lamp-yard.toml", ".");
  scene::Scene fitted = s;
  fitted.points[0].fit_to_camera = true;
  render::FrameCaps caps;
  caps.point_shadow_cubes = 1;
  const render::PackedFrame packed = render::pack_frame(fitted, 320, 180, caps, 0);
  const uint32_t mask = packed.point_shadows.at(0).face_mask;
  EXPECT_LT(std::popcount(mask), 6) << "faces " << mask;
  render::Renderer a(ctx(), s, small()), b(ctx(), fitted, small());
  a.render(0);
  b.render(0);
  const auto va = a.read_visibility(render::point_visibility_slot(0));
  const auto vb = b.read_visibility(render::point_visibility_slot(0));
  ASSERT_EQ(va.size(), vb.size());
  // Cast shadows in view: the ground (which casts none: normal alpha 0.5) where the boxes and
  // the ball hide the lamp.
  const render::GBuffer g = a.read_gbuffer();
  size_t cast = 0;
  for (size_t i = 0; i < va.size(); ++i) cast += g.normal_view[i].w == 0.5f && va[i] < 0.5f;
  EXPECT_GT(cast, 500u) << "shadows on the ground in view";
  // A receiver whose stored distance is quantized differently over the fitted range may flip
  // at an edge: at most 0.1% of the pixels.
  EXPECT_LE(count_differences(va, vb, 1.0f / 255.0f), va.size() / 1000);
}


}  // namespace
}  // namespace penumbra::reference
