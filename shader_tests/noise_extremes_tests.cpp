// Extremes of shaders/penumbra/noise.glsl: huge frame indices, huge, negative and non-finite
// pixels, huge angles, degenerate Vogel counts and out-of-range indices.
//
// NaN and infinity inputs: by default Vulkan lets an implementation optimise as if no value were
// NaN or infinite (only the SignedZeroInfNanPreserve execution mode forbids it), so what these
// tests check for such inputs is the documented behaviour of the shader code on drivers that do
// keep IEEE semantics (lavapipe and NVIDIA's do), not something every conforming driver owes.
#include <gtest/gtest.h>

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

#include "reference/noise_ref.hpp"

namespace penumbra::testing {
namespace {

namespace ref = penumbra::reference;

constexpr const char* kNoise = "penumbra/noise.glsl";
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kMax = std::numeric_limits<float>::max();

const std::vector<uint32_t> kHugeFrames = {
    10'000'000u,  0xFFFFFFFFu,   0xFFFFFFFEu, 0x80000000u, 0x7FFFFFFFu, 1u << 24, (1u << 24) + 1u,
    0xFFFFFFC0u,  // a multiple of 64: the same pattern as frame 0
    123'456'789u, 4'000'000'000u};

class NoiseExtremesTest : public GpuTest {};

// The frame index is wrapped before it touches a float: any frame gives exactly (bit for bit)
// the noise of frame % 64, and stays in [0, 1).
TEST_F(NoiseExtremesTest, TemporalIgnAtHugeFramesEqualsTheWrappedFrame) {
  ShaderFunction<float(glm::vec2, uint32_t)> ign(kNoise, "interleaved_gradient_noise_temporal");
  Rng rng(0xE17001);
  std::vector<std::tuple<glm::vec2, uint32_t>> huge, wrapped;
  for (int i = 0; i < 256; ++i) {
    const glm::vec2 pixel = glm::floor(uniform<glm::vec2>(0.0f, 3840.0f)(rng)) + 0.5f;
    for (const uint32_t frame : kHugeFrames) {
      huge.emplace_back(pixel, frame);
      wrapped.emplace_back(pixel, frame % 64u);
    }
    const uint32_t frame = uniform(0x80000000u, 0xFFFFFFFFu)(rng);
    huge.emplace_back(pixel, frame);
    wrapped.emplace_back(pixel, frame % 64u);
  }
  const std::vector<float> got = ign.run(huge);
  const std::vector<float> want = ign.run(wrapped);
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact(),
                           [&](size_t i) { return format_tuple(huge[i]); });
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_TRUE(got[i] >= 0.0f && got[i] < 1.0f) << format_tuple(huge[i]) << " -> " << got[i];
  }
  // Frame 2^32 - 64 = 0 (mod 64): the spatial pattern itself.
  ShaderFunction<float(glm::vec2)> spatial(kNoise, "interleaved_gradient_noise");
  EXPECT_EQ(ign(glm::vec2(17.5f, 99.5f), 0xFFFFFFC0u), spatial(glm::vec2(17.5f, 99.5f)));
}

// golden_ratio_offset at huge frames: within 2^-24 (+ 2^-32 + the reference's 2^-31) of the long
// double fract(frame / phi), in [0, 1). A float evaluation fract(float(frame) * 0.618034) is off
// by up to 0.5 here (float(4294967295) = 2^32 exactly, ulp 512 ...).
TEST_F(NoiseExtremesTest, GoldenRatioOffsetAtHugeFramesMatchesLongDouble) {
  ShaderFunction<float(uint32_t)> offset(kNoise, "golden_ratio_offset");
  std::vector<std::tuple<uint32_t>> cases;
  for (const uint32_t frame : kHugeFrames) cases.emplace_back(frame);
  for (uint32_t k = 0; k < 64; ++k) cases.emplace_back(0xFFFFFFFFu - k);
  const std::vector<float> got = offset.run(cases);
  std::vector<double> errors, bounds;
  for (size_t i = 0; i < cases.size(); ++i) {
    errors.push_back(
        ref::circular_distance(ref::golden_ratio_offset(std::get<0>(cases[i])), got[i]));
    bounds.push_back(0x1p-24 + 0x1p-32 + ref::kGoldenRatioReferenceError);
    ASSERT_TRUE(got[i] >= 0.0f && got[i] < 1.0f) << format_tuple(cases[i]) << " -> " << got[i];
  }
  EXPECT_TRUE(ref::errors_within_bounds(errors, bounds, [&](size_t i) {
    return format_tuple(cases[i]) + " -> " + format_value(got[i]);
  }));
  // Known values of fract(frame * (sqrt(5) - 1) / 2), from 100-digit decimal arithmetic (Python
  // decimal): frame 1e7 -> 0.88749894848..., frame 2^32 - 1 -> 0.87919630772...; the shader
  // truncates to a multiple of 2^-24 (6e-8).
  EXPECT_NEAR(offset(10'000'000u), 0.887498948482, 0x1p-24);
  EXPECT_NEAR(offset(0xFFFFFFFFu), 0.879196307728, 0x1p-24);
}

// IGN for any finite pixel, however large or negative, is in [0, 1): fract of a non-negative
// value is exact and below 1, and the inner fract keeps the outer argument non-negative. (Past
// |pixel| ~ 2^24 / 0.067 the pattern is meaningless, but still a value in range.)
TEST_F(NoiseExtremesTest, IgnOfAnyFinitePixelIsInUnitInterval) {
  ShaderFunction<float(glm::vec2)> ign(kNoise, "interleaved_gradient_noise");
  Rng rng(0xE17002);
  const auto coordinate = extremes_float({.nan_inf = false, .lo = -1e7f, .hi = 1e7f});
  const auto cases = generate_cases(rng, 20000, vec_of<2>(coordinate));
  const std::vector<float> got = ign.run(cases);
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_TRUE(got[i] >= 0.0f && got[i] < 1.0f) << format_tuple(cases[i]) << " -> " << got[i];
  }
}

