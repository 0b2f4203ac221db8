// Extremes of shaders/penumbra/bias.glsl: degenerate normals and light directions (zero,
// denormal, overflowing, NaN, Inf), N.L exactly 0, negative, NaN, tiny and above 1, huge slope
// scales, singular and non-finite receiver-plane Jacobians, and apply_depth_bias at the ends of
// the depth range in both conventions. Nothing may come out NaN or infinite.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <reference/bias_ref.hpp>
#include <string>
#include <tuple>
#include <vector>

namespace penumbra::testing {
namespace {

using L = std::numeric_limits<float>;
constexpr const char* kBias = "penumbra/bias.glsl";
constexpr double kU = 0x1p-24;
constexpr float kInf = L::infinity();
constexpr float kNaN = L::quiet_NaN();
// See bias_tests.cpp for the derivations.
const Tolerance kOffsetTolerance = Tolerance::absolute(128 * kU);
const Tolerance kSlopeTolerance = Tolerance::relative(32 * kU);

class BiasExtremesTest : public GpuTest {};

// Vectors no normalization can use: zero, signed zero, denormal in every component (which a GPU
// may flush to zero), NaN, infinite.
const std::vector<glm::vec3> kDegenerate = {
    glm::vec3(0.0f),
    glm::vec3(-0.0f, 0.0f, -0.0f),
    glm::vec3(L::denorm_min(), 0.0f, 0.0f),
    glm::vec3(1e-40f, -1e-40f, 1e-40f),
    glm::vec3(kNaN, 0.0f, 1.0f),
    glm::vec3(0.0f, 0.0f, -kNaN),
    glm::vec3(kInf, 0.0f, 0.0f),
    glm::vec3(0.0f, -kInf, 1.0f),
};

TEST_F(BiasExtremesTest, DegenerateNormalsGiveNoOffsetAndNeverNaN) {
  ShaderFunction<glm::vec3(glm::vec3, glm::vec3, float, float)> offset(kBias, "normal_offset");
  const std::vector<glm::vec3> lights = {glm::vec3(0, 1, 0), glm::vec3(1, 1, 0), glm::vec3(0.0f),
                                         glm::vec3(kNaN)};
  std::vector<std::tuple<glm::vec3, glm::vec3, float, float>> cases;
  for (const glm::vec3& n : kDegenerate) {
    for (const glm::vec3& l : lights) cases.emplace_back(n, l, 0.05f, 1.5f);
  }
  const auto got = offset.run(cases);
  for (std::size_t i = 0; i < cases.size(); ++i) {
    EXPECT_EQ(got[i], glm::vec3(0.0f)) << format_tuple(cases[i]) << " -> " << format_value(got[i]);
    EXPECT_EQ(ref::normal_offset(std::get<0>(cases[i]), std::get<1>(cases[i]), 0.05f, 1.5f),
              glm::dvec3(0.0))
        << "reference: " << format_tuple(cases[i]);
  }
}

// Normals and light directions of extreme but finite length, whose squared length under- or
// overflows a float (1e-20, 1e20, FLT_MAX, a smallest normal component), give the offset of their
// unit versions: the comment promises that neither needs to be unit length.
TEST_F(BiasExtremesTest, ExtremeLengthsGiveTheOffsetOfTheUnitVector) {
  ShaderFunction<glm::vec3(glm::vec3, glm::vec3, float, float)> offset(kBias, "normal_offset");
  const std::vector<glm::vec3> dirs = {
      glm::vec3(0.0f, 1e-20f, 0.0f),   glm::vec3(1e20f, 1e20f, 0.0f),
      glm::vec3(L::max(), 0.0f, 0.0f), glm::vec3(L::max(), L::max(), -L::max()),
      glm::vec3(1e-30f, 2e-30f, 0.0f), glm::vec3(0.0f, 0.0f, -L::min())};
  std::vector<std::tuple<glm::vec3, glm::vec3, float, float>> cases;
  std::vector<glm::vec3> want;
  const glm::vec3 light(0.3f, 1.0f, -0.2f);
  for (const glm::vec3& n : dirs) {
    const glm::vec3 unit(glm::normalize(glm::dvec3(n)));  // double: no under- or overflow
    cases.emplace_back(n, light, 0.05f, 1.5f);
    want.push_back(glm::vec3(ref::normal_offset(unit, light, 0.05f, 1.5f)));
    // The extreme vector as the light direction, under a generic normal.
    cases.emplace_back(light, n, 0.05f, 1.5f);
    want.push_back(glm::vec3(ref::normal_offset(light, unit, 0.05f, 1.5f)));
  }
  const auto got = offset.run(cases);
  PENUMBRA_EXPECT_ALL_NEAR(want, got, kOffsetTolerance,
                           [&](std::size_t i) { return format_tuple(cases[i]); });
  for (const glm::vec3& g : got) EXPECT_NE(g, glm::vec3(0.0f));
}

TEST_F(BiasExtremesTest, DegenerateLightDirectionsGiveTheFullOffset) {
  // Without a usable light direction the angle is unknown: the grazing (largest) offset.
  ShaderFunction<float(glm::vec3, glm::vec3)> scale(kBias, "normal_offset_scale");
  ShaderFunction<glm::vec3(glm::vec3, glm::vec3, float, float)> offset(kBias, "normal_offset");
  std::vector<std::tuple<glm::vec3, glm::vec3>> cases;
  std::vector<std::tuple<glm::vec3, glm::vec3, float, float>> offset_cases;
  for (const glm::vec3& l : kDegenerate) {
    cases.emplace_back(glm::vec3(0, 0, 2), l);
    offset_cases.emplace_back(glm::vec3(0, 0, 2), l, 0.25f, 2.0f);
  }
  const std::vector<float> ones(cases.size(), 1.0f);
  PENUMBRA_EXPECT_ALL_NEAR(ones, scale.run(cases), Tolerance::exact(),
                           [&](std::size_t i) { return format_tuple(cases[i]); });
  const std::vector<glm::vec3> full(cases.size(), glm::vec3(0, 0, 0.5f));
  PENUMBRA_EXPECT_ALL_NEAR(full, offset.run(offset_cases), kOffsetTolerance,
                           [&](std::size_t i) { return format_tuple(offset_cases[i]); });
}

TEST_F(BiasExtremesTest, GrazingAndBackFacingAnglesStayFinite) {
  ShaderFunction<float(glm::vec3, glm::vec3)> scale(kBias, "normal_offset_scale");
  const glm::vec3 n(0, 1, 0);
  // N.L exactly 0 (perpendicular), just above and below 0, tiny, exactly 1, exactly -1, and
  // light vectors of extreme (but usable) lengths.
  const std::vector<glm::vec3> lights = {
      glm::vec3(1, 0, 0),           glm::vec3(1, 1e-7f, 0),  glm::vec3(1, -1e-7f, 0),
      glm::vec3(1, 1e-30f, 0),      glm::vec3(1, -0.0f, 0),  glm::vec3(0, 1, 0),
      glm::vec3(0, -1, 0),          glm::vec3(0, 1e-18f, 0), glm::vec3(1e18f, 1e18f, 0),
      glm::vec3(1e-18f, 1e-18f, 0), glm::vec3(-1, -1e-7f, 0)};
  std::vector<std::tuple<glm::vec3, glm::vec3>> cases;
  std::vector<float> want;
  for (const glm::vec3& l : lights) {
    cases.emplace_back(n, l);
    want.push_back(static_cast<float>(ref::normal_offset_scale(n, l)));
  }
  const auto got = scale.run(cases);
  PENUMBRA_EXPECT_ALL_NEAR(want, got, kOffsetTolerance,
                           [&](std::size_t i) { return format_tuple(cases[i]); });
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_TRUE(got[i] >= 0.0f && got[i] <= 1.0f) << format_tuple(cases[i]) << " -> " << got[i];
  }
  EXPECT_EQ(got[0], 1.0f);   // N.L = 0 exactly: grazing, the full offset
  EXPECT_EQ(got[6], 1.0f);   // facing away
  EXPECT_LT(got[5], 1e-6f);  // facing the light: (almost) no offset
}

TEST_F(BiasExtremesTest, SlopeScaledBiasNeverNaNOrInfinite) {
  ShaderFunction<float(float, float, float, float)> bias(kBias, "slope_scaled_bias");
  std::vector<float> cosines = extreme_float_values({.nan_inf = true});
  cosines.push_back(-kNaN);
  cosines.push_back(2.0f);
  std::vector<std::tuple<float, float, float, float>> cases;
  for (float c : cosines) {
    for (float slope : {0.0f, 1e-3f, 1.0f, 1e30f, L::max()}) {
      for (float constant_bias : {0.0f, 1e-4f}) cases.emplace_back(c, constant_bias, slope, 1e-2f);
    }
  }
  const auto got = bias.run(cases);
  std::vector<float> want;
  for (const auto& [c, k, s, m] : cases)
    want.push_back(static_cast<float>(ref::slope_scaled_bias(c, k, s, m)));
  PENUMBRA_EXPECT_ALL_NEAR(want, got, kSlopeTolerance,
                           [&](std::size_t i) { return format_tuple(cases[i]); });
  for (std::size_t i = 0; i < got.size(); ++i) {
    ASSERT_TRUE(std::isfinite(got[i]) && got[i] >= 0.0f && got[i] <= 1e-2f)
        << format_tuple(cases[i]) << " -> " << got[i];
  }
  // The defined values at the edges.
  EXPECT_EQ(bias(0.0f, 1e-4f, 1e-3f, 1e-2f), 1e-2f);  // N.L = 0: tan unbounded -> max
  EXPECT_EQ(bias(-0.0f, 1e-4f, 1e-3f, 1e-2f), 1e-2f);
  EXPECT_EQ(bias(-0.3f, 1e-4f, 1e-3f, 1e-2f), 1e-2f);  // back face -> max
  EXPECT_EQ(bias(kNaN, 1e-4f, 1e-3f, 1e-2f), 1e-2f);
  EXPECT_EQ(bias(1.0f, 1e-4f, L::max(), 1e-2f), 1e-4f);      // tan 0: the constant alone
  EXPECT_EQ(bias(kInf, 1e-4f, 1e-3f, 1e-2f), 1e-4f);         // clamped to cos 1
  EXPECT_EQ(bias(1e-30f, 1e-4f, 0.0f, 1e-2f), 1e-4f);        // no slope term: 0 * huge tan is 0
  EXPECT_EQ(bias(L::min(), 1e-4f, L::max(), 1e-2f), 1e-2f);  // overflow to +Inf, then clamped
}

TEST_F(BiasExtremesTest, SingularAndNonFiniteJacobiansGiveAZeroGradient) {
  ShaderFunction<glm::vec2(glm::vec3, glm::vec3)> gradient(kBias, "receiver_plane_depth_gradient");
  const glm::vec3 dx(1e-3f, 2e-4f, 5e-5f);
  struct Case {
    glm::vec3 dx, dy;
    const char* what;
  };
  const std::vector<Case> table = {
      {glm::vec3(0.0f), glm::vec3(0.0f), "all zero (flat, or a helper invocation)"},
      {dx, glm::vec3(2e-3f, 4e-4f, 1e-4f), "y column = 2 x column: det exactly 0"},
      {dx, glm::vec3(-5e-4f, -1e-4f, 0.0f), "y column = -1/2 x column"},
      {dx, glm::vec3(0.0f, 0.0f, 1e-4f), "zero uv change along y"},
      {glm::vec3(0.0f, 0.0f, 1e-4f), dx, "zero uv change along x"},
      {dx, glm::vec3(1e-3f, 2.00000001e-4f, 0.0f), "parallel up to rounding"},
      {dx, glm::vec3(1e-3f, 2.00002e-4f, 1e-4f), "relative det 1e-5, below the threshold"},
      {glm::vec3(1e-25f, 1e-25f, 1e-25f), glm::vec3(-1e-25f, 1e-25f, 0.0f),
       "products underflow to zero"},
      {glm::vec3(1e30f, 1e30f, 1.0f), glm::vec3(-1e30f, 1e30f, 0.0f), "products overflow"},
      {glm::vec3(kNaN, 0.0f, 0.0f), glm::vec3(0.0f, 1e-3f, 0.0f), "NaN"},
      {dx, glm::vec3(0.0f, 1e-3f, kNaN), "NaN depth derivative"},
      {glm::vec3(kInf, 0.0f, 0.0f), glm::vec3(0.0f, 1e-3f, 0.0f), "Inf"},
      {dx, glm::vec3(0.0f, 1e-3f, -kInf), "Inf depth derivative"},
      {glm::vec3(1e-3f, 0.0f, L::max()), glm::vec3(0.0f, 1e-3f, L::max()),
       "gradient overflows a float"},
  };
  std::vector<std::tuple<glm::vec3, glm::vec3>> cases;
  for (const Case& c : table) cases.emplace_back(c.dx, c.dy);
  const auto got = gradient.run(cases);
  for (std::size_t i = 0; i < table.size(); ++i) {
    EXPECT_EQ(got[i], glm::vec2(0.0f))
        << table[i].what << ": " << format_tuple(cases[i]) << " -> " << format_value(got[i]);
    EXPECT_EQ(ref::receiver_plane_depth_gradient(table[i].dx, table[i].dy), glm::dvec2(0.0))
        << "reference: " << table[i].what;
  }
  // And a regular one next to them is not zero: (dz/du, dz/dv) = (2, -3).
  const glm::vec3 rx(1e-3f, 0.0f, 2e-3f), ry(0.0f, 1e-3f, -3e-3f);
  EXPECT_THAT(gradient(rx, ry), NearTo(glm::vec2(2.0f, -3.0f), Tolerance::ulps(8)));
  // A determinant beyond 2^126 (1e38), where Vulkan no longer bounds the divide's error and a
  // reciprocal flushes to zero: still (3, -2).
  const glm::vec3 hx(1e19f, 0.0f, 3e19f), hy(0.0f, 1e19f, -2e19f);
  EXPECT_THAT(gradient(hx, hy), NearTo(glm::vec2(3.0f, -2.0f), Tolerance::ulps(8)));
  EXPECT_THAT(glm::vec2(ref::receiver_plane_depth_gradient(hx, hy)),
              NearTo(glm::vec2(3.0f, -2.0f), Tolerance::ulps(1)));
}

TEST_F(BiasExtremesTest, ApplyDepthBiasAtTheEndsOfTheDepthRange) {
  ShaderFunction<float(float, float, bool)> apply(kBias, "apply_depth_bias");
  std::vector<std::tuple<float, float, bool>> cases;
  for (bool reverse_z : {true, false}) {
    for (float depth :
         {0.0f, -0.0f, 1.0f, std::nextafter(1.0f, 0.0f), 1e-7f, 0.5f, L::min(), kInf, -kInf}) {
      for (float bias : {0.0f, 1e-7f, 0.01f, 1.0f}) cases.emplace_back(depth, bias, reverse_z);
    }
  }
  const auto got = apply.run(cases);
  std::vector<float> want;
  for (const auto& [d, b, rz] : cases) want.push_back(ref::apply_depth_bias(d, b, rz));
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact(),
                           [&](std::size_t i) { return format_tuple(cases[i]); });
  // Not clamped: a reverse-Z receiver at the near plane biased past 1 stays past 1.
  EXPECT_EQ(apply(1.0f, 0.01f, true), 1.01f);
  EXPECT_EQ(apply(0.0f, 0.01f, false), -0.01f);
}

