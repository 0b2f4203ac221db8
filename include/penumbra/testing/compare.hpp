#pragma once

// Tolerances and batch comparison of host values, with gtest integration.
//
//   PENUMBRA_EXPECT_ALL_NEAR(expected, actual, Tolerance::ulps(2, 1e-6));
//   EXPECT_THAT(value, NearTo(glm::vec3(1, 2, 3), Tolerance::absolute(1e-5)));
//
// A failure reports every failing case (up to a cap, then the total): its index, its inputs,
// the failing components with expected and actual values in decimal and hex float, the absolute
// error and the ULP distance; then a summary with the worst case, the maximum absolute and ULP
// errors and where they occur, and a histogram of the errors of all compared components.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <ostream>
#include <penumbra/testing/values.hpp>
#include <ranges>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

namespace penumbra::testing {

// Distance between two floats in units in the last place: how many representable floats lie
// between them, counting one end. +0 and -0 are 0 apart, the smallest denormals of either sign
// are 2 apart, FLT_MAX and +Inf are 1 apart. A NaN on either side gives INT64_MAX.
constexpr std::int64_t ulp_distance(float a, float b) {
  if (a != a || b != b) return std::numeric_limits<std::int64_t>::max();
  const auto ordered = [](float v) {
    const auto bits = static_cast<std::int64_t>(std::bit_cast<std::int32_t>(v));
    // Negative floats have the sign bit set; mirror them below zero so the mapping is monotonic.
    return bits >= 0 ? bits : std::int64_t{std::numeric_limits<std::int32_t>::min()} - bits;
  };
  const std::int64_t d = ordered(a) - ordered(b);
  return d >= 0 ? d : -d;
}

// The same for doubles (host-side values); saturates at INT64_MAX.
constexpr std::int64_t ulp_distance(double a, double b) {
  if (a != a || b != b) return std::numeric_limits<std::int64_t>::max();
  const auto ordered = [](double v) {
    const auto bits = std::bit_cast<std::int64_t>(v);
    // -bits cannot overflow: bits == INT64_MIN (-0.0) maps to 0 via the subtraction below.
    return bits >= 0 ? bits : std::numeric_limits<std::int64_t>::min() - bits;
  };
  const std::int64_t oa = ordered(a);
  const std::int64_t ob = ordered(b);
  if ((oa >= 0) == (ob >= 0)) return oa >= ob ? oa - ob : ob - oa;
  const std::uint64_t d = oa >= 0
                              ? static_cast<std::uint64_t>(oa) + static_cast<std::uint64_t>(-ob)
                              : static_cast<std::uint64_t>(ob) + static_cast<std::uint64_t>(-oa);
  constexpr auto kMax = static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max());
  return d > kMax ? std::numeric_limits<std::int64_t>::max() : static_cast<std::int64_t>(d);
}

// When two floating-point components count as equal. A component passes if any holds:
//   actual == expected (so +0 == -0), or both are NaN;
//   |actual - expected| <= abs;
//   |actual - expected| <= rel * |expected|;
//   ulp >= 0 and ulp_distance(expected, actual) <= ulp;
//   |actual - expected| <= floor  (the near-zero floor that rescues ULP and relative checks
//                                  where the expected value is tiny or zero).
// An infinity only matches the same infinity. Integer and bool components compare exactly.
// The ULP distance is measured in the component's own type (float, or double for host doubles).
// With a period (modulo), a periodic value (a hash's fract, an angle) is compared at the
// representative of `actual` nearest `expected`: 0.9999 and 0.0001 are 0.0002 apart modulo 1.
struct Tolerance {
  double abs = 0.0;
  double rel = 0.0;
  std::int64_t ulp = -1;
  double floor = 0.0;
  double period = 0.0;  // 0: not periodic

  static Tolerance exact() { return {}; }
  static Tolerance absolute(double abs) { return {.abs = abs}; }
  static Tolerance relative(double rel, double floor = 0.0) { return {.rel = rel, .floor = floor}; }
  static Tolerance ulps(std::int64_t n, double floor = 0.0) { return {.ulp = n, .floor = floor}; }

  // Copies with one bound changed, for combinations: Tolerance::ulps(3).with_abs(1e-3).
  Tolerance with_abs(double value) const;
  Tolerance with_rel(double value) const;
  Tolerance with_ulp(std::int64_t value) const;
  Tolerance with_floor(double value) const;
  // The same bounds, applied modulo `period` (> 0, finite): Tolerance::absolute(1e-6).modulo(1).
  // Throws penumbra::Error for another period.
  Tolerance modulo(double period) const;

