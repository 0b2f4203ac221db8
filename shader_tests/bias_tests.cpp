// Function-level tests of shaders/penumbra/bias.glsl against the independent double-precision
// references in reference/bias_ref.hpp: normal offset (scale and vector), slope-scaled bias,
// receiver-plane depth gradient (random Jacobians with per-case error bounds, and a known plane),
// the tap depth offset, and apply_depth_bias in both depth conventions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/interval.hpp>
#include <penumbra/testing/property.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <reference/bias_ref.hpp>
#include <spec_check.hpp>
#include <string>
#include <tuple>
#include <vector>

namespace penumbra::testing {
namespace {

constexpr const char* kBias = "penumbra/bias.glsl";
// Unit roundoff of float: a correctly rounded operation errs by at most kU relative.
constexpr double kU = 0x1p-24;

// Normal offset, in units of offset_texels * texel_world_size (the scale is in [0, 1]):
// normalizing costs <= 6.5u per component (dot 3u, inversesqrt 2 ULP = 4u plus half the dot's,
// one multiply); the cross product of two such unit vectors is off by <= ~45u in norm (each term
// carries both inputs' 6.5u, plus its own rounding and the subtraction); length() adds the dot's
// 1.5u and sqrt's (1 / inversesqrt: 2 + 2.5 ULP = 9u); applying the scale costs 4 more roundings
// and the normalization's 5.5u. About 66u in all; 128u = 2^-17 ~ 7.6e-6 leaves a factor ~2.
const Tolerance kOffsetTolerance = Tolerance::absolute(128 * kU);

// Slope-scaled bias, relative: (1 - c)(1 + c) 3u, sqrt 9u + 1.5u inherited, the divide by c 2.5
// ULP = 5u, then one multiply and one add of non-negative terms (no cancellation): <= 17.5u.
// 32u = 2^-19 ~ 1.9e-6 relative.
const Tolerance kSlopeTolerance = Tolerance::relative(32 * kU);

class BiasTest : public GpuTest {
 protected:
  BiasTest() : seed_(resolve_seed(0)), rng_(seed_.seed) {}
  std::string seed_note() const {
    return "seed " + std::to_string(seed_.seed) + " (set PENUMBRA_SEED to reproduce)";
  }
  SeedChoice seed_;
  Rng rng_;
};

// A direction of random length (a fifth of them exactly unit length as drawn).
glm::vec3 random_direction(Rng& rng) {
  const glm::vec3 d = unit_vector3()(rng);
  return rng.bernoulli(0.2) ? d : d * uniform(0.05f, 20.0f)(rng);
}

// Compares each case's error in units of its own scale: (actual - expected) / scale must be
// within `tol`; the report shows the scaled values and the inputs.
template <int L>
::testing::AssertionResult scaled_near(const std::vector<glm::vec<L, double>>& expected,
                                       const std::vector<glm::vec<L, float>>& actual,
                                       const std::vector<double>& scale, const Tolerance& tol,
                                       DescribeInputs describe) {
  std::vector<glm::vec<L, double>> e, a;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    e.push_back(expected[i] / scale[i]);
    a.push_back(glm::vec<L, double>(actual[i]) / scale[i]);
  }
  return all_near(e, a, tol, std::move(describe));
}

// ------------------------------------------------------------------------------------------
// Normal offset

TEST_F(BiasTest, NormalOffsetScaleMatchesReference) {
  SCOPED_TRACE(seed_note());
  PENUMBRA_EXPECT_PROPERTY(check_property(
      "normal_offset_scale",
      [&](const auto& cases) {
        ShaderFunction<float(glm::vec3, glm::vec3)> f(kBias, "normal_offset_scale");
        return f.run(cases);
      },
      [](const glm::vec3& n, const glm::vec3& l) {
        return static_cast<float>(ref::normal_offset_scale(n, l));
      },
      kOffsetTolerance, {.cases = 8192}, [](Rng& rng) { return random_direction(rng); },
      [](Rng& rng) { return random_direction(rng); }));
}

TEST_F(BiasTest, NormalOffsetMatchesReference) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<glm::vec3(glm::vec3, glm::vec3, float, float)> offset(kBias, "normal_offset");
  std::vector<std::tuple<glm::vec3, glm::vec3, float, float>> cases;
  std::vector<glm::dvec3> want;
  std::vector<double> scale;
  for (int k = 0; k < 8192; ++k) {
    const glm::vec3 n = random_direction(rng_), l = random_direction(rng_);
    const float texel = uniform(0.001f, 1.0f)(rng_), texels = uniform(0.5f, 3.0f)(rng_);
    cases.emplace_back(n, l, texel, texels);
    want.push_back(ref::normal_offset(n, l, texel, texels));
    scale.push_back(static_cast<double>(texel) * texels);
  }
  const auto got = offset.run(cases);
  EXPECT_TRUE(scaled_near(want, got, scale, kOffsetTolerance, [&](std::size_t i) {
    return format_tuple(cases[i]) + " (offset / (texels * size))";
  }));
}