// N.L exactly 0 (grazing) gives exactly 1, the rule for N.L <= 0, not the cross product's length,
// which float normalisation leaves a few ULP off 1 (in both directions). Every pair has disjoint
// support (normal in the xy plane, light along z, or the other way round), so each product of
// the dot is 0 * x and the dot is exactly 0 on every device, fused or not.
TEST_F(BiasExtremesTest, NormalOffsetScaleAtExactlyPerpendicularIsOne) {
  ShaderFunction<float(glm::vec3, glm::vec3)> scale(kBias, "normal_offset_scale");
  Rng rng(0xB1A5);
  std::vector<std::tuple<glm::vec3, glm::vec3>> cases;
  for (int i = 0; i < 512; ++i) {
    const float a = float(6.283185307179586 * rng.next_unit());
    const float r = float(std::pow(10.0, 6.0 * rng.next_unit() - 3.0));
    const glm::vec3 in_plane(r * std::cos(a), r * std::sin(a), 0.0f);
    const glm::vec3 axis(
        0.0f, 0.0f,
        float(std::pow(10.0, 6.0 * rng.next_unit() - 3.0)) * (i % 2 == 0 ? 1.0f : -1.0f));
    if (i % 4 < 2)
      cases.emplace_back(in_plane, axis);
    else
      cases.emplace_back(axis, in_plane);
  }
  PENUMBRA_EXPECT_ALL_NEAR(std::vector<float>(cases.size(), 1.0f), scale.run(cases),
                           Tolerance::exact(), [&](size_t i) { return format_tuple(cases[i]); });
}

