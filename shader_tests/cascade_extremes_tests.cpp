// Extremes of shaders/penumbra/cascade.glsl: depths exactly at split boundaries, 0, -0,
// denormals, huge, +-Inf and NaN never give an index outside [0, count] or a NaN weight; cascade
// counts 0, 1, 8 and beyond; zero, negative and oversized band widths; coordinates outside [0, 1]
// and exactly on the edges (with and without a border); perspective lights with w = 0, w
// negative (behind), w denormal and w tiny, and non-finite positions.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <reference/cascade_ref.hpp>
#include <string>
#include <tuple>
#include <vector>

namespace penumbra::testing {
namespace {

using Splits = ref::Splits;
using Mat8 = std::array<glm::mat4, 8>;
using Vec3x8 = std::array<glm::vec3, 8>;
using L = std::numeric_limits<float>;

constexpr const char* kCascade = "penumbra/cascade.glsl";
constexpr float kInf = L::infinity();
constexpr float kNaN = L::quiet_NaN();
constexpr double kU = 0x1p-24;
// See cascade_tests.cpp: the ramp's error is <= 9 float roundoffs; 16 leaves room for FMA.
const Tolerance kRampTolerance = Tolerance::absolute(16 * kU);

// Special depths: signed zeros, denormals, tiny, huge, FLT_MAX, infinities and NaN.
std::vector<float> special_depths() {
  std::vector<float> v = extreme_float_values({.nan_inf = true});
  v.push_back(-L::quiet_NaN());
  return v;
}

class CascadeExtremesTest : public GpuTest {};

bool is_nan_free(float x) {
  return !std::isnan(x);
}

TEST_F(CascadeExtremesTest, SelectionByDepthAtBoundariesAndSpecialDepthsForEveryCount) {
  ShaderFunction<int32_t(float, Splits, int32_t)> select(kCascade, "select_cascade_by_depth");
  const Splits splits{glm::vec4(0.5f, 3, 9, 27), glm::vec4(81, 243, 729, 2187)};
  // The last split at +Inf: an open-ended last cascade.
  Splits open = splits;
  open[1].w = kInf;
  std::vector<std::tuple<float, Splits, int32_t>> cases;
  for (const Splits& s : {splits, open}) {
    for (int32_t count : {-5, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 1000, INT32_MAX}) {
      std::vector<float> depths = special_depths();
      for (int i = 0; i < 8; ++i) {
        const float sp = s[static_cast<std::size_t>(i / 4)][i % 4];
        depths.push_back(sp);
        depths.push_back(std::nextafter(sp, kInf));
        depths.push_back(std::nextafter(sp, -kInf));
      }
      for (float d : depths) cases.emplace_back(d, s, count);
    }
  }
  const auto got = select.run(cases);
  std::vector<int32_t> want;
  for (const auto& [d, s, count] : cases) want.push_back(ref::select_cascade_by_depth(d, s, count));
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact(),
                           [&](std::size_t i) { return format_tuple(cases[i]); });
  for (std::size_t i = 0; i < got.size(); ++i) {
    const int32_t n = std::clamp(std::get<2>(cases[i]), 0, 8);
    ASSERT_TRUE(got[i] >= 0 && got[i] <= n) << format_tuple(cases[i]) << " -> " << got[i];
  }
  // Spot checks of the definition itself (not only agreement with the reference).
  const auto at = [&](float d, const Splits& s, int32_t n) { return select(d, s, n); };
  EXPECT_EQ(at(0.0f, splits, 4), 0);
  EXPECT_EQ(at(-0.0f, splits, 4), 0);
  EXPECT_EQ(at(-kInf, splits, 4), 0);
  EXPECT_EQ(at(0.5f, splits, 4), 0);  // exactly at the first split: the nearer cascade
  EXPECT_EQ(at(std::nextafter(0.5f, 1.0f), splits, 4), 1);
  EXPECT_EQ(at(27.0f, splits, 4), 3);
  EXPECT_EQ(at(std::nextafter(27.0f, 28.0f), splits, 4), 4);  // beyond the last: count
  EXPECT_EQ(at(L::max(), splits, 8), 8);
  EXPECT_EQ(at(kInf, splits, 8), 8);
  EXPECT_EQ(at(kInf, open, 8), 7);  // Inf <= Inf
  EXPECT_EQ(at(kNaN, splits, 8), 8);
  EXPECT_EQ(at(kNaN, splits, 1), 1);
  EXPECT_EQ(at(1.0f, splits, 0), 0);
  EXPECT_EQ(at(1.0f, splits, -3), 0);
  EXPECT_EQ(at(1e9f, splits, 100), 8);
}

TEST_F(CascadeExtremesTest, SelectionByDepthVec4FormSpecialDepths) {
  ShaderFunction<int32_t(float, glm::vec4, int32_t)> select(kCascade, "select_cascade_by_depth");
  const glm::vec4 splits(1, 4, 16, 64);
  std::vector<std::tuple<float, glm::vec4, int32_t>> cases;
  std::vector<int32_t> want;
  for (int32_t count : {-1, 0, 1, 2, 3, 4, 5, 8}) {
    std::vector<float> depths = special_depths();
    for (int i = 0; i < 4; ++i) {
      depths.push_back(splits[i]);
      depths.push_back(std::nextafter(splits[i], kInf));
    }
    for (float d : depths) {
      cases.emplace_back(d, splits, count);
      want.push_back(ref::select_cascade_by_depth4(d, splits, count));
    }
  }
  const auto got = select.run(cases);
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact(),
                           [&](std::size_t i) { return format_tuple(cases[i]); });
  EXPECT_EQ(select(64.0f, splits, 4), 3);
  EXPECT_EQ(select(65.0f, splits, 8), 4);  // the vec4 form holds at most 4
}