TEST_F(BiasTest, NormalOffsetKnownAngles) {
  // Normal +Z, light at angle theta from it in the XZ plane: the offset is +Z * sin(theta) for
  // theta < 90 degrees, and the full offset from 90 degrees on (back faces).
  ShaderFunction<glm::vec3(glm::vec3, glm::vec3, float, float)> offset(kBias, "normal_offset");
  const double degrees[] = {0, 30, 45, 60, 89, 90, 91, 120, 180};
  std::vector<std::tuple<glm::vec3, glm::vec3, float, float>> cases;
  std::vector<glm::vec3> want;
  for (double deg : degrees) {
    const double t = deg * std::numbers::pi / 180.0;
    // texel 0.5 m, 2 texels: full offset 1 m.
    cases.emplace_back(glm::vec3(0, 0, 3), glm::vec3(std::sin(t), 0, std::cos(t)), 0.5f, 2.0f);
    want.emplace_back(0, 0, deg < 90 ? std::sin(t) : 1.0);
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, offset.run(cases), kOffsetTolerance,
                           [&](std::size_t i) { return format_tuple(cases[i]); });
}

TEST_F(BiasTest, NormalOffsetGrowsTowardsGrazingAngles) {
  ShaderFunction<float(glm::vec3, glm::vec3)> scale(kBias, "normal_offset_scale");
  std::vector<std::tuple<glm::vec3, glm::vec3>> cases;
  constexpr int kSteps = 2048;
  const glm::vec3 n = glm::normalize(glm::vec3(0.3f, -0.5f, 0.8f));
  const glm::vec3 u = glm::normalize(glm::cross(n, glm::vec3(1, 0, 0)));
  for (int k = 0; k <= kSteps; ++k) {
    const double t = std::numbers::pi * k / kSteps;
    cases.emplace_back(n,
                       n * static_cast<float>(std::cos(t)) + u * static_cast<float>(std::sin(t)));
  }
  const auto got = scale.run(cases);
  for (std::size_t k = 1; k < got.size(); ++k) {
    // Non-decreasing up to the tolerance (the inputs themselves are rounded to float).
    ASSERT_GE(got[k], got[k - 1] - 128 * kU) << "step " << k << ": " << format_tuple(cases[k]);
    ASSERT_TRUE(got[k] >= 0.0f && got[k] <= 1.0f) << got[k];
  }
  EXPECT_LT(got.front(), 1e-5f);
  EXPECT_EQ(got.back(), 1.0f);
}

// ------------------------------------------------------------------------------------------
// Slope-scaled bias

// slope_scaled_bias as bias.glsl writes it: in double the value, on Interval what the spec
// allows a device to return.
template <class T>
T slope_scaled_bias_formula(T n_dot_l, T constant_bias, T slope_scale, T max_bias) {
  using namespace glsl;
  if (is_nan(n_dot_l) || !(n_dot_l >= T(std::numeric_limits<float>::min()))) return max_bias;
  const T c = min(n_dot_l, T(1.0f));
  const T tan_theta = sqrt(max((T(1.0f) - c) * (T(1.0f) + c), T(0.0f))) / c;
  return min(constant_bias + slope_scale * tan_theta, max_bias);
}

// The device lies in the spec's interval for the shader's formula; the interval holds the exact
// tan(acos(n . l)) of the reference; the hand bound (32u relative) is audited.
TEST_F(BiasTest, SlopeScaledBiasMatchesReference) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<float(float, float, float, float)> f(kBias, "slope_scaled_bias");
  const auto cases = generate_cases(
      rng_, 8192,
      // Mostly facing the light, some grazing, some back faces, some exactly 1.
      mix(uniform(-0.3f, 1.0f), 0.8,
          mix(uniform(1e-6f, 1e-2f), 0.7, one_of({1.0f, 0.0f, 0.5f, 0.8660254f}))),
      mix(constant(0.0f), 0.2, uniform(0.0f, 1e-3f)), uniform(0.0f, 5e-3f), uniform(1e-3f, 2e-2f));
  const std::vector<float> got = f.run(cases);
  std::vector<Interval> accepted;
  for (const auto& [n_dot_l, constant_bias, slope, max_bias] : cases) {
    accepted.push_back(spec_interval([&] {
      return slope_scaled_bias_formula<Interval>(n_dot_l, constant_bias, slope, max_bias);
    }));
  }
  const auto exact = [&](std::size_t i) { return std::apply(ref::slope_scaled_bias, cases[i]); };
  EXPECT_TRUE(
      expect_within_spec({.name = "bias.slope_scaled_bias",
                          .exact = exact,
                          .old_bound = [&](std::size_t i) { return 32 * kU * std::fabs(exact(i)); },
                          .describe = [&](std::size_t i) { return format_tuple(cases[i]); }},
                         accepted, got));
}

