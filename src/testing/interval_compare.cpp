// Comparing device results with spec intervals, and auditing hand-picked tolerances against them
// (include/penumbra/testing/interval.hpp).
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
