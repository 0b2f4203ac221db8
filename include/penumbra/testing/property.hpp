#pragma once

// Property tests: N seeded random cases, one batch run, compared with a C++ reference.
//
//   PENUMBRA_EXPECT_PROPERTY(check_property(
//       "saturate", [&](const auto& cases) { return shader_fn.run(cases); },  // the batch
//       [](float x) { return std::clamp(x, 0.0f, 1.0f); },                   // the reference
//       Tolerance::exact(), {.cases = 10000},
//       mix(extremes_float(), 0.3, uniform(-2.0f, 2.0f))));                   // one per argument
//
// The argument types are the generators' result types; the result type is the reference's.
// The seed is the options' seed if non-zero, else PENUMBRA_SEED from the environment (a decimal
// or 0x-hex number, or "random" for a fresh one per process), else kDefaultSeed. A report names
// the seed and how to reproduce the run, then the worst case, then the comparison report.

#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/values.hpp>
#include <string>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

namespace penumbra::testing {

struct PropertyOptions {
  std::size_t cases = 4096;
  std::uint64_t seed = 0;  // 0: PENUMBRA_SEED, else kDefaultSeed
  std::size_t max_reported = 20;
};

struct SeedChoice {
  std::uint64_t seed = kDefaultSeed;
  enum class Origin { options, environment, random, fallback } origin = Origin::fallback;
};

// Picks the seed as described above. Throws penumbra::Error for a malformed PENUMBRA_SEED.
SeedChoice resolve_seed(std::uint64_t requested);

struct PropertyResult {
  std::string name;
  SeedChoice seed;
  bool passed = false;
  ComparisonResult comparison;
  std::string report;

  explicit operator bool() const { return passed; }
};

// Builds PropertyResult::report from the comparison.
std::string property_report(std::string_view name, const SeedChoice& seed,
                            const ComparisonResult& comparison);

// run_batch: (const std::vector<std::tuple<Args...>>&) -> std::vector<R>, one result per case.
// reference: (const Args&...) -> R.
// gens: one generator per argument; Args are their result types.
template <class BatchFn, class RefFn, Generator... Gens>
PropertyResult check_property(std::string_view name, BatchFn&& run_batch, RefFn&& reference,
                              const Tolerance& tol, const PropertyOptions& options,
                              const Gens&... gens) {
  static_assert(sizeof...(Gens) > 0, "check_property: give one generator per argument");
  using Case = std::tuple<generator_result_t<Gens>...>;
  using R = std::remove_cvref_t<std::invoke_result_t<RefFn&, const generator_result_t<Gens>&...>>;
  static_assert(HasComponents<R>, "check_property: the reference's result type has no Components");
  using BatchResult = std::remove_cvref_t<std::invoke_result_t<BatchFn&, const std::vector<Case>&>>;
  static_assert(std::is_convertible_v<BatchResult, std::vector<R>>,
                "check_property: the batch must return std::vector<R>, R the reference's result");

  PropertyResult result;
  result.name = std::string(name);
  result.seed = resolve_seed(options.seed);
  Rng rng(result.seed.seed);
  const std::vector<Case> cases = generate_cases(rng, options.cases, gens...);

  std::vector<R> expected;
  expected.reserve(cases.size());
  for (const Case& c : cases) expected.push_back(std::apply(reference, c));
  const std::vector<R> actual = run_batch(cases);

  result.comparison = compare_batch(
      expected, actual, tol, [&cases](std::size_t i) { return format_tuple(cases[i]); },
      options.max_reported);
  result.passed = result.comparison.passed;
  result.report = property_report(name, result.seed, result.comparison);
  return result;
}

::testing::AssertionResult to_assertion_result(const PropertyResult& result);

}  // namespace penumbra::testing

// PENUMBRA_EXPECT_PROPERTY(check_property(...)): a non-fatal failure carrying the report.
#define PENUMBRA_EXPECT_PROPERTY(...) \
  GTEST_ASSERT_(::penumbra::testing::to_assertion_result(__VA_ARGS__), GTEST_NONFATAL_FAILURE_)
#define PENUMBRA_ASSERT_PROPERTY(...) \
  GTEST_ASSERT_(::penumbra::testing::to_assertion_result(__VA_ARGS__), GTEST_FATAL_FAILURE_)