TEST_F(BiasTest, SlopeScaledBiasKnownValuesAndClamp) {
  ShaderFunction<float(float, float, float, float)> bias(kBias, "slope_scaled_bias");
  // cos 45 degrees: tan 1; cos 60 degrees: tan sqrt(3); facing the light: the constant alone.
  const float c45 = static_cast<float>(std::sqrt(0.5)), c60 = 0.5f;
  const std::vector<std::tuple<float, float, float, float>> cases = {
      {1.0f, 1e-4f, 1e-3f, 1.0f},  {c45, 1e-4f, 1e-3f, 1.0f},
      {c60, 1e-4f, 1e-3f, 1.0f},   {c60, 1e-4f, 1e-3f, 1e-3f},  // clamped
      {0.0f, 1e-4f, 1e-3f, 5e-3f}, {-0.5f, 1e-4f, 1e-3f, 5e-3f}};
  const std::vector<float> want = {
      1e-4f,
      static_cast<float>(1e-4 + 1e-3 * std::tan(std::acos(double(c45)))),
      static_cast<float>(1e-4 + 1e-3 * std::sqrt(3.0)),
      1e-3f,
      5e-3f,
      5e-3f};
  PENUMBRA_EXPECT_ALL_NEAR(want, bias.run(cases), kSlopeTolerance,
                           [&](std::size_t i) { return format_tuple(cases[i]); });
}

TEST_F(BiasTest, SlopeScaledBiasGrowsAsTheSurfaceTurnsAway) {
  ShaderFunction<float(float, float, float, float)> bias(kBias, "slope_scaled_bias");
  std::vector<std::tuple<float, float, float, float>> cases;
  for (int k = 0; k <= 4096; ++k) {
    const float n_dot_l = 1.0f - 1.2f * static_cast<float>(k) / 4096.0f;  // 1 down to -0.2
    cases.emplace_back(n_dot_l, 2e-4f, 1e-3f, 0.05f);
  }
  const auto got = bias.run(cases);
  for (std::size_t k = 1; k < got.size(); ++k) {
    ASSERT_GE(got[k], got[k - 1] * (1.0f - 64 * static_cast<float>(kU)))
        << "n.l = " << std::get<0>(cases[k]);
    ASSERT_TRUE(std::isfinite(got[k]) && got[k] <= 0.05f) << got[k];
  }
  EXPECT_EQ(got.front(), 2e-4f);
  EXPECT_EQ(got.back(), 0.05f);
}

// ------------------------------------------------------------------------------------------
// Receiver-plane depth bias

// Per-component bound on |GPU - exact| for receiver_plane_depth_gradient: numerator and
// determinant are two-product differences, off by <= gamma_2 (2u / (1 - 2u)) times the sum of
// the absolute products whether or not the driver fuses them; the quotient adds the divide's 2.5
// ULP (5u relative) and propagates both errors: |dg| <= (|dn| + |g| |ddet|) / |det| + 5u |g|.
// Doubled for the first-order approximation.
glm::dvec2 gradient_error_bound(const glm::vec3& dx, const glm::vec3& dy, const glm::dvec2& g) {
  const double gamma2 = 2 * kU / (1 - 2 * kU);
  const double a = dx.x, b = dy.x, c = dx.y, d = dy.y, p = dx.z, q = dy.z;
  const double det = a * d - b * c;
  const double ddet = gamma2 * (std::abs(a * d) + std::abs(b * c));
  const double dn[2] = {gamma2 * (std::abs(d * p) + std::abs(c * q)),
                        gamma2 * (std::abs(a * q) + std::abs(b * p))};
  glm::dvec2 bound;
  for (int k = 0; k < 2; ++k) {
    bound[k] = 2.0 * ((dn[k] + std::abs(g[k]) * ddet) / std::abs(det) + 5 * kU * std::abs(g[k]));
  }
  return bound + glm::dvec2(1e-38);
}