// Band fractions: zero, negative (both a hard switch), tiny, ordinary, 1, oversized (clamped).
const std::vector<float> kFractions = {0.0f, -0.0f, -0.5f, L::min(), 1e-7f, 0.1f, 1.0f, 3.0f};

TEST_F(CascadeExtremesTest, BlendWeightNeverNaNAndMatchesReferenceForSpecialInputs) {
  ShaderFunction<float(float, float, float, float)> blend(kCascade, "cascade_blend_weight");
  std::vector<std::tuple<float, float, float, float>> cases;
  // Ordinary cascades, an empty one (near == far), an open one (far = +Inf), near = -Inf.
  const std::vector<std::pair<float, float>> ranges = {
      {10.0f, 30.0f}, {0.0f, 1.0f}, {5.0f, 5.0f}, {2.0f, kInf}, {-kInf, 8.0f}, {0.0f, L::max()}};
  for (const auto& [near, far] : ranges) {
    for (float fraction : kFractions) {
      std::vector<float> depths = special_depths();
      for (float d : {near, far, std::nextafter(far, kInf), std::nextafter(far, -kInf)}) {
        depths.push_back(d);
      }
      for (float d : depths) cases.emplace_back(d, near, far, fraction);
    }
  }
  const auto got = blend.run(cases);
  std::vector<float> want;
  for (const auto& [d, near, far, fraction] : cases) {
    want.push_back(static_cast<float>(ref::cascade_blend_weight(d, near, far, fraction)));
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, got, kRampTolerance,
                           [&](std::size_t i) { return format_tuple(cases[i]); });
  for (std::size_t i = 0; i < got.size(); ++i) {
    ASSERT_TRUE(is_nan_free(got[i]) && got[i] >= 0.0f && got[i] <= 1.0f)
        << format_tuple(cases[i]) << " -> " << got[i];
  }
}

