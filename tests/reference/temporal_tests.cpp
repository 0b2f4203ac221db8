// Flicker between two frames (count_flicker), on a synthetic G-buffer: a ground plane seen by a
// camera, with a visibility that is a function of the world position (a perfectly stable
// shadow), then with changes put in on purpose.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <glm/gtc/matrix_transform.hpp>
#include <penumbra/core/error.hpp>
#include <penumbra/reference/temporal.hpp>
#include <vector>

namespace penumbra::reference {
namespace {

constexpr uint32_t kW = 160, kH = 120;

// A frame of the plane y = 0 from a camera at `eye` looking at `target`: depth and normals as
// the GPU would store them (reverse-Z), the receivers reconstructed from them, and
// visibility(world) per pixel.
FrameSample frame(glm::dvec3 eye, glm::dvec3 target,
                  const std::function<float(glm::dvec3)>& visibility) {
  const glm::dmat4 view = glm::lookAtRH(eye, target, glm::dvec3(0, 1, 0));
  glm::dmat4 proj = glm::perspectiveRH_ZO(glm::radians(50.0), double(kW) / kH, 100.0, 0.1);
  proj[1][1] *= -1.0;  // Vulkan: +y down the image
  const glm::dmat4 inv = glm::inverse(proj * view);
  std::vector<float> depth(size_t{kW} * kH, 0.0f);
  std::vector<glm::vec4> normal(size_t{kW} * kH, glm::vec4(0.0f));
  for (uint32_t y = 0; y < kH; ++y)
    for (uint32_t x = 0; x < kW; ++x) {
      const glm::dvec2 ndc((x + 0.5) / kW * 2.0 - 1.0, (y + 0.5) / kH * 2.0 - 1.0);
      const glm::dvec4 a = inv * glm::dvec4(ndc, 1.0, 1.0), b = inv * glm::dvec4(ndc, 0.5, 1.0);
      const glm::dvec3 p0 = glm::dvec3(a) / a.w, p1 = glm::dvec3(b) / b.w;
      const double t = -p0.y / (p1.y - p0.y);
      if (!(t > 0.0) || (p1.y - p0.y) == 0.0) continue;  // sky
      const glm::dvec3 hit = p0 + t * (p1 - p0);
      const glm::dvec4 c = proj * view * glm::dvec4(hit, 1.0);
      depth[size_t{y} * kW + x] = float(c.z / c.w);
      normal[size_t{y} * kW + x] = glm::vec4(glm::dmat3(view) * glm::dvec3(0, 1, 0), 1.0);
    }
  FrameSample f;
  f.receivers = receivers_from_gbuffer(kW, kH, depth, normal, view, proj, glm::dvec3(0.0));
  f.camera.view = view;
  f.camera.proj = proj;
  f.visibility.assign(f.receivers.size(), 1.0f);
  f.reached.assign(f.receivers.size(), 0);
  for (size_t i = 0; i < f.receivers.size(); ++i)
    if (f.receivers.valid[i]) {
      f.visibility[i] = visibility(f.receivers.position[i]);
      f.reached[i] = 1;
    }
  return f;
}

// A shadow whose edge runs along x = 0.3 with a 2 cm linear penumbra.
float soft_edge(glm::dvec3 p) { return float(std::clamp((p.x - 0.3) / 0.02 + 0.5, 0.0, 1.0)); }

struct Counts {
  size_t edge = 0, changed = 0;
  double fraction() const { return edge ? double(changed) / double(edge) : 0.0; }
};

Counts count(const FrameSample& a, const FrameSample& b, float threshold = 8.0f / 255.0f) {
  Counts c;
  count_flicker(a, b, threshold, c.edge, c.changed);
  return c;
}

const glm::dvec3 kEye(0.0, 2.0, 4.0), kTarget(0.0, 0.0, 0.0);

TEST(Flicker, AStillCameraAndAStillShadowDoNotFlicker) {
  const FrameSample a = frame(kEye, kTarget, soft_edge);
  const Counts c = count(a, a);
  EXPECT_GT(c.edge, 100u) << "the edge crosses the image";
  EXPECT_EQ(c.changed, 0u);
}

// A shadow fixed in the world, seen from a camera moved 1 mm, 1 cm and 10 cm to the side (up
// to 3 pixels here: a pixel spans about 3.5 cm): reprojection through the depth buffer finds
// each point again, and the 2 cm penumbra, sharper than a pixel, stays inside the range of the
// reprojected neighbours. A plain bilinear comparison counts 27% of these edge pixels at 1 mm
// and 71% at 1 cm.
TEST(Flicker, AShadowFixedInTheWorldIsStableUnderSmallCameraMoves) {
  const FrameSample a = frame(kEye, kTarget, soft_edge);
  for (const double step : {0.001, 0.01, 0.1}) {
    const glm::dvec3 d(step, 0.0, 0.0);
    const Counts c = count(a, frame(kEye + d, kTarget + d, soft_edge));
    EXPECT_GT(c.edge, 100u);
    EXPECT_EQ(c.changed, 0u) << "step " << step << ": " << c.changed << " of " << c.edge;
  }
}

// The shadow moves in the world while the camera moves (a cascade that re-fits, a texel snap):
// 10 cm of edge movement (3 pixels) changes most edge pixels.
TEST(Flicker, AShadowThatMovesInTheWorldIsCounted) {
  const FrameSample a = frame(kEye, kTarget, soft_edge);
  const glm::dvec3 d(0.01, 0.0, 0.0);
  const FrameSample b = frame(kEye + d, kTarget + d, [](glm::dvec3 p) {
    return soft_edge(p - glm::dvec3(0.1, 0.0, 0.0));
  });
  const Counts c = count(a, b);
  EXPECT_GT(c.fraction(), 0.3) << c.changed << " of " << c.edge;
  // A threshold above the change hides it.
  EXPECT_EQ(count(a, b, 1.0f).changed, 0u);
}

// Per-pixel noise on a still camera (a filter's rotation changing every frame) is flicker.
TEST(Flicker, NoiseOnAStillCameraIsCounted) {
  const FrameSample a = frame(kEye, kTarget, soft_edge);
  FrameSample b = a;
  size_t n = 0;
  for (size_t i = 0; i < b.visibility.size(); ++i)
    if (b.reached[i] && b.visibility[i] > 0.02f && b.visibility[i] < 0.98f)
      b.visibility[i] = std::clamp(b.visibility[i] + ((n++ % 2) ? 0.1f : -0.1f), 0.0f, 1.0f);
  const Counts c = count(a, b);
  ASSERT_GT(n, 50u);
  EXPECT_GE(c.changed, n * 9 / 10) << "of " << n << " pixels changed by 0.1";
}

// Weighted by n·l, flicker where the light grazes the surface counts for what the frame shows:
// the same changes at weight 0 (a wall edge-on to the sun) are no visible flicker.
TEST(Flicker, WeightedByNDotLChangesWhereTheLightGrazesCountLittle) {
  const FrameSample a = frame(kEye, kTarget, soft_edge);
  FrameSample b = a;
  for (size_t i = 0; i < b.visibility.size(); ++i)
    if (b.reached[i] && b.visibility[i] > 0.02f && b.visibility[i] < 0.98f)
      b.visibility[i] = std::clamp(b.visibility[i] + 0.1f, 0.0f, 1.0f);
  size_t edge = 0, changed = 0;
  double edge_w = 0.0, changed_w = 0.0;
  count_flicker(a, b, 8.0f / 255.0f, edge, changed, nullptr, &edge_w, &changed_w);
  ASSERT_GT(changed, 50u);
  EXPECT_DOUBLE_EQ(edge_w, double(edge));  // no weights: every pixel counts 1
  EXPECT_DOUBLE_EQ(changed_w, double(changed));
  b.weight.assign(b.visibility.size(), 1.0f);
  for (size_t i = 0; i < b.visibility.size(); ++i)
    if (b.visibility[i] > 0.1f && b.visibility[i] < 0.98f) b.weight[i] = 0.0f;  // the changed ones
  edge = changed = 0;
  edge_w = changed_w = 0.0;
  count_flicker(a, b, 8.0f / 255.0f, edge, changed, nullptr, &edge_w, &changed_w);
  EXPECT_GT(changed, 50u);
  EXPECT_GT(edge_w, 0.0);
  EXPECT_LT(changed_w, 0.05 * edge_w) << changed << " of " << edge << " changed";
}

// Pixels that were not on the same surface in the previous frame (disocclusion) or that the
// light does not reach are not counted.
TEST(Flicker, OnlyReprojectablePixelsTheLightReachesCount) {
  const FrameSample a = frame(kEye, kTarget, soft_edge);
  FrameSample unreached = a;
  std::fill(unreached.reached.begin(), unreached.reached.end(), 0);
  EXPECT_EQ(count(a, unreached).edge, 0u);
  EXPECT_EQ(count(unreached, a).edge, 0u);
  // The previous frame saw another surface (10 m lower) everywhere.
  FrameSample lower = a;
  for (auto& p : lower.receivers.position) p.y -= 10.0;
  EXPECT_EQ(count(lower, a).edge, 0u);
  // The previous frame saw a surface at the same place facing another way (the other side of
  // a crease: a room's corner): not the same surface.
  FrameSample turned = a;
  for (auto& n : turned.receivers.normal) n = glm::dvec3(1.0, 0.0, 0.0);
  EXPECT_EQ(count(turned, a).edge, 0u);
}

// The truth's changes excuse the renderer's: a shadow that really moved (a turning sun) moves in
// the truth too, and only the renderer's changes the truth does not share are excess.
TEST(Flicker, ExcessIsTheFlickerTheTruthDoesNotShare) {
  const FrameSample a = frame(kEye, kTarget, soft_edge);
  const glm::dvec3 d(0.01, 0.0, 0.0);
  const FrameSample moved = frame(kEye + d, kTarget + d, [](glm::dvec3 p) {
    return soft_edge(p - glm::dvec3(0.1, 0.0, 0.0));
  });
  const FrameSample still = frame(kEye + d, kTarget + d, soft_edge);
  const Counts c = count(a, moved);
  ASSERT_GT(c.changed, 50u);
  // changed_pixels marks what changed, edge or not: all of the renderer's changed edge pixels.
  const std::vector<uint8_t> truth_moved = changed_pixels(a, moved, 8.0f / 255.0f);
  size_t marked = 0;
  for (uint8_t m : truth_moved) marked += m;
  EXPECT_GE(marked, c.changed);
  const std::vector<uint8_t> truth_still = changed_pixels(a, still, 8.0f / 255.0f);
  EXPECT_EQ(std::count(truth_still.begin(), truth_still.end(), uint8_t{1}), 0);
  // The truth moved the same way: no excess.
  Flicker shared;
  count_excess_flicker(a, moved, 8.0f / 255.0f, truth_moved, shared);
  EXPECT_TRUE(shared.has_truth);
  EXPECT_EQ(shared.excess_changed, 0u);
  // The truth held still: every change is excess.
  Flicker excess;
  count_excess_flicker(a, moved, 8.0f / 255.0f, truth_still, excess);
  EXPECT_EQ(excess.excess_changed, c.changed);
  EXPECT_DOUBLE_EQ(excess.excess_changed_weight, double(c.changed));
  ASSERT_EQ(excess.excess_per_pixel.size(), a.visibility.size());
  EXPECT_THROW(count_excess_flicker(a, moved, 0.03f, std::vector<uint8_t>(3), excess), Error);
}

TEST(Flicker, FramesOfDifferentSizesAreAClearError) {
  const FrameSample a = frame(kEye, kTarget, soft_edge);
  FrameSample b = a;
  b.visibility.pop_back();
  size_t e = 0, c = 0;
  EXPECT_THROW(count_flicker(a, b, 0.03f, e, c), Error);
}

TEST(Flicker, TheImageMarksWhereItFlickered) {
  Flicker f;
  f.width = 2;
  f.height = 1;
  f.changed_per_pixel = {0, 3};
  const std::vector<uint8_t> lit = {100, 100, 100, 255, 100, 100, 100, 255};
  const std::vector<uint8_t> img = flicker_image(f, lit, 3);
  ASSERT_EQ(img.size(), 8u);
  EXPECT_EQ(img[0], img[1]) << "no flicker: grey";
  EXPECT_EQ(img[4], 255) << "every pair flickered: red";
  EXPECT_EQ(img[5], 0);
  EXPECT_THROW((void)flicker_image(f, std::vector<uint8_t>(4), 3), Error);
  // With the truth measured, what the truth shares is blue and the excess red.
  f.has_truth = true;
  f.changed_per_pixel = {3, 3};
  f.excess_per_pixel = {0, 3};
  const std::vector<uint8_t> split = flicker_image(f, lit, 3);
  EXPECT_EQ(split[0], 0) << "shared with the truth: blue";
  EXPECT_EQ(split[2], 255);
  EXPECT_EQ(split[4], 255) << "excess: red";
  EXPECT_EQ(split[6], 0);
}

TEST(Flicker, PathsAreFoundByName) {
  EXPECT_EQ(find_path("translate-1cm").step, 0.01);
  EXPECT_EQ(find_path("yaw-0.05deg").motion, Motion::yaw);
  try {
    (void)find_path("translate-1m");
    FAIL() << "an unknown path must be an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("translate-1mm"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace penumbra::reference
