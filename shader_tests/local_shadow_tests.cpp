// Function-level tests of the world-unit biases (shaders/penumbra/bias.glsl), the spot and point
// light PCSS radii (shaders/penumbra/local_shadow.glsl) against closed forms written here, and
// PCSS's continuity at its degenerate ends (shaders/penumbra/pcss.glsl): angular diameter 0, a
// receiver at the light's near plane, and a blocker search clamped below the filter radius.
// The cube-map filters have their own file, cube_shadow_tests.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <tuple>
#include <vector>

#include "reference/filter_ref.hpp"
#include "reference/local_ref.hpp"

PENUMBRA_GLSL_STRUCT(penumbra::filter_ref::PcssParams, "PcssParams", tan_half_angle,
                     texel_world_size, depth_near, depth_far, max_search_texels, min_filter_texels,
                     max_filter_texels, confidence_fraction);

namespace penumbra::testing {
namespace {

constexpr const char* kBias = "penumbra/bias.glsl";
constexpr const char* kLocal = "penumbra/local_shadow.glsl";
constexpr float kTwoPi = 2.0f * std::numbers::pi_v<float>;
using Local = local_ref::PcssLocalParams;
using Params = filter_ref::PcssParams;

class LocalShadowTest : public GpuTest {};

// ---- world-unit biases -------------------------------------------------------------------------

// constant + slope * texel * tan(theta), at most constant + max_slope * texel; back faces and
// N.L = 0 get the bound.
double world_bias(double n_dot_l, double c, double s, double m, double t) {
  if (!(n_dot_l > 0.0)) return c + m * t;
  const double cc = std::min(n_dot_l, 1.0);
  const double tan_theta = std::sqrt(std::max(1.0 - cc * cc, 0.0)) / cc;
  return std::min(c + s * t * tan_theta, c + m * t);
}

TEST_F(LocalShadowTest, WorldDepthBiasIsTheSlopeTermInTexelsOfTheReceiversFootprint) {
  ShaderFunction<float(float, float, float, float, float)> f(kBias, "world_depth_bias");
  Rng rng(1301);
  std::vector<std::tuple<float, float, float, float, float>> cases;
  for (int i = 0; i < 4096; ++i)
    cases.emplace_back(float(-0.2 + 1.2 * rng.next_unit()), float(0.002 * rng.next_unit()),
                       float(4.0 * rng.next_unit()), float(16.0 * rng.next_unit()),
                       float(0.001 + 0.2 * rng.next_unit()));
  // Known values: facing the light (the constant alone), 45 degrees (tan 1), grazing (bound).
  cases.emplace_back(1.0f, 0.001f, 2.0f, 4.0f, 0.01f);
  cases.emplace_back(float(std::sqrt(0.5)), 0.001f, 2.0f, 4.0f, 0.01f);
  cases.emplace_back(0.0f, 0.001f, 2.0f, 4.0f, 0.01f);
  const auto got = f.run(cases);
  std::vector<float> want;
  for (const auto& [nl, c, s, m, t] : cases) want.push_back(float(world_bias(nl, c, s, m, t)));
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::relative(3e-6, 1e-9),
                           [&](size_t i) { return format_tuple(cases[i]); });
  const size_t k = cases.size() - 3;
  EXPECT_NEAR(got[k], 0.001f, 1e-9f);
  EXPECT_NEAR(got[k + 1], 0.021f, 1e-7f);
  EXPECT_NEAR(got[k + 2], 0.041f, 1e-7f);
  // Negative and NaN parameters count as 0.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(f(0.5f, -1.0f, nan, -3.0f, 0.01f), 0.0f);
  EXPECT_EQ(f(0.5f, 0.001f, 2.0f, 4.0f, nan), 0.001f);
}

// The normal offset grows with a filter's reach beyond one texel; the geometry behind it: a
// receiver moved k texels along its normal stays in front of its own plane at every tap up to k
// texels away, whatever the angle to the light. Before, every filter got the base offset, and a
// PCF radius of 3 put 15-29% of the indoor spot's and the space star's lit receivers in false
// shadow (docs/accuracy.md).
TEST_F(LocalShadowTest, NormalOffsetGrowsWithTheFiltersReach) {
  ShaderFunction<float(float, float)> f(kBias, "filter_normal_offset_texels");
  std::vector<std::tuple<float, float>> cases;
  for (float base : {0.0f, 0.5f, 1.5f, 3.0f})
    for (float reach : {0.0f, 0.5f, 1.0f, 2.0f, 3.0f, 5.0f, 32.0f}) cases.emplace_back(base, reach);
  const auto got = f.run(cases);
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto& [base, reach] = cases[i];
    EXPECT_EQ(got[i], base + std::max(reach - 1.0f, 0.0f)) << format_tuple(cases[i]);
  }
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(f(nan, 3.0f), 2.0f);
  EXPECT_EQ(f(1.5f, nan), 1.5f);
  EXPECT_EQ(f(-1.0f, -2.0f), 0.0f);

