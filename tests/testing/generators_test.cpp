#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <limits>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/generators.hpp>
#include <set>
#include <vector>

namespace {

using penumbra::testing::DepthConvention;
using penumbra::testing::ExtremeOptions;
using penumbra::testing::Rng;
using namespace penumbra::testing;  // the generator factories

constexpr int kDraws = 10000;
using L = std::numeric_limits<float>;

std::uint32_t bits(float f) {
  return std::bit_cast<std::uint32_t>(f);
}

template <class G>
std::set<std::uint32_t> draw_bits(const G& gen, std::uint64_t seed, int n = kDraws) {
  Rng rng(seed);
  std::set<std::uint32_t> seen;
  for (int i = 0; i < n; ++i) seen.insert(bits(gen(rng)));
  return seen;
}

TEST(Rng, DeterministicPerSeed) {
  Rng a(7), b(7), c(8);
  EXPECT_EQ(a.seed(), 7u);
  bool differs = false;
  for (int i = 0; i < 100; ++i) {
    const auto x = a.next_u64();
    EXPECT_EQ(x, b.next_u64());
    differs = differs || x != c.next_u64();
  }
  EXPECT_TRUE(differs);
  a.reseed(7);
  Rng fresh(7);
  EXPECT_EQ(a.next_u64(), fresh.next_u64());
  EXPECT_THROW(a.below(0), penumbra::Error);
}

TEST(Rng, MatchesTheStandardEngine) {
  // The engine is std::mt19937_64, whose output the standard fixes: sequences are portable.
  Rng rng(5489u);
  for (int i = 1; i < 10000; ++i) rng.next_u64();
  EXPECT_EQ(rng.next_u64(), 9981545732273789042ull);
}

TEST(Generators, DeterministicPerSeed) {
  const auto x = mix(extremes_float(), 0.5, uniform(-1.0f, 1.0f));
  const auto dir = unit_vector3();
  const auto k = uniform(0, 100);
  Rng r1(99), r2(99), r3(100);
  const auto c1 = generate_cases(r1, 500, x, dir, k);
  const auto c2 = generate_cases(r2, 500, x, dir, k);
  const auto c3 = generate_cases(r3, 500, x, dir, k);
  ASSERT_EQ(c1.size(), 500u);
  for (size_t i = 0; i < c1.size(); ++i) {
    EXPECT_EQ(bits(std::get<0>(c1[i])), bits(std::get<0>(c2[i])));
    EXPECT_EQ(std::get<1>(c1[i]), std::get<1>(c2[i]));
    EXPECT_EQ(std::get<2>(c1[i]), std::get<2>(c2[i]));
  }
  EXPECT_NE(std::get<1>(c1[0]), std::get<1>(c3[0]));
}

TEST(Uniform, Scalars) {
  Rng rng(1);
  const auto f = uniform(-2.0f, 3.0f);
  const auto i = uniform(-3, 3);
  const auto u = uniform(10u, 12u);
  std::set<int> ints;
  std::set<unsigned> uints;
  float lo = 10, hi = -10;
  for (int n = 0; n < 2000; ++n) {
    const float v = f(rng);
    lo = std::min(lo, v);
    hi = std::max(hi, v);
    ints.insert(i(rng));
    uints.insert(u(rng));
  }
  EXPECT_GE(lo, -2.0f);
  EXPECT_LE(hi, 3.0f);
  EXPECT_LT(lo, -1.9f);
  EXPECT_GT(hi, 2.9f);
  EXPECT_EQ(ints, (std::set<int>{-3, -2, -1, 0, 1, 2, 3}));  // both ends included
  EXPECT_EQ(uints, (std::set<unsigned>{10, 11, 12}));
  EXPECT_EQ(uniform(5, 5)(rng), 5);
  const auto extreme =
      uniform(std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::max());
  (void)extreme(rng);
  EXPECT_THROW(uniform(1.0f, 0.0f), penumbra::Error);
  EXPECT_THROW(uniform(0.0f, L::infinity()), penumbra::Error);
  EXPECT_THROW(uniform(0.0f, L::quiet_NaN()), penumbra::Error);
}

TEST(Uniform, VectorsComponentwise) {
  Rng rng(2);
  const auto g = uniform(glm::vec3(0, 10, -5), glm::vec3(1, 20, -4));
  const auto same = uniform<glm::vec2>(-1.0f, 1.0f);
  const auto iv = uniform<glm::ivec2>(0, 1);
  for (int n = 0; n < 1000; ++n) {
    const glm::vec3 v = g(rng);
    EXPECT_TRUE(v.x >= 0 && v.x <= 1 && v.y >= 10 && v.y <= 20 && v.z >= -5 && v.z <= -4);
    const glm::vec2 w = same(rng);
    EXPECT_TRUE(std::abs(w.x) <= 1 && std::abs(w.y) <= 1);
    const glm::ivec2 k = iv(rng);
    EXPECT_TRUE((k.x == 0 || k.x == 1) && (k.y == 0 || k.y == 1));
  }
  EXPECT_THROW(uniform(glm::vec2(0, 1), glm::vec2(1, 0)), penumbra::Error);
}

TEST(UnitVector3, OnTheSphereAndBalanced) {
  Rng rng(3);
  const auto g = unit_vector3();
  glm::dvec3 sum(0.0);
  for (int n = 0; n < kDraws; ++n) {
    const glm::vec3 v = g(rng);
    EXPECT_NEAR(glm::length(v), 1.0f, 1e-6f);
    sum += glm::dvec3(v);
  }
  EXPECT_LT(glm::length(sum / double(kDraws)), 0.05);
}

TEST(OneOf, PicksEveryListedValueAndNothingElse) {
  Rng rng(4);
  const auto g = one_of({1, 5, 9});
  std::set<int> seen;
  for (int n = 0; n < 300; ++n) seen.insert(g(rng));
  EXPECT_EQ(seen, (std::set<int>{1, 5, 9}));
  EXPECT_THROW(one_of(std::vector<int>{}), penumbra::Error);
}

TEST(Mix, ProbabilityAndEdges) {
  Rng rng(5);
  const auto always_a = mix(constant(1), 1.0, constant(2));
  const auto always_b = mix(constant(1), 0.0, constant(2));
  const auto quarter = mix(constant(1), 0.25, constant(2));
  int a = 0;
  for (int n = 0; n < kDraws; ++n) {
    EXPECT_EQ(always_a(rng), 1);
    EXPECT_EQ(always_b(rng), 2);
    a += quarter(rng) == 1;
  }
  EXPECT_NEAR(a / double(kDraws), 0.25, 0.02);
  EXPECT_THROW(mix(constant(1), 1.5, constant(2)), penumbra::Error);
}

TEST(Combinators, VecOfArrayOfMap) {
  Rng rng(6);
  const auto v = vec_of<4>(one_of({0.0f, 1.0f}));
  const auto arr = array_of<3>(uniform(0, 9));
  const auto squared = map(uniform(2, 2), [](int x) { return x * x; });
  static_assert(std::is_same_v<decltype(v(rng)), glm::vec4>);
  static_assert(std::is_same_v<decltype(arr(rng)), std::array<int, 3>>);
  const glm::vec4 x = v(rng);
  for (int c = 0; c < 4; ++c) EXPECT_TRUE(x[c] == 0.0f || x[c] == 1.0f);
  for (int e : arr(rng)) EXPECT_TRUE(e >= 0 && e <= 9);
  EXPECT_EQ(squared(rng), 4);
}

TEST(ExtremesFloat, ListHoldsEveryNamedSpecial) {
  const auto values = extreme_float_values({.nan_inf = true});
  std::set<std::uint32_t> have;
  for (float v : values) have.insert(bits(v));
  EXPECT_EQ(have.size(), values.size());  // no duplicates
  for (float v : {0.0f,
                  -0.0f,
                  L::denorm_min(),
                  -L::denorm_min(),
                  std::nextafter(L::min(), 0.0f),
                  L::min(),
                  -L::min(),
                  L::max(),
                  -L::max(),
                  std::nextafter(1.0f, 0.0f),
                  1.0f,
                  std::nextafter(1.0f, 2.0f),
                  0.5f,
                  -1.0f,
                  1e-30f,
                  1e30f,
                  -1e30f,
                  L::infinity(),
                  -L::infinity(),
                  L::quiet_NaN()}) {
    EXPECT_TRUE(have.count(bits(v))) << penumbra::testing::format_value(v);
  }
}

TEST(ExtremesFloat, DrawsCoverEverySpecialWithin10000) {
  for (const ExtremeOptions& options :
       {ExtremeOptions{}, ExtremeOptions{.nan_inf = true}, ExtremeOptions{.negative = false}}) {
    const auto gen = extremes_float(options);
    const auto seen = draw_bits(gen, 11);
    for (float v : gen.specials) {
      EXPECT_TRUE(seen.count(bits(v))) << penumbra::testing::format_value(v) << " never drawn";
    }
    // Ordinary values are mixed in.
    EXPECT_GT(seen.size(), gen.specials.size() + 1000);
  }
}

TEST(ExtremesFloat, OptionsExcludeWhatTheyTurnOff) {
  Rng rng(12);
  const auto plain = extremes_float();  // no NaN/Inf by default
  const auto no_denormals = extremes_float({.denormals = false});
  const auto no_max = extremes_float({.max_values = false});
  const auto positive = extremes_float({.negative = false});
  for (int n = 0; n < kDraws; ++n) {
    EXPECT_TRUE(std::isfinite(plain(rng)));
    const float d = no_denormals(rng);
    EXPECT_NE(std::fpclassify(d), FP_SUBNORMAL);
    EXPECT_LT(std::abs(no_max(rng)), 1e31f);
    EXPECT_FALSE(std::signbit(positive(rng)));  // not even -0
  }
}

TEST(DepthExtremes, BothConventionsCoverTheSpecialDepths) {
  for (DepthConvention convention : {DepthConvention::reverse_z, DepthConvention::standard}) {
    const auto gen = depth_extremes(convention);
    const auto seen = draw_bits(gen, 13);
    for (float v : {0.0f, 1.0f, std::nextafter(1.0f, 0.0f), std::nextafter(0.0f, 1.0f), 1e-7f,
                    1.0f - 1e-7f}) {
      EXPECT_TRUE(seen.count(bits(v))) << penumbra::testing::format_value(v);
    }
    for (std::uint32_t b : seen) {
      const float v = std::bit_cast<float>(b);
      EXPECT_TRUE(v >= 0.0f && v <= 1.0f) << v;
    }
  }
  const auto outside = depth_extremes(DepthConvention::reverse_z, {.out_of_range = true});
  const auto seen = draw_bits(outside, 14);
  EXPECT_TRUE(seen.count(bits(std::nextafter(1.0f, 2.0f))));
  EXPECT_TRUE(seen.count(bits(std::nextafter(0.0f, -1.0f))));
}

TEST(DepthExtremes, OrdinaryDrawsFollowThePerspectiveMapping) {
  // Reverse-Z puts distant geometry near 0, standard near 1.
  const auto count_small = [](DepthConvention convention) {
    Rng rng(15);
    const auto gen = depth_extremes(convention, {.special_fraction = 0.0});
    int small = 0;
    for (int n = 0; n < kDraws; ++n) small += gen(rng) < 0.01f;
    return small;
  };
  EXPECT_GT(count_small(DepthConvention::reverse_z), 3 * count_small(DepthConvention::standard));
  EXPECT_THROW(depth_extremes(DepthConvention::standard, {.near = 0.0}), penumbra::Error);
}

}  // namespace

namespace {

// vec_from(): one generator per component, in order, seeded like the others.
TEST(VecFrom, EachComponentFromItsOwnGenerator) {
  const auto g = vec_from(uniform(0.0f, 1.0f), uniform(-10.0f, -5.0f), constant(7.0f));
  Rng a(3), b(3);
  for (int i = 0; i < 1000; ++i) {
    const glm::vec3 v = g(a);
    EXPECT_GE(v.x, 0.0f);
    EXPECT_LE(v.x, 1.0f);
    EXPECT_GE(v.y, -10.0f);
    EXPECT_LE(v.y, -5.0f);
    EXPECT_EQ(v.z, 7.0f);
    EXPECT_EQ(v, g(b)) << "the same seed gives the same vectors";
  }
  const auto u = vec_from(uniform(0u, 3u), constant(9u));
  Rng r(1);
  const glm::uvec2 w = u(r);
  EXPECT_LE(w.x, 3u);
  EXPECT_EQ(w.y, 9u);
}

}  // namespace
