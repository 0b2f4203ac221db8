// Temporal stability of the renderer's shadows along camera paths (measure_flicker): what a
// still frame comparison against the reference cannot see.
#include <gtest/gtest.h>

#include <penumbra/core/error.hpp>
#include <penumbra/reference/temporal.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <penumbra/testing/gpu_test.hpp>

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

scene::Scene shipped(const char* name) { return scene::load_scene(scene::find_scene(name)); }

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

}  // namespace
}  // namespace penumbra::reference
