// shaders/penumbra/temporal.glsl against the C++ references in reference/temporal_ref.hpp:
// the octahedral normal encoding, the reprojection to the last frame's pixels, the same-surface
// test and the clamped blend (the shadow-temporal pass's arithmetic).
#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <limits>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <tuple>
#include <vector>

#include "reference/temporal_ref.hpp"

namespace penumbra::testing {
namespace {

namespace ref = penumbra::reference;

constexpr const char* kTemporal = "penumbra/temporal.glsl";
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

class TemporalTest : public GpuTest {};

glm::vec3 random_unit(Rng& rng) {
  for (;;) {
    const glm::vec3 v = uniform<glm::vec3>(-1.0f, 1.0f)(rng);
    const float l = glm::length(v);
    if (l > 1e-3f && l <= 1.0f) return v / l;
  }
}

// Encoding matches the reference within float rounding, and decoding gives the vector back,
// for random directions and the axes and diagonals, where the folds meet.
TEST_F(TemporalTest, OctahedralEncodingMatchesTheReferenceAndRoundTrips) {
  ShaderFunction<glm::vec2(glm::vec3)> encode(kTemporal, "oct_encode");
  ShaderFunction<glm::vec3(glm::vec2)> decode(kTemporal, "oct_decode");
  Rng rng(0x7E3901);
  std::vector<std::tuple<glm::vec3>> cases;
  for (int i = 0; i < 4096; ++i) cases.emplace_back(random_unit(rng));
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x || y || z) cases.emplace_back(glm::normalize(glm::vec3(x, y, z)));
  const std::vector<glm::vec2> got = encode.run(cases);
  std::vector<glm::vec2> want;
  std::vector<std::tuple<glm::vec2>> encoded;
  for (size_t i = 0; i < cases.size(); ++i) {
    want.push_back(glm::vec2(ref::oct_encode(glm::dvec3(std::get<0>(cases[i])))));
    encoded.emplace_back(got[i]);
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::absolute(1e-6),
                           [&](size_t i) { return format_tuple(cases[i]); });
  const std::vector<glm::vec3> back = decode.run(encoded);
  std::vector<glm::vec3> original;
  for (const auto& c : cases) original.push_back(std::get<0>(c));
  PENUMBRA_EXPECT_ALL_NEAR(original, back, Tolerance::absolute(2e-6),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

// Zero and non-finite vectors encode to (0, 0), which decodes to +Z: no NaN reaches the history.
TEST_F(TemporalTest, DegenerateNormalsEncodeToTheOrigin) {
  ShaderFunction<glm::vec2(glm::vec3)> encode(kTemporal, "oct_encode");
  for (const glm::vec3 n :
       {glm::vec3(0.0f), glm::vec3(kNaN, 0, 1), glm::vec3(kInf, 0, 0), glm::vec3(0, -kInf, 1)})
    EXPECT_EQ(encode(n), glm::vec2(0.0f)) << format_value(n);
  ShaderFunction<glm::vec3(glm::vec2)> decode(kTemporal, "oct_decode");
  EXPECT_EQ(decode(glm::vec2(0.0f)), glm::vec3(0, 0, 1));
}

// Pixel-centre coordinates of view-space points under reverse-Z and standard projections, in
// front of and behind the camera, against the reference in double.
TEST_F(TemporalTest, ReprojectionMatchesTheProjection) {
  ShaderFunction<glm::vec3(glm::mat4, glm::vec3, glm::vec2)> reproject(kTemporal,
                                                                       "temporal_reproject");
  Rng rng(0x7E3902);
  std::vector<std::tuple<glm::mat4, glm::vec3, glm::vec2>> cases;
  for (int i = 0; i < 2048; ++i) {
    const float fov = uniform(20.0f, 100.0f)(rng);
    const glm::vec2 size = glm::floor(uniform<glm::vec2>(16.0f, 4096.0f)(rng));
    glm::mat4 proj = glm::perspectiveRH_ZO(glm::radians(fov), size.x / size.y, 0.05f, 500.0f);
    proj[1][1] *= -1.0f;  // +Y up on screen
    glm::vec3 v = uniform<glm::vec3>(-50.0f, 50.0f)(rng);
    if (i % 8 == 0) v.z = std::abs(v.z);  // behind the camera
    cases.emplace_back(proj, v, size);
  }
  const std::vector<glm::vec3> got = reproject.run(cases);
  std::vector<glm::vec3> want;
  for (const auto& [proj, v, size] : cases) {
    const ref::Reprojected r = ref::reproject(glm::dmat4(proj), glm::dvec3(v), glm::dvec2(size));
    want.push_back(r.in_front ? glm::vec3(glm::vec2(r.pixel), 1.0f) : glm::vec3(0.0f));
  }
  // Pixel coordinates up to ~1e5 for points near the eye plane: relative float rounding.
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::relative(2e-5, 1e-3),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

// The same-surface test agrees with the reference wherever the reference's margin is clear of
// float rounding; sky (distance 0) and NaN distances never match.
TEST_F(TemporalTest, SameSurfaceTestMatchesTheReference) {
  ShaderFunction<bool(float, glm::vec3, float, glm::vec3, float, float, float)> same(
      kTemporal, "temporal_same_surface");
  Rng rng(0x7E3903);
  using Case = std::tuple<float, glm::vec3, float, glm::vec3, float, float, float>;
  std::vector<Case> cases;
  for (int i = 0; i < 4096; ++i) {
    const float expected = uniform(0.01f, 1000.0f)(rng);
    const float stored = expected * uniform(0.97f, 1.03f)(rng) + uniform(-0.005f, 0.005f)(rng);
    const glm::vec3 n = random_unit(rng);
    const glm::vec3 m = glm::normalize(n + 0.35f * random_unit(rng));
    cases.emplace_back(i % 64 == 0 ? 0.0f : stored, m, expected, n, 0.02f, 0.002f, 0.9f);
  }
  cases.emplace_back(kNaN, glm::vec3(0, 0, 1), 1.0f, glm::vec3(0, 0, 1), 0.02f, 0.002f, 0.9f);
  const std::vector<bool> got = same.run(cases);
  size_t compared = 0, inside = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto& [stored, m, expected, n, fraction, constant, min_cos] = cases[i];
    const double margin = ref::same_surface_margin(stored, glm::dvec3(m), expected, glm::dvec3(n),
                                                   fraction, constant, min_cos);
    if (std::abs(margin) < 1e-5 * std::max(1.0, double(expected)))
      continue;  // within rounding of the bound
    ++compared;
    inside += margin > 0.0;
    EXPECT_EQ(got[i], margin > 0.0) << format_tuple(cases[i]) << " margin " << margin;
  }
  // Both outcomes are exercised.
  EXPECT_GT(compared, 4000u);
  EXPECT_GT(inside, 500u);
  EXPECT_LT(inside, compared - 500u);
}

// The blend: the history clamped to the neighbourhood, then moved towards the current value by
// the weight; a weight outside (0, 1] or a non-finite history gives the current value.
TEST_F(TemporalTest, BlendClampsTheHistoryThenMovesTowardsTheCurrentValue) {
  ShaderFunction<glm::vec4(glm::vec4, glm::vec4, glm::vec4, glm::vec4, float)> blend(
      kTemporal, "temporal_blend");
  Rng rng(0x7E3904);
  using Case = std::tuple<glm::vec4, glm::vec4, glm::vec4, glm::vec4, float>;
  std::vector<Case> cases;
  for (int i = 0; i < 4096; ++i) {
    const glm::vec4 a = uniform<glm::vec4>(0.0f, 1.0f)(rng),
                    b = uniform<glm::vec4>(0.0f, 1.0f)(rng);
    glm::vec4 current = uniform<glm::vec4>(0.0f, 1.0f)(rng);
    const glm::vec4 lo = glm::min(glm::min(a, b), current), hi = glm::max(glm::max(a, b), current);
    glm::vec4 history = uniform<glm::vec4>(-0.5f, 1.5f)(rng);
    float weight = uniform(0.0f, 1.0f)(rng);
    if (i % 97 == 0) weight = 0.0f;
    if (i % 89 == 0) weight = 1.5f;
    if (i % 83 == 0) weight = kNaN;
    if (i % 79 == 0) history.y = kNaN;
    if (i % 73 == 0) history.z = -kInf;
    cases.emplace_back(history, current, lo, hi, weight);
  }
  // lo > hi (not the pass's case, which includes the current value): the upper bound wins.
  cases.emplace_back(glm::vec4(0.5f), glm::vec4(0.2f), glm::vec4(0.9f), glm::vec4(0.1f), 0.25f);
  const std::vector<glm::vec4> got = blend.run(cases);
  std::vector<glm::vec4> want;
  for (const auto& [history, current, lo, hi, weight] : cases) {
    const bool finite = std::isfinite(history.x) && std::isfinite(history.y) &&
                        std::isfinite(history.z) && std::isfinite(history.w);
    glm::vec4 w;
    for (int c = 0; c < 4; ++c)
      w[c] =
          float(ref::temporal_blend(finite ? history[c] : kNaN, current[c], lo[c], hi[c], weight));
    want.push_back(w);
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::absolute(2e-7),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

// The depth test accepts a stored distance exactly at the tolerance (fraction x expected +
// constant), and rejects one a float beyond it.
TEST_F(TemporalTest, SameSurfaceAcceptsTheToleranceItself) {
  ShaderFunction<bool(float, glm::vec3, float, glm::vec3, float, float, float)> same(
      kTemporal, "temporal_same_surface");
  const glm::vec3 n(0, 0, 1);
  EXPECT_TRUE(same(1.5f, n, 1.0f, n, 0.0f, 0.5f, 0.9f));
  EXPECT_TRUE(same(0.5f, n, 1.0f, n, 0.25f, 0.25f, 0.9f));
  EXPECT_FALSE(same(std::nextafter(1.5f, 2.0f), n, 1.0f, n, 0.0f, 0.5f, 0.9f));
}

// Reprojection through any projection matrix (an orthographic one's w is 1, not -z); a point on
// the eye plane (w = 0) has no pixel; the same-surface test rejects sky (distance 0) and accepts
// normals exactly at the cosine bound.
TEST_F(TemporalTest, ReprojectionAndSameSurfaceBoundaries) {
  ShaderFunction<glm::vec3(glm::mat4, glm::vec3, glm::vec2)> reproject(kTemporal,
                                                                       "temporal_reproject");
  const glm::mat4 ortho = glm::orthoRH_ZO(-4.0f, 4.0f, -2.0f, 2.0f, 0.1f, 100.0f);
  const glm::vec3 v(1.0f, -0.5f, -10.0f);
  const glm::vec4 c = ortho * glm::vec4(v, 1.0f);
  const glm::vec2 size(800.0f, 400.0f);
  const glm::vec2 want = (glm::vec2(c) / c.w * 0.5f + 0.5f) * size - 0.5f;
  const glm::vec3 got = reproject(ortho, v, size);
  EXPECT_NEAR(got.x, want.x, 1e-3f);
  EXPECT_NEAR(got.y, want.y, 1e-3f);
  EXPECT_EQ(got.z, 1.0f);
  const glm::mat4 persp = glm::perspectiveRH_ZO(1.0f, 2.0f, 0.1f, 100.0f);
  EXPECT_EQ(reproject(persp, glm::vec3(1.0f, 1.0f, 0.0f), size), glm::vec3(0.0f));

  ShaderFunction<bool(float, glm::vec3, float, glm::vec3, float, float, float)> same(
      kTemporal, "temporal_same_surface");
  const glm::vec3 n(0, 0, 1);
  EXPECT_FALSE(same(0.0f, n, 0.1f, n, 0.0f, 0.5f, 0.9f));
  EXPECT_TRUE(same(1.0f, n, 1.0f, n, 0.0f, 0.5f, 1.0f));
}

// A history with any non-finite component (x, the first one checked, here) gives the current
// value.
TEST_F(TemporalTest, NonFiniteHistoryInTheFirstComponentGivesCurrent) {
  ShaderFunction<glm::vec4(glm::vec4, glm::vec4, glm::vec4, glm::vec4, float)> blend(
      kTemporal, "temporal_blend");
  const glm::vec4 current(0.25f, 0.5f, 0.75f, 1.0f);
  EXPECT_EQ(blend(glm::vec4(kNaN, 0, 0, 0), current, glm::vec4(0), glm::vec4(1), 0.1f), current);
  EXPECT_EQ(blend(glm::vec4(kInf, 0, 0, 0), current, glm::vec4(0), glm::vec4(1), 0.1f), current);
}

}  // namespace
}  // namespace penumbra::testing
