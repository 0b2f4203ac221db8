// Acceptance intervals from the Vulkan specification (see include/penumbra/testing/interval.hpp).
//
// Two evaluation modes share the operators: the spec mode, whose ends are floats rounded outward
// with the spec's allowance for each operation, and the real mode, which encloses the exact
// value of a formula in doubles (rounded outward by a double ULP). The spec's "inherited from a
// formula" rule needs both: the device may return anything within E of the exact value x, E the
// largest distance from x of what the formula evaluated under the rules may return.
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/interval.hpp>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::testing::spec {
namespace {

constexpr double kFloatMax = FLT_MAX;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kSmallestNormal = FLT_MIN;  // 2^-126
constexpr double kPi = std::numbers::pi;

struct PathState {
  bool active = false;
  std::vector<bool> path;
  std::size_t depth = 0;
};

thread_local SpecRules t_rules;
thread_local bool t_real = false;  // the real mode (see above)
thread_local PathState t_paths;

// The largest float <= v and the smallest float >= v (v a double, possibly infinite).
double float_down(double v) {
  if (v > kFloatMax) return v == kInf ? kInf : kFloatMax;
  if (v < -kFloatMax) return -kInf;
  float f = static_cast<float>(v);
  if (static_cast<double>(f) > v) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}
double float_up(double v) {
  if (v < -kFloatMax) return v == -kInf ? -kInf : -kFloatMax;
  if (v > kFloatMax) return kInf;
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

// The exact result s + e (|e| at most half a double ULP of s) rounded down or up, to floats in
// the spec mode or to doubles in the real mode.
double round_down(double s, double e) {
  if (!std::isfinite(s)) return s;
  if (t_real) return e < 0.0 ? std::nextafter(s, -kInf) : s;
  return float_down(e < 0.0 ? std::nextafter(s, -kInf) : s);
}
double round_up(double s, double e) {
  if (!std::isfinite(s)) return s;
  if (t_real) return e > 0.0 ? std::nextafter(s, kInf) : s;
  return float_up(e > 0.0 ? std::nextafter(s, kInf) : s);
}

// Error-free transformations in double (exact for float operands; for double operands away
// from overflow and underflow).
std::pair<double, double> exact_sum(double a, double b) {
  const double s = a + b;
  if (!std::isfinite(s)) return {s, 0.0};
  const double bb = s - a;
  return {s, (a - (s - bb)) + (b - bb)};
}
std::pair<double, double> exact_product(double a, double b) {
  const double p = a * b;
  if (!std::isfinite(p)) return {p, 0.0};
  return {p, std::fma(a, b, -p)};
}

// The spec's ulp(x): the smallest distance between two different finite floats a <= x <= b
// (at a power of two, the spacing below it), 2^104 beyond FLT_MAX.
double spec_ulp(double x) {
  const double ax = std::fabs(x);
  if (ax >= kFloatMax) return 0x1p104;
  if (ax < kSmallestNormal) return 0x1p-149;
  int k = 0;
  const double m = std::frexp(ax, &k);  // ax = m 2^k, m in [0.5, 1)
  const double spacing = std::ldexp(1.0, k - 24);
  return m == 0.5 && k - 1 > -126 ? spacing * 0.5 : spacing;
}

Interval make_hull(double lo, double hi) {
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
Interval within(double lo, double hi) {
  if (std::isnan(lo) || std::isnan(hi)) return Interval::any();
  if (t_real) return make_hull(std::nextafter(lo, -kInf), std::nextafter(hi, kInf));
  const double slack_lo = std::fabs(lo) * 0x1p-40, slack_hi = std::fabs(hi) * 0x1p-40;
  double l = lo <= -kFloatMax ? -kInf : float_up(lo - slack_lo);
  double h = hi >= kFloatMax ? kInf : float_down(hi + slack_hi);
  if (hi <= -kFloatMax) h = -kFloatMax;
  if (lo >= kFloatMax) l = kFloatMax;
  return make_hull(l, h);
}
bool has_denormal(double lo, double hi) {
  return (hi > 0.0 && lo < kSmallestNormal) || (lo < 0.0 && hi > -kSmallestNormal);
}

// A denormal operand or result may be flushed to zero (unless the rules say they are kept).
Interval flushable(Interval x) {
  if (t_real || !t_rules.denormals_may_flush || x.is_any()) return x;
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

Interval from_candidates(std::vector<double> values) {
  for (const double v : values)
    if (std::isnan(v)) return Interval::any();
  std::sort(values.begin(), values.end());
  values.erase(std::unique(values.begin(), values.end()), values.end());
  if (values.size() > Interval::kMaxCandidates) return make_hull(values.front(), values.back());
  Interval r = make_hull(values.front(), values.back());
  for (const double v : values) r.points_[r.count_++] = static_cast<float>(v);
  return r;
}

bool precise_sets(const Interval& a, const Interval& b) {
  return !t_real && t_rules.precise && a.count_ > 0 && b.count_ > 0;
}

// A correctly rounded binary operation: `exact` gives the exact result as (s, e).
template <class Exact>
Interval rounded(const Interval& a0, const Interval& b0, Exact exact) {
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

// The spec's "inherited from a formula": anything within E of the exact value, E the largest
// distance from it of what the formula may return under the rules.
template <class Formula>
Interval inherited(Formula formula) {
  const Interval f = formula();
  if (t_real) return f;
  if (f.is_any()) return f;
  t_real = true;
  Interval t;
  try {
    t = formula();
  } catch (...) {
    t_real = false;
    throw;
  }
  t_real = false;
  if (t.is_any()) return Interval::any();
  const double e = std::max({t.lo_ - f.lo_, f.hi_ - t.hi_, 0.0});
  return flushable(within(t.lo_ - e, t.hi_ + e));
}

// A monotonic unary function with an error allowance `bound(x, fx)` (absolute) at each end.
template <class F, class Bound>
Interval monotonic(const Interval& x0, F f, Bound bound, bool increasing) {
  const Interval x = flushable(x0);
  if (x.is_any()) return x;
  const double a = f(x.lo_), b = f(x.hi_);
  if (std::isnan(a) || std::isnan(b)) return Interval::any();
  const double lo = increasing ? a : b, hi = increasing ? b : a;
  const double lo_x = increasing ? x.lo_ : x.hi_, hi_x = increasing ? x.hi_ : x.lo_;
  if (t_real) return within(lo, hi);
  return flushable(within(lo - bound(lo_x, lo), hi + bound(hi_x, hi)));
}

// A piecewise-exact function (floor, abs, ...): applied to each candidate, or to the ends.
template <class F>
Interval exact_map(const Interval& x0, F f) {
  const Interval x = flushable(x0);
  if (x.is_any()) return x;
  if (x.count_ > 0) {
    std::vector<double> out;
    for (std::size_t i = 0; i < x.count_; ++i) out.push_back(f(x.points_[i]));
    return from_candidates(std::move(out));
  }
  return make_hull(f(x.lo_), f(x.hi_));
}

std::string hex(double v) {
  char text[64];
  std::snprintf(text, sizeof text, "%a", v);
  return text;
}
std::string dec(double v) {
  char text[64];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

std::uint64_t floats_between(double a, double b) {
  const auto d = ulp_distance(static_cast<float>(a), static_cast<float>(b));
  return static_cast<std::uint64_t>(d);
}

}  // namespace

const SpecRules& spec_rules() {
  return t_rules;
}

// ---------------------------------------------------------------------------------------------
// Construction and inspection

Interval::Interval(float v) {
  lo_ = hi_ = v;
  count_ = 1;
  any_ = 0;
  points_ = {};
  points_[0] = v;
  if (std::isnan(v)) *this = any();
}

Interval::Interval(double v) {
  points_ = {};
  any_ = 0;
  if (std::isnan(v)) {
    *this = any();
    return;
  }
  const double d = float_down(v), u = float_up(v);
  lo_ = d;
  hi_ = u;
  count_ = 0;
  points_[count_++] = static_cast<float>(d);
  if (u != d) points_[count_++] = static_cast<float>(u);
}

Interval Interval::hull(double lo, double hi) {
  return make_hull(float_down(std::min(lo, hi)), float_up(std::max(lo, hi)));
}

Interval Interval::of(std::span<const float> values) {
  std::vector<double> v(values.begin(), values.end());
  if (v.empty()) throw Error("Interval::of: no values");
  return from_candidates(std::move(v));
}

Interval Interval::any() {
  Interval r = make_hull(-kInf, kInf);
  r.any_ = 1;
  return r;
}

bool Interval::contains(float v) const {
  if (is_any()) return true;
  if (std::isnan(v)) return false;
  if (count_ > 0) {
    for (std::size_t i = 0; i < count_; ++i)
      if (points_[i] == v) return true;
    return false;
  }
  return lo_ <= v && v <= hi_;
}

double Interval::mid() const {
  if (is_any()) return std::numeric_limits<double>::quiet_NaN();
  if (std::isinf(lo_) || std::isinf(hi_)) return lo_ == hi_ ? lo_ : (std::isinf(lo_) ? hi_ : lo_);
  return 0.5 * lo_ + 0.5 * hi_;
}

std::uint64_t Interval::width_floats() const {
  if (is_any()) return std::numeric_limits<std::uint64_t>::max();
  if (count_ > 0) return count_;
  return floats_between(lo_, hi_) + 1;
}

std::string Interval::describe() const {
  if (is_any()) return "any (the spec leaves the result undefined)";
  std::string out;
  if (count_ > 0) {
    out = "{";
    for (std::size_t i = 0; i < count_; ++i) {
      if (i > 0) out += ", ";
      out += hex(points_[i]) + " (" + dec(points_[i]) + ")";
    }
    return out + "}";
  }
  return "[" + hex(lo_) + ", " + hex(hi_) + "] ([" + dec(lo_) + ", " + dec(hi_) + "], " +
         std::to_string(width_floats()) + " floats)";
}

Interval Interval::join(const Interval& a, const Interval& b) {
  if (a.is_any() || b.is_any()) return any();
  if (a.count_ > 0 && b.count_ > 0) {
    std::vector<double> v;
    for (std::size_t i = 0; i < a.count_; ++i) v.push_back(a.points_[i]);
    for (std::size_t i = 0; i < b.count_; ++i) v.push_back(b.points_[i]);
    return from_candidates(std::move(v));
  }
  return make_hull(std::min(a.lo_, b.lo_), std::max(a.hi_, b.hi_));
}

// ---------------------------------------------------------------------------------------------
// Arithmetic: + - * correctly rounded (either neighbour of the exact result), / within 2.5 ULP

Interval operator+(const Interval& a, const Interval& b) {
  return rounded(a, b, exact_sum);
}
Interval operator-(const Interval& a, const Interval& b) {
  return rounded(a, b, [](double x, double y) { return exact_sum(x, -y); });
}
Interval operator*(const Interval& a, const Interval& b) {
  return rounded(a, b, exact_product);
}
Interval operator-(const Interval& a) {
  if (a.is_any()) return a;
  Interval r = a;
  r.lo_ = -a.hi_;
  r.hi_ = -a.lo_;
  for (std::size_t i = 0; i < r.count_; ++i) r.points_[i] = -r.points_[i];
  return r;
}

Interval operator/(const Interval& a0, const Interval& b0) {
  const Interval a = flushable(a0), b = flushable(b0);
  if (a.is_any() || b.is_any()) return Interval::any();
  // A finite numerator over an infinite divisor: IEEE's signed zero.
  if (b.lo_ == b.hi_ && std::isinf(b.lo_) && std::isfinite(a.lo_) && std::isfinite(a.hi_))
    return make_hull(0.0, 0.0);
  if (b.lo_ <= 0.0 && b.hi_ >= 0.0) return Interval::any();  // a divisor that may be 0
  const double blo = std::min(std::fabs(b.lo_), std::fabs(b.hi_));
  const double bhi = std::max(std::fabs(b.lo_), std::fabs(b.hi_));
  if (!t_real && (blo < 0x1p-126 || bhi > 0x1p126)) return Interval::any();  // no bound stated
  double lo = kInf, hi = -kInf;
  for (const double x : {a.lo_, a.hi_}) {
    for (const double y : {b.lo_, b.hi_}) {
      const double q = x / y;
      if (std::isnan(q)) return Interval::any();
      lo = std::min(lo, q);
      hi = std::max(hi, q);
    }
  }
  if (t_real) return within(lo, hi);
  return flushable(within(lo - 2.5 * spec_ulp(lo), hi + 2.5 * spec_ulp(hi)));
}

// ---------------------------------------------------------------------------------------------
// Comparisons: decided when the intervals do not overlap (or are the same single value)

SpecBool::operator bool() const {
  if (state_ != State::maybe) return state_ == State::yes;
  if (!t_paths.active) {
    throw Error(
        "a comparison of intervals that overlap cannot be decided outside spec_interval(); "
        "wrap the reference in spec_interval([&] { ... })");
  }
  PathState& p = t_paths;
  if (p.depth < p.path.size()) return p.path[p.depth++];
  p.path.push_back(false);
  ++p.depth;
  return false;
}

namespace {
SpecBool decided(bool yes, bool no) {
  return SpecBool(yes ? SpecBool::State::yes : (no ? SpecBool::State::no : SpecBool::State::maybe));
}
bool single(const Interval& x) {
  return !x.is_any() && x.lo_ == x.hi_;
}
}  // namespace

SpecBool operator<(const Interval& a, const Interval& b) {
  if (a.is_any() || b.is_any()) return SpecBool(SpecBool::State::maybe);
  return decided(a.hi_ < b.lo_, a.lo_ >= b.hi_);
}
SpecBool operator>(const Interval& a, const Interval& b) {
  return b < a;
}
SpecBool operator<=(const Interval& a, const Interval& b) {
  if (a.is_any() || b.is_any()) return SpecBool(SpecBool::State::maybe);
  return decided(a.hi_ <= b.lo_, a.lo_ > b.hi_);
}
SpecBool operator>=(const Interval& a, const Interval& b) {
  return b <= a;
}
SpecBool operator==(const Interval& a, const Interval& b) {
  if (a.is_any() || b.is_any()) return SpecBool(SpecBool::State::maybe);
  return decided(single(a) && single(b) && a.lo_ == b.lo_, a.hi_ < b.lo_ || b.hi_ < a.lo_);
}
SpecBool operator!=(const Interval& a, const Interval& b) {
  return !(a == b);
}

SpecBool is_nan(const Interval& x) {
  return x.is_any() ? SpecBool(SpecBool::State::maybe) : SpecBool(false);
}
SpecBool is_finite(const Interval& x) {
  if (x.is_any()) return SpecBool(SpecBool::State::maybe);
  return decided(std::isfinite(x.lo_) && std::isfinite(x.hi_), x.lo_ == x.hi_ && std::isinf(x.lo_));
}

namespace detail {

void for_each_spec_path(const SpecRules& rules, const std::function<void()>& run) {
  struct Restore {
    SpecRules rules = t_rules;
    PathState paths = t_paths;
    bool real = t_real;
    ~Restore() {
      t_rules = rules;
      t_paths = std::move(paths);
      t_real = real;
    }
  } restore;
  t_rules = rules;
  t_paths = PathState{.active = true, .path = {}, .depth = 0};
  t_real = false;
  std::size_t runs = 0;
  for (;;) {
    t_paths.depth = 0;
    run();
    ++runs;
    std::vector<bool>& path = t_paths.path;
    path.resize(t_paths.depth);
    while (!path.empty() && path.back()) path.pop_back();
    if (path.empty()) return;
    path.back() = true;
    if (runs >= rules.max_paths) {
      throw Error("spec_interval: the reference has more than " + std::to_string(rules.max_paths) +
                  " ways through comparisons the intervals cannot decide (SpecRules::max_paths)");
    }
  }
}

}  // namespace detail

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
    if (t_rules.precise && !t_real) {
      // A product and a sum, each correctly rounded, or the exact a * b + c rounded once.
      SpecRules hull_rules = t_rules;
      hull_rules.precise = false;
      const SpecRules saved = std::exchange(t_rules, hull_rules);
      const Interval r = a * b + c;
      t_rules = saved;
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
  if (t_real) {
    return monotonic(
        x, [](double v) { return std::sqrt(v); }, [](double, double) { return 0.0; }, true);
  }
  return inherited([&] { return Interval(1.0f) / inversesqrt(x); });
}

// pow(x, y): inherited from exp2(y * log2(x)); undefined for x < 0, and for x = 0 with y <= 0.
Interval pow(const Interval& x, const Interval& y) {
  if (x.is_any() || y.is_any() || x.lo_ < 0.0) return Interval::any();
  if (x.lo_ <= 0.0 && y.lo_ <= 0.0) return Interval::any();
  if (t_real) {
    double lo = kInf, hi = -kInf;
    for (const double a : {x.lo_, x.hi_}) {
      for (const double b : {y.lo_, y.hi_}) {
        const double p = std::pow(a, b);
        lo = std::min(lo, p);
        hi = std::max(hi, p);
      }
    }
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
    err = t_rules.trig_abs_error_outside;
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
  if (t_real) return within(lo, hi);
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
  if (t_real) {
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
    return t_real ? within(-kPi, kPi)
                  : within(-kPi - 4096 * spec_ulp(kPi), kPi + 4096 * spec_ulp(kPi));
  }
  double lo = kInf, hi = -kInf;
  for (const double a : {y.lo_, y.hi_}) {
    for (const double b : {x.lo_, x.hi_}) {
      const double v = std::atan2(a, b);
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  if (t_real) return within(lo, hi);
  return flushable(within(lo - 4096.0 * spec_ulp(lo), hi + 4096.0 * spec_ulp(hi)));
}
// asin, acos: inherited from atan2(x, sqrt(1 - x x)) and atan2(sqrt(1 - x x), x).
Interval asin(const Interval& x) {
  if (x.is_any() || x.lo_ < -1.0 || x.hi_ > 1.0) return Interval::any();
  if (t_real) return within(std::asin(x.lo_), std::asin(x.hi_));
  return inherited([&] { return atan(x, sqrt(Interval(1.0f) - x * x)); });
}
Interval acos(const Interval& x) {
  if (x.is_any() || x.lo_ < -1.0 || x.hi_ > 1.0) return Interval::any();
  if (t_real) return within(std::acos(x.hi_), std::acos(x.lo_));
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

// ---------------------------------------------------------------------------------------------
// Comparing device results with intervals

namespace detail {

WithinComparer::WithinComparer(std::function<std::string(std::size_t)> describe,
                               std::size_t max_reported)
    : describe_(std::move(describe)), max_reported_(max_reported) {}

void WithinComparer::component(std::size_t /*case_index*/, const char* name,
                               const Interval& accepted, float actual) {
  if (!accepted.is_any()) result_.max_width = std::max(result_.max_width, accepted.width_floats());
  if (accepted.contains(actual)) return;
  std::uint64_t outside = std::numeric_limits<std::uint64_t>::max();
  std::string where = "not one of the candidates";
  if (!std::isnan(actual) && accepted.count_ == 0) {
    const bool above = actual > accepted.hi_;
    outside = floats_between(above ? accepted.hi_ : accepted.lo_, actual);
    where = std::to_string(outside) + (outside == 1 ? " float " : " floats ") +
            (above ? "above" : "below");
  } else if (std::isnan(actual)) {
    where = "NaN where the spec defines the result";
  } else {
    double nearest = kInf;
    for (std::size_t i = 0; i < accepted.count_; ++i)
      nearest = std::min<double>(nearest,
                                 static_cast<double>(floats_between(accepted.points_[i], actual)));
    outside = static_cast<std::uint64_t>(nearest);
    where += " (" + std::to_string(outside) + " floats from the nearest)";
  }
  result_.max_outside = std::max(result_.max_outside, outside);
  std::string line = "  ";
  if (*name != '\0') line += std::string(name) + ": ";
  line += hex(actual) + " (" + dec(actual) + ") is " + where + " " + accepted.describe() + "\n";
  case_lines_ += line;
}

void WithinComparer::end_case(std::size_t case_index) {
  ++result_.cases;
  if (case_lines_.empty()) return;
  result_.passed = false;
  ++result_.failing_cases;
  if (reported_ < max_reported_) {
    ++reported_;
    result_.report += "case " + std::to_string(case_index);
    if (describe_) result_.report += " (" + describe_(case_index) + ")";
    result_.report += ":\n" + case_lines_;
  }
  case_lines_.clear();
}

WithinResult WithinComparer::finish() {
  std::string head = std::to_string(result_.failing_cases) + " of " +
                     std::to_string(result_.cases) +
                     " cases outside the intervals the Vulkan spec allows (widest interval " +
                     std::to_string(result_.max_width) + " floats)";
  if (!result_.passed) {
    head += "; furthest outside: " + std::to_string(result_.max_outside) + " floats\n";
    if (result_.failing_cases > reported_) {
      result_.report +=
          "... and " + std::to_string(result_.failing_cases - reported_) + " more failing cases\n";
    }
  } else {
    head += "\n";
  }
  result_.report = head + result_.report;
  return result_;
}

}  // namespace detail

::testing::AssertionResult to_assertion_result(const WithinResult& result) {
  if (result.passed) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << result.report;
}

void ToleranceAudit::add(double expected, double bound, const Interval& accepted) {
  ++cases;
  if (accepted.is_any()) return;
  const double h_lo = float_up(expected - bound), h_hi = float_down(expected + bound);
  const double s_lo = accepted.lo_, s_hi = accepted.hi_;
  if (h_lo < s_lo || h_hi > s_hi) {
    ++too_loose;
    const double width = s_hi - s_lo;
    // A single allowed value: compare with the spacing of floats there.
    const double unit = width > 0.0 ? width : spec_ulp(s_lo);
    width_ratios.push_back((h_hi - h_lo) / unit);
  }
  std::uint64_t tight = 0;
  if (s_lo < h_lo) tight = std::max(tight, floats_between(s_lo, h_lo));
  if (s_hi > h_hi) tight = std::max(tight, floats_between(h_hi, s_hi));
  if (tight > 0) ++too_tight;
  max_tight_floats = std::max(max_tight_floats, tight);
}

double ToleranceAudit::median_ratio() const {
  if (width_ratios.empty()) return 0.0;
  std::vector<double> r = width_ratios;
  std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
  return r[r.size() / 2];
}
double ToleranceAudit::max_ratio() const {
  return width_ratios.empty() ? 0.0 : *std::max_element(width_ratios.begin(), width_ratios.end());
}

std::string ToleranceAudit::describe() const {
  char text[256];
  std::snprintf(text, sizeof text,
                "%zu cases: %zu too loose (its range a median %.3gx, at most %.3gx the "
                "interval's), %zu too tight (rejecting up to %llu floats the spec allows)",
                cases, too_loose, median_ratio(), max_ratio(), too_tight,
                static_cast<unsigned long long>(max_tight_floats));
  return text;
}

}  // namespace penumbra::testing::spec