// A non-finite pixel (fract(inf) = inf - inf = NaN) gives 0 rather than NaN: the shader's final
// range check maps anything outside [0, 1) to 0.
TEST_F(NoiseExtremesTest, IgnOfNonFinitePixelIsZero) {
  ShaderFunction<float(glm::vec2)> ign(kNoise, "interleaved_gradient_noise");
  ShaderFunction<float(glm::vec2, uint32_t)> temporal(kNoise,
                                                      "interleaved_gradient_noise_temporal");
  const std::vector<std::tuple<glm::vec2>> cases = {
      {{kNaN, 0.5f}}, {{0.5f, kNaN}},  {{kInf, 0.5f}}, {{-kInf, 0.5f}},
      {{0.5f, kInf}}, {{kInf, -kInf}}, {{kNaN, kNaN}}};
  const std::vector<float> got = ign.run(cases);
  PENUMBRA_EXPECT_ALL_NEAR(std::vector<float>(cases.size(), 0.0f), got, Tolerance::exact(),
                           [&](size_t i) { return format_tuple(cases[i]); });
  EXPECT_EQ(temporal(glm::vec2(kNaN, 1.5f), 0xFFFFFFFFu), 0.0f);
  EXPECT_EQ(temporal(glm::vec2(kInf, 1.5f), 7u), 0.0f);
}

// Vogel with degenerate arguments: a count below 1 counts as 1 (the single sample at radius
// sqrt(1/2)), the index is clamped to [0, count - 1]; never NaN, always inside the disk.
TEST_F(NoiseExtremesTest, VogelDegenerateCountsAndIndicesAreClamped) {
  ShaderFunction<glm::vec2(int, int, float)> vogel(kNoise, "vogel_disk_sample");
  constexpr int kMin = std::numeric_limits<int>::min(), kMaxInt = std::numeric_limits<int>::max();
  const std::vector<std::tuple<int, int, float>> odd = {
      {0, 0, 0.5f},   {5, 0, 0.5f},        {-3, -7, 0.5f}, {kMaxInt, kMin, 0.5f},  // count -> 1
      {-1, 16, 0.5f}, {kMin, 16, 0.5f},                                            // index -> 0
      {16, 16, 0.5f}, {kMaxInt, 16, 0.5f},                                         // index -> 15
  };
  const std::vector<std::tuple<int, int, float>> clamped = {
      {0, 1, 0.5f},  {0, 1, 0.5f},  {0, 1, 0.5f},   {0, 1, 0.5f},
      {0, 16, 0.5f}, {0, 16, 0.5f}, {15, 16, 0.5f}, {15, 16, 0.5f},
  };
  const std::vector<glm::vec2> got = vogel.run(odd);
  PENUMBRA_EXPECT_ALL_NEAR(vogel.run(clamped), got, Tolerance::exact(),
                           [&](size_t i) { return format_tuple(odd[i]); });
  // The single sample of a one-sample disk: radius sqrt(0.5), at the rotation angle.
  const glm::dvec2 single = ref::vogel_disk_sample(0, 1, 0.5);
  EXPECT_NEAR(got[0].x, single.x, 2e-3);  // 2^-11 (cos) + rounding; see the main tests
  EXPECT_NEAR(got[0].y, single.y, 2e-3);
}