// A random Jacobian (screen -> shadow uv) and depth derivatives; relative determinants near
// the singularity threshold, where rounding could decide either way, are drawn again.
std::tuple<glm::vec3, glm::vec3> random_derivatives(Rng& rng) {
  for (;;) {
    const float s = std::exp2(uniform(-16.0f, -4.0f)(rng));  // uv per pixel
    glm::vec3 dx = uniform(glm::vec3(-1.0f), glm::vec3(1.0f))(rng) * s;
    glm::vec3 dy = uniform(glm::vec3(-1.0f), glm::vec3(1.0f))(rng) * s;
    if (rng.bernoulli(0.1)) {
      // Exactly singular: the y column a power-of-two multiple of the x column.
      const float k = one_of({0.5f, -2.0f, 4.0f})(rng);
      dy.x = dx.x * k;
      dy.y = dx.y * k;
    }
    const double rel = ref::relative_determinant(dx, dy);
    if (rel > ref::kReceiverPlaneMinDet * 0.25 && rel < ref::kReceiverPlaneMinDet * 4) continue;
    return {dx, dy};
  }
}

TEST_F(BiasTest, ReceiverPlaneGradientMatchesReference) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<glm::vec2(glm::vec3, glm::vec3)> gradient(kBias, "receiver_plane_depth_gradient");
  std::vector<std::tuple<glm::vec3, glm::vec3>> cases;
  std::vector<glm::dvec2> want, zero;
  int singular = 0;
  for (int k = 0; k < 8192; ++k) {
    const auto [dx, dy] = random_derivatives(rng_);
    cases.emplace_back(dx, dy);
    want.push_back(ref::receiver_plane_depth_gradient(dx, dy));
    singular += want.back() == glm::dvec2(0.0) ? 1 : 0;
  }
  EXPECT_GT(singular, 400) << "the generator should produce singular Jacobians";
  const auto got = gradient.run(cases);
  std::vector<glm::dvec2> errors;
  std::vector<std::string> notes;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const auto& [dx, dy] = cases[i];
    const bool is_zero = want[i] == glm::dvec2(0.0);
    const glm::dvec2 bound = is_zero ? glm::dvec2(1e-38) : gradient_error_bound(dx, dy, want[i]);
    zero.emplace_back(0.0);
    errors.push_back((glm::dvec2(got[i]) - want[i]) / bound);
    notes.push_back(format_tuple(cases[i]) + ": expected " + format_value(want[i]) + ", got " +
                    format_value(got[i]) + ", bound " + format_value(bound) +
                    " (error / bound shown)");
  }
  PENUMBRA_EXPECT_ALL_NEAR(zero, errors, Tolerance::absolute(1.0),
                           [&](std::size_t i) { return notes[i]; });
}

TEST_F(BiasTest, ReceiverPlaneGradientRecoversAKnownPlane) {
  // A receiver plane depth = alpha u + beta v + gamma seen through a random screen -> uv
  // Jacobian: the screen derivatives of depth are alpha du/dx + beta dv/dx (and likewise for y);
  // the function must give back (alpha, beta) (not the transpose, not swapped).
  SCOPED_TRACE(seed_note());
  ShaderFunction<glm::vec2(glm::vec3, glm::vec3)> gradient(kBias, "receiver_plane_depth_gradient");
  std::vector<std::tuple<glm::vec3, glm::vec3>> cases;
  std::vector<glm::vec2> planes;
  while (cases.size() < 2048) {
    const float s = std::exp2(uniform(-14.0f, -6.0f)(rng_));
    glm::vec3 dx = uniform(glm::vec3(-1.0f), glm::vec3(1.0f))(rng_) * s;
    glm::vec3 dy = uniform(glm::vec3(-1.0f), glm::vec3(1.0f))(rng_) * s;
    if (ref::relative_determinant(dx, dy) < 0.05) continue;  // well conditioned
    const glm::vec2 plane = uniform(glm::vec2(-2.0f), glm::vec2(2.0f))(rng_);
    dx.z = static_cast<float>(double(plane.x) * dx.x + double(plane.y) * dx.y);
    dy.z = static_cast<float>(double(plane.x) * dy.x + double(plane.y) * dy.y);
    cases.emplace_back(dx, dy);
    planes.push_back(plane);
  }
  // Conditioning 1 / 0.05 amplifies the float rounding of the inputs (~1e-7) to ~1e-5 at most.
  PENUMBRA_EXPECT_ALL_NEAR(planes, gradient.run(cases), Tolerance::absolute(1e-4),
                           [&](std::size_t i) { return format_tuple(cases[i]); });
}