TEST_F(CascadeExtremesTest, ZeroBandWidthIsAHardSwitchJustAfterTheSplit) {
  ShaderFunction<float(float, float, float, float)> blend(kCascade, "cascade_blend_weight");
  ShaderFunction<float(float, float, float)> fade(kCascade, "shadow_distance_fade");
  for (float fraction : {0.0f, -0.0f, -1.0f}) {
    EXPECT_EQ(blend(0.0f, 10.0f, 30.0f, fraction), 0.0f);
    EXPECT_EQ(blend(29.999f, 10.0f, 30.0f, fraction), 0.0f);
    EXPECT_EQ(blend(30.0f, 10.0f, 30.0f, fraction), 0.0f);  // the split belongs to this cascade
    EXPECT_EQ(blend(std::nextafter(30.0f, 31.0f), 10.0f, 30.0f, fraction), 1.0f);
    EXPECT_EQ(blend(kInf, 10.0f, 30.0f, fraction), 1.0f);
    EXPECT_EQ(fade(100.0f, 100.0f, fraction), 0.0f);
    EXPECT_EQ(fade(std::nextafter(100.0f, 101.0f), 100.0f, fraction), 1.0f);
  }
  // An empty cascade (near == far) has a zero-width band whatever the fraction.
  EXPECT_EQ(blend(5.0f, 5.0f, 5.0f, 0.5f), 0.0f);
  EXPECT_EQ(blend(std::nextafter(5.0f, 6.0f), 5.0f, 5.0f, 0.5f), 1.0f);
  // A positive band reaches exactly 1 at the split.
  EXPECT_EQ(blend(30.0f, 10.0f, 30.0f, 0.25f), 1.0f);
  EXPECT_EQ(blend(25.0f, 10.0f, 30.0f, 0.25f), 0.0f);
  EXPECT_EQ(blend(27.5f, 10.0f, 30.0f, 0.25f), 0.5f);
}

TEST_F(CascadeExtremesTest, BlendToNextForSpecialDepthsAndIndices) {
  ShaderFunction<float(float, Splits, int32_t, int32_t, float, float)> to_next(
      kCascade, "cascade_blend_to_next");
  const Splits splits{glm::vec4(2, 6, 18, 54), glm::vec4(162, 486, 1458, 4374)};
  std::vector<std::tuple<float, Splits, int32_t, int32_t, float, float>> cases;
  for (int32_t count : {0, 1, 2, 8, 12}) {
    for (int32_t cascade : {INT32_MIN, -1, 0, 1, 6, 7, 8, 9, INT32_MAX}) {
      for (float fraction : kFractions) {
        std::vector<float> depths = special_depths();
        for (int i = 0; i < 8; ++i)
          depths.push_back(splits[static_cast<std::size_t>(i / 4)][i % 4]);
        for (float d : depths) cases.emplace_back(d, splits, cascade, count, 0.1f, fraction);
      }
    }
  }
  const auto got = to_next.run(cases);
  std::vector<float> want;
  for (const auto& [d, s, cascade, count, near, fraction] : cases) {
    want.push_back(
        static_cast<float>(ref::cascade_blend_to_next(d, s, cascade, count, near, fraction)));
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, got, kRampTolerance,
                           [&](std::size_t i) { return format_tuple(cases[i]); });
  for (std::size_t i = 0; i < got.size(); ++i) {
    ASSERT_TRUE(is_nan_free(got[i]) && got[i] >= 0.0f && got[i] <= 1.0f) << format_tuple(cases[i]);
  }
  // The last cascade never blends (the fade takes over); one cascade has nothing to blend with.
  EXPECT_EQ(to_next(4374.0f, splits, 7, 8, 0.1f, 0.5f), 0.0f);
  EXPECT_EQ(to_next(2.0f, splits, 0, 1, 0.1f, 0.5f), 0.0f);
  EXPECT_EQ(to_next(2.0f, splits, 0, 2, 0.1f, 0.5f), 1.0f);
}