// A huge sample count: radii sqrt((i + 0.5) / n) just below 1 and angles from golden_ratio_offset
// at indices up to 2^20, where i * golden angle in float would have lost the angle entirely.
TEST_F(NoiseExtremesTest, VogelHugeCountStaysInsideDiskWithExactAngles) {
  ShaderFunction<glm::vec2(int, int, float)> vogel(kNoise, "vogel_disk_sample");
  constexpr int kCount = 1 << 20;
  std::vector<std::tuple<int, int, float>> cases;
  for (int i = kCount - 256; i < kCount; ++i) cases.emplace_back(i, kCount, 0.0f);
  const std::vector<glm::vec2> got = vogel.run(cases);
  for (size_t k = 0; k < cases.size(); ++k) {
    const int i = std::get<0>(cases[k]);
    const glm::dvec2 want = ref::vogel_disk_sample(i, kCount, 0.0);
    // 2^-11 for sin/cos, 2 pi * (2^-24 + 2^-32) for the golden_ratio_offset angle, rounding.
    const double bound = 0x1p-11 + 2.0 * std::numbers::pi * 0x1p-23 + 1e-6;
    EXPECT_NEAR(got[k].x, want.x, bound) << format_tuple(cases[k]);
    EXPECT_NEAR(got[k].y, want.y, bound) << format_tuple(cases[k]);
    EXPECT_LE(glm::length(glm::dvec2(got[k])), 1.0 + 2.0 * 0x1p-11) << format_tuple(cases[k]);
  }
}

// rotate2 with huge finite angles: the reduction in turns never overflows, so the result stays
// finite and keeps |v| (cos^2 + sin^2 = 1 within 2 * 2^-11 for any reduced angle); past 2^23
// turns the angle's own ulp is a whole turn and the reduction returns 0 (no rotation).
TEST_F(NoiseExtremesTest, Rotate2HugeAnglesStayFiniteAndKeepLength) {
  ShaderFunction<glm::vec2(glm::vec2, float)> rotate(kNoise, "rotate2");
  ShaderFunction<float(float)> wrap(kNoise, "wrap_angle");
  const std::vector<float> angles = {1e5f, -1e5f, 1e6f,  1e7f, -1e7f,
                                     1e8f, 1e20f, 1e30f, kMax, -kMax};
  std::vector<std::tuple<glm::vec2, float>> cases;
  for (const float a : angles) {
    cases.emplace_back(glm::vec2(3.0f, -4.0f), a);
    cases.emplace_back(glm::vec2(0.0f, 1.0f), a);
  }
  const std::vector<glm::vec2> got = rotate.run(cases);
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [v, a] = cases[i];
    ASSERT_TRUE(std::isfinite(got[i].x) && std::isfinite(got[i].y)) << format_tuple(cases[i]);
    // |R v| = |v| sqrt(c^2 + s^2); with |c - cos|, |s - sin| <= 2^-11 that is within
    // |v| (2 * 2^-11 + 2^-21) of |v|, plus the products' roundings.
    EXPECT_NEAR(glm::length(glm::dvec2(got[i])), glm::length(glm::dvec2(v)),
                glm::length(glm::dvec2(v)) * (2.0 * 0x1p-11 + 0x1p-21 + 4.0 * 0x1p-23))
        << format_tuple(cases[i]);
  }
  for (const float a : {1e20f, 1e30f, kMax, -kMax, 0x1p24f * 6.2831855f}) {
    EXPECT_EQ(wrap(a), 0.0f) << a;  // an integer number of turns in float
  }
  // Within [-pi, pi] (the float pi, kTwoPi / 2) for every finite angle.
  Rng rng(0xE17003);
  const auto many = generate_cases(rng, 8192, extremes_float({.nan_inf = false}));
  const std::vector<float> reduced = wrap.run(many);
  for (size_t i = 0; i < reduced.size(); ++i) {
    ASSERT_LE(std::fabs(reduced[i]), std::numbers::pi_v<float>) << format_tuple(many[i]);
  }
}

// The Poisson index wraps modulo 32, for negative and huge indices too.
TEST_F(NoiseExtremesTest, PoissonIndexWrapsModulo32) {
  ShaderFunction<glm::vec2(int)> sample(kNoise, "poisson_disk_sample");
  ShaderFunction<glm::vec2(int, float)> rotated(kNoise, "rotated_poisson_sample");
  constexpr int kMin = std::numeric_limits<int>::min(), kMaxInt = std::numeric_limits<int>::max();
  const std::vector<std::tuple<int>> odd = {{-1}, {32}, {33}, {-32}, {kMaxInt}, {kMin}, {1000}};
  const std::vector<std::tuple<int>> wrapped = {{31}, {0}, {1}, {0}, {31}, {0}, {1000 % 32}};
  PENUMBRA_EXPECT_ALL_NEAR(sample.run(wrapped), sample.run(odd), Tolerance::exact());
  EXPECT_EQ(rotated(-1, 0.75f), rotated(31, 0.75f));
  EXPECT_EQ(rotated(kMaxInt, 2.0f), rotated(31, 2.0f));
}

}  // namespace
}  // namespace penumbra::testing
