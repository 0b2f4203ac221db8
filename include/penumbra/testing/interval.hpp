#pragma once

// Acceptance intervals from the Vulkan specification, for a user's own GLSL functions.
//
// The Vulkan spec ("Precision and Operation of SPIR-V Instructions", appendix "Vulkan
// Environment for SPIR-V") does not fix one float result per operation: + - * are correctly
// rounded in an unspecified direction (either neighbour of the exact result), division is within
// 2.5 ULP, exp/exp2 within 3 + 2|x| ULP, log/log2 within 3 ULP (2^-21 absolute in [0.5, 2]),
// inversesqrt within 2 ULP, sqrt, pow, mix, dot, length, normalize, ... are "inherited" from a
// formula, denormals may be flushed, and a * b + c may be fused unless decorated `precise`. A
// reference written once as a template is evaluated twice:
//
//   template <class T> T my_falloff(T d, T r) {
//     using namespace penumbra::testing::glsl;  // exp, clamp, mix, inversesqrt, ... for both
//     return clamp(T(1.0) - d * inversesqrt(r), T(0.0), T(1.0));
//   }
//   double expected = my_falloff<double>(d, r);                 // the value, in double
//   Interval accepted = spec_interval([&] { return my_falloff<Interval>(d, r); });  // what the
//                                                                // spec allows a device to return
//   PENUMBRA_EXPECT_ALL_WITHIN(accepted_batch, device_batch, describe);
//
// Interval arithmetic rounds outward at every step, so an interval holds the exact real value of
// the written formula and every result a conforming device may return for it: fused multiply-
// adds (rounding is monotonic, so a fused result lies between the two unfused extremes), either
// rounding direction, flushed denormals. Where a branch depends on a comparison the intervals
// cannot decide (x < y with overlapping x and y), spec_interval runs the reference again for each
// way the ambiguous comparisons can go and returns the hull of all the results.
//
// `precise` (SpecRules::precise): the code may not fuse or reorder, so + - * of exactly known
// operands give the set of their rounded results (up to 8 candidates), not a hull: a fused
// a * b + c that an unfused evaluation cannot produce is then rejected.
//
// What it does not model: reassociation beyond contraction in non-precise code (the spec allows
// any rearrangement "using the mathematical properties governing the expressions in precise
// arithmetic"; the interval follows the written order, which holds when the rearranged order's
// roundings are no larger: see docs/testing-shaders.md); RelaxedPrecision (mediump) and half
// floats; functions the spec leaves undefined (atan's 4096 ULP is modelled; sin and cos outside
// [-pi, pi] accept any value unless SpecRules::trig_abs_error_outside states a bound).

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <glm/glm.hpp>
#include <limits>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

namespace penumbra::testing {

namespace spec {

// How the spec is read.
struct SpecRules {
  // Vulkan's default: a denormal operand or result may be flushed to zero (0 is accepted
  // too). false: denormals preserved (DenormPreserve).
  bool denormals_may_flush = true;
  // The code under test is `precise` (NoContraction): no fusing, no reordering.
  bool precise = false;
  // sin/cos outside [-pi, pi]: the spec states no bound; NaN means any value is accepted.
  double trig_abs_error_outside = std::numeric_limits<double>::quiet_NaN();
  // How many ways through ambiguous comparisons spec_interval follows before it gives up
  // (throws penumbra::Error naming the count).
  std::size_t max_paths = 256;
};

// The rules in force on this thread (spec_interval sets them for one evaluation).
const SpecRules& spec_rules();

// A set of float values a device may return: a hull [lo, hi] of floats, optionally narrowed to
// an explicit set of up to 8 candidates (exactly known values: inputs, and results under
// `precise`), or "any" (the spec leaves the result undefined: NaN inputs, log of a negative, a
// division by an interval holding 0, ...).
//
// Trivially default-constructible (glm::vec<N, Interval> needs it); Interval{} is 0.
class Interval {
 public:
  static constexpr std::size_t kMaxCandidates = 8;