TEST_F(CascadeExtremesTest, DistanceFadeNeverNaNForSpecialInputs) {
  ShaderFunction<float(float, float, float)> fade(kCascade, "shadow_distance_fade");
  std::vector<std::tuple<float, float, float>> cases;
  // Not max_distance 0: a denormal depth there is > 0 or == 0 depending on denormal flushing.
  for (float max_distance : {1e-30f, 1.0f, 150.0f, 1e30f, L::max(), kInf}) {
    for (float fraction : kFractions) {
      std::vector<float> depths = special_depths();
      depths.push_back(max_distance);
      depths.push_back(std::nextafter(max_distance, kInf));
      for (float d : depths) cases.emplace_back(d, max_distance, fraction);
    }
  }
  const auto got = fade.run(cases);
  std::vector<float> want;
  for (const auto& [d, m, f] : cases)
    want.push_back(static_cast<float>(ref::shadow_distance_fade(d, m, f)));
  PENUMBRA_EXPECT_ALL_NEAR(want, got, kRampTolerance,
                           [&](std::size_t i) { return format_tuple(cases[i]); });
  for (std::size_t i = 0; i < got.size(); ++i) {
    ASSERT_TRUE(is_nan_free(got[i]) && got[i] >= 0.0f && got[i] <= 1.0f) << format_tuple(cases[i]);
  }
  EXPECT_EQ(fade(kNaN, 150.0f, 0.1f), 1.0f);  // NaN depth: selection says "outside", so lit
  EXPECT_EQ(fade(kInf, 150.0f, 0.1f), 1.0f);
  EXPECT_EQ(fade(-kInf, 150.0f, 0.1f), 0.0f);
  EXPECT_EQ(fade(0.0f, 150.0f, 0.1f), 0.0f);
}

// ------------------------------------------------------------------------------------------
// Coordinates and containment

// clip = (x, y, 0.5, z): w is the position's z exactly (products with 0 and 1 are exact), so the
// cases below control w bit for bit.
glm::mat4 w_from_z() {
  glm::mat4 m(0.0f);
  m[0][0] = 1.0f;  // clip.x = x
  m[1][1] = 1.0f;  // clip.y = y
  m[2][3] = 1.0f;  // clip.w = z
  m[3][2] = 0.5f;  // clip.z = 0.5
  return m;
}

bool in_bounds_cpu(const glm::vec3& c) {
  return c.x >= 0 && c.x <= 1 && c.y >= 0 && c.y <= 1 && c.z >= 0 && c.z <= 1;
}

