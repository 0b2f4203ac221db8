#include <charconv>
#include <cstdlib>
#include <mutex>
#include <penumbra/testing/property.hpp>
#include <random>

namespace penumbra::testing {
namespace {

std::uint64_t parse_seed(std::string_view text) {
  int base = 10;
  std::string_view digits = text;
  if (digits.size() > 2 && digits[0] == '0' && (digits[1] == 'x' || digits[1] == 'X')) {
    base = 16;
    digits.remove_prefix(2);
  }
  std::uint64_t value = 0;
  const auto [ptr, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value, base);
  if (digits.empty() || ec != std::errc() || ptr != digits.data() + digits.size()) {
    throw Error("PENUMBRA_SEED='" + std::string(text) +
                "' is not a seed: expected an unsigned 64-bit integer (decimal or 0x-hex) or "
                "'random'");
  }
  return value;
}

// One random seed per process, so every property of a run names the same one.
std::uint64_t process_random_seed() {
  static std::once_flag once;
  static std::uint64_t seed = 0;
  std::call_once(once, [] {
    std::random_device device;
    seed = (static_cast<std::uint64_t>(device()) << 32) ^ device();
    if (seed == 0) seed = kDefaultSeed;
  });
  return seed;
}

}  // namespace

SeedChoice resolve_seed(std::uint64_t requested) {
  if (requested != 0) return {requested, SeedChoice::Origin::options};
  const char* env = std::getenv("PENUMBRA_SEED");
  if (env == nullptr || *env == '\0') return {kDefaultSeed, SeedChoice::Origin::fallback};
  const std::string_view text(env);
  if (text == "random") return {process_random_seed(), SeedChoice::Origin::random};
  return {parse_seed(text), SeedChoice::Origin::environment};
}

std::string property_report(std::string_view name, const SeedChoice& seed,
                            const ComparisonResult& comparison) {
  std::string out = "property \"" + std::string(name) + "\": ";
  if (comparison.passed) {
    out += "passed " + std::to_string(comparison.cases) + " cases";
  } else {
    out += "FAILED, " + std::to_string(comparison.failing_cases) + " of " +
           std::to_string(comparison.cases) + " cases fail";
  }
  const std::string seed_text = std::to_string(seed.seed);
  switch (seed.origin) {
    case SeedChoice::Origin::options:
      out += "; seed " + seed_text + " (set by the test; every run repeats it)\n";
      break;
    case SeedChoice::Origin::environment:
      out += "; seed " + seed_text +
             " (from PENUMBRA_SEED); reproduce with PENUMBRA_SEED=" + seed_text + "\n";
      break;
    case SeedChoice::Origin::random:
      out += "; seed " + seed_text +
             " (PENUMBRA_SEED=random); reproduce with PENUMBRA_SEED=" + seed_text + "\n";
      break;
    case SeedChoice::Origin::fallback:
      out += "; seed " + seed_text + " (default); reproduce with PENUMBRA_SEED=" + seed_text + "\n";
      break;
  }
  if (!comparison.passed && comparison.cases > 0 && comparison.failing_components > 0) {
    out += "worst case " + std::to_string(comparison.worst_case);
    if (!comparison.worst_inputs.empty()) out += ": inputs " + comparison.worst_inputs;
    out += "\n  " +
           describe_component_mismatch(comparison.worst_component, comparison.worst_expected,
                                       comparison.worst_actual) +
           "\n";
  }
  out += comparison.report;
  return out;
}

::testing::AssertionResult to_assertion_result(const PropertyResult& result) {
  if (result.passed) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << result.report;
}

}  // namespace penumbra::testing
