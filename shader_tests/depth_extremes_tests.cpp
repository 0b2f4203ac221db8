// Extremes of shaders/penumbra/depth.glsl, both depth conventions: depth exactly 0 and 1 (-0
// too), infinite far planes, out-of-range and non-finite depths (never NaN), extreme plane
// ratios (near 1e-4 / far 1e6, 1e-20 / 1e20, far = near + 1 ulp), view distances 0 and
// infinity, NDC/UV overflow.
//
// NaN and infinity inputs: by default Vulkan lets an implementation optimise as if no value were
// NaN or infinite (only the SignedZeroInfNanPreserve execution mode forbids it), so what these
// tests check for such inputs is the documented behaviour of the shader code on drivers that keep
// IEEE semantics (lavapipe and NVIDIA's do). Division of a non-zero by zero giving the signed
// infinity is required of every implementation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "reference/depth_ref.hpp"
#include "reference/noise_ref.hpp"

namespace penumbra::testing {
namespace {

namespace ref = penumbra::reference;
using ref::kRoundingRel;

constexpr const char* kDepth = "penumbra/depth.glsl";
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kMax = std::numeric_limits<float>::max();
constexpr float kDenormMin = std::numeric_limits<float>::denorm_min();

// As in depth_tests.cpp: 6.5 roundings (linearize_depth, view_distance_to_depth), 3.5
// (linearize_depth_infinite); 1.001 for second-order terms.
constexpr double kLinearizeRel = 6.5 * kRoundingRel * 1.001;
constexpr double kLinearizeInfiniteRel = 3.5 * kRoundingRel * 1.001;

struct Planes {
  float near, far;
};
// Typical; the extreme pair of the brief; a 1e38 ratio (the largest far whose products z * (far -
// near) stay finite for z up to far: far^2 < 3.4e38); far one float above near (far - near =
// 2^-23 exactly).
const std::vector<Planes> kPlanes = {
    {0.1f, 1000.0f}, {1e-4f, 1e6f}, {1e-20f, 1e18f}, {1.0f, 1.00000012f}};

std::string describe(float x, float near, float far, bool reverse_z) {
  return format_value(x) + " (" + (reverse_z ? "reverse-Z" : "standard-Z") + " near " +
         format_value(near) + " far " + format_value(far) + ")";
}

class DepthExtremesTest : public GpuTest {};

// Reverse-Z: depth 0 is the far plane and 1 the near plane; standard-Z the other way round. -0
// is depth 0. Within linearize's 6.5 * 2^-23 of the planes (a device's division need not give
// near * far / near = far exactly).
TEST_F(DepthExtremesTest, DepthZeroAndOneAreThePlanes) {
  ShaderFunction<float(float, float, float, bool)> linearize(kDepth, "linearize_depth");
  std::vector<std::tuple<float, float, float, bool>> cases;
  std::vector<double> want;
  for (const Planes& p : kPlanes) {
    for (const bool reverse_z : {true, false}) {
      for (const float d : {0.0f, -0.0f, 1.0f}) {
        cases.emplace_back(d, p.near, p.far, reverse_z);
        want.push_back((d == 1.0f) == reverse_z ? p.near : p.far);
      }
    }
  }
  const std::vector<float> got = linearize.run(cases);
  std::vector<double> actual(got.begin(), got.end()), bounds;
  for (double w : want) bounds.push_back(kLinearizeRel * w);
  EXPECT_TRUE(ref::all_within_bounds(want, actual, bounds, [&](size_t i) {
    const auto [d, near, far, reverse_z] = cases[i];
    return "d = " + describe(d, near, far, reverse_z);
  }));
}

// Linearization over the extreme plane pairs, against the long double projection inverse.
TEST_F(DepthExtremesTest, LinearizeDepthWithExtremePlanes) {
  ShaderFunction<float(float, float, float, bool)> linearize(kDepth, "linearize_depth");
  Rng rng(0xE27001);
  std::vector<std::tuple<float, float, float, bool>> cases;
  for (const Planes& p : kPlanes) {
    for (const auto c : {DepthConvention::reverse_z, DepthConvention::standard}) {
      const auto depth = depth_extremes(c, {.near = p.near, .far = p.far});
      for (int i = 0; i < 4096; ++i) {
        cases.emplace_back(depth(rng), p.near, p.far, c == DepthConvention::reverse_z);
      }
    }
  }
  const std::vector<float> got = linearize.run(cases);
  std::vector<double> want, actual(got.begin(), got.end()), bounds;
  for (const auto& [d, near, far, reverse_z] : cases) {
    const ref::BoundedValue z = ref::linearize_expectation(d, near, far, reverse_z, kLinearizeRel);
    want.push_back(z.value);
    bounds.push_back(z.bound);
  }
  EXPECT_TRUE(ref::all_within_bounds(want, actual, bounds, [&](size_t i) {
    const auto [d, near, far, reverse_z] = cases[i];
    return "d = " + describe(d, near, far, reverse_z);
  }));
}

// An infinite far plane: its depth (0 reverse, 1 standard, -0 too) and a NaN depth give +inf
// exactly, never NaN; the near plane's depth gives near.
TEST_F(DepthExtremesTest, InfiniteFarPlaneDepthIsPositiveInfinity) {
  ShaderFunction<float(float, float, bool)> linearize(kDepth, "linearize_depth_infinite");
  for (const float near : {1e-4f, 0.1f, 1.0f}) {
    EXPECT_EQ(linearize(0.0f, near, true), kInf) << near;
    EXPECT_EQ(linearize(-0.0f, near, true), kInf) << near;
    EXPECT_EQ(linearize(kNaN, near, true), kInf) << near;
    EXPECT_EQ(linearize(1.0f, near, false), kInf) << near;
    EXPECT_EQ(linearize(kNaN, near, false), kInf) << near;
    EXPECT_NEAR(linearize(1.0f, near, true), near, kLinearizeInfiniteRel * near) << near;
    EXPECT_NEAR(linearize(0.0f, near, false), near, kLinearizeInfiniteRel * near) << near;
    EXPECT_NEAR(linearize(-0.0f, near, false), near, kLinearizeInfiniteRel * near) << near;
    // The smallest positive depth: near / 2^-149 overflows (or, flushed to 0, is the far plane):
    // +inf or the largest float, never NaN.
    const float tiny = linearize(kDenormMin, near, true);
    EXPECT_TRUE(tiny == kInf || tiny == kMax || tiny > 1e30f) << near << " -> " << tiny;
  }
}

// Depths outside [0, 1] are clamped and a NaN depth is the far plane, for both conventions and
// both far-plane kinds: each result equals (bit for bit) that of the clamped depth, and none is
// NaN.
TEST_F(DepthExtremesTest, OutOfRangeAndNonFiniteDepthsAreClampedNeverNaN) {
  ShaderFunction<float(float, float, float, bool)> linearize(kDepth, "linearize_depth");
  ShaderFunction<float(float, float, bool)> linearize_infinite(kDepth, "linearize_depth_infinite");
  const std::vector<std::pair<float, float>> odd = {
      // {depth, the depth it must act as; NaN: the far plane's}
      {-1e-7f, 0.0f},
      {std::nextafter(0.0f, -1.0f), 0.0f},
      {-1.0f, 0.0f},
      {-kMax, 0.0f},
      {-kInf, 0.0f},
      {1.0f + 1e-7f, 1.0f},
      {std::nextafter(1.0f, 2.0f), 1.0f},
      {2.0f, 1.0f},
      {kMax, 1.0f},
      {kInf, 1.0f},
      {kNaN, kNaN}};
  std::vector<std::tuple<float, float, float, bool>> cases, clamped;
  std::vector<std::tuple<float, float, bool>> cases_inf, clamped_inf;
  for (const Planes& p : kPlanes) {
    for (const bool reverse_z : {true, false}) {
      for (const auto& [d, as] : odd) {
        const float target = std::isnan(as) ? (reverse_z ? 0.0f : 1.0f) : as;
        cases.emplace_back(d, p.near, p.far, reverse_z);
        clamped.emplace_back(target, p.near, p.far, reverse_z);
        cases_inf.emplace_back(d, p.near, reverse_z);
        clamped_inf.emplace_back(target, p.near, reverse_z);
      }
    }
  }
  const std::vector<float> got = linearize.run(cases);
  PENUMBRA_EXPECT_ALL_NEAR(linearize.run(clamped), got, Tolerance::exact(), [&](size_t i) {
    const auto [d, near, far, reverse_z] = cases[i];
    return "d = " + describe(d, near, far, reverse_z);
  });
  const std::vector<float> got_inf = linearize_infinite.run(cases_inf);
  PENUMBRA_EXPECT_ALL_NEAR(linearize_infinite.run(clamped_inf), got_inf, Tolerance::exact(),
                           [&](size_t i) {
                             const auto [d, near, reverse_z] = cases_inf[i];
                             return "d = " + describe(d, near, kInf, reverse_z);
                           });
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_FALSE(std::isnan(got[i])) << format_tuple(cases[i]);
    EXPECT_FALSE(std::isnan(got_inf[i])) << format_tuple(cases_inf[i]);
  }
}

// Every extreme float as a depth, every plane pair and convention: never NaN, always within
// [near, far] (up to the 6.5 * 2^-23 rounding) for a finite far plane.
TEST_F(DepthExtremesTest, LinearizedDepthIsNeverNaNAndStaysBetweenThePlanes) {
  ShaderFunction<float(float, float, float, bool)> linearize(kDepth, "linearize_depth");
  const std::vector<float> specials = extreme_float_values({.nan_inf = true});
  std::vector<std::tuple<float, float, float, bool>> cases;
  for (const Planes& p : kPlanes) {
    for (const bool reverse_z : {true, false}) {
      for (const float d : specials) cases.emplace_back(d, p.near, p.far, reverse_z);
    }
  }
  const std::vector<float> got = linearize.run(cases);
  for (size_t i = 0; i < got.size(); ++i) {
    const auto [d, near, far, reverse_z] = cases[i];
    EXPECT_GE(got[i], near * (1.0 - kLinearizeRel)) << "d = " << describe(d, near, far, reverse_z);
    EXPECT_LE(got[i], far * (1.0 + kLinearizeRel)) << "d = " << describe(d, near, far, reverse_z);
  }
}

// view_distance_to_depth at a finite z so large that z * (far - near) overflows (from about 1e36
// when the range exceeds 1): the depth approaches its limit at infinity and stays finite. (The
// products' form gave inf / inf = NaN for standard-Z and -0 for reverse-Z there.) Bound: the
// ratios' form, range 1 rounding, far - z or z - near 1, two divisions 2.5 each, the product 1:
// 8 * 2^-23; a reverse-Z depth below FLT_MIN may be flushed.
TEST_F(DepthExtremesTest, ViewDistanceToDepthStaysFiniteWhereTheProductsOverflow) {
  ShaderFunction<float(float, float, float, bool)> to_depth(kDepth, "view_distance_to_depth");
  std::vector<std::tuple<float, float, float, bool>> cases;
  for (const auto& [near, far] : {std::pair{0.01f, 10.0f}, std::pair{0.1f, 1000.0f},
                                  std::pair{1.0f, 1e6f}, std::pair{1e-3f, 1e30f}})
    for (float z = 1e30f; z < kMax; z = z < kMax / 2.0f ? z * 2.0f : kMax)
      for (const bool reverse : {true, false}) cases.emplace_back(z, near, far, reverse);
  const auto got = to_depth.run(cases);
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [z, near, far, reverse] = cases[i];
    const double zd = z, n = near, f = far;
    const double want = reverse ? n * (f - zd) / (zd * (f - n)) : f * (zd - n) / (zd * (f - n));
    const double bound = std::max(8.0 * kRoundingRel * 1.001 * std::fabs(want), ref::kFlushFloor);
    ASSERT_TRUE(std::isfinite(got[i])) << "z " << z << " near " << near << " far " << far
                                       << (reverse ? " reverse" : " standard") << ": " << got[i];
    EXPECT_NEAR(got[i], want, bound)
        << "z " << z << " near " << near << " far " << far << (reverse ? " reverse" : " standard");
  }
}

