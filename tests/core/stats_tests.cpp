#include <gtest/gtest.h>

#include <cmath>
#include <penumbra/core/stats.hpp>
#include <vector>

namespace {

using penumbra::stats::fit_line;
using penumbra::stats::median;

TEST(Stats, MedianOfOddEvenAndEmpty) {
  EXPECT_EQ(median({3.0, 1.0, 2.0}), 2.0);
  EXPECT_EQ(median({4.0, 1.0, 3.0, 2.0}), 2.5);
  EXPECT_TRUE(std::isnan(median({})));
}

TEST(Stats, QuantilesInterpolateBetweenOrderStatistics) {
  EXPECT_EQ(penumbra::stats::quantile({4.0, 1.0, 3.0, 2.0}, 0.0), 1.0);
  EXPECT_EQ(penumbra::stats::quantile({4.0, 1.0, 3.0, 2.0}, 1.0), 4.0);
  EXPECT_DOUBLE_EQ(penumbra::stats::quantile({4.0, 1.0, 3.0, 2.0}, 0.5), 2.5);
  EXPECT_DOUBLE_EQ(penumbra::stats::quantile({0.0, 10.0}, 0.95), 9.5);
  EXPECT_TRUE(std::isnan(penumbra::stats::quantile({}, 0.5)));
  EXPECT_TRUE(std::isnan(penumbra::stats::quantile({1.0}, 1.5)));
}

TEST(Stats, AnExactLineHasZeroErrorAndIsSignificant) {
  const std::vector<double> x{1, 4, 9, 16, 25, 36, 49, 64};
  std::vector<double> y;
  for (double v : x) y.push_back(0.5 + 0.02 * v);
  const auto f = fit_line(x, y);
  EXPECT_NEAR(f.slope, 0.02, 1e-12);
  EXPECT_NEAR(f.intercept, 0.5, 1e-12);
  EXPECT_NEAR(f.slope_stderr, 0.0, 1e-12);
  EXPECT_TRUE(f.significantly_positive());
}

TEST(Stats, SlopeStandardErrorMatchesTheClosedForm) {
  // y = x + e with residuals +-1 alternating: x = 0..3, y = 1, 0, 3, 2. Least squares gives
  // slope 0.6, intercept 0.6; residuals 0.4, -1.2, 1.2, -0.4: SSR = 3.2, Sxx = 5,
  // stderr = sqrt(3.2 / 2 / 5) = 0.565685...
  const auto f = fit_line({0, 1, 2, 3}, {1, 0, 3, 2});
  EXPECT_NEAR(f.slope, 0.6, 1e-12);
  EXPECT_NEAR(f.intercept, 0.6, 1e-12);
  EXPECT_NEAR(f.slope_stderr, std::sqrt(0.32), 1e-12);
  EXPECT_FALSE(f.significantly_positive());  // t = 1.06
  EXPECT_TRUE(f.significantly_positive(1.0));
}

// The timings of a busy lavapipe (a run where the fit came out negative): the per-fetch cost is
// buried in noise, so there is no rate to report.
TEST(Stats, NoiseThatHidesTheSlopeIsNotARate) {
  const std::vector<double> fetches{1, 4, 9, 16, 25, 36, 49, 64};
  const std::vector<double> ms{41.0, 55.2, 38.9, 47.7, 60.1, 36.5, 44.0, 39.8};
  const auto f = fit_line(fetches, ms);
  EXPECT_LT(f.slope, 0.0);
  EXPECT_FALSE(f.significantly_positive());
  // A clear cost over the same noise is one.
  std::vector<double> clear;
  for (size_t i = 0; i < ms.size(); ++i) clear.push_back(ms[i] + 2.0 * fetches[i]);
  EXPECT_TRUE(fit_line(fetches, clear).significantly_positive());
}

TEST(Stats, DegenerateInputsGiveNoFit) {
  EXPECT_TRUE(std::isnan(fit_line({1}, {2}).slope));
  EXPECT_TRUE(std::isnan(fit_line({2, 2, 2}, {1, 2, 3}).slope));
  const auto two = fit_line({0, 1}, {0, 1});
  EXPECT_EQ(two.slope, 1.0);
  EXPECT_TRUE(std::isnan(two.slope_stderr));
  EXPECT_FALSE(two.significantly_positive());
}

}  // namespace
