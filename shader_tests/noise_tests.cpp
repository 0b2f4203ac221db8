// Function-level tests of shaders/penumbra/noise.glsl against the independent references in
// reference/noise_ref.hpp.
//
// How the tolerances are derived (Vulkan spec, "Precision and Operation of SPIR-V Instructions"):
//   * +, -, * and conversions are correctly rounded, but the rounding direction is unspecified:
//     each adds a relative error < 2^-23 (kRoundingRel). floor, round and fract are correctly
//     rounded, so exact wherever the exact result is a float (x - floor(x) always is).
//   * Implementations may contract a * b + c into a fused multiply-add unless the result is
//     `precise` (NoContraction); a fused operation only removes a rounding, so every bound below
//     (a sum of per-operation roundings) also covers contracted code.
//   * division 2.5 ULP, sqrt = 1 / inversesqrt: 2 + 2.5 ULP, sin/cos: absolute 2^-11 in [-pi, pi].
// Noise values are fractions, so their errors are measured on the unit circle (0.9999999 and 0
// are neighbours): a tiny error in fract(large * x) may move a value across 1.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/interval.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <tuple>
#include <vector>

#include "reference/noise_ref.hpp"
#include "spec_check.hpp"

namespace penumbra::testing {
namespace {

namespace ref = penumbra::reference;
using ref::kRoundingRel;

constexpr const char* kNoise = "penumbra/noise.glsl";

// The error bound of the shader's IGN at a pixel whose coordinates carry absolute errors
// (ex, ey) already (0 for exact inputs), against ref::ign() of the exact coordinates.
//   inner = a*x + b*y: two products and a sum, each rounded (< 2^-23 relative), plus the input
//           errors scaled by a and b;
//   fract(inner) is exact, so the inner error carries over unchanged (mod 1);
//   outer = c * fract(inner): the inner error times c, plus one rounding of a value below c;
//   fract(outer) is exact.
// Where the exact inner value lies within its error bound of an integer, the float one may fall
// on the other side: fract(inner) jumps between ~1 and ~0 and the noise by c mod 1 (IGN is
// discontinuous along the lines a*x + b*y = integer), a circular jump of 1 - fract(c) = 0.0171.
// Plus 1e-12 for the double reference's own rounding (|a*x + b*y| < 1e4 here: 1e4 * 2^-52 * c).
double ign_bound(double x, double y, double ex = 0.0, double ey = 0.0) {
  const double ax = std::fabs(double{ref::kIgnA} * x), by = std::fabs(double{ref::kIgnB} * y);
  const double inner = double{ref::kIgnA} * x + double{ref::kIgnB} * y;
  const double inner_error = kRoundingRel * (ax + by + std::fabs(inner)) + double{ref::kIgnA} * ex +
                             double{ref::kIgnB} * ey;
  double bound = double{ref::kIgnC} * inner_error + kRoundingRel * double{ref::kIgnC} + 1e-12;
  if (ref::circular_distance(ref::fraction(inner), 0.0) <= inner_error) {
    bound += ref::circular_distance(ref::fraction(double{ref::kIgnC}), 0.0);
  }
  return bound;
}

// Relative error of a float constant against the exact value it stands for.
double constant_error(float f, double exact) {
  return std::fabs((double{f} - exact) / exact);
}

// common.glsl's kTwoPi and kInvTwoPi: the exact values rounded to float (as glslang rounds the
// literals), and their relative errors.
const double kTwoPiError =
    constant_error(static_cast<float>(2.0 * std::numbers::pi), 2.0 * std::numbers::pi);
const double kInvTwoPiError =
    constant_error(static_cast<float>(0.5 / std::numbers::pi), 0.5 / std::numbers::pi);

class NoiseTest : public GpuTest {};

// ---------------------------------------------------------------------------------------------
// Interleaved gradient noise

// interleaved_gradient_noise as noise.glsl writes it (inner and outer are `precise`).
template <class T>
T ign_formula(T x, T y) {
  using namespace glsl;
  const T inner = T(ref::kIgnA) * x + T(ref::kIgnB) * y;
  const T outer = T(ref::kIgnC) * fract(inner);
  const T noise = fract(outer);
  return (noise >= T(0.0f) && noise < T(1.0f)) ? noise : T(0.0f);
}

// The device lies in the spec's interval for the shader's formula, evaluated as `precise` (the
// set of results of every rounding direction, no fused multiply-add); the interval holds the
// published formula's exact value (modulo 1: where the interval crosses an integer it is all of
// [0, 1]); the hand bound is audited where it is not a wrap.
TEST_F(NoiseTest, IgnMatchesPublishedFormulaWithinDerivedBound) {
  ShaderFunction<float(glm::vec2)> ign(kNoise, "interleaved_gradient_noise");
  Rng rng(0x16A001);
  // Pixel centres of frames up to 8K, and arbitrary sub-pixel positions.
  const auto centre = map(uniform(glm::ivec2(0), glm::ivec2(8191, 4319)),
                          [](glm::ivec2 p) { return glm::vec2(p) + 0.5f; });
  const auto cases =
      generate_cases(rng, 20000, mix(centre, 0.7, uniform<glm::vec2>(0.0f, 4096.0f)));
  const std::vector<float> got = ign.run(cases);
  std::vector<Interval> accepted, enclosures;
  for (const auto& [p] : cases) {
    const auto formula = [&] { return ign_formula<Interval>(p.x, p.y); };
    accepted.push_back(spec_interval(formula, {.precise = true}));
    enclosures.push_back(spec_interval(formula));
  }
  EXPECT_TRUE(expect_within_spec({.name = "noise.interleaved_gradient_noise",
                                  .exact =
                                      [&](size_t i) {
                                        const glm::vec2 p = std::get<0>(cases[i]);
                                        return ref::ign(p.x, p.y);
                                      },
                                  .old_bound =
                                      [&](size_t i) {
                                        const glm::vec2 p = std::get<0>(cases[i]);
                                        return accepted[i].hi() - accepted[i].lo() > 0.5
                                                   ? NAN
                                                   : ign_bound(p.x, p.y);
                                      },
                                  .describe = [&](size_t i) { return format_tuple(cases[i]); }},
                                 accepted, got, enclosures));
}

// The shader evaluates IGN with `precise` (no fused multiply-add), so every device that rounds
// to nearest even (IEEE 754's default; lavapipe and NVIDIA do for fp32 add/mul) returns the same
// bits: the float evaluation in the same order. A driver that ignored `precise` would fuse one of
// the two products into the sum; those results are accepted too, so this checks the operation
// order and constants exactly, not the driver's contraction choice.
TEST_F(NoiseTest, IgnEqualsFloatEvaluationInShaderOrder) {
  ShaderFunction<float(glm::vec2)> ign(kNoise, "interleaved_gradient_noise");
  Rng rng(0x16A002);
  const auto cases = generate_cases(rng, 20000, uniform<glm::vec2>(0.0f, 8192.0f));
  const std::vector<float> got = ign.run(cases);
  std::vector<float> want(cases.size());
  size_t unfused = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    const glm::vec2 p = std::get<0>(cases[i]);
    want[i] = ref::ign_float_order(p);
    if (got[i] == want[i]) {
      ++unfused;
      continue;
    }
    for (const auto c : {ref::IgnContraction::fma_a, ref::IgnContraction::fma_b}) {
      if (got[i] == ref::ign_float_order(p, c)) want[i] = got[i];
    }
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact(),
                           [&](size_t i) { return format_tuple(cases[i]); });
  RecordProperty("unfused_matches", static_cast<int>(unfused));
}

// Values of the published formula with its decimal constants, evaluated in exact rational
// arithmetic (Python fractions.Fraction): fract(52.9829189 * fract(0.06711056 x + 0.00583715 y)).
TEST_F(NoiseTest, IgnKnownValues) {
  ShaderFunction<float(glm::vec2)> ign(kNoise, "interleaved_gradient_noise");
  const std::vector<std::pair<glm::vec2, double>> known = {
      {{0.5f, 0.5f}, 0.932491301435},
      {{1.5f, 0.5f}, 0.488204659249},
      {{0.5f, 1.5f}, 0.241760546492},
      {{10.5f, 20.5f}, 0.675009780714},
      {{100.5f, 37.5f}, 0.049275749908},
      {{639.5f, 479.5f}, 0.941944826683},
      {{0.0f, 0.0f}, 0.0},
  };
  std::vector<std::tuple<glm::vec2>> cases;
  for (const auto& k : known) cases.emplace_back(k.first);
  const std::vector<float> got = ign.run(cases);
  std::vector<double> errors, bounds;
  for (size_t i = 0; i < known.size(); ++i) {
    const glm::vec2 p = known[i].first;
    errors.push_back(ref::circular_distance(known[i].second, got[i]));
    // The float evaluation's bound, plus the decimal constants' rounding to float (the exact
    // formula uses the decimals): c * (|da| x + |db| y) + |dc| for the relative errors d*.
    const double constants =
        double{ref::kIgnC} * (constant_error(ref::kIgnA, 0.06711056) * 0.06711056 * p.x +
                              constant_error(ref::kIgnB, 0.00583715) * 0.00583715 * p.y) +
        constant_error(ref::kIgnC, 52.9829189) * 52.9829189;
    bounds.push_back(ign_bound(p.x, p.y) + constants + 1e-12);  // 1e-12: the 12 printed digits
  }
  EXPECT_TRUE(ref::errors_within_bounds(errors, bounds, [&](size_t i) {
    return format_tuple(cases[i]) + " -> " + format_value(got[i]);
  }));
}

// IGN's defining property: a flat histogram over a screen region, and 3x3 neighbourhoods whose
// mean stays near 1/2 (why it suits 3x3 / TAA resolves). Limits measured on the exact formula
// (16 bins of 4075..4104 per 4096; worst 3x3 mean 0.5 +- 0.091), with room for the rounding.
TEST_F(NoiseTest, IgnIsUniformAndBalancedIn3x3Neighbourhoods) {
  ShaderFunction<float(glm::vec2)> ign(kNoise, "interleaved_gradient_noise");
  constexpr int kSize = 256;
  std::vector<std::tuple<glm::vec2>> cases;
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x)
      cases.emplace_back(glm::vec2(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f));
  }
  const std::vector<float> got = ign.run(cases);
  std::vector<int> histogram(16, 0);
  for (float v : got) {
    ASSERT_TRUE(v >= 0.0f && v < 1.0f) << v;
    ++histogram[static_cast<size_t>(v * 16.0f)];
  }
  for (int count : histogram) EXPECT_NEAR(count, kSize * kSize / 16, 82);  // +-2%
  double worst = 0.0;
  for (int y = 0; y + 3 <= kSize; ++y) {
    for (int x = 0; x + 3 <= kSize; ++x) {
      double sum = 0.0;
      for (int dy = 0; dy < 3; ++dy) {
        for (int dx = 0; dx < 3; ++dx) sum += got[static_cast<size_t>((y + dy) * kSize + x + dx)];
      }
      worst = std::max(worst, std::fabs(sum / 9.0 - 0.5));
    }
  }
  EXPECT_LT(worst, 0.1);
}

