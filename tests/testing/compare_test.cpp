#include <gmock/gmock.h>
#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <penumbra/core/error.hpp>

#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <limits>
#include <penumbra/testing/compare.hpp>
#include <span>
#include <string>
#include <vector>

namespace {

struct Sample {
  glm::vec2 uv;
  float depth;
};

}  // namespace

PENUMBRA_GLSL_STRUCT(Sample, "Sample", uv, depth);

namespace {

using penumbra::testing::all_near;
using penumbra::testing::compare_batch;
using penumbra::testing::ComparisonResult;
using penumbra::testing::ErrorHistogram;
using penumbra::testing::NearTo;
using penumbra::testing::Scalar;
using penumbra::testing::Tolerance;
using penumbra::testing::ulp_distance;
using ::testing::HasSubstr;
using ::testing::Not;

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kDenormMin = std::numeric_limits<float>::denorm_min();
constexpr float kFltMin = std::numeric_limits<float>::min();
constexpr float kFltMax = std::numeric_limits<float>::max();

float up(float x, int n = 1) {
  for (int i = 0; i < n; ++i) x = std::nextafter(x, kInf);
  return x;
}

TEST(UlpDistance, Floats) {
  static_assert(ulp_distance(1.0f, 1.0f) == 0);
  static_assert(ulp_distance(0.0f, -0.0f) == 0);
  EXPECT_EQ(ulp_distance(1.0f, up(1.0f)), 1);
  EXPECT_EQ(ulp_distance(up(1.0f, 5), 1.0f), 5);
  EXPECT_EQ(ulp_distance(0.0f, kDenormMin), 1);
  EXPECT_EQ(ulp_distance(-0.0f, kDenormMin), 1);
  EXPECT_EQ(ulp_distance(-kDenormMin, kDenormMin), 2);  // across the sign, through +-0
  EXPECT_EQ(ulp_distance(std::nextafter(kFltMin, 0.0f), kFltMin), 1);  // denormal to normal
  EXPECT_EQ(ulp_distance(0.0f, kFltMin), 1 << 23);                     // 2^23 denormals
  EXPECT_EQ(ulp_distance(-1.0f, 1.0f), 2 * std::int64_t{0x3f800000});
  EXPECT_EQ(ulp_distance(kFltMax, kInf), 1);
  EXPECT_EQ(ulp_distance(-kInf, kInf), 2 * std::int64_t{0x7f800000});
  EXPECT_EQ(ulp_distance(kNaN, 1.0f), std::numeric_limits<std::int64_t>::max());
  EXPECT_EQ(ulp_distance(1.0f, kNaN), std::numeric_limits<std::int64_t>::max());
  EXPECT_EQ(ulp_distance(kNaN, kNaN), std::numeric_limits<std::int64_t>::max());
}

TEST(UlpDistance, Doubles) {
  static_assert(ulp_distance(0.0, -0.0) == 0);
  EXPECT_EQ(ulp_distance(1.0, std::nextafter(1.0, 2.0)), 1);
  EXPECT_EQ(ulp_distance(-std::numeric_limits<double>::denorm_min(),
                         std::numeric_limits<double>::denorm_min()),
            2);
  // 2 * 0x7fefffffffffffff does not fit: saturates.
  EXPECT_EQ(ulp_distance(-std::numeric_limits<double>::max(), std::numeric_limits<double>::max()),
            std::numeric_limits<std::int64_t>::max());
  EXPECT_EQ(ulp_distance(std::nan(""), 0.0), std::numeric_limits<std::int64_t>::max());
}

TEST(Tolerance, Exact) {
  const Tolerance t = Tolerance::exact();
  EXPECT_TRUE(t.accepts(1.0, 1.0));
  EXPECT_TRUE(t.accepts(0.0, -0.0));
  EXPECT_FALSE(t.accepts(1.0, up(1.0f)));
  EXPECT_TRUE(t.accepts(kNaN, -kNaN));  // both NaN
  EXPECT_FALSE(t.accepts(kNaN, 1.0));
  EXPECT_FALSE(t.accepts(1.0, kNaN));
  EXPECT_TRUE(t.accepts(kInf, kInf));
  EXPECT_FALSE(t.accepts(kInf, -kInf));
  EXPECT_EQ(t.describe(), "exact");
}

TEST(Tolerance, Absolute) {
  const Tolerance t = Tolerance::absolute(0.1);
  EXPECT_TRUE(t.accepts(1.0, 1.05));
  EXPECT_TRUE(t.accepts(1.0, 0.95));
  EXPECT_FALSE(t.accepts(1.0, 1.2));
  EXPECT_FALSE(t.accepts(kInf, kFltMax));  // infinities match only exactly
  EXPECT_FALSE(t.accepts(kFltMax, kInf));
  EXPECT_EQ(t.describe(), "|error| <= 0.1");
}

TEST(Tolerance, Relative) {
  const Tolerance t = Tolerance::relative(0.01);
  EXPECT_TRUE(t.accepts(100.0, 100.5));
  EXPECT_FALSE(t.accepts(100.0, 102.0));
  EXPECT_TRUE(t.accepts(-100.0, -100.9));
  EXPECT_FALSE(t.accepts(0.0, 1e-10));  // relative to zero accepts nothing...
  const Tolerance floored = Tolerance::relative(0.01, 1e-9);
  EXPECT_TRUE(floored.accepts(0.0, 1e-10));  // ...unless a floor rescues it
  EXPECT_FALSE(floored.accepts(0.0, 1e-8));
  EXPECT_EQ(floored.describe(),
            "|error| <= 0.01 * |expected| or |error| <= 1e-09 (near-zero floor)");
}

TEST(Tolerance, Ulps) {
  const Tolerance t = Tolerance::ulps(2);
  EXPECT_TRUE(t.accepts(1.0, up(1.0f, 2)));
  EXPECT_FALSE(t.accepts(1.0, up(1.0f, 3)));
  EXPECT_TRUE(t.accepts(-kDenormMin, kDenormMin));
  EXPECT_FALSE(t.accepts(kFltMax, kInf));  // 1 ULP apart, but infinities must match exactly
  EXPECT_FALSE(t.accepts(0.0, 1e-7));      // billions of ULPs from zero
  const Tolerance floored = Tolerance::ulps(2, 1e-6);
  EXPECT_TRUE(floored.accepts(0.0, 1e-7));
  EXPECT_FALSE(floored.accepts(0.0, 1e-5));
  EXPECT_TRUE(Tolerance::ulps(0).accepts(0.0, -0.0));
  EXPECT_FALSE(Tolerance::ulps(0).accepts(1.0, up(1.0f)));
  EXPECT_EQ(floored.describe(), "<= 2 ULP or |error| <= 1e-06 (near-zero floor)");
  EXPECT_EQ(Tolerance::ulps(3).with_abs(1e-3).describe(), "|error| <= 0.001 or <= 3 ULP");
}

TEST(Tolerance, ScalarsOfEachKind) {
  const Tolerance loose = Tolerance::absolute(10.0);
  EXPECT_FALSE(loose.accepts(Scalar::of(3), Scalar::of(4)));  // integers compare exactly
  EXPECT_TRUE(loose.accepts(Scalar::of(3u), Scalar::of(3u)));
  EXPECT_FALSE(loose.accepts(Scalar::of(true), Scalar::of(false)));
  EXPECT_TRUE(loose.accepts(Scalar::of(3.0f), Scalar::of(4.0f)));
  // f64 counts double ULPs.
  EXPECT_TRUE(Tolerance::ulps(1).accepts(Scalar::of(1.0), Scalar::of(std::nextafter(1.0, 2.0))));
  EXPECT_FALSE(Tolerance::ulps(1).accepts(Scalar::of(1.0), Scalar::of(1.0 + 1e-12)));
}

TEST(ErrorHistogram, Bins) {
  EXPECT_EQ(ErrorHistogram::bin_of(0, false), 0u);
  EXPECT_EQ(ErrorHistogram::bin_of(1, false), 1u);
  EXPECT_EQ(ErrorHistogram::bin_of(4, false), 2u);
  EXPECT_EQ(ErrorHistogram::bin_of(5, false), 3u);
  EXPECT_EQ(ErrorHistogram::bin_of(256, false), 4u);
  EXPECT_EQ(ErrorHistogram::bin_of(65536, false), 5u);
  EXPECT_EQ(ErrorHistogram::bin_of(65537, false), 6u);
  EXPECT_EQ(ErrorHistogram::bin_of(0, true), 7u);
}

TEST(CompareBatch, EqualBatchesPass) {
  const std::vector<glm::vec3> a = {{1, 2, 3}, {4, 5, 6}};
  const ComparisonResult r = compare_batch(a, a, Tolerance::exact());
  EXPECT_TRUE(r.passed);
  EXPECT_EQ(r.cases, 2u);
  EXPECT_EQ(r.components, 6u);
  EXPECT_EQ(r.failing_cases, 0u);
  EXPECT_EQ(r.histogram.total[0], 6u);
  EXPECT_THAT(r.report, HasSubstr("passed: 2 cases (6 components)"));
}

// 100 cases of x * 0.1; cases 3 and 10..39 are 2 ULP off, case 50 is NaN.
struct WrongBatch {
  std::vector<float> inputs, expected, actual;
  WrongBatch() {
    for (int i = 0; i < 100; ++i) {
      const float x = static_cast<float>(i);
      inputs.push_back(x);
      expected.push_back(x * 0.1f);
      actual.push_back(x * 0.1f);
    }
    actual[3] = up(actual[3], 2);
    for (int i = 10; i < 40; ++i)
      actual[static_cast<size_t>(i)] = up(actual[static_cast<size_t>(i)], 2);
    actual[50] = kNaN;
  }
  std::string describe(size_t i) const { return "x=" + penumbra::testing::format_value(inputs[i]); }
};

TEST(CompareBatch, WrongAnswerReportsEverything) {
  const WrongBatch b;
  const ComparisonResult r = compare_batch(
      b.expected, b.actual, Tolerance::ulps(1), [&](size_t i) { return b.describe(i); },
      /*max_reported=*/5);
  EXPECT_FALSE(r.passed);
  EXPECT_EQ(r.cases, 100u);
  EXPECT_EQ(r.failing_cases, 32u);
  EXPECT_EQ(r.failing_components, 32u);
  ASSERT_EQ(r.failing_case_indices.size(), 32u);
  EXPECT_EQ(r.failing_case_indices.front(), 3u);
  EXPECT_EQ(r.failing_case_indices.back(), 50u);
  EXPECT_EQ(r.max_ulp, std::numeric_limits<std::int64_t>::max());  // the NaN
  EXPECT_EQ(r.worst_case, 50u);
  EXPECT_EQ(r.worst_inputs, "x=50 (0x1.9p+5)");
  EXPECT_TRUE(std::isinf(r.max_abs_error));
  EXPECT_EQ(r.histogram.total[0], 68u);
  EXPECT_EQ(r.histogram.total[2], 31u);  // <= 4 ULP
  EXPECT_EQ(r.histogram.failing[2], 31u);
  EXPECT_EQ(r.histogram.total[7], 1u);  // NaN mismatch

  const std::string& report = r.report;
  EXPECT_THAT(report, HasSubstr("FAILED: 32 of 100 cases fail (32 of 100 components)"));
  EXPECT_THAT(report, HasSubstr("tolerance: <= 1 ULP"));
  // Case 3: index, inputs, both values in decimal and hex, errors.
  const float e3 = 3.0f * 0.1f;
  const std::string line3 = "case 3: inputs x=3 (0x1.8p+1)\n  value: expected " +
                            penumbra::testing::format_value(e3) + ", actual " +
                            penumbra::testing::format_value(up(e3, 2)) + ", abs error ";
  EXPECT_THAT(report, HasSubstr(line3));
  EXPECT_THAT(report, HasSubstr("0x1.333334p-2"));  // 0.3f expected
  EXPECT_THAT(report, HasSubstr("0x1.333338p-2"));  // 2 ULP above it
  EXPECT_THAT(report, HasSubstr(", 2 ULP\n"));
  EXPECT_THAT(report, HasSubstr("case 13: inputs x=13"));
  EXPECT_THAT(report, Not(HasSubstr("case 14:")));  // the cap of 5
  EXPECT_THAT(report, HasSubstr("... and 27 more failing cases (32 total)"));
  // Summary.
  EXPECT_THAT(report, HasSubstr("worst: case 50, inputs x=50 (0x1.9p+5)"));
  EXPECT_THAT(report, HasSubstr("actual nan (bits 0x7fc00000)"));
  EXPECT_THAT(report, HasSubstr("max abs error: inf at case 50"));
  EXPECT_THAT(report, HasSubstr("max ULP distance: n/a (NaN mismatch) at case 50"));
  EXPECT_THAT(report, HasSubstr("error histogram over 100 components:"));
  EXPECT_THAT(report, HasSubstr("exact                     68  68.000%"));
  EXPECT_THAT(report, HasSubstr("<= 4 ULP                  31  31.000%"));
  EXPECT_THAT(report, HasSubstr("31 failing"));
  EXPECT_THAT(report, HasSubstr("NaN/Inf mismatch           1   1.000%"));
}

TEST(CompareBatch, WrongAnswerFailsTheExpectation) {
  const WrongBatch b;
  EXPECT_NONFATAL_FAILURE(PENUMBRA_EXPECT_ALL_NEAR(b.expected, b.actual, Tolerance::ulps(1)),
                          "... and 12 more failing cases (32 total)");
  EXPECT_NONFATAL_FAILURE(PENUMBRA_EXPECT_ALL_NEAR(b.expected, b.actual, Tolerance::ulps(1),
                                                   [&](size_t i) { return b.describe(i); }),
                          "case 3: inputs x=3");
  // With a wide enough tolerance only the NaN fails.
  EXPECT_NONFATAL_FAILURE(PENUMBRA_EXPECT_ALL_NEAR(b.expected, b.actual, Tolerance::ulps(2)),
                          "FAILED: 1 of 100 cases fail");
}

TEST(CompareBatch, PassingExpectationAndSpans) {
  const std::vector<float> e = {1.0f, 2.0f};
  const std::vector<float> a = {up(1.0f), 2.0f};
  PENUMBRA_EXPECT_ALL_NEAR(e, a, Tolerance::ulps(1));
  PENUMBRA_ASSERT_ALL_NEAR(std::span<const float>(e), std::span<const float>(a),
                           Tolerance::ulps(1));
  EXPECT_TRUE(all_near(e, a, Tolerance::absolute(1e-6)));
  EXPECT_TRUE(
      compare_batch(std::span<const float>(e), std::span<const float>(a), Tolerance::ulps(1))
          .passed);
  EXPECT_FALSE(compare_batch<float>(e, a, Tolerance::exact()).passed);
  EXPECT_FALSE(all_near(e, a, Tolerance::exact()));
}

TEST(CompareBatch, SizeMismatchFails) {
  const std::vector<float> e = {1.0f, 2.0f};
  const std::vector<float> a = {1.0f};
  const ComparisonResult r = compare_batch(e, a, Tolerance::exact());
  EXPECT_FALSE(r.passed);
  EXPECT_THAT(r.report, HasSubstr("size mismatch: expected 2 values, actual has 1"));
}

TEST(CompareBatch, ComponentNamesOfVectorsMatricesAndStructs) {
  std::vector<glm::vec3> ev(4, glm::vec3(1.0f)), av = ev;
  av[2].y = 1.5f;
  auto r = compare_batch(ev, av, Tolerance::absolute(0.1));
  EXPECT_FALSE(r.passed);
  EXPECT_EQ(r.worst_case, 2u);
  EXPECT_EQ(r.worst_component, "y");
  EXPECT_THAT(r.report,
              HasSubstr("case 2\n  y: expected 1 (0x1p+0), actual 1.5 (0x1.8p+0), abs error 0.5"));

  std::vector<glm::mat3> em(2, glm::mat3(1.0f)), am = em;
  am[1][2][1] = 0.25f;
  r = compare_batch(em, am, Tolerance::exact());
  EXPECT_EQ(r.worst_component, "c2.r1");
  EXPECT_THAT(r.report, HasSubstr("c2.r1: expected 0 (0x0p+0), actual 0.25 (0x1p-2)"));

  std::vector<Sample> es = {{{0.5f, 0.5f}, 0.25f}}, as = es;
  as[0].uv.x = 0.75f;
  as[0].depth = 0.0f;
  r = compare_batch(es, as, Tolerance::absolute(0.3));
  EXPECT_EQ(r.failing_components, 0u);  // both within 0.3
  r = compare_batch(es, as, Tolerance::absolute(0.1));
  EXPECT_EQ(r.failing_components, 2u);
  // Both are 2.5x the tolerance; the tie goes to the larger ULP distance (0.25 -> 0 is huge).
  EXPECT_EQ(r.worst_component, "depth");
  EXPECT_THAT(r.report, HasSubstr("  uv.x: expected 0.5"));
  EXPECT_THAT(r.report, HasSubstr("  depth: expected 0.25"));
}

TEST(CompareBatch, IntegersAndBoolsCompareExactly) {
  const std::vector<glm::ivec2> e = {{1, 2}, {3, 4}};
  const std::vector<glm::ivec2> a = {{1, 2}, {3, 5}};
  const auto r = compare_batch(e, a, Tolerance::absolute(100.0));
  EXPECT_FALSE(r.passed);
  EXPECT_THAT(r.report, HasSubstr("y: expected 4, actual 5, abs error 1, differs by 1"));
  const std::vector<glm::bvec2> eb = {{true, false}};
  const std::vector<glm::bvec2> ab = {{true, true}};
  EXPECT_FALSE(compare_batch(eb, ab, Tolerance::absolute(1.0)).passed);
}

TEST(CompareBatch, WorstIsMeasuredInToleranceUnits) {
  // Under a relative tolerance, a small error on a small value is worse than a larger error
  // on a large value.
  const std::vector<float> e = {1000.0f, 0.001f};
  const std::vector<float> a = {1000.5f, 0.0011f};
  const auto r = compare_batch(e, a, Tolerance::relative(1e-4));
  EXPECT_EQ(r.failing_cases, 2u);
  EXPECT_EQ(r.worst_case, 1u);
  EXPECT_EQ(r.max_abs_case, 0u);
}

TEST(CompareBatch, PerCaseComponentCap) {
  std::vector<std::array<float, 20>> e(1), a(1);
  for (auto& v : a[0]) v = 1.0f;
  const auto r = compare_batch(e, a, Tolerance::exact());
  EXPECT_EQ(r.failing_components, 20u);
  EXPECT_THAT(r.report, HasSubstr("[15]: expected 0"));
  EXPECT_THAT(r.report, Not(HasSubstr("[16]: expected 0")));
  EXPECT_THAT(r.report, HasSubstr("... and 4 more failing components in this case"));
}

TEST(CompareBatch, LargeBatchIsFast) {
  // 200k vec4 cases: a smoke test that comparison is not the bottleneck of a 1e6-case batch.
  std::vector<glm::vec4> e(200000, glm::vec4(0.5f)), a = e;
  a[123456].w = up(0.5f, 3);
  const auto r = compare_batch(e, a, Tolerance::ulps(2));
  EXPECT_EQ(r.failing_case_indices, std::vector<size_t>{123456});
  EXPECT_EQ(r.max_ulp, 3);
}

TEST(NearTo, MatchesSingleValues) {
  EXPECT_THAT(up(1.0f), NearTo(1.0f, Tolerance::ulps(1)));
  EXPECT_THAT(up(1.0f, 3), Not(NearTo(1.0f, Tolerance::ulps(1))));
  EXPECT_THAT(glm::vec3(1, 2, 3.001f), NearTo(glm::vec3(1, 2, 3), Tolerance::absolute(0.01)));
  EXPECT_THAT(glm::mat2(1.0f), NearTo(glm::mat2(1.0f), Tolerance::exact()));
  EXPECT_THAT((Sample{{0, 0}, 1}), NearTo(Sample{{0, 0}, 1}, Tolerance::exact()));
}

TEST(NearTo, DescribesAndExplains) {
  const auto matcher = NearTo(glm::vec3(1, 2, 3), Tolerance::absolute(0.01));
  EXPECT_EQ(::testing::DescribeMatcher<glm::vec3>(matcher),
            "is near vec3(1, 2, 3) (|error| <= 0.01)");
  EXPECT_NONFATAL_FAILURE(
      EXPECT_THAT(glm::vec3(1, 2.5f, 3), matcher),
      "Actual: vec3(1, 2.5, 3), which differs at y: expected 2 (0x1p+1), actual 2.5 (0x1.4p+1)");
}

}  // namespace