// view_distance_to_depth at the planes (exact zeros where the difference vanishes), at z = 0
// (the signed infinity IEEE division gives) and at z = +inf or NaN (the limit at infinity).
TEST_F(DepthExtremesTest, ViewDistanceToDepthAtPlanesZeroAndInfinity) {
  ShaderFunction<float(float, float, float, bool)> to_depth(kDepth, "view_distance_to_depth");
  ShaderFunction<float(float, float, bool)> to_depth_inf(kDepth, "view_distance_to_depth_infinite");
  for (const Planes& p : kPlanes) {
    const std::string planes = describe(0.0f, p.near, p.far, true);
    // far - far and near - near are exactly 0: reverse-Z's far plane and standard-Z's near plane
    // are exactly depth 0 on every device.
    EXPECT_EQ(to_depth(p.far, p.near, p.far, true), 0.0f) << planes;
    EXPECT_EQ(to_depth(p.near, p.near, p.far, false), 0.0f) << planes;
    EXPECT_NEAR(to_depth(p.near, p.near, p.far, true), 1.0, kLinearizeRel) << planes;
    EXPECT_NEAR(to_depth(p.far, p.near, p.far, false), 1.0, kLinearizeRel) << planes;
    // z = 0: a non-zero divided by +0.
    EXPECT_EQ(to_depth(0.0f, p.near, p.far, true), kInf) << planes;
    EXPECT_EQ(to_depth(0.0f, p.near, p.far, false), -kInf) << planes;
    // z = +inf and NaN: the limits -near / (far - near) and far / (far - near) (the range
    // rounded once, the division 2.5 ULP: 3.5 * 2^-23).
    const double range = double{p.far} - double{p.near};
    const double reverse_limit = -double{p.near} / range, standard_limit = double{p.far} / range;
    // (A limit below FLT_MIN, reverse-Z's at far / near = 1e38, may be flushed to -0.)
    const double reverse_bound =
        std::max(3.5 * kRoundingRel * 1.001 * std::fabs(reverse_limit), ref::kFlushFloor);
    for (const float z : {kInf, kNaN}) {
      EXPECT_NEAR(to_depth(z, p.near, p.far, true), reverse_limit, reverse_bound)
          << planes << " z " << z;
      EXPECT_NEAR(to_depth(z, p.near, p.far, false), standard_limit,
                  3.5 * kRoundingRel * 1.001 * standard_limit)
          << planes << " z " << z;
    }
  }
  for (const float near : {1e-4f, 0.1f, 1.0f}) {
    EXPECT_EQ(to_depth_inf(kInf, near, true), 0.0f) << near;
    EXPECT_EQ(to_depth_inf(kInf, near, false), 1.0f) << near;
    EXPECT_EQ(to_depth_inf(kNaN, near, true), 0.0f) << near;
    EXPECT_EQ(to_depth_inf(kNaN, near, false), 1.0f) << near;
    EXPECT_EQ(to_depth_inf(0.0f, near, true), kInf) << near;
    EXPECT_EQ(to_depth_inf(0.0f, near, false), -kInf) << near;
    EXPECT_NEAR(to_depth_inf(near, near, true), 1.0, 2.5 * kRoundingRel) << near;
    EXPECT_NEAR(to_depth_inf(near, near, false), 0.0, 2.5 * kRoundingRel) << near;
  }
}

