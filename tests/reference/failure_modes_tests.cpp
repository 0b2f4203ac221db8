// Acne, leaks and the contact gap told apart, on a box standing on a plane under a hard sun 30
// degrees up: the blocker distances, the gap a known bias leaves, and acne and leaks against the
// filter's blur near shadow edges, in closed form.
#include <gtest/gtest.h>

#include <cmath>
#include <penumbra/core/error.hpp>
#include <penumbra/reference/failure_modes.hpp>

#include "reference_test_util.hpp"

namespace penumbra::reference {
namespace {

using C = ReceiverClass;
constexpr double kElevation = 0.5235987755982988;  // 30 degrees
constexpr double kTexel = 0.01;                    // world size of a texel at every receiver
constexpr double kReach = 2.0 * kTexel;            // a filter reaching 2 texels

struct BoxOnPlane {
  scene::Scene scene;
  std::unique_ptr<Tracer> tracer;
  AreaLight sun = test::sun_light({-std::cos(kElevation), std::sin(kElevation), 0.0}, 0.0);
  Receivers receivers;
  std::vector<double> x;   // each receiver's x on the plane (z = 0 for the shadow line)
  size_t clear_begin = 0;  // receivers [clear_begin, end) are far from any caster

  BoxOnPlane() {
    test::add(scene, test::quad(-10, 10, -10, 10, 0.0));
    // The unit box on the plane, x and z in [-0.5, 0.5]: light from -x, so its shadow lies on
    // +x, umbra for x in [0.5, 0.5 + 1 / tan 30deg] = [0.5, 2.232].
    test::add(scene, scene::make_box({1.0f, 1.0f, 1.0f}), test::translate({0.0, 0.5, 0.0}));
    tracer = std::make_unique<Tracer>(scene, glm::dvec3(0.0));
    std::vector<glm::dvec3> p, n;
    for (double v = 0.5005; v < 2.4; v += 0.0005) {  // the shadow line and past its far end
      p.emplace_back(v, 0.0, 0.0);
      x.push_back(v);
    }
    clear_begin = p.size();
    for (int k = 0; k < 200; ++k) {  // lit, nothing within metres
      p.emplace_back(-8.0 + 0.02 * k, 0.0, 6.0);
      x.push_back(p.back().x);
    }
    n.assign(p.size(), glm::dvec3(0, 1, 0));
    receivers = receivers_from_points(p, n, glm::dvec3(0.0));
  }
  std::vector<float> reach() const { return std::vector<float>(receivers.size(), float(kReach)); }
  std::vector<float> texels() const { return std::vector<float>(receivers.size(), float(kTexel)); }
};

constexpr double kShadowEnd = 0.5 + 1.7320508075688772;  // 1 / tan 30deg past the box's face

TEST(FailureModes, BlockerAndContactDistancesMatchTheGeometry) {
  BoxOnPlane s;
  const CasterProbe probe = probe_casters(*s.tracer, s.receivers, s.sun, s.reach(), 8, 2);
  for (size_t i = 0; i < s.clear_begin; ++i) {
    const double x = s.x[i];
    if (x < kShadowEnd - 0.01) {
      // The ray to the sun meets the box's face x = 0.5 after (x - 0.5) / cos 30deg; along the
      // plane that is x - 0.5.
      ASSERT_NEAR(probe.blocker_distance[i], (x - 0.5) / std::cos(kElevation), 2e-4) << x;
      ASSERT_NEAR(probe.contact_distance[i], x - 0.5, 2e-4) << x;
      // The plane's normal against the ray to the sun 30 degrees up.
      ASSERT_NEAR(probe.light_cosine[i], std::sin(kElevation), 1e-6) << x;
      ASSERT_EQ(probe.caster_in_reach[i], 1);
    } else if (x > kShadowEnd + 0.01) {
      ASSERT_TRUE(std::isinf(probe.blocker_distance[i])) << x;
    }
    // Within the ring's footprint of the shadow's far edge (the ring stretches by 1 / sin 30deg
    // along x on the plane): both a caster and the light are in reach.
    if (std::abs(x - kShadowEnd) < 0.5 * 2.0 * kReach) {
      ASSERT_TRUE(probe.caster_in_reach[i] && probe.light_in_reach[i]) << x;
    }
    if (x > 0.6 && x < kShadowEnd - 2.5 * kReach) {
      ASSERT_EQ(probe.light_in_reach[i], 0) << x;
    }
  }
  for (size_t i = s.clear_begin; i < s.receivers.size(); ++i) {
    ASSERT_TRUE(std::isinf(probe.blocker_distance[i]));
    ASSERT_EQ(probe.caster_in_reach[i], 0);
    ASSERT_EQ(probe.light_in_reach[i], 1);
  }
}

// A GPU whose depth bias b lets a receiver through where its blocker is nearer than b along the
// light: the lit gap on the plane is b cos 30deg wide.
TEST(FailureModes, AKnownBiasShowsAKnownContactGap) {
  BoxOnPlane s;
  const CasterProbe probe = probe_casters(*s.tracer, s.receivers, s.sun, s.reach(), 8, 2);
  const Visibility truth = s.tracer->trace(s.receivers, s.sun, {});
  const std::vector<C> classes(s.receivers.size(), C::lit);
  for (double bias : {0.0, 0.02, 0.05, 0.1}) {
    std::vector<float> v(truth.value);
    for (size_t i = 0; i < v.size(); ++i)
      if (probe.blocker_distance[i] < bias) v[i] = 1.0f;
    const FailureModes f = compute_failure_modes(v, truth, classes, probe, s.texels(), 0);
    // The gap's receivers lie evenly over [0, want) texels from the contact (one every 0.05):
    // the largest is want, the 95th percentile 0.95 want.
    const double want = bias * std::cos(kElevation) / kTexel;  // texels
    EXPECT_NEAR(f.contact_gap_max_texels, want, 0.06) << "bias " << bias;
    EXPECT_NEAR(f.contact_gap_texels, 0.95 * want, 0.06) << "bias " << bias;
    EXPECT_NEAR(f.contact_gap_world, 0.95 * want * kTexel, 0.06 * kTexel) << "bias " << bias;
    // Across the light, in the map's plane: b cos 30deg along the plane is b cos 30deg sin 30deg
    // across the light (the depth bias b along the light, seen from the side).
    EXPECT_NEAR(f.contact_gap_map_texels, 0.95 * want * std::sin(kElevation), 0.03)
        << "bias " << bias;
    EXPECT_EQ(f.leak_receivers, 0u) << "the gap is not a leak, bias " << bias;
    EXPECT_EQ(f.acne_receivers, 0u);
    EXPECT_NEAR(double(f.contact_receivers), 0.64 / 0.0005, 2.0);  // within 64 texels
    // A quarter of the umbra beyond the gap speckled lit: the shadow still starts at the gap
    // (the speckles do not touch it; they are leaks).
    for (size_t i = 0; i < v.size(); i += 4)
      if (probe.blocker_distance[i] >= bias) v[i] = 1.0f;
    const FailureModes speckled = compute_failure_modes(v, truth, classes, probe, s.texels(), 0);
    // (Speckles within seed_texels = 1 of the contact start the gap themselves.)
    EXPECT_NEAR(speckled.contact_gap_texels, want, 1.0) << "speckled, bias " << bias;
    EXPECT_GT(speckled.leak_receivers, 100u) << "the speckles are leaks, bias " << bias;
  }
}

TEST(FailureModes, AcneIsFalseShadowWithNoCasterInReachAndBlurIsNot) {
  BoxOnPlane s;
  const CasterProbe probe = probe_casters(*s.tracer, s.receivers, s.sun, s.reach(), 8, 2);
  const Visibility truth = s.tracer->trace(s.receivers, s.sun, {});
  const std::vector<C> classes(s.receivers.size(), C::lit);
  std::vector<float> v(truth.value);
  // Every tenth clear receiver darkened: acne.
  size_t acne = 0, clear = 0;
  for (size_t i = s.clear_begin; i < v.size(); ++i, ++clear)
    if ((i - s.clear_begin) % 10 == 0) {
      v[i] = 0.5f;
      ++acne;
    }
  // Lit receivers just past the shadow's far edge, within the filter's reach of it, darkened:
  // the filter's blur, not acne.
  size_t blurred = 0;
  for (size_t i = 0; i < s.clear_begin; ++i)
    if (s.x[i] > kShadowEnd + 0.002 && s.x[i] < kShadowEnd + 0.03 && truth.value[i] == 1.0f) {
      v[i] = 0.5f;
      ++blurred;
    }
  ASSERT_GT(blurred, 20u);
  std::vector<FailureMode> modes;
  const FailureModes f = compute_failure_modes(v, truth, classes, probe, s.texels(), 0, {}, &modes);
  EXPECT_EQ(f.acne_receivers, acne);
  // Clear: the 200 far receivers and those of the line beyond the ring's reach of the shadow.
  EXPECT_GE(f.clear_receivers, clear);
  EXPECT_NEAR(f.acne, double(acne) / double(f.clear_receivers), 1e-12);
  EXPECT_EQ(modes[s.clear_begin], FailureMode::acne);
  EXPECT_EQ(f.leak_receivers, 0u);
}

TEST(FailureModes, LeaksAreFalseLightDeepInTheUmbraNotAtItsEdgeOrContact) {
  BoxOnPlane s;
  const CasterProbe probe = probe_casters(*s.tracer, s.receivers, s.sun, s.reach(), 8, 2);
  const Visibility truth = s.tracer->trace(s.receivers, s.sun, {});
  const std::vector<C> classes(s.receivers.size(), C::lit);
  std::vector<float> v(truth.value);
  size_t leaks = 0, edge = 0;
  for (size_t i = 0; i < s.clear_begin; ++i) {
    if (s.x[i] > 1.2 && s.x[i] < 1.3) {  // deep in the umbra: light leaking in
      v[i] = 1.0f;
      ++leaks;
    }
    if (s.x[i] > kShadowEnd - 0.03 && s.x[i] < kShadowEnd - 0.002) {  // the far edge: blur
      v[i] = 1.0f;
      ++edge;
    }
  }
  ASSERT_GT(edge, 20u);
  std::vector<FailureMode> modes;
  const FailureModes f = compute_failure_modes(v, truth, classes, probe, s.texels(), 0, {}, &modes);
  EXPECT_EQ(f.leak_receivers, leaks);
  EXPECT_NEAR(f.leak, double(leaks) / double(s.receivers.size()), 1e-12);
  EXPECT_EQ(f.contact_gap_texels, 0.0);  // the contact itself stays dark
  EXPECT_EQ(f.acne_receivers, 0u);
}

TEST(FailureModes, NoContactSeenIsNaNAndBadInputIsNamed) {
  BoxOnPlane s;
  CasterProbe probe = probe_casters(*s.tracer, s.receivers, s.sun, s.reach(), 8, 2);
  const Visibility truth = s.tracer->trace(s.receivers, s.sun, {});
  const std::vector<C> classes(s.receivers.size(), C::lit);
  const std::vector<float> unknown(s.receivers.size(), std::nanf(""));
  const FailureModes f = compute_failure_modes(truth.value, truth, classes, probe, unknown, 0);
  EXPECT_TRUE(std::isnan(f.contact_gap_texels));
  EXPECT_EQ(f.contact_receivers, 0u);
  EXPECT_NE(f.to_json().find("\"contact_gap_texels\": null"), std::string::npos);
  EXPECT_NE(f.to_json().find("\"contact_gap_map_texels\": null"), std::string::npos);
  try {
    probe.light_cosine.pop_back();
    compute_failure_modes(truth.value, truth, classes, probe, s.texels(), 0);
    FAIL() << "a probe without a cosine per receiver must be refused";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("the caster probe's cosines"), std::string::npos)
        << e.what();
  }
  probe.light_cosine.push_back(0.5f);
  try {
    compute_failure_modes(truth.value, truth, classes, probe, std::vector<float>(3, 1.0f), 0);
    FAIL() << "a texel array of the wrong size must be refused";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("the texel sizes has 3 values"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace penumbra::reference