TEST_F(BiasTest, ReceiverPlaneDepthOffsetIsTheGradientDotTheTapOffset) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<float(glm::vec2, glm::vec2)> offset(kBias, "receiver_plane_depth_offset");
  std::vector<std::tuple<glm::vec2, glm::vec2>> cases;
  std::vector<double> want;
  std::vector<double> scale;
  for (int k = 0; k < 4096; ++k) {
    const glm::vec2 g = uniform(glm::vec2(-10.0f), glm::vec2(10.0f))(rng_);
    const glm::vec2 o = uniform(glm::vec2(-0.01f), glm::vec2(0.01f))(rng_);
    cases.emplace_back(g, o);
    want.push_back(double(g.x) * o.x + double(g.y) * o.y);
    // A two-term dot product: gamma_2 of the absolute terms (FMA or not).
    scale.push_back(std::abs(double(g.x) * o.x) + std::abs(double(g.y) * o.y) + 1e-38);
  }
  const auto got = offset.run(cases);
  std::vector<double> e, a;
  for (std::size_t i = 0; i < got.size(); ++i) {
    e.push_back(want[i] / scale[i]);
    a.push_back(static_cast<double>(got[i]) / scale[i]);
  }
  PENUMBRA_EXPECT_ALL_NEAR(e, a, Tolerance::absolute(2 * 2 * kU / (1 - 2 * kU)),
                           [&](std::size_t i) { return format_tuple(cases[i]) + " (scaled)"; });
}

// ------------------------------------------------------------------------------------------
// Applying a depth bias

TEST_F(BiasTest, ApplyDepthBiasMovesTowardsTheLightInBothConventions) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<float(float, float, bool)> apply(kBias, "apply_depth_bias");
  for (DepthConvention convention : {DepthConvention::reverse_z, DepthConvention::standard}) {
    const bool reverse_z = convention == DepthConvention::reverse_z;
    SCOPED_TRACE(reverse_z ? "reverse-Z" : "standard depth");
    // One correctly rounded add or subtract: exact against the reference, except that a GPU
    // may flush denormal inputs and results to zero (depth_extremes draws the smallest
    // denormal), hence the floor of FLT_MIN.
    const auto result = check_property(
        "apply_depth_bias", [&](const auto& cases) { return apply.run(cases); },
        [](float depth, float bias, bool rz) { return ref::apply_depth_bias(depth, bias, rz); },
        Tolerance::ulps(0, std::numeric_limits<float>::min()), {.cases = 4096},
        depth_extremes(convention), mix(constant(0.0f), 0.1, uniform(0.0f, 1e-3f)),
        constant(reverse_z));
    PENUMBRA_EXPECT_PROPERTY(result);
  }
  // Towards the light: reverse-Z near is 1 (larger is closer), standard near is 0.
  EXPECT_EQ(apply(0.5f, 0.25f, true), 0.75f);
  EXPECT_EQ(apply(0.5f, 0.25f, false), 0.25f);
  EXPECT_EQ(apply(0.5f, 0.0f, true), 0.5f);
  EXPECT_EQ(apply(0.5f, 0.0f, false), 0.5f);
}

// The guards of the normal offset and the light-ward bias at their boundaries: a zero normal or
// light direction gives the full offset (scale 1); a direction whose squared length is exactly
// FLT_MIN is long enough to move along.
TEST_F(BiasTest, GuardsAtTheirBoundaries) {
  ShaderFunction<float(glm::vec3, glm::vec3)> scale(kBias, "normal_offset_scale");
  EXPECT_EQ(scale(glm::vec3(0.0f), glm::vec3(0, 0, 1)), 1.0f);
  EXPECT_EQ(scale(glm::vec3(0, 0, 1), glm::vec3(0.0f)), 1.0f);
  EXPECT_LT(scale(glm::vec3(0, 0, 1), glm::vec3(0, 0, 1)), 1e-5f);
  ShaderFunction<glm::vec3(glm::vec3, glm::vec3, float)> toward(kBias, "bias_toward_light");
  const float tiny = 0x1p-63f;  // tiny * tiny = FLT_MIN
  EXPECT_EQ(toward(glm::vec3(0.0f), glm::vec3(tiny, 0.0f, 0.0f), 0.5f), glm::vec3(0.5f, 0, 0));
  EXPECT_EQ(toward(glm::vec3(1.0f), glm::vec3(0.0f, 2.0f, 0.0f), 0.0f), glm::vec3(1.0f));
}

}  // namespace
}  // namespace penumbra::testing