// NDC <-> UV is affine with no clamping: values outside [0, 1] / [-1, 1] map linearly,
// infinities stay infinities of the same sign, and an overflowing uv * 2 gives the infinity (or
// the largest float: Vulkan allows either when the exact result is beyond the range).
TEST_F(DepthExtremesTest, NdcUvAreUnclampedAndKeepInfinities) {
  ShaderFunction<glm::vec2(glm::vec2)> to_uv(kDepth, "ndc_to_uv");
  ShaderFunction<glm::vec2(glm::vec2)> to_ndc(kDepth, "uv_to_ndc");
  const std::vector<float> values = {-kInf, kInf, kMax, -kMax, 1e30f, -1e30f, 3.0f, -2.0f};
  std::vector<std::tuple<glm::vec2>> cases;
  for (const float v : values) cases.emplace_back(glm::vec2(v, -v));
  const std::vector<glm::vec2> uv = to_uv.run(cases), ndc = to_ndc.run(cases);
  std::vector<double> want_uv, got_uv, want_ndc, got_ndc, bound_uv, bound_ndc;
  for (size_t i = 0; i < cases.size(); ++i) {
    const glm::vec2 v = std::get<0>(cases[i]);
    for (int c = 0; c < 2; ++c) {
      want_uv.push_back(double{v[c]} * 0.5 + 0.5);
      got_uv.push_back(uv[i][c]);
      bound_uv.push_back(kRoundingRel * std::fabs(want_uv.back()));
      want_ndc.push_back(double{v[c]} * 2.0 - 1.0);
      got_ndc.push_back(ndc[i][c]);
      bound_ndc.push_back(kRoundingRel * std::fabs(want_ndc.back()));
    }
  }
  const auto describe_case = [&](size_t k) {
    return format_tuple(cases[k / 2]) + (k % 2 == 0 ? " .x" : " .y");
  };
  EXPECT_TRUE(ref::all_within_bounds(want_uv, got_uv, bound_uv, describe_case));
  EXPECT_TRUE(ref::all_within_bounds(want_ndc, got_ndc, bound_ndc, describe_case));
}