TEST_F(CascadeExtremesTest, PerspectiveWAtOrBehindTheLightIsOutsideNeverNaN) {
  ShaderFunction<glm::vec3(glm::mat4, glm::vec3)> to_coord(kCascade, "world_to_shadow_coord");
  ShaderFunction<bool(glm::vec3, float, float)> in_bounds(kCascade, "shadow_coord_in_bounds");
  const glm::mat4 m = w_from_z();
  const glm::vec3 outside(-1.0f);
  struct Case {
    glm::vec3 p;
    bool valid;  // expected: a coordinate (true) or kShadowCoordOutside (false)
  };
  const std::vector<Case> table = {
      {glm::vec3(0.5f, 0.5f, 0.0f), false},     // w = 0
      {glm::vec3(0.0f, 0.0f, -0.0f), false},    // w = -0
      {glm::vec3(0.5f, 0.5f, -1.0f), false},    // behind the light
      {glm::vec3(0.5f, 0.5f, -1e-30f), false},  // just behind
      {glm::vec3(0.0f, 0.0f, 1e-40f), false},   // w denormal (a GPU may flush it to 0)
      {glm::vec3(0.0f, 0.0f, -L::denorm_min()), false},
      {glm::vec3(0.0f, 0.0f, L::min()), true},  // the smallest normal w: valid (depth huge)
      {glm::vec3(1.0f, 1.0f, 1e-30f), true},    // tiny w: xy / w = 1e30 finite, z/w = 5e29
      {glm::vec3(1e10f, 0.0f, 1e-30f), false},  // tiny w: xy / w overflows -> outside
      {glm::vec3(0.0f, 0.0f, kInf), false},     // w = +Inf
      {glm::vec3(kNaN, 0.0f, 1.0f), false},     // NaN position
      {glm::vec3(kInf, 0.0f, 1.0f), false},     // infinite position
      {glm::vec3(0.0f, -kInf, 1.0f), false},
      {glm::vec3(0.0f, 0.0f, kNaN), false},          // NaN w
      {glm::vec3(L::max(), L::max(), 0.5f), false},  // overflow after the divide
      {glm::vec3(0.5f, -0.5f, 1.0f), true},          // an ordinary point
      {glm::vec3(1.0f, 1.0f, 2.0f), true},           // ndc (0.5, 0.5, 0.25)
  };
  std::vector<std::tuple<glm::mat4, glm::vec3>> cases;
  for (const Case& c : table) cases.emplace_back(m, c.p);
  const auto got = to_coord.run(cases);
  for (std::size_t i = 0; i < table.size(); ++i) {
    SCOPED_TRACE("position " + format_value(table[i].p));
    const glm::vec3 c = got[i];
    EXPECT_FALSE(std::isnan(c.x) || std::isnan(c.y) || std::isnan(c.z)) << format_value(c);
    const ref::ShadowCoord r = ref::world_to_shadow_coord(m, table[i].p);
    EXPECT_EQ(!r.outside, table[i].valid) << "the reference disagrees with the table";
    if (table[i].valid) {
      EXPECT_NE(c, outside) << format_value(c);
      EXPECT_THAT(c, NearTo(glm::vec3(r.coord), Tolerance::ulps(4)));
    } else {
      EXPECT_EQ(c, outside) << format_value(c);
    }
    // Only the ordinary points land in the shadow map.
    EXPECT_EQ(in_bounds(c, 0.0f, 1024.0f),
              r.outside ? false : ref::shadow_coord_in_bounds(r.coord, 0.0f, 1024.0f));
  }
  EXPECT_THAT(got.back(), NearTo(glm::vec3(0.75f, 0.75f, 0.25f), Tolerance::exact()));

  // A huge w (beyond 2^126, where Vulkan no longer bounds the divide's error and reciprocals
  // flush to zero) still divides correctly: clip = (x, y, z, z).
  glm::mat4 huge(0.0f);
  huge[0][0] = 1.0f;
  huge[1][1] = 1.0f;
  huge[2][2] = 1.0f;
  huge[2][3] = 1.0f;
  const glm::vec3 p(0.5f * L::max(), -0.25f * L::max(), L::max());
  EXPECT_THAT(to_coord(huge, p), NearTo(glm::vec3(0.75f, 0.375f, 1.0f), Tolerance::ulps(4)));
  const glm::vec3 q(2.0f * 0x1p126f, 0.0f, 0x1p127f);  // ndc.x = 1 at w = 2^127
  EXPECT_THAT(to_coord(huge, q), NearTo(glm::vec3(1.0f, 0.5f, 1.0f), Tolerance::ulps(4)));
}