namespace {

using penumbra::testing::Tolerance;

// A periodic value (a hash's fract) compared modulo its period: 0.9999 and 0.0001 are 0.0002
// apart; half a period apart is as far as it gets.
TEST(Tolerance, ModuloComparesPeriodicValuesAcrossTheWrap) {
  const Tolerance plain = Tolerance::absolute(1e-3);
  const Tolerance periodic = plain.modulo(1.0);
  EXPECT_FALSE(plain.accepts(0.9999, 0.0001));
  EXPECT_TRUE(periodic.accepts(0.9999, 0.0001));
  EXPECT_TRUE(periodic.accepts(0.0001, 0.9999));
  EXPECT_TRUE(periodic.accepts(0.25, 3.2502)) << "any number of periods away";
  EXPECT_FALSE(periodic.accepts(0.25, 0.75));
  EXPECT_FALSE(periodic.accepts(0.9999, 0.0101));
  EXPECT_TRUE(Tolerance::ulps(2).modulo(1.0).accepts(penumbra::testing::Scalar::of(0.0f),
                                                     penumbra::testing::Scalar::of(1.0f)));
  EXPECT_THAT(periodic.describe(), ::testing::HasSubstr("(modulo 1)"));
  EXPECT_THROW(plain.modulo(0.0), penumbra::Error);
  EXPECT_THROW(plain.modulo(std::numeric_limits<double>::infinity()), penumbra::Error);
  // In a batch: every case across the wrap passes, one half a period off fails.
  std::vector<float> expected{0.9999f, 0.5f, 0.0f}, actual{0.0001f, 0.5f, 0.9995f};
  EXPECT_TRUE(penumbra::testing::compare_batch(std::span<const float>(expected),
                                               std::span<const float>(actual), periodic)
                  .passed);
  actual[1] = 0.0f;
  EXPECT_FALSE(penumbra::testing::compare_batch(std::span<const float>(expected),
                                                std::span<const float>(actual), periodic)
                   .passed);
}

}  // namespace
