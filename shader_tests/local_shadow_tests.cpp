// Function-level tests of the world-unit biases (shaders/penumbra/bias.glsl), the spot and point
// light PCSS radii and the cube-map compare reference (shaders/penumbra/local_shadow.glsl)
// against closed forms written here, the whole spot and point light PCSS (pcss_spot_shadow_array,
// pcss_cube_shadow_array, its filtering path included) against a reference built on
// reference/filter_ref.hpp, and PCSS's continuity at its degenerate ends
// (shaders/penumbra/pcss.glsl): angular diameter 0, a receiver at the light's near plane, and a
// blocker search clamped below the filter radius. The cube-map filters' taps, seams, layers and
// bad input have their own file, cube_shadow_tests.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <iostream>
#include <limits>
#include <memory>
#include <numbers>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <span>
#include <string>
#include <tuple>
#include <vector>

#include "reference/depth_ref.hpp"
#include "reference/filter_ref.hpp"
#include "reference/local_ref.hpp"
#include "vogel_offsets.hpp"

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

// ---- cube-map compare reference ---------------------------------------------------------------

// cube_compare_depth's closed form in double: t = clamp((distance - near) * inv_range, 0, 1), 1
// (the far plane) when that product is NaN, 1 - t under reverse-Z.
float cube_compare_reference(float distance, float near, float inv_range, bool reverse_z) {
  const double q = (double(distance) - double(near)) * double(inv_range);
  const double t = std::isnan(q) ? 1.0 : std::clamp(q, 0.0, 1.0);
  return float(reverse_z ? 1.0 - t : t);
}

// Random distances from before the near plane to past the far one, so both clamps are reached,
// both conventions; then known points and infinite inputs. Tolerance: the GPU rounds
// distance - near and the product (2 roundings of a t <= 1: 2^-23), and 1 - t rounds by at most
// 2^-25 (exact for t >= 0.5): 2^-22 covers both; a clamped t is exact.
TEST_F(LocalShadowTest, CubeCompareDepthIsTheClampedLinearDistance) {
  ShaderFunction<float(float, float, float, bool)> f(kLocal, "cube_compare_depth");
  const float inf = std::numeric_limits<float>::infinity();
  Rng rng(1304);
  std::vector<std::tuple<float, float, float, bool>> cases;
  for (int i = 0; i < 4096; ++i) {
    const double near = 0.01 + rng.next_unit(), far = near + 0.5 + 50.0 * rng.next_unit();
    const float distance = float(1.2 * far * rng.next_unit());
    cases.emplace_back(distance, float(near), float(1.0 / (far - near)), i % 2 == 0);
  }
  for (bool reverse_z : {true, false}) {
    cases.emplace_back(0.5f, 0.5f, 0.25f, reverse_z);  // at the near plane: t = 0
    cases.emplace_back(4.5f, 0.5f, 0.25f, reverse_z);  // at the far plane: t = 1
    cases.emplace_back(2.5f, 0.5f, 0.25f, reverse_z);  // half-way: t = 0.5
    cases.emplace_back(inf, 0.5f, 0.25f, reverse_z);   // infinitely far: t = 1
    cases.emplace_back(-inf, 0.5f, 0.25f, reverse_z);  // t = 0
    cases.emplace_back(2.5f, 0.5f, inf, reverse_z);    // a zero range: t = 1
    cases.emplace_back(0.25f, 0.5f, inf, reverse_z);   // before the near plane of it: t = 0
  }
  std::vector<float> want;
  for (const auto& [distance, near, inv_range, reverse_z] : cases)
    want.push_back(cube_compare_reference(distance, near, inv_range, reverse_z));
  const auto got = f.run(cases);
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::absolute(0x1p-22),
                           [&](size_t i) { return format_tuple(cases[i]); });
  // Both clamps and the interior are reached.
  size_t low = 0, high = 0;
  for (const auto& [distance, near, inv_range, reverse_z] : cases) {
    const double q = (double(distance) - double(near)) * double(inv_range);
    low += q < 0.0;
    high += q > 1.0;
  }
  EXPECT_GT(low, 100u);
  EXPECT_GT(high, 100u);
}

