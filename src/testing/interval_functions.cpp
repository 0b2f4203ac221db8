// GLSL.std.450 on spec intervals (include/penumbra/testing/interval.hpp): each function follows
// the precision the Vulkan spec's table gives it, in the spec mode, and encloses the exact value
// in the real mode (see interval.cpp).
#include <algorithm>
#include <cmath>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/interval.hpp>
#include <string>
#include <utility>
#include <vector>

#include "interval_impl.hpp"

namespace penumbra::testing::spec {

using namespace impl;

// ---------------------------------------------------------------------------------------------
// GLSL.std.450

Interval abs(const Interval& x) {
  if (x.is_any()) return x;
  if (x.count_ > 0 || x.lo_ >= 0.0) return exact_map(x, [](double v) { return std::fabs(v); });
  if (x.hi_ <= 0.0) return -x;
  return make_hull(0.0, std::max(-x.lo_, x.hi_));
}

Interval sign(const Interval& x) {
  const auto s = [](double v) { return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0); };
  if (x.is_any() || x.count_ > 0) return exact_map(x, s);
  std::vector<double> v{s(x.lo_), s(x.hi_)};
  if (x.lo_ < 0.0 && x.hi_ > 0.0) v.push_back(0.0);
  return from_candidates(std::move(v));
}

Interval floor(const Interval& x) {
  return exact_map(x, [](double v) { return std::floor(v); });
}
Interval ceil(const Interval& x) {
  return exact_map(x, [](double v) { return std::ceil(v); });
}
Interval trunc(const Interval& x) {
  return exact_map(x, [](double v) { return std::trunc(v); });
}

// fract(x) = x - floor(x), correctly rounded: just below an integer it may round up to 1.
Interval fract(const Interval& x0) {
  const Interval x = flushable(x0);
  if (x.is_any()) return x;
  const auto one = [](double v) {
    const auto [s, e] = exact_sum(v, -std::floor(v));
    return std::pair{round_down(s, e), round_up(s, e)};
  };
  if (x.count_ > 0) {
    std::vector<double> out;
    for (std::size_t i = 0; i < x.count_; ++i) {
      const auto [d, u] = one(x.points_[i]);
      out.push_back(d);
      out.push_back(u);
    }
    return flushable(from_candidates(std::move(out)));
  }
  if (!std::isfinite(x.lo_) || !std::isfinite(x.hi_)) return Interval::any();
  if (std::floor(x.lo_) != std::floor(x.hi_)) return make_hull(0.0, 1.0);
  return flushable(make_hull(one(x.lo_).first, one(x.hi_).second));
}

Interval min(const Interval& a, const Interval& b) {
  if (a.is_any() || b.is_any()) return Interval::any();
  if (a.count_ > 0 && b.count_ > 0) {
    std::vector<double> v;
    for (std::size_t i = 0; i < a.count_; ++i)
      for (std::size_t j = 0; j < b.count_; ++j) v.push_back(std::min(a.points_[i], b.points_[j]));
    return from_candidates(std::move(v));
  }
  return make_hull(std::min(a.lo_, b.lo_), std::min(a.hi_, b.hi_));
}
Interval max(const Interval& a, const Interval& b) {
  return -min(-a, -b);
}
Interval clamp(const Interval& x, const Interval& lo, const Interval& hi) {
  return min(max(x, lo), hi);
}

Interval step(const Interval& edge, const Interval& x) {
  const SpecBool below = x < edge;
  if (below.state() == SpecBool::State::yes) return Interval(0.0f);
  if (below.state() == SpecBool::State::no) return Interval(1.0f);
  const float both[2] = {0.0f, 1.0f};
  return Interval::of(both);
}

// mix(x, y, a): inherited from x * (1 - a) + y * a.
Interval mix(const Interval& x, const Interval& y, const Interval& a) {
  return inherited([&] { return x * (Interval(1.0f) - a) + y * a; });
}

// smoothstep: inherited from t * t * (3 - 2 t), t = clamp((x - e0) / (e1 - e0), 0, 1).
Interval smoothstep(const Interval& e0, const Interval& e1, const Interval& x) {
  return inherited([&] {
    const Interval t = clamp((x - e0) / (e1 - e0), Interval(0.0f), Interval(1.0f));
    return t * t * (Interval(3.0f) - Interval(2.0f) * t);
  });
}