TEST_F(NoiseTest, TemporalIgnMatchesReferenceWithinDerivedBound) {
  ShaderFunction<float(glm::vec2, uint32_t)> ign(kNoise, "interleaved_gradient_noise_temporal");
  Rng rng(0x16A003);
  const auto centre = map(uniform(glm::ivec2(0), glm::ivec2(3839, 2159)),
                          [](glm::ivec2 p) { return glm::vec2(p) + 0.5f; });
  const auto cases =
      generate_cases(rng, 20000, centre, mix(uniform(0u, 63u), 0.5, uniform(0u, 0xFFFFFFFFu)));
  const std::vector<float> got = ign.run(cases);
  std::vector<double> errors, bounds;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [p, frame] = cases[i];
    const glm::dvec2 s = ref::ign_temporal_pixel(p, frame);
    errors.push_back(ref::circular_distance(ref::ign(s.x, s.y), got[i]));
    // The shifted pixel p + o * k: the product and the sum each rounded (a fused version has
    // one rounding); float(frame % 64) is exact.
    const double shift = double{ref::kIgnFrameOffset} * (frame % ref::kIgnFramePeriod);
    const double ex = kRoundingRel * (shift + std::fabs(s.x));
    const double ey = kRoundingRel * (shift + std::fabs(s.y));
    bounds.push_back(ign_bound(s.x, s.y, ex, ey));
  }
  EXPECT_TRUE(ref::errors_within_bounds(errors, bounds, [&](size_t i) {
    return format_tuple(cases[i]) + " -> " + format_value(got[i]);
  }));
}

