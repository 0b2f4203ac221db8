// The metrics of a visibility image against the reference, on small hand-made inputs.
#include <gtest/gtest.h>

#include <cmath>
#include <penumbra/core/error.hpp>
#include <penumbra/reference/metrics.hpp>

namespace penumbra::reference {
namespace {

using C = ReceiverClass;

Visibility ref(std::vector<float> values) {
  Visibility v;
  v.value = values;
  v.std_error.assign(values.size(), 0.01f);
  v.samples.assign(values.size(), 256);
  return v;
}

TEST(ReferenceMetrics, FalseLightAndFalseShadowAreKeptApart) {
  // Receivers 0-4 measured; 5 faces away; 6 is sky.
  const auto r = ref({0.0f, 1.0f, 0.5f, 0.0f, 1.0f, 0.0f, 0.0f});
  const std::vector<float> v{0.0f, 1.0f, 0.45f, 0.8f, 0.6f, 1.0f, 1.0f};
  const std::vector<C> c{C::lit, C::lit, C::lit, C::lit, C::lit, C::facing_away, C::none};
  const Metrics m = compute_metrics(v, r, c, false);
  EXPECT_EQ(m.receivers, 5u);
  EXPECT_EQ(m.facing_away, 1u);
  EXPECT_NEAR(m.mean_abs, (0.05 + 0.8 + 0.4) / 5.0, 1e-6);
  EXPECT_NEAR(m.rmse, std::sqrt((0.05 * 0.05 + 0.64 + 0.16) / 5.0), 1e-6);
  EXPECT_NEAR(m.p99_abs, 0.8, 1e-6);
  EXPECT_NEAR(m.false_light, 1.0 / 5.0, 1e-12);   // receiver 3 (0.8 > 0 + 0.1)
  EXPECT_NEAR(m.false_shadow, 1.0 / 5.0, 1e-12);  // receiver 4 (0.6 < 1 - 0.1)
  EXPECT_TRUE(std::isnan(m.misclassified));       // not a hard light
  EXPECT_NEAR(m.mean_abs_facing_away, 1.0, 1e-12);
  EXPECT_NEAR(m.reference_partial_fraction, 1.0 / 5.0, 1e-12);  // receiver 2 (R = 0.5)
  EXPECT_NEAR(m.reference_std_error, 0.01, 1e-6);
  EXPECT_NEAR(m.shadowed_fraction, 2.0 / 5.0, 1e-12);  // receivers 0 and 3
}

TEST(ReferenceMetrics, NonFiniteGpuValuesAreCountedNotMeasured) {
  // A NaN or inf visibility where the light reaches (a broken shader, a 0/0 in a filter) is
  // counted apart; on the sky or facing away it is not a receiver of this light.
  const auto r = ref({0.0f, 1.0f, 1.0f, 1.0f, 1.0f});
  const std::vector<float> v{0.0f, NAN, INFINITY, 1.0f, NAN};
  const std::vector<C> c{C::lit, C::lit, C::lit, C::lit, C::none};
  const Metrics m = compute_metrics(v, r, c, true);
  EXPECT_EQ(m.non_finite, 2u);
  EXPECT_EQ(m.receivers, 2u);
  EXPECT_NE(m.to_json().find("\"non_finite\": 2"), std::string::npos);
}

TEST(ReferenceMetrics, HardLightsCountMisclassifiedPixels) {
  const auto r = ref({0.0f, 1.0f, 1.0f, 0.0f});
  const std::vector<float> v{0.0f, 0.4f, 1.0f, 0.7f};
  const std::vector<C> c(4, C::lit);
  const Metrics m = compute_metrics(v, r, c, true);
  EXPECT_NEAR(m.misclassified, 0.5, 1e-12);
  const Metrics tight = compute_metrics(v, r, c, true, MetricsOptions{0.65});
  EXPECT_NEAR(tight.false_light, 0.25, 1e-12);  // 0.7 > 0 + 0.65 only
  EXPECT_NEAR(tight.false_shadow, 0.0, 1e-12);  // 0.4 is not < 1 - 0.65
}

TEST(ReferenceMetrics, TheLitWeightedMeanCountsGrazingErrorsLittle) {
  const auto r = ref({0.0f, 0.0f, 0.0f});
  const std::vector<float> v{1.0f, 0.0f, 0.0f};
  const std::vector<C> c(3, C::lit);
  const std::vector<float> grazing{0.01f, 1.0f, 1.0f}, facing{1.0f, 0.01f, 0.01f};
  EXPECT_NEAR(compute_metrics(v, r, c, false, {}, grazing).mean_abs_lit, 0.01 / 2.01, 1e-6);
  EXPECT_NEAR(compute_metrics(v, r, c, false, {}, facing).mean_abs_lit, 1.0 / 1.02, 1e-6);
  EXPECT_NEAR(compute_metrics(v, r, c, false).mean_abs, 1.0 / 3.0, 1e-6);  // unweighted
  EXPECT_EQ(compute_metrics(v, r, c, false).mean_abs_lit, 0.0);
  EXPECT_THROW(compute_metrics(v, r, c, false, {}, std::vector<float>{1.0f}), Error);
}

TEST(ReferenceMetrics, P99IsAPercentileNotTheMaximum) {
  std::vector<float> values(1000, 0.0f), v(1000, 0.0f);
  for (int i = 0; i < 1000; ++i) v[i] = float(i) / 1000.0f;
  const std::vector<C> c(1000, C::lit);
  const Metrics m = compute_metrics(v, ref(values), c, false);
  EXPECT_NEAR(m.p99_abs, 0.989, 1e-6);
}

TEST(ReferenceMetrics, NoReceiversGiveZeroesNotNaNsAndSizesAreChecked) {
  const Metrics m = compute_metrics(std::vector<float>{1.0f}, ref({0.0f}), std::vector<C>{C::none},
                                    false);
  EXPECT_EQ(m.receivers, 0u);
  EXPECT_EQ(m.mean_abs, 0.0);
  EXPECT_NE(m.to_json().find("\"receivers\": 0"), std::string::npos);
  EXPECT_THROW(compute_metrics(std::vector<float>{1.0f, 1.0f}, ref({0.0f}),
                               std::vector<C>{C::lit}, false),
               Error);
}

TEST(ReferenceMetrics, ErrorImagePaintsTooDarkBlueAndTooLightRed) {
  const std::vector<float> r{0.5f, 0.5f, 0.5f, 0.5f};
  const std::vector<float> v{0.0f, 1.0f, 0.51f, 0.0f};
  const std::vector<C> c{C::lit, C::lit, C::lit, C::facing_away};
  const std::vector<uint8_t> frame(16, 128);
  const auto img = error_image(v, r, c, frame);
  EXPECT_GT(img[2], img[0]);          // too dark: blue
  EXPECT_GT(img[4], img[6]);          // too light: red
  EXPECT_EQ(img[8], img[10]);         // within 0.02: grey
  EXPECT_EQ(img[12], img[14]);        // facing away: not painted
  EXPECT_EQ(img[3], 255);
}

}  // namespace
}  // namespace penumbra::reference