// A Jacobian whose products sum to exactly FLT_MIN (du/dx dv/dy = 2^-63 2^-63 = 2^-126, the
// other product 0) is the smallest usable one: the determinant is FLT_MIN itself, inside the
// division's accurate range, and the gradient is (dz/dx / du/dx, dz/dy / dv/dy) (a diagonal J).
// Every value is a power of two times a small integer, so the exact gradient is a float; the
// division may still be 2.5 ULP off (Vulkan), hence 3 ULP.
TEST_F(BiasExtremesTest, ReceiverPlaneGradientAtTheSmallestNormalSize) {
  ShaderFunction<glm::vec2(glm::vec3, glm::vec3)> gradient(kBias, "receiver_plane_depth_gradient");
  const float s = 0x1p-63f;
  const std::vector<std::tuple<glm::vec3, glm::vec3>> cases = {
      {{s, 0.0f, 0.75f * 0x1p-60f}, {0.0f, s, -0x1p-61f}},
      {{-s, 0.0f, 0x1p-62f}, {0.0f, -s, 3.0f * 0x1p-62f}},
      {{0.0f, s, 0x1p-60f}, {s, 0.0f, -0x1p-60f}}};  // J anti-diagonal: dz/du = dz/dy / du/dy
  const std::vector<glm::vec2> want = {{6.0f, -4.0f}, {-2.0f, -6.0f}, {-8.0f, 8.0f}};
  PENUMBRA_EXPECT_ALL_NEAR(want, gradient.run(cases), Tolerance::ulps(3),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

// world_depth_bias: each NaN (or negative) parameter counts as 0 (its documented rule), checked
// against the closed form with that parameter 0. n_dot_l 0.6: tan(theta) = 0.8 / 0.6 = 4/3; the
// cases are chosen so that the 0 removes the slope term or makes the cap the constant, where the
// result is exact (c + 0 * x = c, min(c + x, c) = c for x >= 0); with n_dot_l 1, tan(theta) = 0.
TEST_F(BiasExtremesTest, WorldDepthBiasNaNOrNegativeParametersCountAsZero) {
  ShaderFunction<float(float, float, float, float, float)> bias(kBias, "world_depth_bias");
  // (n_dot_l, constant_world, slope_texels, max_slope_texels, texel_world) -> expected
  const std::vector<std::tuple<float, float, float, float, float>> cases = {
      {1.0f, kNaN, 2.0f, 3.0f, 0.5f},    // constant 0, tan 0: 0
      {1.0f, -1.0f, 2.0f, 3.0f, 0.5f},   // the same
      {0.6f, kNaN, 2.0f, 0.0f, 0.5f},    // constant 0, cap 0 + 0: 0
      {0.6f, 0.25f, kNaN, 3.0f, 0.5f},   // slope 0: the constant
      {0.6f, 0.25f, -2.0f, 3.0f, 0.5f},  // the same
      {0.6f, 0.25f, 2.0f, kNaN, 0.5f},   // cap = constant + 0
      {0.6f, 0.25f, 2.0f, -3.0f, 0.5f},  // the same
      {0.6f, 0.25f, 2.0f, 3.0f, kNaN},   // texel 0: the constant
      {0.6f, 0.25f, 2.0f, 3.0f, -0.5f},  // the same
      {0.6f, kNaN, kNaN, kNaN, kNaN}};   // everything 0
  const std::vector<float> want = {0.0f,  0.0f,  0.0f,  0.25f, 0.25f,
                                   0.25f, 0.25f, 0.25f, 0.25f, 0.0f};
  PENUMBRA_EXPECT_ALL_NEAR(want, bias.run(cases), Tolerance::exact(),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

// cube_texel_world_size for resolutions in (0, 1] (any positive resolution is valid: a face
// texel spans 2 m / resolution). 2 m is exact; the division is within 2.5 ULP (Vulkan), hence
// 3 ULP, of the exact quotient.
TEST_F(BiasExtremesTest, CubeTexelWorldSizeForResolutionsUpToOne) {
  ShaderFunction<float(glm::vec3, float)> texel(kBias, "cube_texel_world_size");
  std::vector<std::tuple<glm::vec3, float>> cases;
  std::vector<float> want;
  for (const float resolution : {1.0f, 0.5f, 0.75f, 1e-3f, 0x1p-20f}) {
    for (const glm::vec3 v : {glm::vec3(3.0f, -4.0f, 1.0f), glm::vec3(-0.1f, 0.05f, 0.0f)}) {
      cases.emplace_back(v, resolution);
      const double m =
          std::max({std::fabs(double{v.x}), std::fabs(double{v.y}), std::fabs(double{v.z})});
      want.push_back(float(2.0 * m / double{resolution}));
    }
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, texel.run(cases), Tolerance::ulps(3),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

// cube_texel_world_size of a NaN direction or a resolution that is not positive: 0.
TEST_F(BiasExtremesTest, CubeTexelSizeOfBadInputIsZero) {
  ShaderFunction<float(glm::vec3, float)> texel(kBias, "cube_texel_world_size");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(texel(glm::vec3(nan, 0.0f, 0.0f), 512.0f), 0.0f);
  EXPECT_EQ(texel(glm::vec3(1.0f, 0.0f, 0.0f), 0.0f), 0.0f);
  EXPECT_EQ(texel(glm::vec3(1.0f, 0.0f, 0.0f), -4.0f), 0.0f);
  EXPECT_EQ(texel(glm::vec3(1.0f, 0.0f, 0.0f), 512.0f), 2.0f / 512.0f);
}

}  // namespace
}  // namespace penumbra::testing