// Reconstruction at the planes, for the extreme planes near 1e-4, far 1e6: the precise route
// (linearize, then view_position_from_view_distance) puts depth 1 (reverse) / 0 (standard) on the
// near plane (view z = -near) and depth 0 / 1 on the far plane, in both conventions; the inverse
// matrix does too, except standard-Z's far plane, which its float matrix cannot represent.
TEST_F(DepthExtremesTest, ReconstructionAtThePlanes) {
  ShaderFunction<glm::vec3(glm::vec2, float, glm::mat4)> via_matrix(kDepth,
                                                                    "view_position_from_depth");
  ShaderFunction<float(float, float, float, bool)> linearize(kDepth, "linearize_depth");
  ShaderFunction<glm::vec3(glm::vec2, float, float, float)> via_distance(
      kDepth, "view_position_from_view_distance");
  const double near = 1e-4, far = 1e6, t = 1.0, aspect = 1.5;
  for (const bool reverse_z : {true, false}) {
    const glm::mat4 inv_proj(glm::inverse(ref::perspective(t, aspect, near, far, reverse_z)));
    for (const bool near_plane : {true, false}) {
      const float d = near_plane == reverse_z ? 1.0f : 0.0f;
      const double plane = near_plane ? near : far;
      const glm::vec2 uv(0.25f, 0.75f);
      const glm::dvec3 want = ref::view_position(glm::dvec2(uv), plane, t, aspect);
      const float z = linearize(d, static_cast<float>(near), static_cast<float>(far), reverse_z);
      const glm::vec3 precise =
          via_distance(uv, z, static_cast<float>(t), static_cast<float>(aspect));
      const glm::vec3 matrix = via_matrix(uv, d, inv_proj);
      const ref::BoundedPosition bounded = ref::inverse_projection_reconstruction(uv, d, inv_proj);
      const std::string what = std::string(reverse_z ? "reverse-Z" : "standard-Z") +
                               (near_plane ? " near plane" : " far plane");
      for (int c = 0; c < 3; ++c) {
        // precise: linearize's 6.5 roundings and the product chain's 4.
        EXPECT_NEAR(precise[c], want[c], (6.5 + 4.0) * kRoundingRel * 1.001 * std::fabs(want[c]))
            << what << " ."
            << "xyz"[c];
        if (std::isfinite(bounded.value[c])) {
          // matrix: its own derived bound around the double evaluation of the float matrix ...
          EXPECT_NEAR(matrix[c], bounded.value[c], bounded.bound[c]) << what << " ."
                                                                     << "xyz"[c];
          // ... which is the plane point up to the float inverse's rounding (host-side check).
          EXPECT_NEAR(bounded.value[c], want[c], 1e-6 * plane) << what << " ."
                                                               << "xyz"[c];
        } else {
          // Standard-Z with far / near = 1e10: the float inverse matrix's w row, 1 / near -
          // d (1 / near - 1 / far), has 1 / near - 1 / far round to 1 / near, so at d = 1 w is
          // exactly 0 and the matrix route has no finite answer: the far plane is lost in the
          // matrix itself. Reverse-Z's matrix keeps both planes.
          EXPECT_FALSE(reverse_z) << what << " ."
                                  << "xyz"[c];
          EXPECT_FALSE(std::isfinite(matrix[c])) << what << " ."
                                                 << "xyz"[c];
        }
      }
    }
  }
}

