#include <gmock/gmock.h>
#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <glm/glm.hpp>
#include <optional>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/property.hpp>
#include <string>
#include <tuple>
#include <vector>

namespace {

using ::testing::HasSubstr;
using namespace penumbra::testing;

// Sets (or unsets) PENUMBRA_SEED for one test and restores it afterwards.
class ScopedSeedEnv {
 public:
  explicit ScopedSeedEnv(const char* value) {
    if (const char* old = std::getenv("PENUMBRA_SEED")) old_ = old;
    if (value) {
      setenv("PENUMBRA_SEED", value, 1);
    } else {
      unsetenv("PENUMBRA_SEED");
    }
  }
  ~ScopedSeedEnv() {
    if (old_) {
      setenv("PENUMBRA_SEED", old_->c_str(), 1);
    } else {
      unsetenv("PENUMBRA_SEED");
    }
  }

 private:
  std::optional<std::string> old_;
};

// The function under test and its reference: a lerp.
float lerp_ref(float a, float b, float t) {
  return a + (b - a) * t;
}

using LerpCase = std::tuple<float, float, float>;

// A CPU stand-in for a GPU batch: exact except that t > 0.9 is (wrongly) clamped to 0.9.
std::vector<float> buggy_lerp_batch(const std::vector<LerpCase>& cases) {
  std::vector<float> out;
  out.reserve(cases.size());
  for (const auto& [a, b, t] : cases) out.push_back(lerp_ref(a, b, t > 0.9f ? 0.9f : t));
  return out;
}

std::vector<float> good_lerp_batch(const std::vector<LerpCase>& cases) {
  std::vector<float> out;
  for (const auto& [a, b, t] : cases) out.push_back(lerp_ref(a, b, t));
  return out;
}

PropertyResult run_lerp(bool buggy, PropertyOptions options) {
  const auto ab = uniform(-10.0f, 10.0f);
  return check_property("lerp", buggy ? buggy_lerp_batch : good_lerp_batch, lerp_ref,
                        Tolerance::ulps(4, 1e-6), options, ab, ab, uniform(0.0f, 1.0f));
}

TEST(Property, CorrectBatchPasses) {
  const ScopedSeedEnv env(nullptr);
  const PropertyResult r = run_lerp(false, {.cases = 2000});
  EXPECT_TRUE(r.passed) << r.report;
  EXPECT_EQ(r.comparison.cases, 2000u);
  EXPECT_THAT(r.report, HasSubstr("property \"lerp\": passed 2000 cases; seed 12345 (default)"));
  PENUMBRA_EXPECT_PROPERTY(r);
}

TEST(Property, InjectedBugFailsAndNamesSeedAndWorstCase) {
  const ScopedSeedEnv env(nullptr);
  const PropertyResult r = run_lerp(true, {.cases = 4096, .max_reported = 3});
  ASSERT_FALSE(r.passed);
  EXPECT_EQ(r.seed.seed, kDefaultSeed);
  EXPECT_GT(r.comparison.failing_cases, 100u);
  EXPECT_THAT(r.report, HasSubstr("FAILED, "));
  EXPECT_THAT(r.report, HasSubstr("seed 12345 (default); reproduce with PENUMBRA_SEED=12345"));
  EXPECT_THAT(r.report, HasSubstr("worst case " + std::to_string(r.comparison.worst_case) +
                                  ": inputs " + r.comparison.worst_inputs));
  EXPECT_THAT(r.report, HasSubstr("more failing cases"));
  EXPECT_THAT(r.report, HasSubstr("error histogram"));

  // The worst case really is one the bug touches, and its inputs are printed as a tuple.
  Rng rng(r.seed.seed);
  const auto ab = uniform(-10.0f, 10.0f);
  const auto cases = generate_cases(rng, 4096, ab, ab, uniform(0.0f, 1.0f));
  const auto& [a, b, t] = cases[r.comparison.worst_case];
  EXPECT_GT(t, 0.9f);
  EXPECT_EQ(r.comparison.worst_inputs, format_tuple(cases[r.comparison.worst_case]));
  (void)a;
  (void)b;

  EXPECT_NONFATAL_FAILURE(PENUMBRA_EXPECT_PROPERTY(run_lerp(true, {.cases = 512})),
                          "reproduce with PENUMBRA_SEED=12345");
}

TEST(Property, SeedFromEnvironmentReproduces) {
  const ScopedSeedEnv env("4242");
  const PropertyResult first = run_lerp(true, {.cases = 1000});
  const PropertyResult again = run_lerp(true, {.cases = 1000});
  EXPECT_EQ(first.seed.seed, 4242u);
  EXPECT_THAT(first.report,
              HasSubstr("seed 4242 (from PENUMBRA_SEED); reproduce with PENUMBRA_SEED=4242"));
  EXPECT_EQ(first.report, again.report);
  const ScopedSeedEnv other("0x10");
  const PropertyResult different = run_lerp(true, {.cases = 1000});
  EXPECT_EQ(different.seed.seed, 16u);
  EXPECT_NE(first.comparison.failing_case_indices, different.comparison.failing_case_indices);
}

TEST(Property, SeedFixedByTheTestWins) {
  const ScopedSeedEnv env("4242");
  const PropertyResult r = run_lerp(true, {.cases = 100, .seed = 7});
  EXPECT_EQ(r.seed.seed, 7u);
  EXPECT_THAT(r.report, HasSubstr("seed 7 (set by the test"));
}

TEST(Property, RandomSeedIsNamed) {
  const ScopedSeedEnv env("random");
  const PropertyResult r = run_lerp(true, {.cases = 1000});
  EXPECT_EQ(r.seed.origin, SeedChoice::Origin::random);
  EXPECT_THAT(r.report, HasSubstr("reproduce with PENUMBRA_SEED=" + std::to_string(r.seed.seed)));
}

TEST(Property, MalformedSeedIsAnError) {
  const ScopedSeedEnv env("12abc");
  EXPECT_THROW(resolve_seed(0), penumbra::Error);
  try {
    resolve_seed(0);
  } catch (const penumbra::Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("PENUMBRA_SEED='12abc'"));
  }
}