// Bit-exact reproducibility of the temporal variant (see IgnEqualsFloatEvaluationInShaderOrder):
// the shift rounded per operation, then IGN in shader order; fused variants accepted.
TEST_F(NoiseTest, TemporalIgnEqualsFloatEvaluationInShaderOrder) {
  ShaderFunction<float(glm::vec2, uint32_t)> ign(kNoise, "interleaved_gradient_noise_temporal");
  Rng rng(0x16A004);
  const auto cases =
      generate_cases(rng, 20000, uniform<glm::vec2>(0.0f, 4096.0f), uniform(0u, 0xFFFFFFFFu));
  const std::vector<float> got = ign.run(cases);
  std::vector<float> want(cases.size());
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [p, frame] = cases[i];
    want[i] = ref::ign_float_order(ref::ign_temporal_pixel_float(p, frame, false));
    if (got[i] == want[i]) continue;
    for (bool fused_shift : {false, true}) {
      for (const auto c :
           {ref::IgnContraction::none, ref::IgnContraction::fma_a, ref::IgnContraction::fma_b}) {
        const float alt =
            ref::ign_float_order(ref::ign_temporal_pixel_float(p, frame, fused_shift), c);
        if (got[i] == alt) want[i] = alt;
      }
    }
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact(),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

// Over its 64-frame period each pixel sees a well-spread set of values: mean near 1/2 and every
// quarter of [0, 1) hit 16 +- 4 times (the exact formula: |mean - 1/2| <= 0.027, 14..18 hits).
TEST_F(NoiseTest, TemporalIgnSpreadsEachPixelOverThePeriod) {
  ShaderFunction<float(glm::vec2, uint32_t)> ign(kNoise, "interleaved_gradient_noise_temporal");
  std::vector<std::tuple<glm::vec2, uint32_t>> cases;
  for (int y = 0; y < 256; y += 7) {
    for (int x = 0; x < 256; x += 7) {
      for (uint32_t k = 0; k < 64; ++k)
        cases.emplace_back(glm::vec2(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f),
                           k);
    }
  }
  const std::vector<float> got = ign.run(cases);
  for (size_t start = 0; start < got.size(); start += 64) {
    double sum = 0.0;
    int quarters[4] = {0, 0, 0, 0};
    for (size_t k = 0; k < 64; ++k) {
      sum += got[start + k];
      ++quarters[static_cast<int>(got[start + k] * 4.0f)];
    }
    EXPECT_NEAR(sum / 64.0, 0.5, 0.04) << format_tuple(cases[start]);
    for (int q : quarters) EXPECT_NEAR(q, 16, 4) << format_tuple(cases[start]);
  }
}

// ---------------------------------------------------------------------------------------------
// Golden-ratio offsets

// The shader's 64-bit fixed-point product is exact but for two truncations: the constant
// (floor(2^64 / phi), error < frame * 2^-64 < 2^-32) and the result (to a multiple of 2^-24,
// error < 2^-24); its final conversion float(24-bit integer) * 2^-24 is exact. Plus the long
// double reference's own error (2^-31).
constexpr double kGoldenRatioBound = 0x1p-24 + 0x1p-32 + ref::kGoldenRatioReferenceError;

TEST_F(NoiseTest, GoldenRatioOffsetMatchesLongDoubleReference) {
  ShaderFunction<float(uint32_t)> offset(kNoise, "golden_ratio_offset");
  Rng rng(0x60DE11);
  const auto cases = generate_cases(
      rng, 20000,
      mix(uniform(0u, 1000u), 0.2, mix(uniform(0u, 1u << 24), 0.3, uniform(0u, 0xFFFFFFFFu))));
  const std::vector<float> got = offset.run(cases);
  std::vector<double> errors, bounds(cases.size(), kGoldenRatioBound);
  for (size_t i = 0; i < cases.size(); ++i) {
    errors.push_back(
        ref::circular_distance(ref::golden_ratio_offset(std::get<0>(cases[i])), got[i]));
  }
  EXPECT_TRUE(ref::errors_within_bounds(errors, bounds, [&](size_t i) {
    return format_tuple(cases[i]) + " -> " + format_value(got[i]);
  }));
  for (size_t i = 0; i < cases.size(); ++i) {
    // In [0, 1) and on the 2^-24 grid the shader promises.
    ASSERT_TRUE(got[i] >= 0.0f && got[i] < 1.0f) << format_tuple(cases[i]) << " -> " << got[i];
    const double scaled = double{got[i]} * 0x1p24;
    ASSERT_EQ(scaled, std::floor(scaled)) << format_tuple(cases[i]) << " -> " << got[i];
  }
}

// The three-distance theorem: n consecutive terms of fract(k / phi) split the circle into gaps of
// at most three lengths, the largest the sum of the other two. Checked at frames near 2^32, where
// a float evaluation (float(frame) * 0.618) would collapse them onto a few values.
TEST_F(NoiseTest, GoldenRatioOffsetsOfConsecutiveFramesHaveThreeGapLengths) {
  ShaderFunction<float(uint32_t)> offset(kNoise, "golden_ratio_offset");
  for (const uint32_t first : {0u, 10'000'000u, 0xFFFFFFFFu - 999u}) {
    std::vector<std::tuple<uint32_t>> cases;
    for (uint32_t k = 0; k < 1000; ++k) cases.emplace_back(first + k);
    std::vector<float> got = offset.run(cases);
    std::sort(got.begin(), got.end());
    std::vector<double> gaps;
    for (size_t k = 0; k + 1 < got.size(); ++k) gaps.push_back(double{got[k + 1]} - got[k]);
    gaps.push_back(1.0 - got.back() + got.front());
    std::sort(gaps.begin(), gaps.end());
    // Cluster the gap lengths; each value is truncated to 2^-24, so a gap moves by < 2^-23.
    std::vector<double> lengths = {gaps.front()};
    for (double g : gaps) {
      if (g - lengths.back() > 0x1p-22) lengths.push_back(g);
    }
    EXPECT_LE(lengths.size(), 3u) << "first frame " << first;
    EXPECT_GT(gaps.front(), 0.0) << "first frame " << first << ": two frames share an offset";
    if (lengths.size() == 3) {
      EXPECT_NEAR(lengths[2], lengths[0] + lengths[1], 0x1p-21) << "first frame " << first;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Rotation

// The error of the shader's angle reduction wrap_angle(a) = 2pi_f * (t - round(t)), t = a *
// (1/2pi)_f, against the exact angle a (mod 2 pi): the constants' relative errors times |a|, the
// rounding of t (2^-23 |t| turns = 2^-23 |a| radians), and the final product (< 2^-23 * pi).
double wrap_angle_error(double angle) {
  return std::fabs(angle) * (kInvTwoPiError + kTwoPiError + kRoundingRel) +
         std::numbers::pi * (kRoundingRel + kTwoPiError);
}

// A rotated component c * v.x - s * v.y (or s * v.x + c * v.y): cos and sin each off by at most
// 2^-11 + the angle error, times |v.x| and |v.y|; then two products and a sum, each rounded.
double rotation_component_bound(glm::dvec2 v, double angle_error) {
  const double l1 = std::fabs(v.x) + std::fabs(v.y);
  return l1 * (ref::kTrigAbs + angle_error) + 2.0 * kRoundingRel * l1;
}

TEST_F(NoiseTest, Rotate2MatchesDoubleRotation) {
  ShaderFunction<glm::vec2(glm::vec2, float)> rotate(kNoise, "rotate2");
  Rng rng(0x207A7E);
  const float pi = std::numbers::pi_v<float>;
  const auto cases =
      generate_cases(rng, 20000, uniform<glm::vec2>(-10.0f, 10.0f),
                     mix(uniform(-pi, pi), 0.5,
                         mix(one_of({0.0f, pi, -pi, pi / 2, -pi / 2, 2 * pi, -2 * pi, 3 * pi}), 0.1,
                             uniform(-1000.0f, 1000.0f))));
  const std::vector<glm::vec2> got = rotate.run(cases);
  std::vector<double> want, actual, bounds;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [v, angle] = cases[i];
    const glm::dvec2 r = ref::rotate2(glm::dvec2(v), angle);
    const double bound = rotation_component_bound(glm::dvec2(v), wrap_angle_error(angle));
    for (int c = 0; c < 2; ++c) {
      want.push_back(r[c]);
      actual.push_back(got[i][c]);
      bounds.push_back(bound);
    }
  }
  EXPECT_TRUE(ref::all_within_bounds(want, actual, bounds, [&](size_t k) {
    return format_tuple(cases[k / 2]) + (k % 2 == 0 ? " .x" : " .y");
  }));
}

// rotate2_cos_sin(v, (c, s)) is plain arithmetic: two products and a sum per component.
// rotate2_cos_sin as noise.glsl writes it, per component.
template <class T>
T rotate_x_formula(T x, T y, T c, T s) {
  return c * x - s * y;
}
template <class T>
T rotate_y_formula(T x, T y, T c, T s) {
  return s * x + c * y;
}

TEST_F(NoiseTest, Rotate2CosSinMatchesDoubleRotation) {
  ShaderFunction<glm::vec2(glm::vec2, glm::vec2)> rotate(kNoise, "rotate2_cos_sin");
  Rng rng(0x207A7F);
  const auto cases = generate_cases(
      rng, 20000, uniform<glm::vec2>(-10.0f, 10.0f),
      map(uniform(-4.0f, 4.0f), [](float a) { return glm::vec2(std::cos(a), std::sin(a)); }));
  const std::vector<glm::vec2> got = rotate.run(cases);
  std::vector<Interval> accepted;
  std::vector<float> actual;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [v, cs] = cases[i];
    accepted.push_back(
        spec_interval([&] { return rotate_x_formula<Interval>(v.x, v.y, cs.x, cs.y); }));
    accepted.push_back(
        spec_interval([&] { return rotate_y_formula<Interval>(v.x, v.y, cs.x, cs.y); }));
    actual.insert(actual.end(), {got[i].x, got[i].y});
  }
  // The hand bound: each product rounded, then the sum: < 2^-23 of each term, and of the result.
  const auto terms = [&](size_t k) {
    const auto [v, cs] = cases[k / 2];
    return k % 2 == 0 ? std::fabs(double{cs.x} * v.x) + std::fabs(double{cs.y} * v.y)
                      : std::fabs(double{cs.y} * v.x) + std::fabs(double{cs.x} * v.y);
  };
  EXPECT_TRUE(expect_within_spec(
      {.name = "noise.rotate2_cos_sin",
       .exact =
           [&](size_t k) {
             const auto [v, cs] = cases[k / 2];
             return k % 2 == 0 ? double{cs.x} * v.x - double{cs.y} * v.y
                               : double{cs.y} * v.x + double{cs.x} * v.y;
           },
       .old_bound = [&](size_t k) { return 2.0 * kRoundingRel * terms(k); },
       .describe =
           [&](size_t k) { return format_tuple(cases[k / 2]) + (k % 2 == 0 ? " .x" : " .y"); }},
      accepted, actual));
}

// ---------------------------------------------------------------------------------------------
// Vogel disk

// A component of the shader's Vogel sample radius * (cos a, sin a):
//   radius = sqrt((i + 0.5) / n): float(i) + 0.5 exact (i < 2^23), the division 2.5 ULP, sqrt
//     2 + 2.5 ULP of its result, the division's error halved by the square root;
//   angle in turns t = rotation * (1/2pi)_f - g: the constant, the product and the difference
//     rounded; g = golden_ratio_offset(i) within 2^-24 + 2^-32 turns of i / phi (mod 1); then
//     t - round(t) exact and the product by 2pi_f (constant and rounding);
//   cos / sin: 2^-11 absolute; the final product radius * cos: one rounding.
double vogel_component_bound(int index, int count, double rotation) {
  const double radius = std::sqrt((index + 0.5) / count);
  const double radius_rel = (kRoundingRel * (ref::kDivisionUlps / 2.0 + ref::kSqrtUlps));
  const double turns = std::fabs(rotation) / (2.0 * std::numbers::pi);
  const double turns_error =
      turns * (kInvTwoPiError + kRoundingRel) + kRoundingRel * (turns + 1.0) + 0x1p-24 + 0x1p-32;
  const double angle_error =
      2.0 * std::numbers::pi * turns_error + std::numbers::pi * (kRoundingRel + kTwoPiError);
  return radius * (ref::kTrigAbs + angle_error) + radius * (radius_rel + kRoundingRel);
}

TEST_F(NoiseTest, VogelDiskMatchesGoldenAngleSpiral) {
  ShaderFunction<glm::vec2(int, int, float)> vogel(kNoise, "vogel_disk_sample");
  Rng rng(0x70CE1);
  const float two_pi = 2.0f * std::numbers::pi_v<float>;
  std::vector<std::tuple<int, int, float>> cases;
  for (const int count : {1, 2, 3, 7, 8, 12, 16, 24, 32, 64, 100, 1000}) {
    for (int rep = 0; rep < 3; ++rep) {
      const float rotation = rep == 0 ? 0.0f : uniform(-two_pi, two_pi)(rng);
      for (int i = 0; i < count; ++i) cases.emplace_back(i, count, rotation);
    }
  }
  const std::vector<glm::vec2> got = vogel.run(cases);
  std::vector<double> want, actual, bounds;
  for (size_t k = 0; k < cases.size(); ++k) {
    const auto [i, n, rotation] = cases[k];
    const glm::dvec2 r = ref::vogel_disk_sample(i, n, rotation);
    const double bound = vogel_component_bound(i, n, rotation);
    want.insert(want.end(), {r.x, r.y});
    actual.insert(actual.end(), {got[k].x, got[k].y});
    bounds.insert(bounds.end(), {bound, bound});
  }
  EXPECT_TRUE(ref::all_within_bounds(want, actual, bounds, [&](size_t k) {
    return format_tuple(cases[k / 2]) + (k % 2 == 0 ? " .x" : " .y");
  }));
  // Inside the unit disk, up to the radius and sin/cos error of the outermost sample.
  for (size_t k = 0; k < cases.size(); ++k) {
    const auto [i, n, rotation] = cases[k];
    const double bound = vogel_component_bound(i, n, rotation);
    EXPECT_LE(glm::length(glm::dvec2(got[k])), 1.0 + std::sqrt(2.0) * bound)
        << format_tuple(cases[k]);
  }
}

// ---------------------------------------------------------------------------------------------
// Poisson disk

TEST_F(NoiseTest, PoissonTableIsTheStatedDartThrowingSet) {
  ShaderFunction<glm::vec2(int)> sample(kNoise, "poisson_disk_sample");
  std::vector<std::tuple<int>> cases;
  for (int i = 0; i < ref::kPoissonCount; ++i) cases.emplace_back(i);
  const std::vector<glm::vec2> got = sample.run(cases);

  // The values read back from the GPU are a Poisson-disk set inside the unit disk.
  double min_distance = 1e9;
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_LE(glm::length(glm::dvec2(got[i])), 1.0) << "entry " << i;
    for (size_t j = i + 1; j < got.size(); ++j) {
      min_distance = std::min(min_distance, glm::distance(glm::dvec2(got[i]), glm::dvec2(got[j])));
    }
  }
  EXPECT_GE(min_distance, ref::kPoissonMinDistance);
  RecordProperty("min_distance", std::to_string(min_distance));

  // And they are exactly the generator's output with the stated parameters, rounded to float
  // (the table's 9-digit literals round-trip floats; constants are not flushed or reassociated).
  const auto generated = ref::dart_throw_poisson_disk(
      ref::kPoissonSeed, ref::kPoissonCount, ref::kPoissonMinDistance, ref::kPoissonMaxDarts);
  ASSERT_TRUE(generated.has_value());
  std::vector<glm::vec2> want;
  for (const glm::dvec2& p : *generated) want.emplace_back(p);
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact());

  // Roughly centred (a lopsided kernel would bias a filter): the mean of 32 darts, |mean| < 0.05.
  glm::dvec2 mean(0.0);
  for (const glm::vec2& p : got) mean += glm::dvec2(p) / 32.0;
  EXPECT_LT(glm::length(mean), 0.05);
}