// ray_plane_point when the ray meets the plane exactly at the cap (max_stretch 1 and `through`
// on the plane: t = 1 exactly and the move is `through - p` itself, so |move| and the cap are the
// same length of the same vector): the move is not beyond the cap, so the hit, `through`, comes
// back exactly (eye + dir * 1 is exact for these small binary fractions).
TEST_F(DepthExtremesTest, RayPlanePointExactlyAtTheCapIsTheHit) {
  ShaderFunction<glm::vec3(glm::vec3, glm::vec3, glm::vec3, glm::vec3, float)> footprint(
      kDepth, "ray_plane_point");
  using Case = std::tuple<glm::vec3, glm::vec3, glm::vec3, glm::vec3, float>;
  const std::vector<Case> cases = {
      {{0.0f, 0.0f, 0.0f}, {1.0f, 0.0f, -2.0f}, {0.0f, 0.0f, -2.0f}, {0.0f, 0.0f, 1.0f}, 1.0f},
      {{0.5f, 1.0f, 0.0f}, {1.5f, 1.0f, -2.0f}, {0.5f, 1.0f, -2.0f}, {0.0f, 0.0f, 1.0f}, 1.0f},
      {{0.0f, 0.0f, 0.0f}, {3.0f, -0.25f, 0.0f}, {3.0f, 0.5f, 0.0f}, {-2.0f, 0.0f, 0.0f}, 1.0f},
      {{1.0f, 2.0f, 3.0f}, {1.0f, 6.0f, 3.75f}, {1.0f, 6.0f, 3.0f}, {0.0f, 0.5f, 0.0f}, 1.0f}};
  const std::vector<glm::vec3> got = footprint.run(cases);
  for (size_t i = 0; i < cases.size(); ++i)
    EXPECT_EQ(got[i], std::get<1>(cases[i]))
        << format_tuple(cases[i]) << " -> " << format_value(got[i]);
}