  // The plane y = 0 with the light at angle theta, texel t: the receiver moved by normal_offset
  // with the filter's offset; a tap d texels across (perpendicular to the light) finds the
  // plane behind it (farther from the light) for every |d| <= reach.
  ShaderFunction<glm::vec3(glm::vec3, glm::vec3, float, float)> offset(kBias, "normal_offset");
  const float t = 0.01f;
  for (float reach : {1.0f, 2.0f, 3.0f, 5.0f}) {
    const float k = f(1.0f, reach);
    for (float degrees : {5.0f, 30.0f, 60.0f, 85.0f, 89.0f}) {
      const float a = glm::radians(degrees);
      const glm::vec3 l(std::sin(a), std::cos(a), 0.0f), across(std::cos(a), -std::sin(a), 0.0f);
      const glm::vec3 q = offset(glm::vec3(0, 1, 0), l, t, k);
      for (float d = -reach; d <= reach; d += 0.5f) {
        const glm::vec3 tap = q + across * (d * t);
        // Along -l from the tap to the plane: positive distance, the plane is behind the tap.
        const double s = double(tap.y) / double(l.y);
        EXPECT_GE(s, -1e-7) << "reach " << reach << ", " << degrees << " degrees, tap " << d;
      }
    }
  }
}

TEST_F(LocalShadowTest, BiasTowardLightMovesAlongTheRayByExactlyTheBias) {
  ShaderFunction<glm::vec3(glm::vec3, glm::vec3, float)> f(kBias, "bias_toward_light");
  Rng rng(1302);
  std::vector<std::tuple<glm::vec3, glm::vec3, float>> cases;
  for (int i = 0; i < 4096; ++i) {
    const glm::vec3 p = unit_vector3()(rng) * float(100.0 * rng.next_unit());
    const glm::vec3 l = unit_vector3()(rng) * float(0.01 + 50.0 * rng.next_unit());
    cases.emplace_back(p, l, float(0.5 * rng.next_unit()));
  }
  const auto got = f.run(cases);
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto& [p, l, b] = cases[i];
    const glm::dvec3 d = glm::dvec3(got[i]) - glm::dvec3(p);
    const glm::dvec3 u = glm::normalize(glm::dvec3(l));
    // Along the ray (the shadow-map uv is unchanged), by b: the float rounding of p + offset is
    // at most an ULP of |p| (100 m: 8e-6 m).
    const double slack = 1e-5 + 1e-6 * b;
    ASSERT_NEAR(glm::dot(d, u), b, slack) << format_tuple(cases[i]);
    ASSERT_NEAR(glm::length(d - glm::dot(d, u) * u), 0.0, slack) << format_tuple(cases[i]);
  }
  // No bias, a negative or NaN one, and degenerate directions leave p where it is.
  const glm::vec3 p(1.0f, 2.0f, 3.0f);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const auto& [l, b] : std::vector<std::pair<glm::vec3, float>>{
           {{0, 1, 0}, 0.0f},
           {{0, 1, 0}, -0.1f},
           {{0, 1, 0}, nan},
           {{0, 0, 0}, 0.1f},
           {{1e-30f, 0, 0}, 0.1f},
           {{nan, 1, 0}, 0.1f},
           {{std::numeric_limits<float>::infinity(), 0, 0}, 0.1f}})
    EXPECT_EQ(f(p, l, b), p) << l.x << " " << l.y << " " << b;
}

