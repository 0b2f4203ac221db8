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

// Cascades that move by whole texels keep the shadows still while the sun turns and the camera
// yaws; without the snapping every texel of every cascade moves by a fraction each frame. At
// 640x360, 8 frames: sun 0.54% against 4.84%, yaw 0.46% against 1.23% (sideways moves are the
// same either way: the cascades' centres follow the camera by whole texels both times).
TEST_F(TemporalGpu, SnappingTheCascadesToTexelsKeepsTheShadowsStill) {
  for (const char* name : {"sun-0.05deg", "yaw-0.05deg"}) {
    scene::Scene s = shipped("default");
    const CameraPath path = find_path(name);
    const Flicker snapped = sun_flicker(ctx(), s, path, 6);
    scene::set_param(s, "shadows.snap_to_texels", "false");
    const Flicker unsnapped = sun_flicker(ctx(), s, path, 6);
    EXPECT_GT(unsnapped.fraction(), 1.5 * snapped.fraction())
        << name << ": snapped " << snapped.changed << " of " << snapped.edge_pixels
        << ", unsnapped " << unsnapped.changed << " of " << unsnapped.edge_pixels;
  }
}

TEST_F(TemporalGpu, MeasuringPutsTheCameraAndTheSunBack) {
  scene::Scene s = shipped("default");
  render::Renderer r(ctx(), s, small());
  const scene::Camera before = r.scene().camera;
  const glm::vec3 sun = r.scene().sun->direction;
  for (const auto& path : standard_paths()) (void)measure_flicker(r, path, {2});
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