TEST_F(NoiseTest, RotatedPoissonSampleMatchesDoubleRotation) {
  ShaderFunction<glm::vec2(int, float)> sample(kNoise, "rotated_poisson_sample");
  ShaderFunction<glm::vec2(int)> table(kNoise, "poisson_disk_sample");
  std::vector<std::tuple<int>> entries;
  for (int i = 0; i < 32; ++i) entries.emplace_back(i);
  const std::vector<glm::vec2> disk = table.run(entries);

  Rng rng(0x9015);
  const float two_pi = 2.0f * std::numbers::pi_v<float>;
  const auto cases = generate_cases(rng, 8000, uniform(0, 31), uniform(0.0f, two_pi));
  const std::vector<glm::vec2> got = sample.run(cases);
  std::vector<double> want, actual, bounds;
  for (size_t k = 0; k < cases.size(); ++k) {
    const auto [i, angle] = cases[k];
    const glm::dvec2 v(disk[static_cast<size_t>(i)]);
    const glm::dvec2 r = ref::rotate2(v, angle);
    const double bound = rotation_component_bound(v, wrap_angle_error(angle));
    want.insert(want.end(), {r.x, r.y});
    actual.insert(actual.end(), {got[k].x, got[k].y});
    bounds.insert(bounds.end(), {bound, bound});
  }
  EXPECT_TRUE(ref::all_within_bounds(want, actual, bounds, [&](size_t k) {
    return format_tuple(cases[k / 2]) + (k % 2 == 0 ? " .x" : " .y");
  }));
}

}  // namespace
}  // namespace penumbra::testing