// ray_plane_point with `through` at the eye: no ray at all (dir = 0, so t = x / 0 and the hit
// are not finite) and no direction to move along, so the point stays at p, exactly.
TEST_F(DepthExtremesTest, RayPlanePointWithoutARayStaysAtThePoint) {
  ShaderFunction<glm::vec3(glm::vec3, glm::vec3, glm::vec3, glm::vec3, float)> footprint(
      kDepth, "ray_plane_point");
  using Case = std::tuple<glm::vec3, glm::vec3, glm::vec3, glm::vec3, float>;
  const std::vector<Case> cases = {
      {{0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, -2.0f}, {0.0f, 0.0f, 1.0f}, 1.0f},
      {{1.0f, 2.0f, 3.0f}, {1.0f, 2.0f, 3.0f}, {4.0f, -1.0f, 0.5f}, {0.0f, 0.6f, 0.8f}, 8.0f},
      {{-5.0f, 0.0f, 7.0f}, {-5.0f, 0.0f, 7.0f}, {-5.0f, 0.0f, 7.0f}, {1.0f, 0.0f, 0.0f}, 2.0f}};
  const std::vector<glm::vec3> got = footprint.run(cases);
  for (size_t i = 0; i < cases.size(); ++i)
    EXPECT_EQ(got[i], std::get<2>(cases[i]))
        << format_tuple(cases[i]) << " -> " << format_value(got[i]);
}

}  // namespace
}  // namespace penumbra::testing