// fma: inherited from OpFMul followed by OpFAdd (fused or not).
Interval fma(const Interval& a, const Interval& b, const Interval& c) {
  return inherited([&] {
    if (thread_state().rules.precise && !thread_state().real) {
      // A product and a sum, each correctly rounded, or the exact a * b + c rounded once.
      SpecRules hull_rules = thread_state().rules;
      hull_rules.precise = false;
      const SpecRules saved = std::exchange(thread_state().rules, hull_rules);
      const Interval r = a * b + c;
      thread_state().rules = saved;
      return r;
    }
    return a * b + c;
  });
}

// exp, exp2: 3 + 2 |x| ULP.
Interval exp(const Interval& x) {
  const double n = 3.0 + 2.0 * std::max(std::fabs(x.lo_), std::fabs(x.hi_));
  return monotonic(
      x, [](double v) { return std::exp(v); }, [n](double, double fx) { return n * spec_ulp(fx); },
      true);
}
Interval exp2(const Interval& x) {
  const double n = 3.0 + 2.0 * std::max(std::fabs(x.lo_), std::fabs(x.hi_));
  return monotonic(
      x, [](double v) { return std::exp2(v); }, [n](double, double fx) { return n * spec_ulp(fx); },
      true);
}

// log, log2: 3 ULP outside [0.5, 2], absolute error below 2^-21 inside; undefined below 0.
namespace {
template <class F>
Interval logarithm(const Interval& x, F f) {
  if (x.is_any() || x.lo_ < 0.0) return Interval::any();
  return monotonic(
      x, f, [](double v, double fv) { return v >= 0.5 && v <= 2.0 ? 0x1p-21 : 3.0 * spec_ulp(fv); },
      true);
}
}  // namespace
Interval log(const Interval& x) {
  return logarithm(x, [](double v) { return std::log(v); });
}
Interval log2(const Interval& x) {
  return logarithm(x, [](double v) { return std::log2(v); });
}

// inversesqrt: 2 ULP; undefined below 0.
Interval inversesqrt(const Interval& x) {
  if (x.is_any() || x.lo_ < 0.0) return Interval::any();
  return monotonic(
      x, [](double v) { return 1.0 / std::sqrt(v); },
      [](double, double fv) { return 2.0 * spec_ulp(fv); }, false);
}

// sqrt: inherited from 1.0 / inversesqrt(x).
Interval sqrt(const Interval& x) {
  if (x.is_any() || x.lo_ < 0.0) return Interval::any();
  if (thread_state().real) {
    return monotonic(
        x, [](double v) { return std::sqrt(v); }, [](double, double) { return 0.0; }, true);
  }
  return inherited([&] { return Interval(1.0f) / inversesqrt(x); });
}

// pow(x, y): inherited from exp2(y * log2(x)); undefined for x < 0, and for x = 0 with y <= 0.
Interval pow(const Interval& x, const Interval& y) {
  if (x.is_any() || y.is_any() || x.lo_ < 0.0) return Interval::any();
  if (x.lo_ <= 0.0 && y.lo_ <= 0.0) return Interval::any();
  if (thread_state().real) {
    const auto [lo, hi] = corner_range(x, y, [](double a, double b) { return std::pow(a, b); });
    return within(lo, hi);
  }
  return inherited([&] { return exp2(y * log2(x)); });
}

// sin, cos: absolute error at most 2^-11 in [-pi, pi]; outside, SpecRules::trig_abs_error_outside.
namespace {
template <class F>
Interval trig(const Interval& x0, F f, double peak_phase) {
  const Interval x = flushable(x0);
  if (x.is_any() || !std::isfinite(x.lo_) || !std::isfinite(x.hi_)) return Interval::any();
  double err = 0x1p-11;
  if (x.lo_ < -kPi || x.hi_ > kPi) {
    err = thread_state().rules.trig_abs_error_outside;
    if (std::isnan(err)) return Interval::any();
  }
  // The exact range: the ends, and every peak (f = +-1) between them.
  double lo = std::min(f(x.lo_), f(x.hi_)), hi = std::max(f(x.lo_), f(x.hi_));
  const double first = std::ceil((x.lo_ - peak_phase) / kPi);
  if (first * kPi + peak_phase <= x.hi_) {
    for (double k = first; k * kPi + peak_phase <= x.hi_ && k < first + 3; k += 1.0) {
      const double v = f(k * kPi + peak_phase);
      lo = std::min(lo, v > 0 ? lo : -1.0);
      hi = std::max(hi, v > 0 ? 1.0 : hi);
    }
  }
  if (thread_state().real) return within(lo, hi);
  return flushable(within(lo - err, hi + err));
}
}  // namespace
Interval sin(const Interval& x) {
  return trig(
      x, [](double v) { return std::sin(v); }, kPi / 2);
}
Interval cos(const Interval& x) {
  return trig(
      x, [](double v) { return std::cos(v); }, 0.0);
}
// tan: inherited from sin / cos.
Interval tan(const Interval& x) {
  if (thread_state().real) {
    const double a = std::tan(x.lo_), b = std::tan(x.hi_);
    if (std::floor(x.lo_ / kPi - 0.5) != std::floor(x.hi_ / kPi - 0.5)) return Interval::any();
    return within(std::min(a, b), std::max(a, b));
  }
  return inherited([&] { return sin(x) / cos(x); });
}

