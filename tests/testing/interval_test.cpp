// Self-tests of the spec-derived intervals (include/penumbra/testing/interval.hpp), on the CPU:
// each rule of the Vulkan spec's precision table, checked at values where the answer is known.
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/interval.hpp>
#include <vector>

namespace penumbra::testing {
namespace {

float next_up(float v) {
  return std::nextafter(v, INFINITY);
}
float next_down(float v) {
  return std::nextafter(v, -INFINITY);
}

// A reference written once, for double and for Interval.
template <class T>
T falloff(T d, T r) {
  using namespace glsl;
  return clamp(T(1.0) - d * inversesqrt(r), T(0.0), T(1.0));
}

TEST(Interval, CorrectlyRoundedSumAcceptsBothNeighboursAndNothingBeyond) {
  const float a = 1.0f, b = 0x1p-30f;  // 1 + 2^-30 lies between 1 and next_up(1)
  const Interval s = Interval(a) + Interval(b);
  EXPECT_TRUE(s.contains(1.0f));
  EXPECT_TRUE(s.contains(next_up(1.0f)));
  EXPECT_FALSE(s.contains(next_down(1.0f))) << s.describe();
  EXPECT_FALSE(s.contains(next_up(next_up(1.0f)))) << s.describe();
  // An exact result is the only one allowed.
  const Interval exact = Interval(1.5f) + Interval(0.25f);
  EXPECT_EQ(exact.width_floats(), 1u);
  EXPECT_TRUE(exact.contains(1.75f));
  EXPECT_FALSE(exact.contains(next_up(1.75f)));
  EXPECT_FALSE(exact.contains(next_down(1.75f)));
}

TEST(Interval, ProductOneUlpOutsideIsRejected) {
  const float a = 1.1f, b = 3.3f;
  const double exact = double{a} * double{b};
  const auto down = static_cast<float>(exact);  // nearest; then the other neighbour
  const float lo = static_cast<double>(down) <= exact ? down : next_down(down);
  const float hi = next_up(lo);
  const Interval p = Interval(a) * Interval(b);
  EXPECT_TRUE(p.contains(lo));
  EXPECT_TRUE(p.contains(hi));
  EXPECT_FALSE(p.contains(next_down(lo)));
  EXPECT_FALSE(p.contains(next_up(hi)));
}

// a * b + c where the fused result differs from both unfused ones.
struct FusedCase {
  float a, b, c;
};
FusedCase fused_case() {
  const float a = 1.0f + 0x1p-12f, b = 1.0f + 0x1p-12f;  // a b = 1 + 2^-11 + 2^-24
  const float c = -1.0f;
  return {a, b, c};
}

TEST(Interval, FusedMultiplyAddIsAcceptedUnlessPrecise) {
  const auto [a, b, c] = fused_case();
  const float fused = std::fma(a, b, c);  // 2^-11 + 2^-24, exactly
  const float unfused = a * b + c;        // the product rounds first
  ASSERT_NE(fused, unfused);
  const auto expr = [&] { return Interval(a) * Interval(b) + Interval(c); };
  const Interval loose = spec_interval(expr);
  EXPECT_TRUE(loose.contains(fused)) << loose.describe();
  EXPECT_TRUE(loose.contains(unfused)) << loose.describe();
  const Interval precise = spec_interval(expr, {.precise = true});
  EXPECT_FALSE(precise.contains(fused)) << precise.describe();
  EXPECT_TRUE(precise.contains(unfused)) << precise.describe();
  EXPECT_FALSE(precise.candidates().empty());
}

TEST(Interval, DivisionAllowsTwoAndAHalfUlp) {
  const Interval q = Interval(1.0f) / Interval(3.0f);
  // 1/3 rounds up to the float third = 1/3 + ulp/3 (ulp = 2^-25 here), so the allowed range
  // [1/3 - 2.5 ulp, 1/3 + 2.5 ulp] is [third - 2.83 ulp, third + 2.17 ulp]: 5 floats.
  const float third = 1.0f / 3.0f;
  ASSERT_GT(double{third}, 1.0 / 3.0);
  float lo = third, hi = third;
  for (int i = 0; i < 2; ++i) lo = next_down(lo), hi = next_up(hi);
  EXPECT_TRUE(q.contains(lo) && q.contains(hi)) << q.describe();
  EXPECT_FALSE(q.contains(next_down(lo))) << q.describe();
  EXPECT_FALSE(q.contains(next_up(hi))) << q.describe();
  EXPECT_EQ(q.width_floats(), 5u);
  // Divisors outside [2^-126, 2^126] have no stated bound; a divisor that may be 0 neither.
  EXPECT_TRUE((Interval(1.0f) / Interval(0x1p127f)).is_any());
  EXPECT_TRUE((Interval(1.0f) / Interval::hull(-1.0, 1.0)).is_any());
}

TEST(Interval, DenormalsMayBeFlushedUnlessPreserved) {
  const float tiny = 0x1p-140f;
  const Interval t = spec_interval([&] { return Interval(tiny) * Interval(1.0f); });
  EXPECT_TRUE(t.contains(tiny));
  EXPECT_TRUE(t.contains(0.0f));
  const Interval kept = spec_interval([&] { return Interval(tiny) * Interval(1.0f); },
                                      {.denormals_may_flush = false});
  EXPECT_FALSE(kept.contains(0.0f)) << kept.describe();
}

TEST(Interval, ExpAndLogFollowTheirUlpAndAbsoluteBounds) {
  // exp(1): 3 + 2 ULP = 5 ULP around e.
  const Interval e = exp(Interval(1.0f));
  const double exact = std::exp(1.0);
  const auto near = static_cast<float>(exact);
  float v = near;
  for (int i = 0; i < 4; ++i) v = next_up(v);
  EXPECT_TRUE(e.contains(v)) << e.describe();
  for (int i = 0; i < 3; ++i) v = next_up(v);
  EXPECT_FALSE(e.contains(v)) << e.describe();
  // log inside [0.5, 2]: an absolute 2^-21, far more than 3 ULP of log(1.5) = 0.405.
  const Interval l = log(Interval(1.5f));
  EXPECT_TRUE(l.contains(static_cast<float>(std::log(1.5) + 0x1p-22)));
  EXPECT_FALSE(l.contains(static_cast<float>(std::log(1.5) + 0x1p-20)));
  EXPECT_TRUE(log(Interval(-1.0f)).is_any());
}

TEST(Interval, SqrtAndPowAreInherited) {
  // sqrt(4) from 1 / inversesqrt(4): inversesqrt within 2 ULP of 0.5, then 2.5 ULP division.
  const Interval s = sqrt(Interval(4.0f));
  EXPECT_TRUE(s.contains(2.0f));
  EXPECT_TRUE(s.contains(next_up(next_up(2.0f)))) << s.describe();
  EXPECT_FALSE(s.contains(2.01f)) << s.describe();
  EXPECT_TRUE(sqrt(Interval(0.0f)).contains(0.0f));
  // Symmetric about the exact value (the inherited rule).
  EXPECT_NEAR(2.0 - s.lo(), s.hi() - 2.0, 4 * 0x1p-22);
  const Interval p = pow(Interval(2.0f), Interval(10.0f));
  EXPECT_TRUE(p.contains(1024.0f));
  EXPECT_TRUE(pow(Interval(-2.0f), Interval(2.0f)).is_any());
  EXPECT_TRUE(pow(Interval(0.0f), Interval(2.0f)).contains(0.0f));
}

TEST(Interval, TrigonometryHasTheSpecsAbsoluteBoundInsideMinusPiToPi) {
  const Interval s = sin(Interval(1.0f));
  EXPECT_TRUE(s.contains(static_cast<float>(std::sin(1.0) + 0x1p-12)));
  EXPECT_FALSE(s.contains(static_cast<float>(std::sin(1.0) + 0x1p-10)));
  EXPECT_TRUE(sin(Interval(10.0f)).is_any());
  const Interval stated =
      spec_interval([] { return sin(Interval(10.0f)); }, {.trig_abs_error_outside = 1e-3});
  EXPECT_FALSE(stated.is_any());
  EXPECT_TRUE(stated.contains(static_cast<float>(std::sin(10.0))));
  // The range of cos over an interval holding 0 reaches 1.
  EXPECT_GE(cos(Interval::hull(-0.5, 0.5)).hi(), 1.0);
}

TEST(Interval, AmbiguousBranchesAreEnumerated) {
  // x < 1 cannot be decided for x = 0.5 + 0.5 rounded either way... it can; use an overlap.
  const Interval x = Interval::hull(0.5, 1.5);
  const Interval r = spec_interval([&] { return x < Interval(1.0f) ? Interval(10.0f) : x; });
  EXPECT_TRUE(r.contains(10.0f));
  EXPECT_TRUE(r.contains(1.25f));
  // Outside spec_interval an undecidable comparison is an error, not a guess.
  EXPECT_THROW((void)static_cast<bool>(x < Interval(1.0f)), Error);
  // Decided comparisons need no enumeration.
  EXPECT_TRUE(static_cast<bool>(Interval(0.5f) < Interval(1.0f)));
}

TEST(Interval, ATemplateReferenceGivesTheValueAndTheInterval) {
  const float d = 0.3f, r = 2.0f;
  const double value = falloff<double>(d, r);
  const Interval accepted = spec_interval([&] { return falloff<Interval>(d, r); });
  EXPECT_TRUE(accepted.contains(static_cast<float>(value))) << accepted.describe();
  EXPECT_LT(accepted.width_floats(), 16u) << accepted.describe();
}

TEST(Interval, VectorsUseTheInheritedDotLengthAndNormalize) {
  const IntervalVec<3> v = to_interval(glm::vec3(3.0f, 4.0f, 12.0f));
  EXPECT_TRUE(dot(v, v).contains(169.0f));
  EXPECT_TRUE(length(v).contains(13.0f));
  const IntervalVec<3> n = normalize(v);
  EXPECT_TRUE(n.x.contains(3.0f / 13.0f)) << n.x.describe();
  const IntervalVec<3> c = cross(to_interval(glm::vec3(1, 0, 0)), to_interval(glm::vec3(0, 1, 0)));
  EXPECT_TRUE(c.z.contains(1.0f));
  EXPECT_EQ(c.z.width_floats(), 1u);
}

TEST(Interval, CompareWithinReportsWhereAValueFell) {
  std::vector<Interval> accepted{Interval(1.0f) + Interval(0x1p-30f), Interval(2.0f)};
  std::vector<float> good{1.0f, 2.0f};
  std::vector<float> bad{next_up(next_up(1.0f)), 2.0f};
  EXPECT_TRUE(compare_within(accepted, good).passed);
  const WithinResult r =
      compare_within(accepted, bad, [](std::size_t i) { return "x = " + std::to_string(i); });
  EXPECT_FALSE(r.passed);
  EXPECT_EQ(r.failing_cases, 1u);
  EXPECT_EQ(r.max_outside, 1u);
  EXPECT_NE(r.report.find("1 float above"), std::string::npos) << r.report;
  EXPECT_NE(r.report.find("x = 0"), std::string::npos) << r.report;
}

TEST(Interval, ToleranceAuditCountsLooseAndTightBounds) {
  ToleranceAudit audit;
  const Interval two = Interval(1.0f) + Interval(0x1p-30f);  // {1, 1 + 2^-23}
  audit.add(1.0, 4 * 0x1p-23, two);  // accepts 1 +- 4 ULP: 3 floats too many above
  audit.add(1.0, 0.0, two);          // accepts only 1: too tight by 1 float
  EXPECT_EQ(audit.too_loose, 1u);
  EXPECT_EQ(audit.too_tight, 1u);
  EXPECT_EQ(audit.max_tight_floats, 1u);
  // The bound's range (1 - 4 * 2^-23 to 1 + 4 * 2^-23: 8 * 2^-23) over
  // the interval's (one float step, 2^-23).
  EXPECT_DOUBLE_EQ(audit.max_ratio(), 8.0);
}

}  // namespace
}  // namespace penumbra::testing