  // For float values: the ULP distance is that of the two values rounded to float.
  bool accepts(double expected, double actual) const;
  // With the ULP distance already known (the comparison's own type).
  bool accepts(double expected, double actual, std::int64_t ulp_dist) const;
  // Exact for integers and bools; float ULPs for f32, double ULPs for f64.
  bool accepts(const Scalar& expected, const Scalar& actual) const;

  // "exact", or e.g. "<= 2 ULP or |error| <= 1e-06 (floor)".
  std::string describe() const;
};

// One row per bin; a component falls in the first bin that holds its error. Integers count
// their difference as ULPs; a NaN/number mismatch or an infinity mismatch is "NaN/Inf mismatch".
struct ErrorHistogram {
  static constexpr std::size_t kBins = 8;
  static constexpr std::array<std::string_view, kBins> kLabels = {
      "exact",      "<= 1 ULP",     "<= 4 ULP",    "<= 16 ULP",
      "<= 256 ULP", "<= 65536 ULP", "> 65536 ULP", "NaN/Inf mismatch"};
  std::array<std::size_t, kBins> total{};
  std::array<std::size_t, kBins> failing{};

  static std::size_t bin_of(std::int64_t ulp_dist, bool nan_or_inf_mismatch);
  std::string format() const;
};

struct ComparisonResult {
  bool passed = true;
  std::size_t cases = 0;
  std::size_t components = 0;  // compared scalar components, over all cases
  std::size_t failing_cases = 0;
  std::size_t failing_components = 0;
  std::vector<std::size_t> failing_case_indices;  // all of them, ascending

  // Over all compared components (NaN/Inf mismatches count as +inf and INT64_MAX).
  double max_abs_error = 0.0;
  std::size_t max_abs_case = 0;
  std::string max_abs_component;
  std::int64_t max_ulp = 0;
  std::size_t max_ulp_case = 0;
  std::string max_ulp_component;

  // The component furthest outside the tolerance (measured in the tolerance's own units); when
  // everything passed, the one closest to failing.
  std::size_t worst_case = 0;
  std::string worst_component;  // "" for a scalar value, else e.g. "c2.r1" or "dir.x"
  Scalar worst_expected;
  Scalar worst_actual;
  std::string worst_inputs;  // describe_inputs(worst_case), or ""

  ErrorHistogram histogram;
  std::string report;  // the full text, for a failure message or a log

  explicit operator bool() const { return passed; }
};

// The debug printf lines of the last ShaderFunction run on this thread, per case (set by
// ShaderFunction::run). A failing batch comparison over as many cases lists each reported
// case's lines after its mismatches.
void set_last_run_printf(const std::vector<std::vector<std::string>>& per_case);
const std::vector<std::vector<std::string>>& last_run_printf();

// Describes the inputs of case i, e.g. [&](size_t i) { return format_tuple(args[i]); }.
using DescribeInputs = std::function<std::string(std::size_t)>;

namespace detail {

// The type-independent part of compare_batch: fed one component at a time.
class BatchComparer {
 public:
  BatchComparer(const Tolerance& tol, DescribeInputs describe_inputs, std::size_t max_reported);
  ~BatchComparer();
  BatchComparer(const BatchComparer&) = delete;
  BatchComparer& operator=(const BatchComparer&) = delete;