TEST(Property, VectorResultsAndWrongBatchSize) {
  const ScopedSeedEnv env(nullptr);
  const auto reflect_ref = [](glm::vec3 i, glm::vec3 n) { return glm::reflect(i, n); };
  const auto batch = [&](const std::vector<std::tuple<glm::vec3, glm::vec3>>& cases) {
    std::vector<glm::vec3> out;
    for (const auto& [i, n] : cases) out.push_back(reflect_ref(i, n));
    return out;
  };
  PENUMBRA_EXPECT_PROPERTY(check_property("reflect", batch, reflect_ref, Tolerance::exact(),
                                          {.cases = 256}, unit_vector3(), unit_vector3()));

  const auto short_batch = [&](const std::vector<std::tuple<glm::vec3, glm::vec3>>& cases) {
    auto out = batch(cases);
    out.pop_back();
    return out;
  };
  const PropertyResult r = check_property("reflect", short_batch, reflect_ref, Tolerance::exact(),
                                          {.cases = 16}, unit_vector3(), unit_vector3());
  EXPECT_FALSE(r.passed);
  EXPECT_THAT(r.report, HasSubstr("size mismatch: expected 16 values, actual has 15"));
}

TEST(Property, TupleResultsNameTheirElements) {
  // A function with an out parameter comes back as a tuple (return value, out value).
  const ScopedSeedEnv env(nullptr);
  const auto ref = [](float x) { return std::make_tuple(x * 2.0f, glm::vec2(x, -x)); };
  const auto batch = [&](const std::vector<std::tuple<float>>& cases) {
    std::vector<std::tuple<float, glm::vec2>> out;
    for (const auto& [x] : cases) {
      auto r = ref(x);
      if (x > 0.5f) std::get<1>(r).y = 0.0f;  // the out parameter is wrong
      out.push_back(r);
    }
    return out;
  };
  const PropertyResult r =
      check_property("twice", batch, ref, Tolerance::ulps(1), {.cases = 200}, uniform(0.0f, 1.0f));
  EXPECT_FALSE(r.passed);
  EXPECT_EQ(r.comparison.worst_component, "#1.y");
  EXPECT_THAT(r.report, HasSubstr("  #1.y: expected -"));
}

TEST(Property, ExtremesFindNaNHandlingBugs) {
  // A "saturate" whose batch forgets that NaN must map to 0 (a reference decision).
  const ScopedSeedEnv env(nullptr);
  const auto ref = [](float x) { return x > 0.0f ? (x < 1.0f ? x : 1.0f) : 0.0f; };
  const auto batch = [](const std::vector<std::tuple<float>>& cases) {
    std::vector<float> out;
    for (const auto& [x] : cases)
      out.push_back(std::fmin(std::fmax(x, 0.0f), 1.0f) + (x != x ? x : 0.0f));
    return out;
  };
  const PropertyResult r = check_property("saturate", batch, ref, Tolerance::exact(),
                                          {.cases = 2000}, extremes_float({.nan_inf = true}));
  EXPECT_FALSE(r.passed);
  EXPECT_THAT(r.report, HasSubstr("inputs (nan)"));
  EXPECT_THAT(r.report, HasSubstr("NaN/Inf mismatch"));
}

}  // namespace
