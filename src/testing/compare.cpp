#include <algorithm>
#include <charconv>
#include <cmath>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/compare.hpp>
#include <tuple>

namespace penumbra::testing {
namespace {

constexpr std::int64_t kNoUlp = std::numeric_limits<std::int64_t>::max();
constexpr double kInf = std::numeric_limits<double>::infinity();
// Failing components listed per reported case before "... and K more".
constexpr std::size_t kMaxComponentsPerCase = 16;
constexpr std::size_t kHistogramBarWidth = 40;

std::string format_number(double value, int precision = 9) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value < 0 ? "-inf" : "inf";
  char buf[64];
  const auto result =
      std::to_chars(buf, buf + sizeof(buf), value, std::chars_format::general, precision);
  return std::string(buf, result.ptr);
}

// The error of one component pair.
struct Measure {
  double abs_error = 0.0;
  std::int64_t ulp = 0;
  bool mismatch = false;  // NaN vs number, or an infinity vs anything else
  bool floating = false;
};

template <class F>
Measure measure_floating(F e, F a) {
  Measure m;
  m.floating = true;
  const bool nan_e = std::isnan(e);
  const bool nan_a = std::isnan(a);
  if (nan_e || nan_a) {
    if (nan_e && nan_a) return m;  // NaN where NaN was expected: exact
    m.abs_error = kInf;
    m.ulp = kNoUlp;
    m.mismatch = true;
    return m;
  }
  if ((std::isinf(e) || std::isinf(a)) && e != a) {
    m.abs_error = kInf;
    m.ulp = ulp_distance(e, a);
    m.mismatch = true;
    return m;
  }
  m.abs_error = std::fabs(static_cast<double>(a) - static_cast<double>(e));
  m.ulp = ulp_distance(e, a);
  return m;
}

Measure measure(const Scalar& e, const Scalar& a) {
  if (e.kind == Scalar::Kind::f32 && a.kind == Scalar::Kind::f32) return measure_floating(e.f, a.f);
  if (e.kind == Scalar::Kind::f64 && a.kind == Scalar::Kind::f64) return measure_floating(e.d, a.d);
  if (e.is_floating() || a.is_floating()) return measure_floating(e.as_double(), a.as_double());
  Measure m;
  m.abs_error = std::fabs(a.as_double() - e.as_double());
  m.ulp = static_cast<std::int64_t>(m.abs_error);
  return m;
}

// actual moved by whole periods to the representative nearest expected (Tolerance::period);
// unchanged when the tolerance is not periodic or either value is not finite.
double nearest_representative(double period, double expected, double actual) {
  if (!(period > 0.0) || !std::isfinite(expected) || !std::isfinite(actual)) return actual;
  return actual - period * std::round((actual - expected) / period);
}

// The same for a component, in a's own type (integers and bools unchanged).
Scalar wrapped(const Tolerance& tol, const Scalar& e, const Scalar& a) {
  if (!(tol.period > 0.0) || !e.is_floating() || !a.is_floating()) return a;
  const double shifted = nearest_representative(tol.period, e.as_double(), a.as_double());
  return a.kind == Scalar::Kind::f32 ? Scalar::of(static_cast<float>(shifted))
                                     : Scalar::of(shifted);
}

bool passes(const Tolerance& tol, const Scalar& e, const Scalar& a, const Measure& m) {
  if (!m.floating) return m.abs_error == 0.0;
  if (m.mismatch) return false;
  return tol.accepts(e.as_double(), a.as_double(), m.ulp);
}

// How far outside the tolerance a component lies, in the tolerance's own units: the smallest
// of error/bound over the tolerance's modes (<= 1 passes). Exact comparisons rank by ULPs.
double excess(const Tolerance& tol, const Scalar& e, const Measure& m) {
  if (m.mismatch) return kInf;
  if (m.abs_error == 0.0 && m.ulp == 0) return 0.0;
  if (!m.floating) return kInf;
  double best = kInf;
  bool any = false;
  if (tol.abs > 0) {
    best = std::min(best, m.abs_error / tol.abs);
    any = true;
  }
  const double expected_abs = std::fabs(e.as_double());
  if (tol.rel > 0 && expected_abs > 0) {
    best = std::min(best, m.abs_error / (tol.rel * expected_abs));
    any = true;
  }
  if (tol.ulp >= 0) {
    // A bound of 0 ULP counts as half a ULP, so 1 ULP off is 2x the tolerance, not infinitely.
    const double bound = tol.ulp > 0 ? static_cast<double>(tol.ulp) : 0.5;
    best = std::min(best, static_cast<double>(m.ulp) / bound);
    any = true;
  }
  if (tol.floor > 0) {
    best = std::min(best, m.abs_error / tol.floor);
    any = true;
  }
  if (!any || std::isinf(best)) return 1.0 + static_cast<double>(m.ulp);
  return best;
}

std::string component_label(std::string_view name) {
  return name.empty() ? std::string("value") : std::string(name);
}

std::string describe_errors(const Measure& m) {
  std::string out = "abs error " + format_number(m.abs_error);
  if (!m.floating) {
    out += ", differs by " + format_number(m.abs_error, 17);
  } else if (m.ulp == kNoUlp) {
    out += ", ULP distance n/a (NaN)";
  } else {
    out += ", " + std::to_string(m.ulp) + " ULP";
  }
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Tolerance

Tolerance Tolerance::with_abs(double value) const {
  Tolerance t = *this;
  t.abs = value;
  return t;
}
Tolerance Tolerance::with_rel(double value) const {
  Tolerance t = *this;
  t.rel = value;
  return t;
}
Tolerance Tolerance::with_ulp(std::int64_t value) const {
  Tolerance t = *this;
  t.ulp = value;
  return t;
}
Tolerance Tolerance::with_floor(double value) const {
  Tolerance t = *this;
  t.floor = value;
  return t;
}

Tolerance Tolerance::modulo(double value) const {
  if (!(value > 0.0) || !std::isfinite(value))
    throw Error("Tolerance::modulo(" + format_number(value, 17) +
                "): the period must be > 0 and finite");
  Tolerance t = *this;
  t.period = value;
  return t;
}

bool Tolerance::accepts(double expected, double actual, std::int64_t ulp_dist) const {
  const bool nan_e = std::isnan(expected);
  const bool nan_a = std::isnan(actual);
  if (nan_e || nan_a) return nan_e && nan_a;
  if (std::isinf(expected) || std::isinf(actual)) return expected == actual;
  if (expected == actual) return true;
  const double d = std::fabs(actual - expected);
  return d <= abs || d <= rel * std::fabs(expected) || (ulp >= 0 && ulp_dist <= ulp) || d <= floor;
}

bool Tolerance::accepts(double expected, double actual) const {
  actual = nearest_representative(period, expected, actual);
  constexpr double kFloatMax = std::numeric_limits<float>::max();
  std::int64_t ulp_dist = kNoUlp;
  // Out-of-range doubles have no float ULP distance (and converting them would be undefined).
  if (!(std::fabs(expected) > kFloatMax) && !(std::fabs(actual) > kFloatMax)) {
    ulp_dist = ulp_distance(static_cast<float>(expected), static_cast<float>(actual));
  }
  return accepts(expected, actual, ulp_dist);
}

bool Tolerance::accepts(const Scalar& expected, const Scalar& actual) const {
  const Scalar a = wrapped(*this, expected, actual);
  const Measure m = measure(expected, a);
  return passes(*this, expected, a, m);
}

std::string Tolerance::describe() const {
  std::string out;
  const auto add = [&](const std::string& part) {
    if (!out.empty()) out += " or ";
    out += part;
  };
  if (abs > 0) add("|error| <= " + format_number(abs, 6));
  if (rel > 0) add("|error| <= " + format_number(rel, 6) + " * |expected|");
  if (ulp >= 0) add("<= " + std::to_string(ulp) + " ULP");
  if (floor > 0) add("|error| <= " + format_number(floor, 6) + " (near-zero floor)");
  if (out.empty()) out = "exact";
  if (period > 0) out += " (modulo " + format_number(period, 6) + ")";
  return out;
}

// ---------------------------------------------------------------------------------------------
// Histogram

std::size_t ErrorHistogram::bin_of(std::int64_t ulp_dist, bool nan_or_inf_mismatch) {
  if (nan_or_inf_mismatch) return 7;
  if (ulp_dist <= 0) return 0;
  if (ulp_dist <= 1) return 1;
  if (ulp_dist <= 4) return 2;
  if (ulp_dist <= 16) return 3;
  if (ulp_dist <= 256) return 4;
  if (ulp_dist <= 65536) return 5;
  return 6;
}

std::string ErrorHistogram::format() const {
  std::size_t sum = 0;
  std::size_t peak = 0;
  for (std::size_t n : total) {
    sum += n;
    peak = std::max(peak, n);
  }
  std::string out;
  for (std::size_t b = 0; b < kBins; ++b) {
    char line[128];
    const double percent =
        sum == 0 ? 0.0 : 100.0 * static_cast<double>(total[b]) / static_cast<double>(sum);
    std::snprintf(line, sizeof(line), "    %-17s %10zu %7.3f%%  ", std::string(kLabels[b]).c_str(),
                  total[b], percent);
    out += line;
    std::size_t bar = 0;
    if (total[b] > 0 && peak > 0) {
      bar = std::max<std::size_t>(1, total[b] * kHistogramBarWidth / peak);
    }
    out.append(bar, '#');
    if (failing[b] > 0) {
      out.append(kHistogramBarWidth - bar + 1, ' ');
      out += std::to_string(failing[b]) + " failing";
    }
    out += '\n';
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// BatchComparer

namespace {
thread_local std::vector<std::vector<std::string>> g_last_run_printf;
}  // namespace

void set_last_run_printf(const std::vector<std::vector<std::string>>& per_case) {
  g_last_run_printf = per_case;
}
const std::vector<std::vector<std::string>>& last_run_printf() {
  return g_last_run_printf;
}

namespace detail {

struct BatchComparer::State {
  struct Failure {
    std::string name;
    Scalar expected;
    Scalar actual;
  };

  Tolerance tol;
  DescribeInputs describe;
  std::size_t max_reported = 20;
  ComparisonResult result;

  std::vector<Failure> current;     // failing components of the current case, capped
  std::size_t current_failing = 0;  // all failing components of the current case
  std::string cases_text;           // the reported failing cases
  // Where each reported case's printf lines go in cases_text (inserted by finish() when the last
  // run printed and had as many cases as were compared).
  std::vector<std::pair<std::size_t, std::size_t>> printf_at;  // (offset, case)

  bool have_worst = false;
  bool worst_failing = false;
  double worst_score = 0.0;
  std::int64_t worst_ulp = 0;
  double worst_abs = 0.0;
  bool have_max = false;

  std::string inputs_of(std::size_t i) const { return describe ? describe(i) : std::string(); }
};

BatchComparer::BatchComparer(const Tolerance& tol, DescribeInputs describe_inputs,
                             std::size_t max_reported)
    : state_(std::make_unique<State>()) {
  state_->tol = tol;
  state_->describe = std::move(describe_inputs);
  state_->max_reported = max_reported;
}

BatchComparer::~BatchComparer() = default;

void BatchComparer::component(std::size_t case_index, std::string_view name, const Scalar& expected,
                              const Scalar& actual) {
  State& s = *state_;
  ComparisonResult& r = s.result;
  const Scalar a = wrapped(s.tol, expected, actual);
  const Measure m = measure(expected, a);
  const bool ok = passes(s.tol, expected, a, m);
  ++r.components;

  const std::size_t bin = ErrorHistogram::bin_of(m.ulp, m.mismatch);
  ++r.histogram.total[bin];
  if (!ok) ++r.histogram.failing[bin];

  if (!s.have_max || m.abs_error > r.max_abs_error) {
    r.max_abs_error = m.abs_error;
    r.max_abs_case = case_index;
    r.max_abs_component.assign(name);
  }
  if (!s.have_max || m.ulp > r.max_ulp) {
    r.max_ulp = m.ulp;
    r.max_ulp_case = case_index;
    r.max_ulp_component.assign(name);
  }
  s.have_max = true;

  const double score = excess(s.tol, expected, m);
  const auto key = std::make_tuple(!ok, score, m.ulp, m.abs_error);
  if (!s.have_worst ||
      key > std::make_tuple(s.worst_failing, s.worst_score, s.worst_ulp, s.worst_abs)) {
    s.have_worst = true;
    s.worst_failing = !ok;
    s.worst_score = score;
    s.worst_ulp = m.ulp;
    s.worst_abs = m.abs_error;
    r.worst_case = case_index;
    r.worst_component.assign(name);
    r.worst_expected = expected;
    r.worst_actual = actual;
  }

  if (!ok) {
    ++r.failing_components;
    ++s.current_failing;
    if (r.failing_cases < s.max_reported && s.current.size() < kMaxComponentsPerCase) {
      s.current.push_back({std::string(name), expected, actual});
    }
  }
}

void BatchComparer::end_case(std::size_t case_index) {
  State& s = *state_;
  ComparisonResult& r = s.result;
  ++r.cases;
  if (s.current_failing == 0) return;
  ++r.failing_cases;
  r.failing_case_indices.push_back(case_index);
  if (r.failing_cases <= s.max_reported) {
    s.cases_text += "case " + std::to_string(case_index);
    if (s.describe) s.cases_text += ": inputs " + s.describe(case_index);
    s.cases_text += '\n';
    for (const auto& f : s.current) {
      s.cases_text += "  " + describe_component_mismatch(f.name, f.expected, f.actual) + '\n';
    }
    if (s.current_failing > s.current.size()) {
      s.cases_text += "  ... and " + std::to_string(s.current_failing - s.current.size()) +
                      " more failing components in this case\n";
    }
    s.printf_at.emplace_back(s.cases_text.size(), case_index);
  }
  s.current.clear();
  s.current_failing = 0;
}

ComparisonResult BatchComparer::finish() {
  State& s = *state_;
  ComparisonResult r = std::move(s.result);
  r.passed = r.failing_components == 0;
  if (r.cases > 0) r.worst_inputs = s.inputs_of(r.worst_case);

  const auto& printed = last_run_printf();
  if (!r.passed && printed.size() == r.cases) {
    for (auto it = s.printf_at.rbegin(); it != s.printf_at.rend(); ++it) {
      const auto& lines = printed[it->second];
      std::string text;
      constexpr std::size_t kMaxLines = 16;
      for (std::size_t k = 0; k < lines.size() && k < kMaxLines; ++k)
        text += "  printf: " + lines[k] + '\n';
      if (lines.size() > kMaxLines)
        text += "  printf: ... and " + std::to_string(lines.size() - kMaxLines) + " more lines\n";
      s.cases_text.insert(it->first, text);
    }
  }
  std::string& out = r.report;
  if (r.passed) {
    out += "passed: " + std::to_string(r.cases) + " cases (" + std::to_string(r.components) +
           " components) within tolerance: " + s.tol.describe() + '\n';
  } else {
    out += "FAILED: " + std::to_string(r.failing_cases) + " of " + std::to_string(r.cases) +
           " cases fail (" + std::to_string(r.failing_components) + " of " +
           std::to_string(r.components) + " components), tolerance: " + s.tol.describe() + '\n';
    out += s.cases_text;
    if (r.failing_cases > s.max_reported) {
      out += "... and " + std::to_string(r.failing_cases - s.max_reported) +
             " more failing cases (" + std::to_string(r.failing_cases) + " total)\n";
    }
  }
  if (r.cases == 0) return r;

  const auto where = [&](std::size_t case_index, const std::string& component) {
    std::string text = "case " + std::to_string(case_index);
    if (!component.empty()) text += ", component " + component;
    if (s.describe) text += ", inputs " + s.inputs_of(case_index);
    return text;
  };
  out += "summary:\n";
  out += r.passed ? "  closest to the tolerance: " : "  worst: ";
  out += where(r.worst_case, r.worst_component) + "\n    " +
         describe_component_mismatch(r.worst_component, r.worst_expected, r.worst_actual) + '\n';
  out += "  max abs error: " + format_number(r.max_abs_error);
  if (r.max_abs_error > 0) out += " at " + where(r.max_abs_case, r.max_abs_component);
  out += '\n';
  out += "  max ULP distance: " +
         (r.max_ulp == kNoUlp ? std::string("n/a (NaN mismatch)") : std::to_string(r.max_ulp));
  if (r.max_ulp > 0) out += " at " + where(r.max_ulp_case, r.max_ulp_component);
  out += '\n';
  out += "  error histogram over " + std::to_string(r.components) + " components:\n";
  out += r.histogram.format();
  return r;
}

ComparisonResult BatchComparer::size_mismatch(std::size_t expected_size, std::size_t actual_size) {
  ComparisonResult r;
  r.passed = false;
  r.cases = std::max(expected_size, actual_size);
  r.report = "FAILED: size mismatch: expected " + std::to_string(expected_size) +
             " values, actual has " + std::to_string(actual_size) + '\n';
  return r;
}

}  // namespace detail

std::string describe_component_mismatch(std::string_view name, const Scalar& expected,
                                        const Scalar& actual) {
  const Measure m = measure(expected, actual);
  return component_label(name) + ": expected " + format_scalar(expected) + ", actual " +
         format_scalar(actual) + ", " + describe_errors(m);
}

::testing::AssertionResult to_assertion_result(const ComparisonResult& result) {
  if (result.passed) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << result.report;
}

}  // namespace penumbra::testing