// atan, atan2: 4096 ULP.
Interval atan(const Interval& x) {
  return monotonic(
      x, [](double v) { return std::atan(v); },
      [](double, double fv) { return 4096.0 * spec_ulp(fv); }, true);
}
Interval atan(const Interval& y, const Interval& x) {
  if (x.is_any() || y.is_any()) return Interval::any();
  if (x.lo_ <= 0.0 && y.lo_ <= 0.0 && y.hi_ >= 0.0) {
    if (x.lo_ == 0.0 && x.hi_ == 0.0 && y.lo_ == 0.0 && y.hi_ == 0.0) return Interval::any();
    return thread_state().real ? within(-kPi, kPi)
                               : within(-kPi - 4096 * spec_ulp(kPi), kPi + 4096 * spec_ulp(kPi));
  }
  const auto [lo, hi] = corner_range(y, x, [](double a, double b) { return std::atan2(a, b); });
  if (thread_state().real) return within(lo, hi);
  return flushable(within(lo - 4096.0 * spec_ulp(lo), hi + 4096.0 * spec_ulp(hi)));
}
// asin, acos: inherited from atan2(x, sqrt(1 - x x)) and atan2(sqrt(1 - x x), x).
Interval asin(const Interval& x) {
  if (x.is_any() || x.lo_ < -1.0 || x.hi_ > 1.0) return Interval::any();
  if (thread_state().real) return within(std::asin(x.lo_), std::asin(x.hi_));
  return inherited([&] { return atan(x, sqrt(Interval(1.0f) - x * x)); });
}
Interval acos(const Interval& x) {
  if (x.is_any() || x.lo_ < -1.0 || x.hi_ > 1.0) return Interval::any();
  if (thread_state().real) return within(std::acos(x.hi_), std::acos(x.lo_));
  return inherited([&] { return atan(sqrt(Interval(1.0f) - x * x), x); });
}

// dot: inherited from the sum of the products, in any order of the sum.
Interval dot_of(std::span<const Interval> x, std::span<const Interval> y) {
  if (x.size() != y.size() || x.empty()) throw Error("dot: vectors of different or zero length");
  return inherited([&] {
    std::vector<Interval> terms;
    for (std::size_t i = 0; i < x.size(); ++i) terms.push_back(x[i] * y[i]);
    // Every order: add any two of the remaining terms, until one is left (n <= 4: 18 orders).
    std::function<Interval(std::vector<Interval>)> all = [&](std::vector<Interval> t) {
      if (t.size() == 1) return t[0];
      bool first = true;
      Interval out{};
      for (std::size_t i = 0; i < t.size(); ++i) {
        for (std::size_t j = i + 1; j < t.size(); ++j) {
          std::vector<Interval> next;
          for (std::size_t k = 0; k < t.size(); ++k)
            if (k != i && k != j) next.push_back(t[k]);
          next.push_back(t[i] + t[j]);
          const Interval r = all(std::move(next));
          out = first ? r : Interval::join(out, r);
          first = false;
        }
      }
      return out;
    };
    return terms.size() <= 4 ? all(terms) : [&] {
      Interval s = terms[0];
      for (std::size_t i = 1; i < terms.size(); ++i) s = s + terms[i];
      return s;
    }();
  });
}

// length: inherited from sqrt(dot(x, x)).
Interval length_of(std::span<const Interval> x) {
  return inherited([&] { return sqrt(dot_of(x, x)); });
}

}  // namespace penumbra::testing::spec