// A product (distance - near) * inv_range that is NaN (a NaN input, inf * 0, inf - inf) counts as
// the far plane: 1, 0 under reverse-Z. Exact: no arithmetic reaches the result.
TEST_F(LocalShadowTest, CubeCompareDepthOfANaNIsTheFarPlane) {
  ShaderFunction<float(float, float, float, bool)> f(kLocal, "cube_compare_depth");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<std::tuple<float, float, float, bool>> cases;
  for (bool reverse_z : {true, false}) {
    cases.emplace_back(nan, 0.5f, 0.25f, reverse_z);  // NaN distance
    cases.emplace_back(2.5f, nan, 0.25f, reverse_z);  // NaN near
    cases.emplace_back(2.5f, 0.5f, nan, reverse_z);   // NaN inverse range
    cases.emplace_back(inf, 0.5f, 0.0f, reverse_z);   // inf * 0
    cases.emplace_back(inf, inf, 0.25f, reverse_z);   // inf - inf
  }
  std::vector<float> want;
  for (const auto& [distance, near, inv_range, reverse_z] : cases)
    want.push_back(cube_compare_reference(distance, near, inv_range, reverse_z));
  PENUMBRA_EXPECT_ALL_NEAR(want, f.run(cases), Tolerance::exact(),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

// ---- PCSS of spot lights (2D array maps) and point lights (cube arrays) ------------------------
//
// Both against one reference written from local_shadow.glsl's header with filter_ref.hpp's taps:
// search radius R (z_r - near) / (z_r near texel_at_unit) clamped to [min_filter + 1,
// max(max_search, min_filter + 1)]; blocker search with nearest reads (filter_ref); lit without
// blockers; the mean blocker depth made a distance (spot: the projection's view distance; cube:
// near + t (far - near)); filter radius R (z_r - z_b) / (z_r z_b texel_at_unit) clamped to
// [min_filter, max(max_filter, min_filter)] and to the search radius; shadowed when every search
// tap is a blocker; else the Vogel disk PCF of the compare taps, faded by the confidence. The
// sample positions come back from noise.glsl (and the cube's tap basis from local_shadow.glsl),
// tested in their own files, so this checks the composition, the radii and the taps.
//
// Tolerance per case. The bilinear compare taps: 2 * 2^-subTexelPrecisionBits, plus 2e-4 for
// float tap positions (as pcss_tests.cpp). The filter radius depends on the GPU's float mean of
// the blockers' depths (a sum of k depths, then a division: within (k + 4) 2^-24 relative) made a
// distance (within 8 ULP), which the radius amplifies by R / (t z_b^2) (a perspective depth makes
// the distance itself more sensitive): the reference evaluates the radius at both ends of that
// range, plus 1e-5 of R / (z_b t) for the radius' own float operations (a few ULP each, and the
// rounding of z_r - z_b). A filter radius off by dr moves every filter tap by at most dr texels,
// and a bilinear compare tap by at most |dx| + |dy| <= 2 dr: the value by at most 2 c dr with c
// the confidence. Searches with a tap within 1e-3 texel of an edge between differing texels are
// skipped, as in pcss_tests.cpp.

struct LocalPcssExpected {
  double value = 1.0;
  double tolerance = 0.0;
  bool ambiguous = false;
  int blockers = 0;
  bool filtered = false;  // took the filtering path (some but not all search taps blockers)
};

LocalPcssExpected local_pcss_reference(const filter_ref::DepthMap& m, glm::dvec2 uv, float receiver,
                                       double receiver_distance, const Local& p,
                                       std::span<const glm::dvec2> search_offsets,
                                       std::span<const glm::dvec2> filter_offsets, bool reverse_z,
                                       const std::function<double(double)>& distance_of,
                                       double base_tolerance) {
  LocalPcssExpected e;
  if (!filter_ref::in_map(uv, receiver)) return e;
  const float d = filter_ref::clamp_depth(receiver);
  const double zr = receiver_distance, R = p.light_radius, t = p.texel_at_unit;
  const double lo = std::max<double>(p.min_filter_texels, 0.0) + 1.0;
  const double search = std::clamp(R * (zr - p.near) / (zr * p.near * t), lo,
                                   std::max<double>(p.max_search_texels, lo));
  const auto s = filter_ref::blocker_search(m, uv, d, search_offsets, search, reverse_z);
  e.ambiguous = s.ambiguous;
  e.blockers = s.count;
  if (s.count == 0) return e;
  const int n = int(search_offsets.size());
  if (s.count == n) {  // the filter never outgrows the search: fully shadowed
    e.value = 0.0;
    return e;
  }
  const double fmin = std::max<double>(p.min_filter_texels, 0.0);
  const double fmax = std::max<double>(p.max_filter_texels, fmin);
  const auto radius = [&](double zb) {
    return std::min(std::clamp(R * (zr - zb) / (zr * zb * t), fmin, fmax), search);
  };
  const double mean_error = (s.count + 4) * 0x1p-24, distance_error = 8 * 0x1p-23;
  const double zb = distance_of(s.average);
  const double zb_a = distance_of(s.average * (1 - mean_error)) * (1 - distance_error);
  const double zb_b = distance_of(s.average * (1 + mean_error)) * (1 + distance_error);
  const double r = radius(zb);
  const double dr = std::abs(radius(zb_a) - radius(zb_b)) + 1e-5 * R / (std::min(zb_a, zb_b) * t);
  const double filtered = filter_ref::disk_pcf(m, uv, d, filter_offsets, r, reverse_z);
  const double c = filter_ref::confidence(s.count, n, p.confidence_fraction);
  e.filtered = true;
  e.value = 1.0 - c * (1.0 - filtered);
  e.tolerance = base_tolerance + 2.0 * c * dr;
  return e;
}

double compare_tap_bound() {
  return 2.0 * std::ldexp(1.0, -int(shared_context().info().limits.subTexelPrecisionBits));
}

// want[i] within tolerance[i] of got[i]: the expected values handed to the comparison are got
// clamped into [want - tolerance, want + tolerance], so an exact comparison reports the cases
// outside with the end they missed.
std::vector<float> clamp_into(const std::vector<LocalPcssExpected>& want,
                              const std::vector<float>& got) {
  std::vector<float> out;
  for (size_t i = 0; i < want.size(); ++i) {
    const double lo = want[i].value - want[i].tolerance, hi = want[i].value + want[i].tolerance;
    out.push_back(std::isnan(got[i]) ? float(want[i].value)
                                     : float(std::clamp(double(got[i]), lo, hi)));
  }
  return out;
}

// A depth map of `layers` layers (or cube faces) through a compare sampler (linear, the
// convention's compare) or a raw one (nearest).
std::shared_ptr<Texture> local_depth_texture(const std::vector<filter_ref::DepthMap>& maps,
                                             bool compare, bool reverse_z, bool cube) {
  DepthTextureDesc d;
  d.width = uint32_t(maps[0].width);
  d.height = uint32_t(maps[0].height);
  d.layers = uint32_t(cube ? maps.size() / 6 : maps.size());
  d.array = true;
  d.cube = cube;
  d.sampler.compare = compare;
  d.sampler.filter = compare ? VK_FILTER_LINEAR : VK_FILTER_NEAREST;
  d.sampler.compare_op = reverse_z ? VK_COMPARE_OP_GREATER_OR_EQUAL : VK_COMPARE_OP_LESS_OR_EQUAL;
  std::vector<float> all;
  for (const auto& m : maps) all.insert(all.end(), m.depth.begin(), m.depth.end());
  return make_depth_texture(d, all);
}

// A ground at stored depth `ground` with `boxes` rectangles (2..20 texels a side) of blockers,
// each at stored_of(distance) for a distance in [box_near, box_far].
filter_ref::DepthMap local_scene(Rng& rng, int size, int boxes, float ground, double box_near,
                                 double box_far, const std::function<float(double)>& stored_of) {
  filter_ref::DepthMap m{size, size, std::vector<float>(size_t(size * size), ground)};
  for (int b = 0; b < boxes; ++b) {
    const int w = 2 + int(rng.below(19)), h = 2 + int(rng.below(19));
    const int x0 = int(rng.below(uint64_t(size))), y0 = int(rng.below(uint64_t(size)));
    const float depth = stored_of(box_near + (box_far - box_near) * rng.next_unit());
    for (int y = y0; y < std::min(size, y0 + h); ++y)
      for (int x = x0; x < std::min(size, x0 + w); ++x) m.depth[size_t(y * size + x)] = depth;
  }
  return m;
}

Local random_local_params(Rng& rng, double texel_at_unit, double near, double far) {
  Local p;
  p.light_radius = float(0.05 + 0.35 * rng.next_unit());
  p.texel_at_unit = float(texel_at_unit);
  p.near = float(near);
  p.far = float(far);
  p.max_search_texels = float(4.0 + 12.0 * rng.next_unit());
  p.min_filter_texels = float(2.0 * rng.next_unit());
  p.max_filter_texels = float(4.0 + 12.0 * rng.next_unit());
  p.confidence_fraction = rng.bernoulli(0.2) ? 0.0f : float(0.5 * rng.next_unit());
  return p;
}

// How many cases took each path; every path must be exercised.
struct PathCounts {
  size_t compared = 0, skipped = 0, lit = 0, shadowed = 0, filtered = 0;
  void add(const LocalPcssExpected& e) {
    ++compared;
    lit += e.blockers == 0;
    shadowed += e.blockers > 0 && !e.filtered;
    filtered += e.filtered;
  }
};

// Compares each case's result with its reference (expected(i)), leaving out the cases whose
// search taps sit too near a texel edge to call (ambiguous), and checks that every path was
// taken often enough to mean something: few left out, some lit, some shadowed without
// filtering, most filtered.
template <class Cases, class Expected>
void expect_pcss_matches_reference(const Cases& cases, const std::vector<float>& got,
                                   bool reverse_z, Expected expected) {
  std::vector<LocalPcssExpected> want;
  std::vector<float> got_checked;
  std::vector<size_t> index;
  PathCounts paths;
  for (size_t i = 0; i < cases.size(); ++i) {
    const LocalPcssExpected e = expected(i);
    if (e.ambiguous) {
      ++paths.skipped;
      continue;
    }
    paths.add(e);
    want.push_back(e);
    got_checked.push_back(got[i]);
    index.push_back(i);
  }
  PENUMBRA_EXPECT_ALL_NEAR(clamp_into(want, got_checked), got_checked, Tolerance::exact(),
                           [&](size_t k) { return format_tuple(cases[index[k]]); });
  std::cout << "[ local pcss ] " << (reverse_z ? "reverse-Z" : "standard") << ": compared "
            << paths.compared << " of " << cases.size() << " (" << paths.lit << " no-blocker, "
            << paths.shadowed << " all-blocker, " << paths.filtered << " filtered)\n";
  EXPECT_LT(paths.skipped, cases.size() / 10);
  EXPECT_GT(paths.lit, cases.size() / 50);
  EXPECT_GT(paths.shadowed, cases.size() / 100);
  EXPECT_GT(paths.filtered, cases.size() / 2);
}

using SpotPcss = ShaderFunction<float(Sampler2DArrayShadow, Sampler2DArray, glm::vec3, int32_t,
                                      glm::vec2, float, Local, int32_t, float, bool, glm::vec2)>;

// Three layers, each its own scene (ground 8, 12 or 16 m from a 90-degree spot, boxes of
// blockers between 1 m and 90% of that), 128 texels a side; receivers just in front of the
// ground (a depth bias' worth) or anywhere in front of it, both conventions, every tier, and a
// few outside the map (lit). Each layer's result is the reference's on that layer's map: a
// function reading another layer misses by far more than the tolerance.
TEST_F(LocalShadowTest, SpotPcssArrayMatchesTheReferenceOnEachLayer) {
  constexpr int size = 128;
  constexpr double near = 0.5, far = 40.0, texel_at_unit = 2.0 / size;  // tan(45 deg) = 1
  const double grounds[3] = {8.0, 12.0, 16.0};
  Rng rng(1305);
  for (bool reverse_z : {true, false}) {
    SCOPED_TRACE(reverse_z ? "reverse-Z" : "standard depth");
    const auto stored_of = [&](double z) {
      return float(reference::depth_from_view_distance(z, near, far, reverse_z));
    };
    const auto distance_of = [&](double depth) {
      return double(reference::view_distance_from_depth(depth, near, far, reverse_z));
    };
    std::vector<filter_ref::DepthMap> layers;
    for (double ground : grounds)
      layers.push_back(local_scene(rng, size, 60, stored_of(ground), 1.0, 0.9 * ground, stored_of));
    SpotPcss pcss(kLocal, "pcss_spot_shadow_array");
    pcss.bind(0, local_depth_texture(layers, true, reverse_z, false))
        .bind(1, local_depth_texture(layers, false, reverse_z, false));
    const glm::vec2 texel(1.0f / size);
    std::vector<
        std::tuple<glm::vec3, int32_t, glm::vec2, float, Local, int32_t, float, bool, glm::vec2>>
        cases;
    std::vector<std::pair<int, float>> sets;
    for (int i = 0; i < 6000; ++i) {
      const int32_t layer = int32_t(rng.below(3));
      const double ground = grounds[layer];
      const double zr =
          rng.bernoulli(0.8) ? ground * 0.998 : ground * (0.3 + 0.69 * rng.next_unit());
      glm::vec3 coord(float(rng.next_unit()), float(rng.next_unit()), stored_of(zr));
      if (i < 8) coord.x = i % 2 ? -0.01f : 1.01f;  // outside the map: lit
      const int32_t tier = i % 3;
      const float rot = float(kTwoPi * rng.next_unit());
      cases.emplace_back(coord, layer, texel, float(zr),
                         random_local_params(rng, texel_at_unit, near, far), tier, rot, reverse_z,
                         glm::vec2(0.0f));
      sets.emplace_back(filter_ref::pcss_search_taps(tier), rot);
      sets.emplace_back(filter_ref::pcss_filter_taps(tier), rot);
    }
    const auto offsets = vogel_offsets(sets);
    const auto got = pcss.run(cases);
    const double base = compare_tap_bound() + 2e-4;
    expect_pcss_matches_reference(cases, got, reverse_z, [&](size_t i) {
      const auto& [c, layer, ts, zr, p, tier, rot, rz, g] = cases[i];
      return local_pcss_reference(layers[size_t(layer)], {c.x, c.y}, c.z, zr, p, offsets[2 * i],
                                  offsets[2 * i + 1], reverse_z, distance_of, base);
    });
  }
}

// A receiver on a tilted plane (the map stores the plane, standard depth: 0.5 + g . (uv - c))
// moved 0.001 towards the light: the flat search (plane_gradient 0) finds the plane's near half
// and shadows the receiver in part; given the plane's gradient it finds nothing and the receiver
// is exactly lit. The gradient reaches the search.
TEST_F(LocalShadowTest, SpotPcssArraySearchesAgainstTheReceiversPlane) {
  constexpr int n = 64;
  const glm::vec2 g(0.06f, -0.04f), c(0.5f, 0.5f);
  filter_ref::DepthMap lit{n, n, std::vector<float>(size_t(n * n), 0.9f)}, plane{n, n, {}};
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const glm::vec2 uv((float(x) + 0.5f) / float(n), (float(y) + 0.5f) / float(n));
      plane.depth.push_back(0.5f + glm::dot(g, uv - c));
    }
  SpotPcss pcss(kLocal, "pcss_spot_shadow_array");
  pcss.bind(0, local_depth_texture({lit, plane}, true, false, false))
      .bind(1, local_depth_texture({lit, plane}, false, false, false));
  Local p;
  p.light_radius = 0.3f;
  p.texel_at_unit = 2.0f / n;
  p.near = 0.5f;
  p.far = 40.0f;
  p.max_search_texels = 10.0f;
  p.min_filter_texels = 1.0f;
  p.max_filter_texels = 10.0f;
  const float depth = 0.5f - 0.001f;
  const float zr = float(reference::view_distance_from_depth(depth, 0.5, 40.0, false));
  const glm::vec3 coord(c, depth);
  const glm::vec2 texel(1.0f / n);
  for (int32_t tier : {0, 1, 2}) {
    SCOPED_TRACE("tier " + std::to_string(tier));
    const float flat = pcss(coord, 1, texel, zr, p, tier, 0.4f, false, glm::vec2(0.0f));
    EXPECT_LT(flat, 0.99f);
    EXPECT_EQ(pcss(coord, 1, texel, zr, p, tier, 0.4f, false, g), 1.0f);
    EXPECT_EQ(pcss(coord, 0, texel, zr, p, tier, 0.4f, false, glm::vec2(0.0f)), 1.0f);
  }
}

using CubePcss = ShaderFunction<float(SamplerCubeArrayShadow, SamplerCubeArray, glm::vec3, int32_t,
                                      float, float, float, Local, int32_t, float, bool, glm::vec3)>;

// The face and (u, v) of direction w (Vulkan's cube-map face selection: the major axis picks the
// face, +X, -X, +Y, -Y, +Z, -Z; u = (sc / |ma| + 1) / 2, v = (tc / |ma| + 1) / 2).
glm::dvec2 cube_face_uv(glm::dvec3 w, int& face) {
  const glm::dvec3 a = glm::abs(w);
  double sc, tc, ma;
  if (a.x >= a.y && a.x >= a.z) {
    face = w.x >= 0 ? 0 : 1;
    sc = w.x >= 0 ? -w.z : w.z;
    tc = -w.y;
    ma = a.x;
  } else if (a.y >= a.z) {
    face = w.y >= 0 ? 2 : 3;
    sc = w.x;
    tc = w.y >= 0 ? w.z : -w.z;
    ma = a.y;
  } else {
    face = w.z >= 0 ? 4 : 5;
    sc = w.z >= 0 ? w.x : -w.x;
    tc = -w.y;
    ma = a.z;
  }
  return {0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0)};
}