  void component(std::size_t case_index, std::string_view name, const Scalar& expected,
                 const Scalar& actual);
  void end_case(std::size_t case_index);
  ComparisonResult finish();
  ComparisonResult size_mismatch(std::size_t expected_size, std::size_t actual_size);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace detail

// Compares two equally long batches elementwise and over every scalar component.
template <HasComponents T>
ComparisonResult compare_batch(std::span<const T> expected, std::span<const T> actual,
                               const Tolerance& tol, DescribeInputs describe_inputs = {},
                               std::size_t max_reported = 20) {
  detail::BatchComparer comparer(tol, std::move(describe_inputs), max_reported);
  if (expected.size() != actual.size()) {
    return comparer.size_mismatch(expected.size(), actual.size());
  }
  std::vector<Scalar> actual_components;
  actual_components.reserve(Components<T>::count);
  for (std::size_t i = 0; i < expected.size(); ++i) {
    actual_components.clear();
    Components<T>::visit(
        actual[i], [&](std::string_view, const Scalar& s) { actual_components.push_back(s); });
    std::size_t k = 0;
    Components<T>::visit(expected[i], [&](std::string_view name, const Scalar& s) {
      comparer.component(i, name, s, actual_components[k++]);
    });
    comparer.end_case(i);
  }
  return comparer.finish();
}

// Any two contiguous ranges of the same element type (std::vector, std::array, std::span).
template <std::ranges::contiguous_range E, std::ranges::contiguous_range A>
requires std::is_same_v<std::ranges::range_value_t<E>, std::ranges::range_value_t<A>> &&
    HasComponents<std::ranges::range_value_t<E>>
        ComparisonResult compare_batch(const E& expected, const A& actual, const Tolerance& tol,
                                       DescribeInputs describe_inputs = {},
                                       std::size_t max_reported = 20) {
  using T = std::ranges::range_value_t<E>;
  return compare_batch<T>(
      std::span<const T>(std::ranges::data(expected), std::ranges::size(expected)),
      std::span<const T>(std::ranges::data(actual), std::ranges::size(actual)), tol,
      std::move(describe_inputs), max_reported);
}

// A gtest assertion over a batch: success carries nothing, failure carries the report.
::testing::AssertionResult to_assertion_result(const ComparisonResult& result);

template <std::ranges::contiguous_range E, std::ranges::contiguous_range A>
requires(std::is_same_v<std::ranges::range_value_t<E>, std::ranges::range_value_t<A>>&&
             HasComponents<std::ranges::range_value_t<E>>)::testing::AssertionResult
    all_near(const E& expected, const A& actual, const Tolerance& tol,
             DescribeInputs describe_inputs = {}, std::size_t max_reported = 20) {
  return to_assertion_result(
      compare_batch(expected, actual, tol, std::move(describe_inputs), max_reported));
}

// "x: expected 1 (0x1p+0), actual 1.00000012 (0x1.000002p+0), abs error 1.1920929e-07, 1 ULP"
std::string describe_component_mismatch(std::string_view name, const Scalar& expected,
                                        const Scalar& actual);

// Explains why one value does (not) match: its failing components with both values and errors.
// Empty when it matches.
template <HasComponents T>
std::string explain_mismatch(const T& expected, const T& actual, const Tolerance& tol) {
  std::vector<Scalar> actual_components;
  Components<T>::visit(actual,
                       [&](std::string_view, const Scalar& s) { actual_components.push_back(s); });
  std::string out;
  std::size_t k = 0;
  Components<T>::visit(expected, [&](std::string_view name, const Scalar& e) {
    const Scalar& a = actual_components[k++];
    if (tol.accepts(e, a)) return;
    if (!out.empty()) out += "; ";
    out += describe_component_mismatch(name, e, a);
  });
  return out;
}

// gmock matcher for one value (float, vector, matrix, array, described struct):
//   EXPECT_THAT(f(x), NearTo(1.0f, Tolerance::ulps(2)));
template <HasComponents T>
class NearToMatcher {
 public:
  using is_gtest_matcher = void;

  NearToMatcher(T expected, Tolerance tol) : expected_(std::move(expected)), tol_(tol) {}

  bool MatchAndExplain(const T& actual, std::ostream* os) const {
    const std::string why = explain_mismatch(expected_, actual, tol_);
    if (os != nullptr) {
      if (why.empty()) {
        *os << "every component is within tolerance";
      } else {
        *os << "which differs at " << why;
      }
    }
    return why.empty();
  }
  void DescribeTo(std::ostream* os) const {
    *os << "is near " << format_value(expected_) << " (" << tol_.describe() << ")";
  }
  void DescribeNegationTo(std::ostream* os) const {
    *os << "is not near " << format_value(expected_) << " (" << tol_.describe() << ")";
  }

 private:
  T expected_;
  Tolerance tol_;
};

template <HasComponents T>
NearToMatcher<T> NearTo(const T& expected, const Tolerance& tol) {
  return NearToMatcher<T>(expected, tol);
}

}  // namespace penumbra::testing

// PENUMBRA_EXPECT_ALL_NEAR(expected, actual, tol [, describe_inputs [, max_reported]])
// expected/actual: std::vector, std::array or std::span of the same Components type.
#define PENUMBRA_EXPECT_ALL_NEAR(...) \
  GTEST_ASSERT_(::penumbra::testing::all_near(__VA_ARGS__), GTEST_NONFATAL_FAILURE_)
#define PENUMBRA_ASSERT_ALL_NEAR(...) \
  GTEST_ASSERT_(::penumbra::testing::all_near(__VA_ARGS__), GTEST_FATAL_FAILURE_)
