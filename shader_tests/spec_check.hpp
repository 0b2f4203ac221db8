#pragma once

// Checks a batch of device results against the Vulkan spec's intervals for the shader's formula
// (a template reference evaluated on penumbra::testing::Interval), and the intervals against the
// independent reference: each interval must hold the exact value the independent reference
// computes (in long double), so a formula that is wrong mathematically fails on the host, and a
// device that is not within what the spec allows fails on the device. The hand-derived bound the
// test used before is audited against the interval and the audit printed:
//   [tolerance-audit] depth.linearize_depth: 40960 cases: 0 too loose ..., 12 too tight ...
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <penumbra/testing/interval.hpp>
#include <string>
#include <vector>

namespace penumbra::testing {

struct SpecCheck {
  std::string name;                                  // "depth.linearize_depth"
  std::function<double(std::size_t)> exact;          // the independent reference's value
  std::function<double(std::size_t)> old_bound;      // the hand-derived bound (absolute), or {}
                                                     // (NaN for a case it cannot be compared on)
  std::function<std::string(std::size_t)> describe;  // the case's inputs
};

// accepted[i]: spec_interval of the formula for case i; got[i]: the device's result.
// enclosures: where `accepted` holds candidate sets (SpecRules::precise), the same formula's
// hulls without `precise`, which hold the exact value (a set of rounded results need not,
// across a fract's wrap); empty: `accepted` itself.
inline ::testing::AssertionResult expect_within_spec(const SpecCheck& check,
                                                     const std::vector<Interval>& accepted,
                                                     const std::vector<float>& got,
                                                     const std::vector<Interval>& enclosures = {}) {
  const WithinResult device = compare_within(accepted, got, check.describe);
  std::string formula_errors;
  std::size_t wrong = 0;
  ToleranceAudit audit;
  for (std::size_t i = 0; i < accepted.size(); ++i) {
    const Interval& hull = enclosures.empty() ? accepted[i] : enclosures.at(i);
    if (accepted[i].is_any() || hull.is_any()) continue;
    const double x = check.exact(i);
    if (!(hull.lo() <= x && x <= hull.hi()) && !std::isnan(x)) {
      if (++wrong <= 10) {
        formula_errors += "  case " + std::to_string(i) + " (" + check.describe(i) +
                          "): exact value " + std::to_string(x) + " outside " + hull.describe() +
                          "\n";
      }
    }
    if (check.old_bound) {
      const double bound = check.old_bound(i);  // NaN: not comparable for this case
      if (!std::isnan(bound)) audit.add(x, bound, accepted[i]);
    }
  }
  if (check.old_bound) {
    std::printf("[tolerance-audit] %s: %s; widest interval %llu floats\n", check.name.c_str(),
                audit.describe().c_str(), static_cast<unsigned long long>(device.max_width));
    // PENUMBRA_TOLERANCE_AUDIT=FILE appends one CSV row per check (docs/data/intervals/).
    if (const char* path = std::getenv("PENUMBRA_TOLERANCE_AUDIT"); path != nullptr && *path) {
      if (std::FILE* f = std::fopen(path, "a")) {
        std::fprintf(f, "%s,%zu,%zu,%.4g,%.4g,%zu,%llu\n", check.name.c_str(), audit.cases,
                     audit.too_loose, audit.median_ratio(), audit.max_ratio(), audit.too_tight,
                     static_cast<unsigned long long>(audit.max_tight_floats));
        const bool failed = std::fclose(f) != 0;
        if (failed) std::fprintf(stderr, "could not write %s\n", path);
      }
    }
  }
  if (device.passed && wrong == 0) return ::testing::AssertionSuccess();
  auto failure = ::testing::AssertionFailure() << check.name << ":\n";
  if (wrong > 0) {
    failure << wrong << " intervals do not hold the independent reference's exact value (the "
            << "formula is wrong):\n"
            << formula_errors;
  }
  if (!device.passed) failure << device.report;
  return failure;
}

}  // namespace penumbra::testing