// Point lights: four cubes of 64 texels per face, every face its own scene (ground 6-18 m away,
// boxes between 0.5 m and 90% of that), near 0.1, far 20. The receivers look along the six axes
// from the light, at every distance the ground allows, through the whole pipeline of
// pcss_cube_shadow_array (flat search). Along an axis the taps' basis lies in the face's plane,
// so the tap at Vogel offset o, radius r, is the face's texel-space point centre + J o r, J the
// linear map from that plane to the face's texels (read off cube_face_uv for the basis of
// cube_tangent_basis); the taps stay inside the face (16 texels at most from its centre), so the
// 2D reference on that face is the cube's value. Most cases take the filtering path (some but
// not all search taps blockers), which cube_shadow_tests.cpp does not reach.
TEST_F(LocalShadowTest, CubePcssArrayMatchesTheReferenceOnEachFace) {
  constexpr int n = 64, cubes = 4;
  constexpr double near = 0.1, far = 20.0;
  Rng rng(1306);
  ShaderFunction<void(glm::vec3, Out<glm::vec3>, Out<glm::vec3>)> basis(kLocal,
                                                                        "cube_tangent_basis");
  const glm::vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (bool reverse_z : {true, false}) {
    SCOPED_TRACE(reverse_z ? "reverse-Z" : "standard depth");
    const auto stored_of = [&](double z) {
      const double t = std::clamp((z - near) / (far - near), 0.0, 1.0);
      return float(reverse_z ? 1.0 - t : t);
    };
    const auto distance_of = [&](double stored) {
      return near + (reverse_z ? 1.0 - stored : stored) * (far - near);
    };
    std::vector<filter_ref::DepthMap> faces;
    std::vector<double> ground;
    for (int f = 0; f < 6 * cubes; ++f) {
      ground.push_back(6.0 + 12.0 * rng.next_unit());
      faces.push_back(
          local_scene(rng, n, 25, stored_of(ground.back()), 0.5, 0.9 * ground.back(), stored_of));
    }
    CubePcss pcss(kLocal, "pcss_cube_shadow_array");
    pcss.bind(0, local_depth_texture(faces, true, reverse_z, true))
        .bind(1, local_depth_texture(faces, false, reverse_z, true));
    // J of each face: the texel-space step of a unit step along t and along b.
    glm::dmat2 jacobian[6];
    for (int a = 0; a < 6; ++a) {
      const auto [t, b] = basis(axes[a]);
      int face = -1;
      const glm::dvec2 o = cube_face_uv(glm::dvec3(axes[a]), face);
      EXPECT_EQ(face, a);
      jacobian[a] = glm::dmat2(
          (cube_face_uv(glm::dvec3(axes[a]) + 2.0 / n * glm::dvec3(t), face) - o) * double(n),
          (cube_face_uv(glm::dvec3(axes[a]) + 2.0 / n * glm::dvec3(b), face) - o) * double(n));
    }
    std::vector<
        std::tuple<glm::vec3, int32_t, float, float, float, Local, int32_t, float, bool, glm::vec3>>
        cases;
    std::vector<std::pair<int, float>> sets;
    std::vector<int> face_of;
    for (int i = 0; i < 6000; ++i) {
      const int32_t cube = int32_t(rng.below(cubes));
      const int a = int(rng.below(6));
      const double g = ground[size_t(6 * cube + a)];
      const float zr = float(rng.bernoulli(0.8) ? g * 0.998 : g * (0.3 + 0.69 * rng.next_unit()));
      const float ref = stored_of(zr);
      const int32_t tier = i % 3;
      const float rot = float(kTwoPi * rng.next_unit());
      cases.emplace_back(axes[a] * zr, cube, ref, zr, float(n),
                         random_local_params(rng, 2.0 / n, near, far), tier, rot, reverse_z,
                         glm::vec3(0.0f));
      sets.emplace_back(filter_ref::pcss_search_taps(tier), rot);
      sets.emplace_back(filter_ref::pcss_filter_taps(tier), rot);
      face_of.push_back(6 * cube + a);
    }
    auto offsets = vogel_offsets(sets);
    for (size_t i = 0; i < cases.size(); ++i) {
      const int a = face_of[i] % 6;
      for (auto* set : {&offsets[2 * i], &offsets[2 * i + 1]})
        for (glm::dvec2& o : *set) o = jacobian[a] * o;
    }
    const auto got = pcss.run(cases);
    const double base = compare_tap_bound() + 2e-4;
    expect_pcss_matches_reference(cases, got, reverse_z, [&](size_t i) {
      const auto& [dir, cube, ref, zr, res, p, tier, rot, rz, normal] = cases[i];
      return local_pcss_reference(faces[size_t(face_of[i])], {0.5, 0.5}, ref, zr, p, offsets[2 * i],
                                  offsets[2 * i + 1], reverse_z, distance_of, base);
    });
  }
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

// local_nonneg: the guard every local-light parameter goes through.
TEST_F(LocalShadowTest, NonNegativeCopyOfNonFiniteOrNegativeIsZero) {
  ShaderFunction<float(float)> f(kLocal, "local_nonneg");
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<std::tuple<float>> cases{
      {std::numeric_limits<float>::quiet_NaN()}, {inf}, {-inf}, {-1.0f}, {0.0f}, {2.5f}};
  EXPECT_EQ(f.run(cases), (std::vector<float>{0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 2.5f}));
}

// cube_tangent_basis: with normalize(dir), a right-handed orthonormal basis for any direction
// (Duff et al.'s branchless form), including the sign switch at z = 0 and next to -Z.
TEST_F(LocalShadowTest, TangentBasisIsRightHandedAndOrthonormalEverywhere) {
  ShaderFunction<void(glm::vec3, Out<glm::vec3>, Out<glm::vec3>)> basis(kLocal,
                                                                        "cube_tangent_basis");
  Rng rng(0x7A16);
  std::vector<std::tuple<glm::vec3>> cases;
  for (int i = 0; i < 2000; ++i) {
    const glm::vec3 d = unit_vector3()(rng) * float(0.01 + 100.0 * rng.next_unit());
    cases.emplace_back(i % 5 == 0 ? glm::vec3(d.x, d.y, 0.0f) : d);
  }
  cases.emplace_back(glm::vec3(0.0f, 1e-4f, -1.0f));
  cases.emplace_back(glm::vec3(1.0f, 0.0f, 0.0f));
  // A zero or non-finite direction gives the basis of +Z.
  for (const glm::vec3& bad :
       {glm::vec3(0.0f), glm::vec3(std::numeric_limits<float>::infinity(), 0.0f, 0.0f)}) {
    const auto [t, b] = basis(bad);
    EXPECT_EQ(t, glm::vec3(1.0f, 0.0f, 0.0f));
    EXPECT_EQ(b, glm::vec3(0.0f, 1.0f, 0.0f));
  }
  const auto got = basis.run(cases);
  for (std::size_t i = 0; i < got.size(); ++i) {
    const glm::dvec3 n = glm::normalize(glm::dvec3(std::get<0>(cases[i])));
    const auto [t32, b32] = got[i];
    const glm::dvec3 t(t32), b(b32);
    SCOPED_TRACE(format_tuple(cases[i]));
    EXPECT_NEAR(glm::length(t), 1.0, 1e-5);
    EXPECT_NEAR(glm::length(b), 1.0, 1e-5);
    EXPECT_NEAR(glm::dot(t, b), 0.0, 1e-5);
    EXPECT_NEAR(glm::dot(t, n), 0.0, 1e-5);
    EXPECT_NEAR(glm::dot(b, n), 0.0, 1e-5);
    EXPECT_NEAR(glm::dot(glm::cross(t, b), n), 1.0, 1e-5);
  }
}

// A point light (radius 0) has search radius 0, clamped up to min_filter + 1, even where the
// quotient's denominator is 0 too (near 0, a receiver at the light): 0 / 0 must not reach the
// clamp (a NaN radius means the largest search).
TEST_F(LocalShadowTest, PointLightSearchRadiusIsTheLowerBoundEvenOverZero) {
  ShaderFunction<float(float, Local)> search(kLocal, "pcss_local_search_radius_texels");
  Local p;
  p.light_radius = 0.0f;
  p.texel_at_unit = 0.002f;
  p.near = 0.0f;
  p.far = 20.0f;
  p.max_search_texels = 16.0f;
  p.min_filter_texels = 1.0f;
  p.max_filter_texels = 8.0f;
  p.confidence_fraction = 0.25f;
  EXPECT_EQ(search(5.0f, p), 2.0f);
  EXPECT_EQ(search(0.0f, p), 2.0f);
  p.near = 0.5f;
  EXPECT_EQ(search(5.0f, p), 2.0f);
}

}  // namespace
}  // namespace penumbra::testing