  Interval() = default;
  Interval(float v);   // NOLINT(google-explicit-constructor): exactly v
  Interval(double v);  // NOLINT(google-explicit-constructor): a literal; the float(s) nearest v
  template <std::integral I>
  Interval(I v) : Interval(static_cast<double>(v)) {}  // NOLINT(google-explicit-constructor)

  // Every float in [lo, hi], the ends rounded outward to floats.
  static Interval hull(double lo, double hi);
  // Exactly these values (more than kMaxCandidates: their hull).
  static Interval of(std::span<const float> values);
  static Interval any();

  double lo() const { return lo_; }
  double hi() const { return hi_; }
  bool is_any() const { return any_ != 0; }
  // The explicit candidates (empty for a hull or "any").
  std::span<const float> candidates() const { return {points_.data(), count_}; }
  // Whether a device may return v (+0 and -0 are the same; NaN only for "any").
  bool contains(float v) const;
  // How many floats the interval accepts (1 for a single value; saturates at UINT64_MAX).
  std::uint64_t width_floats() const;
  // "[0x1.8p-1, 0x1.800002p-1] (2 floats)", "{0.5, 0.50000006}", "any".
  std::string describe() const;

  friend Interval operator+(const Interval& a, const Interval& b);
  friend Interval operator-(const Interval& a, const Interval& b);
  friend Interval operator*(const Interval& a, const Interval& b);
  friend Interval operator/(const Interval& a, const Interval& b);
  friend Interval operator-(const Interval& a);
  Interval& operator+=(const Interval& b) { return *this = *this + b; }
  Interval& operator-=(const Interval& b) { return *this = *this - b; }
  Interval& operator*=(const Interval& b) { return *this = *this * b; }
  Interval& operator/=(const Interval& b) { return *this = *this / b; }

  // GLSL.std.450 under the spec's precision rules, as hidden friends: unqualified calls with
  // an Interval argument find them (argument-dependent lookup), and they never capture a call
  // with doubles. `using namespace penumbra::testing::glsl` brings in the double forms.
  friend Interval abs(const Interval& x);
  friend Interval sign(const Interval& x);
  friend Interval floor(const Interval& x);
  friend Interval ceil(const Interval& x);
  friend Interval trunc(const Interval& x);
  friend Interval fract(const Interval& x);
  friend Interval min(const Interval& a, const Interval& b);
  friend Interval max(const Interval& a, const Interval& b);
  friend Interval clamp(const Interval& x, const Interval& lo, const Interval& hi);
  friend Interval step(const Interval& edge, const Interval& x);
  friend Interval mix(const Interval& x, const Interval& y, const Interval& a);
  friend Interval smoothstep(const Interval& e0, const Interval& e1, const Interval& x);
  friend Interval fma(const Interval& a, const Interval& b, const Interval& c);
  friend Interval exp(const Interval& x);
  friend Interval exp2(const Interval& x);
  friend Interval log(const Interval& x);
  friend Interval log2(const Interval& x);
  friend Interval inversesqrt(const Interval& x);
  friend Interval sqrt(const Interval& x);
  friend Interval pow(const Interval& x, const Interval& y);
  friend Interval sin(const Interval& x);
  friend Interval cos(const Interval& x);
  friend Interval tan(const Interval& x);
  friend Interval atan(const Interval& x);
  friend Interval atan(const Interval& y, const Interval& x);  // atan2
  friend Interval asin(const Interval& x);
  friend Interval acos(const Interval& x);

  // Union (for the results of several ways through a reference).
  static Interval join(const Interval& a, const Interval& b);