TEST_F(CascadeExtremesTest, CoordinatesOutsideTheUnitSquareOrDepthRangeAreOutside) {
  ShaderFunction<bool(glm::vec3, float, float)> in_bounds(kCascade, "shadow_coord_in_bounds");
  const float res = 1024.0f;
  const float b = 2.0f / res;  // a 2-texel border in uv, exact
  struct Case {
    glm::vec3 c;
    float border;
    bool inside;
  };
  const std::vector<Case> table = {
      {glm::vec3(0.0f, 0.0f, 0.0f), 0.0f, true},  // edges are inclusive
      {glm::vec3(1.0f, 1.0f, 1.0f), 0.0f, true},
      {glm::vec3(-0.0f, 0.5f, -0.0f), 0.0f, true},
      {glm::vec3(-1e-7f, 0.5f, 0.5f), 0.0f, false},
      {glm::vec3(0.5f, -1e-7f, 0.5f), 0.0f, false},
      {glm::vec3(std::nextafter(1.0f, 2.0f), 0.5f, 0.5f), 0.0f, false},
      {glm::vec3(0.5f, std::nextafter(1.0f, 2.0f), 0.5f), 0.0f, false},
      {glm::vec3(0.5f, 0.5f, -1e-7f), 0.0f, false},
      {glm::vec3(0.5f, 0.5f, std::nextafter(1.0f, 2.0f)), 0.0f, false},
      {glm::vec3(1.5f, 0.5f, 0.5f), 0.0f, false},
      {glm::vec3(-3.0f, 7.0f, 0.5f), 0.0f, false},
      {glm::vec3(b, b, 0.5f), 2.0f, true},  // exactly on the border: inside
      {glm::vec3(1.0f - b, 1.0f - b, 0.5f), 2.0f, true},
      {glm::vec3(std::nextafter(b, 0.0f), 0.5f, 0.5f), 2.0f, false},
      {glm::vec3(0.5f, std::nextafter(1.0f - b, 2.0f), 0.5f), 2.0f, false},
      {glm::vec3(0.0f, 0.5f, 0.5f), 2.0f, false},
      {glm::vec3(kNaN, 0.5f, 0.5f), 0.0f, false},
      {glm::vec3(0.5f, kNaN, 0.5f), 0.0f, false},
      {glm::vec3(0.5f, 0.5f, kNaN), 0.0f, false},
      {glm::vec3(kInf, 0.5f, 0.5f), 0.0f, false},
      {glm::vec3(-kInf, 0.5f, 0.5f), 0.0f, false},
      {glm::vec3(0.5f, 0.5f, kInf), 0.0f, false},
      {glm::vec3(-1.0f), 0.0f, false},  // kShadowCoordOutside
      {glm::vec3(L::max(), 0.5f, 0.5f), 0.0f, false},
  };
  std::vector<std::tuple<glm::vec3, float, float>> cases;
  std::vector<bool> want, want_ref;
  for (const Case& c : table) {
    cases.emplace_back(c.c, c.border, res);
    want.push_back(c.inside);
    want_ref.push_back(ref::shadow_coord_in_bounds(glm::dvec3(c.c), c.border, res));
  }
  EXPECT_EQ(want, want_ref) << "the table disagrees with the reference";
  const auto got = in_bounds.run(cases);  // std::vector<bool>: compared case by case
  for (std::size_t i = 0; i < cases.size(); ++i) {
    EXPECT_EQ(got[i], want[i]) << format_tuple(cases[i]);
  }
}

TEST_F(CascadeExtremesTest, ContainmentSelectionSkipsNonFiniteAndOutsideLevels) {
  ShaderFunction<int32_t(Vec3x8, int32_t, float, float)> select(kCascade,
                                                                "select_cascade_by_containment");
  Vec3x8 coords{};
  coords.fill(glm::vec3(0.5f));
  const glm::vec3 bad[] = {glm::vec3(kNaN), glm::vec3(kInf), glm::vec3(-1.0f),
                           glm::vec3(0.5f, 0.5f, 1.5f), glm::vec3(1.0f, 0.0f, -1e-7f)};
  std::vector<std::tuple<Vec3x8, int32_t, float, float>> cases;
  for (int32_t count : {-1, 0, 1, 3, 8, 9}) {
    for (int first_good = 0; first_good <= 8; ++first_good) {
      Vec3x8 c = coords;
      for (int i = 0; i < first_good; ++i) c[static_cast<std::size_t>(i)] = bad[i % 5];
      cases.emplace_back(c, count, 0.0f, 2048.0f);
    }
  }
  const auto got = select.run(cases);
  std::vector<int32_t> want;
  for (const auto& [c, count, border, res] : cases) {
    want.push_back(ref::select_cascade_by_containment(c, count, border, res));
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact(),
                           [&](std::size_t i) { return format_tuple(cases[i]); });
  // The first good level is found; with all of them bad, the answer is count.
  EXPECT_EQ(want[3], 0);          // count -1: clamped to 0
  EXPECT_EQ(want[9 * 4 + 5], 5);  // count 8, levels 0..4 bad
  EXPECT_EQ(want[9 * 4 + 8], 8);  // count 8, all bad
}