TEST_F(LocalShadowTest, TexelFootprintsOfPerspectiveAndCubeMaps) {
  ShaderFunction<float(float, float)> spot(kBias, "perspective_texel_world_size");
  ShaderFunction<float(glm::vec3, float)> cube(kBias, "cube_texel_world_size");
  EXPECT_FLOAT_EQ(spot(0.002f, 6.0f), 0.012f);
  EXPECT_EQ(spot(0.002f, -1.0f), 0.0f);  // behind the light
  EXPECT_EQ(spot(0.002f, std::numeric_limits<float>::quiet_NaN()), 0.0f);
  // A cube face texel spans 2 m / resolution at major-axis length m.
  EXPECT_FLOAT_EQ(cube(glm::vec3(0.5f, -3.0f, 1.0f), 512.0f), 6.0f / 512.0f);
  EXPECT_FLOAT_EQ(cube(glm::vec3(-4.0f, 1.0f, 3.9f), 1024.0f), 8.0f / 1024.0f);
  EXPECT_EQ(cube(glm::vec3(1.0f), 0.0f), 0.0f);
}

// ---- PCSS of sphere lights ---------------------------------------------------------------------

TEST_F(LocalShadowTest, SphereLightPcssRadiiFollowTheLightsCone) {
  ShaderFunction<float(float, Local)> search(kLocal, "pcss_local_search_radius_texels");
  ShaderFunction<float(float, float, Local)> filter(kLocal, "pcss_local_filter_radius_texels");
  Rng rng(1303);
  std::vector<std::tuple<float, Local>> sc;
  std::vector<std::tuple<float, float, Local>> fc;
  std::vector<float> sw, fw;
  for (int i = 0; i < 2048; ++i) {
    Local p;
    p.light_radius = float(0.3 * rng.next_unit());
    p.texel_at_unit = float(0.0005 + 0.004 * rng.next_unit());
    p.near = float(0.05 + 0.5 * rng.next_unit());
    p.far = p.near + float(5.0 + 20.0 * rng.next_unit());
    p.max_search_texels = float(4.0 + 40.0 * rng.next_unit());
    p.min_filter_texels = float(2.0 * rng.next_unit());
    p.max_filter_texels = float(4.0 + 40.0 * rng.next_unit());
    const double zr = p.near + (p.far - p.near) * rng.next_unit();
    const double zb = p.near + (zr - p.near) * rng.next_unit();
    sc.emplace_back(float(zr), p);
    fc.emplace_back(float(zr), float(zb), p);
    // Search: R (zr - near) / (zr near t), clamped to [min + 1, max(max_search, min + 1)].
    const double lo = p.min_filter_texels + 1.0;
    const double s = p.light_radius * (zr - p.near) / (zr * p.near * p.texel_at_unit);
    sw.push_back(float(std::clamp(s, lo, std::max<double>(p.max_search_texels, lo))));
    // Filter: R (zr - zb) / (zr zb t), clamped to [min, max(max, min)].
    const double f = p.light_radius * (zr - zb) / (zr * zb * p.texel_at_unit);
    fw.push_back(float(std::clamp(f, double(p.min_filter_texels),
                                  std::max<double>(p.max_filter_texels, p.min_filter_texels))));
  }
  PENUMBRA_EXPECT_ALL_NEAR(sw, search.run(sc), Tolerance::relative(1e-5, 1e-6));
  PENUMBRA_EXPECT_ALL_NEAR(fw, filter.run(fc), Tolerance::relative(1e-5, 1e-6));

  // Far from a small light the radius tends to the sun's: R / z -> tan(theta / 2).
  Local far_light;
  far_light.light_radius = 1000.0f * 0.01f;   // tan(theta / 2) = 0.01 at 1000 m
  far_light.texel_at_unit = 0.01f / 1000.0f;  // 1 cm texels at 1000 m
  far_light.near = 1.0f;
  far_light.far = 2000.0f;
  far_light.max_search_texels = 1e6f;
  far_light.max_filter_texels = 1e6f;
  // A blocker 2 m above the receiver: the sun's radius is 0.01 * 2 / 0.01 = 2 texels.
  EXPECT_NEAR(filter(1000.0f, 998.0f, far_light), 2.0f, 0.01f);

  // Degenerate ends: a point light (R = 0) or a receiver at the near plane searches the
  // minimum filter's footprint (min + 1) and filters with the minimum; a blocker at the light
  // (zb = 0) gives the largest filter, and nothing is NaN.
  Local p = far_light;
  p.min_filter_texels = 1.5f;
  p.max_search_texels = 16.0f;
  p.max_filter_texels = 24.0f;
  Local point = p;
  point.light_radius = 0.0f;
  EXPECT_EQ(search(10.0f, point), 2.5f);
  EXPECT_EQ(filter(10.0f, 5.0f, point), 1.5f);
  EXPECT_EQ(search(p.near, p), 2.5f);
  EXPECT_EQ(filter(10.0f, 0.0f, p), 24.0f);
  Local zero_near = p;
  zero_near.near = 0.0f;
  EXPECT_EQ(search(10.0f, zero_near), 16.0f);
  EXPECT_EQ(search(10.0f, point), 2.5f);
}

