// Acceptance intervals from the Vulkan specification (see include/penumbra/testing/interval.hpp).
//
// Two evaluation modes share the operators: the spec mode, whose ends are floats rounded outward
// with the spec's allowance for each operation, and the real mode, which encloses the exact
// value of a formula in doubles (rounded outward by a double ULP). The spec's "inherited from a
// formula" rule needs both: the device may return anything within E of the exact value x, E the
// largest distance from x of what the formula evaluated under the rules may return.
#include <algorithm>
#include <cmath>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/interval.hpp>
#include <string>
#include <utility>
#include <vector>

#include "interval_impl.hpp"

namespace penumbra::testing::spec {

namespace impl {
ThreadState& thread_state() {
  thread_local ThreadState s;
  return s;
}
}  // namespace impl

using namespace impl;

const SpecRules& spec_rules() {
  return thread_state().rules;
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
  if (!thread_state().real && (blo < 0x1p-126 || bhi > 0x1p126))
    return Interval::any();  // no bound stated
  const auto [lo, hi] = corner_range(a, b, [](double x, double y) { return x / y; });
  if (std::isnan(lo)) return Interval::any();
  if (thread_state().real) return within(lo, hi);
  return flushable(within(lo - 2.5 * spec_ulp(lo), hi + 2.5 * spec_ulp(hi)));
}

// ---------------------------------------------------------------------------------------------
// Comparisons: decided when the intervals do not overlap (or are the same single value)

SpecBool::operator bool() const {
  if (state_ != State::maybe) return state_ == State::yes;
  if (!thread_state().paths.active) {
    throw Error(
        "a comparison of intervals that overlap cannot be decided outside spec_interval(); "
        "wrap the reference in spec_interval([&] { ... })");
  }
  PathState& p = thread_state().paths;
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
    SpecRules rules = thread_state().rules;
    PathState paths = thread_state().paths;
    bool real = thread_state().real;
    ~Restore() {
      thread_state().rules = rules;
      thread_state().paths = std::move(paths);
      thread_state().real = real;
    }
  } restore;
  thread_state().rules = rules;
  thread_state().paths = PathState{.active = true, .path = {}, .depth = 0};
  thread_state().real = false;
  std::size_t runs = 0;
  for (;;) {
    thread_state().paths.depth = 0;
    run();
    ++runs;
    std::vector<bool>& path = thread_state().paths.path;
    path.resize(thread_state().paths.depth);
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

}  // namespace penumbra::testing::spec