TEST_F(CascadeExtremesTest, PositionSelectionWithDegenerateMatricesAndPoints) {
  ShaderFunction<int32_t(glm::vec3, Mat8, int32_t, float, float, Out<glm::vec3>)> select(
      kCascade, "select_cascade_by_position");
  // Level 0: w from z (perspective-like); levels 1..7: scaled orthographic boxes of half width
  // 2^i around the origin (ndc = p / 2^i), depth from z.
  Mat8 m{};
  m[0] = w_from_z();
  for (int i = 1; i < 8; ++i) {
    const float s = 1.0f / static_cast<float>(1 << i);
    glm::mat4 o(1.0f);
    o[0][0] = s;
    o[1][1] = s;
    o[2][2] = 0.5f * s;
    o[3][2] = 0.5f;  // depth = 0.5 + 0.5 z / 2^i
    m[static_cast<std::size_t>(i)] = o;
  }
  std::vector<std::tuple<glm::vec3, Mat8, int32_t, float, float>> cases;
  const std::vector<glm::vec3> points = {
      glm::vec3(0.0f, 0.0f, 0.0f),    glm::vec3(0.0f, 0.0f, -1.0f),  glm::vec3(0.1f, 0.1f, 1.0f),
      glm::vec3(3.0f, -3.0f, 0.0f),   glm::vec3(100.0f, 0.0f, 0.0f), glm::vec3(1e6f, 1e6f, 1e6f),
      glm::vec3(kNaN, 0.0f, 0.0f),    glm::vec3(kInf, 0.0f, 0.0f),   glm::vec3(0.0f, 0.0f, -kInf),
      glm::vec3(L::max(), 0.0f, 0.0f)};
  for (int32_t count : {0, 1, 2, 8}) {
    for (const glm::vec3& p : points) cases.emplace_back(p, m, count, 0.0f, 1024.0f);
  }
  const auto got = select.run(cases);
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const auto& [p, levels, count, border, res] = cases[i];
    const int32_t want = ref::select_cascade_by_position(p, levels, count, border, res);
    const auto [level, coord] = got[i];
    EXPECT_EQ(level, want) << format_tuple(cases[i]);
    EXPECT_FALSE(std::isnan(coord.x) || std::isnan(coord.y) || std::isnan(coord.z))
        << format_tuple(cases[i]);
    if (level < std::clamp(count, 0, 8)) {
      EXPECT_TRUE(in_bounds_cpu(coord)) << format_tuple(cases[i]) << " -> " << format_value(coord);
    } else {
      EXPECT_EQ(coord, glm::vec3(-1.0f)) << format_tuple(cases[i]);
    }
  }
}

// shadow_coord_in_bounds is false for a non-finite component, each alone (NaN, +inf, -inf in u,
// v or depth with the others inside), whatever the border: also with border_texels = -inf, which
// bounds no finite uv (the control cases are in bounds) and which an infinite uv would pass
// (inf >= -inf) if the finiteness test let it through to the comparisons.
TEST_F(CascadeExtremesTest, NonFiniteCoordComponentIsOutOfBoundsForAnyBorder) {
  ShaderFunction<bool(glm::vec3, float, float)> in_bounds(kCascade, "shadow_coord_in_bounds");
  std::vector<std::tuple<glm::vec3, float, float>> cases;
  for (const float border : {0.0f, 2.0f, -kInf}) {
    for (int component = 0; component < 3; ++component) {
      for (const float bad : {kNaN, kInf, -kInf}) {
        glm::vec3 c(0.5f, 0.25f, 0.75f);
        c[component] = bad;
        cases.emplace_back(c, border, 1024.0f);
      }
    }
  }
  const std::vector<bool> got = in_bounds.run(cases);
  for (size_t i = 0; i < cases.size(); ++i) EXPECT_FALSE(got[i]) << format_tuple(cases[i]);
  // Controls: finite coordinates pass with an infinitely negative border, even far outside.
  EXPECT_TRUE(in_bounds(glm::vec3(0.5f, 0.25f, 0.75f), -kInf, 1024.0f));
  EXPECT_TRUE(in_bounds(glm::vec3(-3e30f, 4e30f, 0.0f), -kInf, 1024.0f));
}

}  // namespace
}  // namespace penumbra::testing
