#pragma once

// The internals the interval sources share (interval.cpp, interval_functions.cpp,
// interval_compare.cpp): rounding to floats, the spec's ULP, the evaluation state of the thread.
// Not installed.
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/interval.hpp>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::testing::spec::impl {

constexpr double kFloatMax = FLT_MAX;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kSmallestNormal = FLT_MIN;  // 2^-126
constexpr double kPi = std::numbers::pi;

struct PathState {
  bool active = false;
  std::vector<bool> path;
  std::size_t depth = 0;
};

// The evaluation state of this thread: the rules in force, the real mode (see interval.cpp), the
// ways through undecided comparisons. One accessor (defined in interval.cpp): a thread_local
// declared extern across translation units trips GCC's null-pointer sanitizer.
struct ThreadState {
  SpecRules rules;
  bool real = false;
  PathState paths;
};
ThreadState& thread_state();

// The largest float <= v and the smallest float >= v (v a double, possibly infinite).
inline double float_down(double v) {
  if (v > kFloatMax) return v == kInf ? kInf : kFloatMax;
  if (v < -kFloatMax) return -kInf;
  float f = static_cast<float>(v);
  if (static_cast<double>(f) > v) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}
inline double float_up(double v) {
  if (v < -kFloatMax) return v == -kInf ? -kInf : -kFloatMax;
  if (v > kFloatMax) return kInf;
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

// The exact result s + e (|e| at most half a double ULP of s) rounded down or up, to floats in
// the spec mode or to doubles in the real mode.
inline double round_down(double s, double e) {
  if (!std::isfinite(s)) return s;
  if (thread_state().real) return e < 0.0 ? std::nextafter(s, -kInf) : s;
  return float_down(e < 0.0 ? std::nextafter(s, -kInf) : s);
}
inline double round_up(double s, double e) {
  if (!std::isfinite(s)) return s;
  if (thread_state().real) return e > 0.0 ? std::nextafter(s, kInf) : s;
  return float_up(e > 0.0 ? std::nextafter(s, kInf) : s);
}

// Error-free transformations in double (exact for float operands; for double operands away
// from overflow and underflow).
inline std::pair<double, double> exact_sum(double a, double b) {
  const double s = a + b;
  if (!std::isfinite(s)) return {s, 0.0};
  const double bb = s - a;
  return {s, (a - (s - bb)) + (b - bb)};
}
inline std::pair<double, double> exact_product(double a, double b) {
  const double p = a * b;
  if (!std::isfinite(p)) return {p, 0.0};
  return {p, std::fma(a, b, -p)};
}

// The spec's ulp(x): the smallest distance between two different finite floats a <= x <= b
// (at a power of two, the spacing below it), 2^104 beyond FLT_MAX.
inline double spec_ulp(double x) {
  const double ax = std::fabs(x);
  if (ax >= kFloatMax) return 0x1p104;
  if (ax < kSmallestNormal) return 0x1p-149;
  int k = 0;
  const double m = std::frexp(ax, &k);  // ax = m 2^k, m in [0.5, 1)
  const double spacing = std::ldexp(1.0, k - 24);
  return m == 0.5 && k - 1 > -126 ? spacing * 0.5 : spacing;
}

inline Interval make_hull(double lo, double hi) {
  Interval r{};
  r.lo_ = lo;
  r.hi_ = hi;
  r.count_ = 0;
  r.any_ = 0;
  return r;
}

// Floats within [lo, hi] (bounds from a double computation: a relative slack of 2^-40 absorbs
// its error), with the spec's overflow rule: a range reaching past FLT_MAX may also return
// infinity, one reaching past -FLT_MAX minus infinity.
inline Interval within(double lo, double hi) {
  if (std::isnan(lo) || std::isnan(hi)) return Interval::any();
  if (thread_state().real) return make_hull(std::nextafter(lo, -kInf), std::nextafter(hi, kInf));
  const double slack_lo = std::fabs(lo) * 0x1p-40, slack_hi = std::fabs(hi) * 0x1p-40;
  double l = lo <= -kFloatMax ? -kInf : float_up(lo - slack_lo);
  double h = hi >= kFloatMax ? kInf : float_down(hi + slack_hi);
  if (hi <= -kFloatMax) h = -kFloatMax;
  if (lo >= kFloatMax) l = kFloatMax;
  return make_hull(l, h);
}
inline bool has_denormal(double lo, double hi) {
  return (hi > 0.0 && lo < kSmallestNormal) || (lo < 0.0 && hi > -kSmallestNormal);
}

// A denormal operand or result may be flushed to zero (unless the rules say they are kept).
inline Interval flushable(Interval x) {
  if (thread_state().real || !thread_state().rules.denormals_may_flush || x.is_any()) return x;
  if (x.count_ > 0) {
    bool denormal = false;
    bool zero = false;
    for (std::size_t i = 0; i < x.count_; ++i) {
      denormal |= has_denormal(x.points_[i], x.points_[i]);
      zero |= x.points_[i] == 0.0f;
    }
    if (!denormal || zero) return x;
    if (x.count_ < Interval::kMaxCandidates) {
      x.points_[x.count_++] = 0.0f;
      x.lo_ = std::min(x.lo_, 0.0);
      x.hi_ = std::max(x.hi_, 0.0);
      return x;
    }
    x.count_ = 0;
  }
  if (has_denormal(x.lo_, x.hi_)) {
    x.lo_ = std::min(x.lo_, 0.0);
    x.hi_ = std::max(x.hi_, 0.0);
  }
  return x;
}

inline Interval from_candidates(std::vector<double> values) {
  for (const double v : values)
    if (std::isnan(v)) return Interval::any();
  std::sort(values.begin(), values.end());
  values.erase(std::unique(values.begin(), values.end()), values.end());
  if (values.size() > Interval::kMaxCandidates) return make_hull(values.front(), values.back());
  Interval r = make_hull(values.front(), values.back());
  for (const double v : values) r.points_[r.count_++] = static_cast<float>(v);
  return r;
}

inline bool precise_sets(const Interval& a, const Interval& b) {
  return !thread_state().real && thread_state().rules.precise && a.count_ > 0 && b.count_ > 0;
}

// A correctly rounded binary operation: `exact` gives the exact result as (s, e).
template <class Exact>
inline Interval rounded(const Interval& a0, const Interval& b0, Exact exact) {
  const Interval a = flushable(a0), b = flushable(b0);
  if (a.is_any() || b.is_any()) return Interval::any();
  if (precise_sets(a, b)) {
    std::vector<double> out;
    for (std::size_t i = 0; i < a.count_; ++i) {
      for (std::size_t j = 0; j < b.count_; ++j) {
        const auto [s, e] = exact(a.points_[i], b.points_[j]);
        out.push_back(round_down(s, e));
        out.push_back(round_up(s, e));
      }
    }
    return flushable(from_candidates(std::move(out)));
  }
  double lo = kInf, hi = -kInf;
  const double as[2] = {a.lo_, a.hi_}, bs[2] = {b.lo_, b.hi_};
  for (const double x : as) {
    for (const double y : bs) {
      const auto [s, e] = exact(x, y);
      if (std::isnan(s)) return Interval::any();
      lo = std::min(lo, round_down(s, e));
      hi = std::max(hi, round_up(s, e));
    }
  }
  return flushable(make_hull(lo, hi));
}

// The range of f over the corners of the box [a.lo, a.hi] x [b.lo, b.hi], for an f monotonic in
// each argument over the box (a quotient away from 0, pow for x > 0, atan2 off its cut); both
// NaN when f is NaN at a corner.
template <class F>
inline std::pair<double, double> corner_range(const Interval& a, const Interval& b, F f) {
  double lo = kInf, hi = -kInf;
  for (const double x : {a.lo_, a.hi_}) {
    for (const double y : {b.lo_, b.hi_}) {
      const double v = f(x, y);
      if (std::isnan(v)) return {v, v};
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  return {lo, hi};
}

// The spec's "inherited from a formula": anything within E of the exact value, E the largest
// distance from it of what the formula may return under the rules.
template <class Formula>
inline Interval inherited(Formula formula) {
  const Interval f = formula();
  if (thread_state().real) return f;
  if (f.is_any()) return f;
  thread_state().real = true;
  Interval t;
  try {
    t = formula();
  } catch (...) {
    thread_state().real = false;
    throw;
  }
  thread_state().real = false;
  if (t.is_any()) return Interval::any();
  const double e = std::max({t.lo_ - f.lo_, f.hi_ - t.hi_, 0.0});
  return flushable(within(t.lo_ - e, t.hi_ + e));
}

// A monotonic unary function with an error allowance `bound(x, fx)` (absolute) at each end.
template <class F, class Bound>
inline Interval monotonic(const Interval& x0, F f, Bound bound, bool increasing) {
  const Interval x = flushable(x0);
  if (x.is_any()) return x;
  const double a = f(x.lo_), b = f(x.hi_);
  if (std::isnan(a) || std::isnan(b)) return Interval::any();
  const double lo = increasing ? a : b, hi = increasing ? b : a;
  const double lo_x = increasing ? x.lo_ : x.hi_, hi_x = increasing ? x.hi_ : x.lo_;
  if (thread_state().real) return within(lo, hi);
  return flushable(within(lo - bound(lo_x, lo), hi + bound(hi_x, hi)));
}

// A piecewise-exact function (floor, abs, ...): applied to each candidate, or to the ends.
template <class F>
inline Interval exact_map(const Interval& x0, F f) {
  const Interval x = flushable(x0);
  if (x.is_any()) return x;
  if (x.count_ > 0) {
    std::vector<double> out;
    for (std::size_t i = 0; i < x.count_; ++i) out.push_back(f(x.points_[i]));
    return from_candidates(std::move(out));
  }
  return make_hull(f(x.lo_), f(x.hi_));
}

inline std::string hex(double v) {
  char text[64];
  std::snprintf(text, sizeof text, "%a", v);
  return text;
}
inline std::string dec(double v) {
  char text[64];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

inline std::uint64_t floats_between(double a, double b) {
  const auto d = ulp_distance(static_cast<float>(a), static_cast<float>(b));
  return static_cast<std::uint64_t>(d);
}

}  // namespace penumbra::testing::spec::impl