// ---- PCSS continuity at its degenerate ends ----------------------------------------------------

using PcssFn = ShaderFunction<float(Sampler2DShadow, Sampler2D, glm::vec3, glm::vec2, Params,
                                    int32_t, float, bool)>;

// The largest jump of the shadow-factor profile across a straight blocker edge, sampled every
// 0.05 texels over +-16 texels with one rotation of the tap sets (the high tier: 32 search and 64
// filter taps). Measured: with the continuity rules the profile moves by at most 0.03-0.05 per
// step (a tap crossing a texel edge); without them (the shaders before) the early-out where the
// search shrinks to a point jumps by 0.53 (angular diameter 0) and 0.50 (near plane), and the
// search cut short below the filter by 0.37. 0.1 separates the two.
double largest_jump(PcssFn& pcss, const Params& p, float d_receiver, float d_blocker,
                    bool reverse_z) {
  const int width = 256, height = 8, edge = 128;
  filter_ref::DepthMap map{width, height, std::vector<float>(size_t(width * height))};
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      map.depth[size_t(y * width + x)] = x < edge ? d_blocker : d_receiver;
  DepthTextureDesc d;
  d.width = uint32_t(width);
  d.height = uint32_t(height);
  d.sampler.filter = VK_FILTER_LINEAR;
  d.sampler.compare = true;
  d.sampler.compare_op = reverse_z ? VK_COMPARE_OP_GREATER_OR_EQUAL : VK_COMPARE_OP_LESS_OR_EQUAL;
  DepthTextureDesc raw = d;
  raw.sampler = {};
  pcss.bind(0, make_depth_texture(d, map.depth)).bind(1, make_depth_texture(raw, map.depth));
  std::vector<std::tuple<glm::vec3, glm::vec2, Params, int32_t, float, bool>> cases;
  std::vector<double> xs;
  for (double x = -16.0; x <= 16.0; x += 0.05) xs.push_back(x);
  for (double x : xs)
    cases.emplace_back(glm::vec3(float((edge + x) / width), 0.5f, d_receiver),
                       glm::vec2(1.0f / width, 1.0f / height), p, 2, kTwoPi * 0.3f, reverse_z);
  const auto got = pcss.run(cases);
  double jump = 0.0;
  for (size_t i = 1; i < got.size(); ++i)
    jump = std::max(jump, double(std::abs(got[i] - got[i - 1])));
  return jump;
}

TEST_F(LocalShadowTest, SunPcssIsContinuousAtItsDegenerateEnds) {
  PcssFn pcss("penumbra/pcss.glsl", "pcss_shadow");
  for (bool reverse_z : {true, false}) {
    const auto depth = [&](double f) { return float(reverse_z ? 1.0 - f : f); };
    Params p;
    p.texel_world_size = 0.05f;
    p.depth_near = 0.0f;
    p.depth_far = 100.0f;
    p.max_search_texels = 16.0f;
    p.min_filter_texels = 1.0f;
    p.max_filter_texels = 32.0f;
    p.confidence_fraction = 0.0f;
    // A light of angular diameter 0: PCF with the minimum filter, not a step at the edge.
    Params zero = p;
    zero.tan_half_angle = 0.0f;
    EXPECT_LT(largest_jump(pcss, zero, depth(0.6), depth(0.4), reverse_z), 0.1)
        << "angular diameter 0, reverse_z " << reverse_z;
    // A receiver at the near plane with its blocker pancaked onto it (depth clamping).
    Params sun = p;
    sun.tan_half_angle = float(std::tan(0.53 * std::numbers::pi / 360.0));
    EXPECT_LT(largest_jump(pcss, sun, depth(0.0002), depth(0.0), reverse_z), 0.1)
        << "near plane, reverse_z " << reverse_z;
    // A wide light whose filter (up to 32 texels) outgrows a 4-texel search: the penumbra
    // narrows to the searched disk instead of being cut off.
    Params wide = p;
    wide.tan_half_angle = 0.05f;
    wide.max_search_texels = 4.0f;
    EXPECT_LT(largest_jump(pcss, wide, depth(0.6), depth(0.4), reverse_z), 0.1)
        << "search below the filter, reverse_z " << reverse_z;
  }
}

}  // namespace
}  // namespace penumbra::testing