  // For the implementation: the fields are public to keep the type an aggregate-like literal.
  double lo_;
  double hi_;
  std::array<float, kMaxCandidates> points_;
  std::uint8_t count_;
  std::uint8_t any_;
};

// The result of comparing intervals: decided, or "maybe". Converting a "maybe" to bool asks
// spec_interval which way this run goes (outside spec_interval it throws penumbra::Error).
class SpecBool {
 public:
  enum class State : std::uint8_t { no, yes, maybe };
  constexpr SpecBool(bool v) : state_(v ? State::yes : State::no) {}  // NOLINT
  constexpr explicit SpecBool(State s) : state_(s) {}
  operator bool() const;  // NOLINT(google-explicit-constructor): used in if, ?:, &&
  State state() const { return state_; }
  friend SpecBool operator!(SpecBool b) {
    return SpecBool(b.state_ == State::maybe ? State::maybe
                                             : (b.state_ == State::yes ? State::no : State::yes));
  }

 private:
  State state_;
};

SpecBool operator<(const Interval& a, const Interval& b);
SpecBool operator>(const Interval& a, const Interval& b);
SpecBool operator<=(const Interval& a, const Interval& b);
SpecBool operator>=(const Interval& a, const Interval& b);
SpecBool operator==(const Interval& a, const Interval& b);
SpecBool operator!=(const Interval& a, const Interval& b);
// GLSL's isnan / isinf, and finiteness (the shaders' penumbra_is_nan / penumbra_is_finite): an
// "any" interval may be NaN or not.
SpecBool is_nan(const Interval& x);
SpecBool is_finite(const Interval& x);

template <glm::length_t N>
using IntervalVec = glm::vec<N, Interval, glm::defaultp>;

// dot is inherited from the sum of products in any order: the hull over every order of the sum.
Interval dot_of(std::span<const Interval> x, std::span<const Interval> y);
template <glm::length_t N>
Interval dot(const IntervalVec<N>& x, const IntervalVec<N>& y) {
  std::array<Interval, N> a, b;
  for (glm::length_t i = 0; i < N; ++i) a[i] = x[i], b[i] = y[i];
  return dot_of(a, b);
}
// length(x) is inherited from sqrt(dot(x, x)); normalize(x) from x * inversesqrt(dot(x, x)).
Interval length_of(std::span<const Interval> x);
template <glm::length_t N>
Interval length(const IntervalVec<N>& x) {
  std::array<Interval, N> a;
  for (glm::length_t i = 0; i < N; ++i) a[i] = x[i];
  return length_of(a);
}
template <glm::length_t N>
Interval distance(const IntervalVec<N>& x, const IntervalVec<N>& y) {
  return length(x - y);
}
template <glm::length_t N>
IntervalVec<N> normalize(const IntervalVec<N>& x) {
  const Interval r = inversesqrt(dot(x, x));
  IntervalVec<N> out;
  for (glm::length_t i = 0; i < N; ++i) out[i] = x[i] * r;
  return out;
}
inline IntervalVec<3> cross(const IntervalVec<3>& a, const IntervalVec<3>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
// Componentwise forms of the scalar functions above, for vectors.
#define PENUMBRA_INTERVAL_VEC1(fn)                           \
  template <glm::length_t N>                                 \
  IntervalVec<N> fn(const IntervalVec<N>& x) {               \
    IntervalVec<N> out;                                      \
    for (glm::length_t i = 0; i < N; ++i) out[i] = fn(x[i]); \
    return out;                                              \
  }
PENUMBRA_INTERVAL_VEC1(abs)
PENUMBRA_INTERVAL_VEC1(floor)
PENUMBRA_INTERVAL_VEC1(fract)
PENUMBRA_INTERVAL_VEC1(sqrt)
PENUMBRA_INTERVAL_VEC1(exp2)
#undef PENUMBRA_INTERVAL_VEC1
template <glm::length_t N>
IntervalVec<N> min(const IntervalVec<N>& a, const IntervalVec<N>& b) {
  IntervalVec<N> out;
  for (glm::length_t i = 0; i < N; ++i) out[i] = min(a[i], b[i]);
  return out;
}
template <glm::length_t N>
IntervalVec<N> max(const IntervalVec<N>& a, const IntervalVec<N>& b) {
  IntervalVec<N> out;
  for (glm::length_t i = 0; i < N; ++i) out[i] = max(a[i], b[i]);
  return out;
}
template <glm::length_t N>
IntervalVec<N> clamp(const IntervalVec<N>& x, const Interval& lo, const Interval& hi) {
  IntervalVec<N> out;
  for (glm::length_t i = 0; i < N; ++i) out[i] = clamp(x[i], lo, hi);
  return out;
}
template <glm::length_t N>
IntervalVec<N> mix(const IntervalVec<N>& x, const IntervalVec<N>& y, const Interval& a) {
  IntervalVec<N> out;
  for (glm::length_t i = 0; i < N; ++i) out[i] = mix(x[i], y[i], a);
  return out;
}

// Converting the harness's case values: float -> Interval, glm::vec<N, float> ->
// IntervalVec<N>; other types (bool, int, uint, structs) are passed unchanged.
inline Interval to_interval(float v) {
  return Interval(v);
}
template <glm::length_t N, glm::qualifier Q>
IntervalVec<N> to_interval(const glm::vec<N, float, Q>& v) {
  IntervalVec<N> out;
  for (glm::length_t i = 0; i < N; ++i) out[i] = Interval(v[i]);
  return out;
}
template <class T>
requires(!std::is_same_v<T, float>) const T& to_interval(const T& v) {
  return v;
}

namespace detail {
// Runs `run` once per way through the ambiguous comparisons (at most rules.max_paths), with the
// rules in force, and hands each result to `collect`.
void for_each_spec_path(const SpecRules& rules, const std::function<void()>& run);

inline Interval join_results(const Interval& a, const Interval& b) {
  return Interval::join(a, b);
}
template <glm::length_t N>
IntervalVec<N> join_results(const IntervalVec<N>& a, const IntervalVec<N>& b) {
  IntervalVec<N> out;
  for (glm::length_t i = 0; i < N; ++i) out[i] = Interval::join(a[i], b[i]);
  return out;
}
}  // namespace detail

// What the spec allows for the value `reference` computes (an Interval or an IntervalVec):
// the hull over every way through its ambiguous comparisons.
template <class F>
auto spec_interval(F&& reference, const SpecRules& rules = {}) {
  using R = std::remove_cvref_t<std::invoke_result_t<F&>>;
  bool first = true;
  R out{};
  detail::for_each_spec_path(rules, [&] {
    R r = reference();
    out = first ? r : detail::join_results(out, r);
    first = false;
  });
  return out;
}

// The comparison: passes exactly when every component of every actual value lies in its
// interval; a failure lists each failing case with its inputs, the interval, the value, and how
// many floats outside the interval it fell (above or below).
struct WithinResult {
  bool passed = true;
  std::size_t cases = 0;
  std::size_t failing_cases = 0;
  // Over all components: the largest distance outside (in floats), and the widest interval.
  std::uint64_t max_outside = 0;
  std::uint64_t max_width = 0;
  std::string report;
  explicit operator bool() const { return passed; }
};

namespace detail {
class WithinComparer {
 public:
  WithinComparer(std::function<std::string(std::size_t)> describe, std::size_t max_reported);
  void component(std::size_t case_index, const char* name, const Interval& accepted, float actual);
  void end_case(std::size_t case_index);
  WithinResult finish();

 private:
  std::function<std::string(std::size_t)> describe_;
  std::size_t max_reported_;
  WithinResult result_;
  std::string case_lines_;
  std::size_t reported_ = 0;
};
}  // namespace detail

inline void visit_within(detail::WithinComparer& c, std::size_t i, const Interval& accepted,
                         float actual) {
  c.component(i, "", accepted, actual);
}
template <glm::length_t N, glm::qualifier Q>
void visit_within(detail::WithinComparer& c, std::size_t i, const IntervalVec<N>& accepted,
                  const glm::vec<N, float, Q>& actual) {
  static constexpr const char* kNames[] = {"x", "y", "z", "w"};
  for (glm::length_t k = 0; k < N; ++k) c.component(i, kNames[k], accepted[k], actual[k]);
}

template <class A, class V>
WithinResult compare_within(const std::vector<A>& accepted, const std::vector<V>& actual,
                            std::function<std::string(std::size_t)> describe = {},
                            std::size_t max_reported = 20) {
  detail::WithinComparer comparer(std::move(describe), max_reported);
  const std::size_t n = std::min(accepted.size(), actual.size());
  for (std::size_t i = 0; i < n; ++i) {
    visit_within(comparer, i, accepted[i], actual[i]);
    comparer.end_case(i);
  }
  WithinResult r = comparer.finish();
  if (accepted.size() != actual.size()) {
    r.passed = false;
    r.report = std::to_string(accepted.size()) + " accepted intervals but " +
               std::to_string(actual.size()) + " actual values\n" + r.report;
  }
  return r;
}

::testing::AssertionResult to_assertion_result(const WithinResult& result);

// How a hand-picked tolerance compares with the spec: for a value expected in double with an
// absolute bound, whether it accepts a float the interval does not (too loose: by how much
// wider its range is than the interval's) and whether the interval holds a float it rejects (too
// tight: a conforming device could fail the test; by how many floats).
struct ToleranceAudit {
  std::size_t cases = 0;
  std::size_t too_loose = 0;
  std::size_t too_tight = 0;
  std::vector<double> width_ratios;    // the bound's range over the interval's, per loose case
  std::uint64_t max_tight_floats = 0;  // floats the interval allows beyond the bound
  void add(double expected, double bound, const Interval& accepted);
  double median_ratio() const;
  double max_ratio() const;
  // "8000 cases: 8000 too loose (range a median 3.1x, at most 40x the interval's), 0 too tight"
  std::string describe() const;
};

}  // namespace spec

using spec::compare_within;
using spec::Interval;
using spec::IntervalVec;
using spec::spec_interval;
using spec::spec_rules;
using spec::SpecBool;
using spec::SpecRules;
using spec::to_assertion_result;
using spec::to_interval;
using spec::ToleranceAudit;
using spec::WithinResult;

// The double forms, so that one template reference serves both types with unqualified calls.
namespace glsl {
using std::abs, std::floor, std::ceil, std::trunc, std::exp, std::exp2, std::log, std::log2,
    std::sqrt, std::pow, std::sin, std::cos, std::tan, std::atan, std::asin, std::acos, std::fma,
    std::min, std::max;
inline double atan(double y, double x) {
  return std::atan2(y, x);
}
inline double sign(double x) {
  return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0);
}
inline double fract(double x) {
  return x - std::floor(x);
}
inline double clamp(double x, double lo, double hi) {
  return std::min(std::max(x, lo), hi);
}
inline double step(double edge, double x) {
  return x < edge ? 0.0 : 1.0;
}
inline double mix(double x, double y, double a) {
  return x * (1.0 - a) + y * a;
}
inline double smoothstep(double e0, double e1, double x) {
  const double t = clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}
inline double inversesqrt(double x) {
  return 1.0 / std::sqrt(x);
}
using glm::dot, glm::length, glm::distance, glm::normalize, glm::cross;
}  // namespace glsl

}  // namespace penumbra::testing

#define PENUMBRA_EXPECT_ALL_WITHIN(...)                                                           \
  GTEST_ASSERT_(                                                                                  \
      ::penumbra::testing::to_assertion_result(::penumbra::testing::compare_within(__VA_ARGS__)), \
      GTEST_NONFATAL_FAILURE_)
