// The ray-traced reference against closed forms (a straight edge under the sun's disk, a sphere
// in front of a sphere light, a closed box, an alpha-masked plane), its sampling, determinism,
// cache and bad input. Each closed-form check is also run against a deliberately broken light
// (a doubled radius) and must fail there: the checks can see a broken sampler.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <penumbra/core/error.hpp>
#include <penumbra/reference/reference.hpp>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "reference_test_util.hpp"

namespace penumbra::reference {
namespace {

namespace fs = std::filesystem;
using namespace test;
constexpr double kPi = std::numbers::pi;

// Every receiver within 3 of its own standard errors of the expected value.
::testing::AssertionResult within_3_sigma(const Visibility& v, const std::vector<double>& expected) {
  size_t bad = 0;
  std::string first;
  for (size_t i = 0; i < expected.size(); ++i) {
    const double e = std::abs(double(v.value[i]) - expected[i]);
    if (!(e <= 3.0 * v.std_error[i])) {
      if (bad++ == 0) {
        char b[200];
        std::snprintf(b, sizeof b, "receiver %zu: reference %.5f, closed form %.5f, 3 sigma %.5f",
                      i, v.value[i], expected[i], 3.0 * v.std_error[i]);
        first = b;
      }
    }
  }
  if (bad == 0) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << bad << " of " << expected.size() << " receivers off; first: " << first;
}

// Visible fraction of the unit disk with x >= c: the disk-segment area over pi.
double disk_fraction_right_of(double c) {
  if (c <= -1.0) return 1.0;
  if (c >= 1.0) return 0.0;
  return (std::acos(c) - c * std::sqrt(1.0 - c * c)) / kPi;
}

// Solid angle of the intersection of two spherical caps of angular radii a and b whose centres
// are g apart.
double cap_intersection(double a, double b, double g) {
  if (g >= a + b) return 0.0;
  if (g <= std::abs(a - b)) return 2.0 * kPi * (1.0 - std::cos(std::min(a, b)));
  const double ca = std::cos(a), cb = std::cos(b), cg = std::cos(g);
  const double sa = std::sin(a), sb = std::sin(b), sg = std::sin(g);
  return 2.0 * (kPi - std::acos((cg - ca * cb) / (sa * sb)) -
                ca * std::acos((cb - cg * ca) / (sg * sa)) - cb * std::acos((ca - cg * cb) / (sg * sb)));
}

TraceOptions exact_options(uint32_t samples = 4096) {
  TraceOptions o;
  o.samples = samples;
  o.adaptive = false;
  o.threads = 2;
  return o;
}

// ---- the straight edge under the sun ---------------------------------------------------------
// A half-plane occluder at height h covering x < 0 (+ offset), the sun straight above: a ground
// point at x sees the disk's part right of -x / (h tan(theta / 2)); the profile goes from 0 to
// 1 over 2 h tan(theta / 2).
struct EdgeCase {
  Receivers receivers;
  std::vector<double> expected;
};

EdgeCase straight_edge(const Tracer& tracer, glm::dvec3 world_offset, double h,
                       double diameter_degrees) {
  const double w = h * std::tan(0.5 * glm::radians(diameter_degrees));
  std::vector<glm::dvec3> points, normals;
  EdgeCase c;
  for (int i = 0; i <= 40; ++i) {
    const double x = -1.2 * w + 2.4 * w * i / 40.0;
    points.push_back(world_offset + glm::dvec3(x, 0.0, 0.37 * i / 40.0));
    normals.emplace_back(0.0, 1.0, 0.0);
    c.expected.push_back(disk_fraction_right_of(-x / w));
  }
  c.receivers = receivers_from_points(points, normals, tracer.origin());
  return c;
}

scene::Scene edge_scene(glm::dvec3 world_offset, double h) {
  scene::Scene s;
  s.name = "edge";
  add(s, quad(-100.0, 0.0, -100.0, 100.0, 0.0), translate(world_offset + glm::dvec3(0, h, 0)));
  return s;
}

TEST(ReferenceClosedForm, StraightEdgeUnderTheSunIsTheDiskSegmentFraction) {
  for (double diameter : {0.53, 2.0, 10.0}) {
    SCOPED_TRACE("angular diameter " + std::to_string(diameter));
    const Tracer tracer(edge_scene({}, 1.0), glm::dvec3(0.0));
    const auto c = straight_edge(tracer, {}, 1.0, diameter);
    const auto v = tracer.trace(c.receivers, sun_light({0, 1, 0}, diameter), exact_options());
    EXPECT_TRUE(within_3_sigma(v, c.expected));
    EXPECT_EQ(v.value.front(), 0.0f);  // in the umbra
    EXPECT_EQ(v.value.back(), 1.0f);   // fully lit
  }
}

TEST(ReferenceClosedForm, DoubledSunDiskFailsTheStraightEdgeCheck) {
  const Tracer tracer(edge_scene({}, 1.0), glm::dvec3(0.0));
  const auto c = straight_edge(tracer, {}, 1.0, 2.0);
  const auto v = tracer.trace(c.receivers, sun_light({0, 1, 0}, 4.0), exact_options());
  EXPECT_FALSE(within_3_sigma(v, c.expected));
}

TEST(ReferenceClosedForm, StraightEdgeHoldsOneHundredKilometresFromTheOrigin) {
  // The scene and the camera (the render origin) 1e5 m out on two axes.
  const glm::dvec3 far(1.0e5, 20.0, -1.0e5);
  const Tracer tracer(edge_scene(far, 0.5), far + glm::dvec3(3.0, 2.0, 4.0));
  const auto c = straight_edge(tracer, far, 0.5, 0.53);
  const auto v = tracer.trace(c.receivers, sun_light({0, 1, 0}, 0.53), exact_options());
  EXPECT_TRUE(within_3_sigma(v, c.expected));
}

// ---- a sphere in front of a sphere light -----------------------------------------------------
struct SphereCase {
  Receivers receivers;
  std::vector<double> expected;
};

constexpr double kLightHeight = 6.0, kLightRadius = 0.8, kBallHeight = 2.5, kBallRadius = 0.5;

SphereCase sphere_case(const Tracer& tracer) {
  SphereCase c;
  std::vector<glm::dvec3> points, normals;
  const glm::dvec3 light(0, kLightHeight, 0), ball(0, kBallHeight, 0);
  for (int i = 0; i <= 30; ++i) {
    const glm::dvec3 p(0.1 * i, 0.0, 0.03 * i);
    points.push_back(p);
    normals.emplace_back(0, 1, 0);
    const glm::dvec3 to_light = light - p, to_ball = ball - p;
    const double a = std::asin(kLightRadius / glm::length(to_light));
    const double b = std::asin(kBallRadius / glm::length(to_ball));
    const double g = std::acos(std::clamp(
        glm::dot(glm::normalize(to_light), glm::normalize(to_ball)), -1.0, 1.0));
    c.expected.push_back(1.0 - cap_intersection(a, b, g) / (2.0 * kPi * (1.0 - std::cos(a))));
  }
  c.receivers = receivers_from_points(points, normals, tracer.origin());
  return c;
}

scene::Scene ball_scene() {
  scene::Scene s;
  s.name = "ball";
  // Finely tessellated: its silhouette is within cos(pi / 256) of the sphere's.
  add(s, scene::make_sphere(float(kBallRadius), 256, 128), translate({0, kBallHeight, 0}));
  return s;
}

TEST(ReferenceClosedForm, SphereInFrontOfASphereLightIsTheCapIntersection) {
  const Tracer tracer(ball_scene(), glm::dvec3(1.0, 1.0, 1.0));
  const auto c = sphere_case(tracer);
  const auto v = tracer.trace(c.receivers, sphere_light({0, kLightHeight, 0}, kLightRadius),
                              exact_options());
  EXPECT_TRUE(within_3_sigma(v, c.expected));
  // The profile spans umbra to lit.
  EXPECT_LT(c.expected.front(), 0.05);
  EXPECT_EQ(c.expected.back(), 1.0);
}

TEST(ReferenceClosedForm, DoubledSphereLightFailsTheCapIntersectionCheck) {
  const Tracer tracer(ball_scene(), glm::dvec3(1.0, 1.0, 1.0));
  const auto c = sphere_case(tracer);
  const auto v = tracer.trace(c.receivers, sphere_light({0, kLightHeight, 0}, 2.0 * kLightRadius),
                              exact_options());
  EXPECT_FALSE(within_3_sigma(v, c.expected));
}

// ---- a closed box ------------------------------------------------------------------------------
TEST(ReferenceClosedForm, InsideAClosedBoxIsExactlyDark) {
  scene::Scene s;
  s.name = "box";
  add(s, scene::make_box({2.0f, 2.0f, 2.0f}), translate({0, 1, 0}));
  const Tracer tracer(s, glm::dvec3(0.0));
  std::vector<glm::dvec3> points, normals;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.9, 0.9);
  for (int i = 0; i < 500; ++i) {
    points.emplace_back(u(rng), 1.0 + u(rng), u(rng));
    normals.push_back(glm::normalize(glm::dvec3(u(rng), u(rng) + 0.01, u(rng))));
  }
  const auto r = receivers_from_points(points, normals, glm::dvec3(0.0));
  for (const auto& light : {sun_light({0.3, 1, 0.2}, 5.0), sphere_light({0, 5, 0}, 0.5),
                            sphere_light({4, 1, 0}, 0.0)}) {
    const auto v = tracer.trace(r, light, exact_options(256));
    for (size_t i = 0; i < v.value.size(); ++i) ASSERT_EQ(v.value[i], 0.0f) << "receiver " << i;
  }
}

// ---- the shadow terminator ---------------------------------------------------------------------
TEST(ReferenceTerminator, OffsetIsZeroOnFlatTrianglesAndAtCornersAndMovesOutOnCurvedOnes) {
  const std::array<glm::dvec3, 3> v{glm::dvec3(0, 0, 0), glm::dvec3(1, 0, 0), glm::dvec3(0, 0, 1)};
  const std::array<glm::dvec3, 3> flat{glm::dvec3(0, 1, 0), glm::dvec3(0, 1, 0),
                                       glm::dvec3(0, 1, 0)};
  // Normals tilted away from the centre, as on a coarse sphere.
  const glm::dvec3 centre = (v[0] + v[1] + v[2]) / 3.0;
  std::array<glm::dvec3, 3> curved;
  for (int k = 0; k < 3; ++k)
    curved[k] = glm::normalize(glm::dvec3(0, 1, 0) + 0.5 * (v[k] - centre));
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 200; ++i) {
    double a = u(rng), b = u(rng);
    if (a + b > 1.0) a = 1.0 - a, b = 1.0 - b;
    const glm::dvec3 bary(1.0 - a - b, a, b);
    const glm::dvec3 p = bary[0] * v[0] + bary[1] * v[1] + bary[2] * v[2];
    EXPECT_EQ(terminator_offset(v, flat, p, bary), glm::dvec3(0.0));
    const glm::dvec3 o = terminator_offset(v, curved, p, bary);
    EXPECT_GE(o.y, 0.0);  // out of the triangle, to the normals' side
    if (std::min({bary[0], bary[1], bary[2]}) > 0.05) {
      EXPECT_GT(o.y, 0.0);
    }
  }
  for (int k = 0; k < 3; ++k) {
    glm::dvec3 bary(0.0);
    bary[k] = 1.0;
    EXPECT_EQ(terminator_offset(v, curved, v[k], bary), glm::dvec3(0.0)) << "corner " << k;
  }
  // On an edge the opposite corner has no weight: a neighbour sharing the edge (its third
  // corner anywhere, with any normal) gives the same offset, so the surface is continuous.
  std::array<glm::dvec3, 3> w = v, wn = curved;
  w[2] = glm::dvec3(0.3, -0.2, -1.0);
  wn[2] = glm::normalize(glm::dvec3(0.2, 1.0, -0.6));
  const glm::dvec3 edge_bary(0.4, 0.6, 0.0);
  const glm::dvec3 p = 0.4 * v[0] + 0.6 * v[1];
  EXPECT_EQ(terminator_offset(v, curved, p, edge_bary), terminator_offset(w, wn, p, edge_bary));
}

// A coarse sphere (12 x 6 facets) with smooth normals under a hard sun. Receivers on its
// facets where the interpolated normal faces the sun but the facet itself faces away: the
// shading lights them, the flat triangles shadow them. `smooth` (the default) traces from the
// smooth surface and finds them lit, as on the sphere the normals describe; `geometric` keeps
// the facets' self-shadowing. A flat-shaded box gives the same either way.
TEST(ReferenceTerminator, SmoothTerminatorLightsTheSmoothSurfaceTheNormalsDescribe) {
  const scene::Mesh ball = scene::make_sphere(1.0f, 12, 6);
  scene::Scene s;
  add(s, ball, translate({0, 2, 0}));
  const glm::dvec3 to_sun = glm::normalize(glm::dvec3(1.0, 0.13, 0.21));
  std::vector<glm::dvec3> points, normals, back_points, back_normals;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.05, 0.95);
  for (size_t t = 0; t + 2 < ball.indices.size(); t += 3) {
    const auto& a = ball.vertices[ball.indices[t]];
    const auto& b = ball.vertices[ball.indices[t + 1]];
    const auto& c = ball.vertices[ball.indices[t + 2]];
    const glm::dvec3 face = glm::cross(glm::dvec3(b.position - a.position),
                                       glm::dvec3(c.position - a.position));
    if (!(glm::length(face) > 1e-9)) continue;
    const bool faces_away = glm::dot(face, to_sun) < 0.0;
    for (int i = 0; i < 100; ++i) {
      double x = u(rng), y = u(rng);
      if (x + y > 0.95) x = 0.95 - x, y = 0.95 - y;
      x = std::max(x, 0.02), y = std::max(y, 0.02);
      const double z = 1.0 - x - y;
      const glm::dvec3 n = glm::normalize(z * glm::dvec3(a.normal) + x * glm::dvec3(b.normal) +
                                          y * glm::dvec3(c.normal));
      const glm::dvec3 p = glm::dvec3(0, 2, 0) + z * glm::dvec3(a.position) +
                           x * glm::dvec3(b.position) + y * glm::dvec3(c.position);
      if (glm::dot(n, to_sun) < -0.1) {  // the far side
        back_points.push_back(p);
        back_normals.push_back(n);
      }
      if (!faces_away || glm::dot(n, to_sun) < 0.05) continue;  // not at the terminator
      points.push_back(p);
      normals.push_back(n);
    }
  }
  ASSERT_GT(points.size(), 100u);
  const Tracer tracer(s, glm::dvec3(0.0));
  const auto r = receivers_from_points(points, normals, glm::dvec3(0.0));
  TraceOptions smooth = exact_options(1), geometric = smooth;
  geometric.terminator = Terminator::geometric;
  const auto vs = tracer.trace(r, sun_light(to_sun, 0.0), smooth);
  const auto vg = tracer.trace(r, sun_light(to_sun, 0.0), geometric);
  size_t lit_smooth = 0, lit_geometric = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    lit_smooth += vs.value[i] == 1.0f;
    lit_geometric += vg.value[i] == 1.0f;
  }
  EXPECT_EQ(lit_smooth, points.size()) << "of " << points.size();
  EXPECT_EQ(lit_geometric, 0u) << "of " << points.size();

  // The far side (interpolated normal away from the sun) stays dark either way.
  ASSERT_GT(back_points.size(), 500u);
  const auto rb = receivers_from_points(back_points, back_normals, glm::dvec3(0.0));
  for (const auto& o : {smooth, geometric}) {
    const auto vb = tracer.trace(rb, sun_light(to_sun, 0.0), o);
    for (float x : vb.value) EXPECT_EQ(x, 0.0f);
  }

  // A flat-shaded box: the same bits with either model.
  scene::Scene boxes;
  add(boxes, scene::make_box({1.0f, 1.0f, 1.0f}), translate({0, 0.5, 0}));
  add(boxes, scene::make_box({0.4f, 2.0f, 0.4f}), translate({1.0, 1.0, 0.3}));
  const Tracer box_tracer(boxes, glm::dvec3(0.0));
  std::vector<glm::dvec3> ground, up;
  for (int i = 0; i < 400; ++i) {
    ground.emplace_back(-2.0 + 4.0 * u(rng), 1.0, -2.0 + 4.0 * u(rng));  // the top and around
    up.emplace_back(0, 1, 0);
  }
  const auto rg = receivers_from_points(ground, up, glm::dvec3(0.0));
  TraceOptions soft_smooth = exact_options(64), soft_geometric = soft_smooth;
  soft_geometric.terminator = Terminator::geometric;
  const auto a = box_tracer.trace(rg, sun_light({-0.6, 1.0, 0.2}, 5.0), soft_smooth);
  const auto b = box_tracer.trace(rg, sun_light({-0.6, 1.0, 0.2}, 5.0), soft_geometric);
  EXPECT_EQ(a.value, b.value);
}

// ---- an alpha-masked plane ---------------------------------------------------------------------
scene::Material stripes(float scale) {
  scene::Material m;
  m.alpha = scene::AlphaMode::masked;
  m.mask = scene::MaskPattern::stripes;
  m.mask_scale = {scale, 1.0f};
  return m;
}

TEST(ReferenceClosedForm, HardRaysThroughAMaskedPlaneFollowTheMaskAtTheHit) {
  // The plane at y = 1 over [0, 10]²: u = x / 10, 40 stripes, each 0.25 m with half cut out.
  scene::Scene s;
  add(s, quad(0, 10, 0, 10, 1.0), glm::mat4(1.0f), stripes(40.0f));
  const Tracer tracer(s, glm::dvec3(0.0));
  std::vector<glm::dvec3> points, normals;
  std::vector<double> expected;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.5, 9.5);
  for (int i = 0; i < 2000; ++i) {
    const double x = u(rng), z = u(rng);
    const double f = x / 10.0 * 40.0 - std::floor(x / 10.0 * 40.0);
    if (std::abs(f - 0.5) < 1e-4 || f < 1e-4 || f > 1 - 1e-4) continue;  // on a stripe edge
    points.emplace_back(x, 0.0, z);
    normals.emplace_back(0, 1, 0);
    expected.push_back(f < 0.5 ? 0.0 : 1.0);  // opaque half blocks the light
  }
  const auto v = tracer.trace(receivers_from_points(points, normals, glm::dvec3(0.0)),
                              sun_light({0, 1, 0}, 0.0), exact_options());
  size_t lit = 0;
  for (size_t i = 0; i < expected.size(); ++i) {
    ASSERT_EQ(double(v.value[i]), expected[i]) << "receiver at x = " << points[i].x;
    lit += v.value[i] == 1.0f;
  }
  EXPECT_GT(lit, expected.size() / 3);  // both halves are sampled
  EXPECT_LT(lit, 2 * expected.size() / 3);
}

TEST(ReferenceClosedForm, SunThroughAMaskedPlaneSeesTheMasksCoverage) {
  // The disk's footprint on the plane (radius rho = h tan(theta / 2)) spans many stripes: the
  // visible fraction is the part of that disk over cut-out stripes, integrated exactly here
  // (chord lengths over each cut-out interval).
  const double h = 1.0, diameter = 20.0;
  const double rho = h * std::tan(0.5 * glm::radians(diameter));
  const double period = 10.0 / 400.0;  // the footprint spans 14 stripes
  scene::Scene s;
  add(s, quad(-5, 5, -5, 5, h), glm::mat4(1.0f), stripes(400.0f));
  const Tracer tracer(s, glm::dvec3(0.0));
  // Area of {|x'| <= rho, x' in [a, b]} ∩ disk: ∫ 2 sqrt(rho² - x²) dx in closed form.
  const auto chord_area = [&](double a, double b) {
    a = std::clamp(a, -rho, rho);
    b = std::clamp(b, -rho, rho);
    const auto F = [&](double x) {
      return x * std::sqrt(rho * rho - x * x) + rho * rho * std::asin(x / rho);
    };
    return F(b) - F(a);
  };
  std::vector<glm::dvec3> points, normals;
  std::vector<double> expected;
  for (int i = 0; i < 24; ++i) {
    const double x0 = -0.4 + 0.8 * i / 23.0;  // receiver x; u = (x + 5) / 10
    points.emplace_back(x0, 0.0, 0.1);
    normals.emplace_back(0, 1, 0);
    double cut = 0.0;  // cut-out where fract((x + 5) / period) >= 0.5
    for (int k = -400; k <= 400; ++k) {
      const double a = -5.0 + (k + 0.5) * period, b = -5.0 + (k + 1.0) * period;
      cut += chord_area(a - x0, b - x0);
    }
    expected.push_back(cut / (kPi * rho * rho));
  }
  const auto r = receivers_from_points(points, normals, glm::dvec3(0.0));
  const auto v = tracer.trace(r, sun_light({0, 1, 0}, diameter), exact_options());
  EXPECT_TRUE(within_3_sigma(v, expected));
  for (double e : expected) EXPECT_NEAR(e, 0.5, 0.02);  // about the stripes' coverage

  // The same plane without its mask is opaque: the check sees the difference.
  scene::Scene opaque;
  add(opaque, quad(-5, 5, -5, 5, h));
  const auto blocked = Tracer(opaque, glm::dvec3(0.0)).trace(r, sun_light({0, 1, 0}, diameter),
                                                              exact_options());
  EXPECT_FALSE(within_3_sigma(blocked, expected));
}

// ---- hard lights, adaptive sampling ------------------------------------------------------------
TEST(ReferenceSampling, HardLightsTraceOneRayToTheCentre) {
  const Tracer tracer(edge_scene({}, 1.0), glm::dvec3(0.0));
  const auto c = straight_edge(tracer, {}, 1.0, 2.0);
  for (const auto& light : {sun_light({0, 1, 0}, 0.0), sphere_light({0, 50, 0}, 0.0)}) {
    const auto v = tracer.trace(c.receivers, light, exact_options());
    for (size_t i = 0; i < v.value.size(); ++i) {
      const double x = c.receivers.position[i].x;
      if (std::abs(x) < 1e-9) continue;  // on the edge itself
      const bool blocked = x < 0.0;
      EXPECT_EQ(v.value[i], blocked ? 0.0f : 1.0f) << "x = " << x;
      EXPECT_EQ(v.samples[i], 1u);
      EXPECT_EQ(v.std_error[i], 0.0f);
    }
    EXPECT_EQ(v.rays, c.receivers.size());
  }
}

TEST(ReferenceSampling, AdaptiveStopsWhereTheFirstRaysAgree) {
  const Tracer tracer(edge_scene({}, 1.0), glm::dvec3(0.0));
  const auto c = straight_edge(tracer, {}, 1.0, 2.0);
  TraceOptions o;
  o.samples = 256;
  o.initial_samples = 16;
  const auto v = tracer.trace(c.receivers, sun_light({0, 1, 0}, 2.0), o);
  size_t stopped = 0, full = 0;
  for (size_t i = 0; i < v.value.size(); ++i) {
    if (v.samples[i] == 16) {
      ++stopped;
      EXPECT_TRUE(v.value[i] == 0.0f || v.value[i] == 1.0f);
      EXPECT_FLOAT_EQ(v.std_error[i], 1.0f / 16.0f);  // one sample's worth, the floor
    } else {
      ++full;
      EXPECT_EQ(v.samples[i], 256u);
    }
  }
  EXPECT_GT(stopped, 5u);  // umbra and lit ends
  EXPECT_GT(full, 20u);    // the penumbra
}

TEST(ReferenceSampling, SobolPrefixesAreStratifiedInEachDimension) {
  for (uint64_t seed : {0ull, 1ull, 12345ull}) {
    for (uint32_t k : {4u, 8u}) {
      const uint32_t n = 1u << k;
      std::set<uint32_t> x, y;
      for (uint32_t i = 0; i < n; ++i) {
        const auto p = sobol_owen(i, seed);
        ASSERT_GE(p.x, 0.0);
        ASSERT_LT(p.x, 1.0);
        ASSERT_GE(p.y, 0.0);
        ASSERT_LT(p.y, 1.0);
        x.insert(uint32_t(p.x * n));
        y.insert(uint32_t(p.y * n));
      }
      EXPECT_EQ(x.size(), n) << "seed " << seed;  // one point in each 1/n interval
      EXPECT_EQ(y.size(), n) << "seed " << seed;
    }
  }
  EXPECT_NE(sobol_owen(3, 1).x, sobol_owen(3, 2).x);  // seeds scramble differently
}

TEST(ReferenceSampling, ConcentricMapPreservesArea) {
  // Points of a fine grid land uniformly: the fraction inside radius r is r².
  size_t inside = 0, total = 0;
  for (int i = 0; i < 200; ++i)
    for (int j = 0; j < 200; ++j) {
      const auto d = concentric_disk({(i + 0.5) / 200.0, (j + 0.5) / 200.0});
      ASSERT_LE(glm::length(d), 1.0 + 1e-12);
      inside += glm::length(d) < 0.5;
      ++total;
    }
  EXPECT_NEAR(double(inside) / double(total), 0.25, 0.005);
}

// ---- determinism and the cache ----------------------------------------------------------------
bool same_bits(const Visibility& a, const Visibility& b) {
  return a.value.size() == b.value.size() &&
         std::memcmp(a.value.data(), b.value.data(), a.value.size() * sizeof(float)) == 0 &&
         std::memcmp(a.std_error.data(), b.std_error.data(), a.value.size() * sizeof(float)) == 0 &&
         a.samples == b.samples;
}

TEST(ReferenceDeterminism, SameSeedSameBitsWhateverTheThreadCount) {
  const Tracer tracer(ball_scene(), glm::dvec3(0.0));
  const auto c = sphere_case(tracer);
  const auto light = sphere_light({0, kLightHeight, 0}, kLightRadius);
  TraceOptions one;
  one.threads = 1;
  TraceOptions two = one;
  two.threads = 2;
  const auto a = tracer.trace(c.receivers, light, one);
  EXPECT_TRUE(same_bits(a, tracer.trace(c.receivers, light, two)));
  EXPECT_TRUE(same_bits(a, tracer.trace(c.receivers, light, one)));
  TraceOptions other = one;
  other.seed = 2;
  EXPECT_FALSE(same_bits(a, tracer.trace(c.receivers, light, other)));
}

// With a shared pattern every receiver draws the same light samples, so the estimate depends on
// the receiver's position only: the same point twice (two frames' pixels on one surface point)
// gets the same value; with independent patterns their Monte Carlo noise differs.
TEST(ReferenceDeterminism, ASharedPatternGivesTheSamePointTheSameValue) {
  const Tracer tracer(ball_scene(), glm::dvec3(0.0));
  const auto c = sphere_case(tracer);
  const auto light = sphere_light({0, kLightHeight, 0}, kLightRadius);
  // Every receiver twice: [0, n) and [n, 2n) are the same points.
  Receivers twice = c.receivers;
  twice.position.insert(twice.position.end(), c.receivers.position.begin(),
                        c.receivers.position.end());
  twice.normal.insert(twice.normal.end(), c.receivers.normal.begin(), c.receivers.normal.end());
  twice.valid.insert(twice.valid.end(), c.receivers.valid.begin(), c.receivers.valid.end());
  twice.width = uint32_t(twice.position.size());
  twice.height = 1;
  const size_t n = c.receivers.size();
  auto differing = [&](const Visibility& v, size_t* partial) {
    size_t d = 0;
    *partial = 0;
    for (size_t i = 0; i < n; ++i) {
      if (v.value[i] > 0.0f && v.value[i] < 1.0f) ++*partial;
      d += v.value[i] != v.value[n + i];
    }
    return d;
  };
  TraceOptions independent;
  size_t partial = 0;
  EXPECT_GT(differing(tracer.trace(twice, light, independent), &partial), 0u);
  ASSERT_GE(partial, 8u) << "the case must have penumbra receivers";
  TraceOptions shared;
  shared.shared_pattern = true;
  const auto v = tracer.trace(twice, light, shared);
  EXPECT_EQ(differing(v, &partial), 0u);
  ASSERT_GE(partial, 8u);
  // The shared pattern is still an estimate of the same visibility.
  const auto reference = tracer.trace(c.receivers, light, independent);
  double mean = 0.0;
  for (size_t i = 0; i < n; ++i) mean += std::abs(double(v.value[i]) - reference.value[i]);
  EXPECT_LT(mean / double(n), 0.02);
  EXPECT_NE(cache_key(tracer, c.receivers, light, shared),
            cache_key(tracer, c.receivers, light, independent));
}

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() /
           ("penumbra-reference-test-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

TEST(ReferenceCache, ReturnsTheSameBitsAndMissesWhenAnyKeyPartChanges) {
  TempDir dir;
  scene::Scene s = ball_scene();
  const Tracer tracer(s, glm::dvec3(0.0));
  const auto c = sphere_case(tracer);
  const auto light = sphere_light({0, kLightHeight, 0}, kLightRadius);
  TraceOptions o;
  const auto first = trace_cached(tracer, c.receivers, light, o, dir.path);
  EXPECT_FALSE(first.from_cache);
  const auto again = trace_cached(tracer, c.receivers, light, o, dir.path);
  EXPECT_TRUE(again.from_cache);
  EXPECT_TRUE(same_bits(first, again));
  EXPECT_EQ(first.rays, again.rays);

  const uint64_t key = cache_key(tracer, c.receivers, light, o);
  std::set<uint64_t> keys{key};
  auto expect_new = [&](uint64_t k, const char* what) {
    EXPECT_TRUE(keys.insert(k).second) << what << " did not change the key";
  };
  TraceOptions seed = o;
  seed.seed = 7;
  expect_new(cache_key(tracer, c.receivers, light, seed), "the seed");
  TraceOptions samples = o;
  samples.samples = 128;
  expect_new(cache_key(tracer, c.receivers, light, samples), "the sample count");
  TraceOptions adaptive = o;
  adaptive.adaptive = false;
  expect_new(cache_key(tracer, c.receivers, light, adaptive), "adaptive sampling");
  expect_new(cache_key(tracer, c.receivers, sphere_light({0, kLightHeight, 0}, 0.7), o),
             "the light's radius");
  expect_new(cache_key(tracer, c.receivers, sphere_light({0.1, kLightHeight, 0}, kLightRadius), o),
             "the light's position");
  Receivers moved = c.receivers;
  moved.position[3].x += 1e-9;
  expect_new(cache_key(tracer, moved, light, o), "a receiver");
  scene::Scene shifted = s;
  shifted.instances[0].transform[3].x += 0.001f;
  expect_new(cache_key(Tracer(shifted, glm::dvec3(0.0)), c.receivers, light, o), "the geometry");
  scene::Scene no_casters = s;
  no_casters.instances[0].casts_shadows = false;
  expect_new(cache_key(Tracer(no_casters, glm::dvec3(0.0)), c.receivers, light, o),
             "casts_shadows");
  expect_new(cache_key(Tracer(s, glm::dvec3(0.5, 0, 0)), c.receivers, light, o), "the origin");
  // A seed change traces anew (and is then cached itself).
  EXPECT_FALSE(trace_cached(tracer, c.receivers, light, seed, dir.path).from_cache);
}

TEST(ReferenceCache, ACorruptFileIsAMissNotAResult) {
  TempDir dir;
  const Tracer tracer(ball_scene(), glm::dvec3(0.0));
  const auto c = sphere_case(tracer);
  const auto light = sphere_light({0, kLightHeight, 0}, kLightRadius);
  const auto first = trace_cached(tracer, c.receivers, light, {}, dir.path);
  ASSERT_EQ(std::distance(fs::directory_iterator(dir.path), fs::directory_iterator()), 1);
  const fs::path file = fs::directory_iterator(dir.path)->path();
  fs::resize_file(file, fs::file_size(file) / 2);  // truncated
  EXPECT_FALSE(cache_load(dir.path, cache_key(tracer, c.receivers, light, {}), c.receivers.size()));
  const auto again = trace_cached(tracer, c.receivers, light, {}, dir.path);
  EXPECT_FALSE(again.from_cache);
  EXPECT_TRUE(same_bits(first, again));
}

TEST(ReferenceCache, AnUnwritableDirectoryIsAnErrorNamingIt) {
  TempDir dir;
  fs::create_directories(dir.path);
  const fs::path blocker = dir.path / "file";
  std::ofstream(blocker) << "x";
  const Tracer tracer(ball_scene(), glm::dvec3(0.0));
  const auto c = sphere_case(tracer);
  try {
    trace_cached(tracer, c.receivers, sphere_light({0, 6, 0}, 0.5), {}, blocker / "cache");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(blocker.string()), std::string::npos) << e.what();
  }
}

// ---- bad input ---------------------------------------------------------------------------------
TEST(ReferenceBadInput, NothingCastsAndAnEmptySceneAreFullyLit) {
  scene::Scene none = ball_scene();
  none.instances[0].casts_shadows = false;
  scene::Scene empty;
  for (const scene::Scene* s : {&none, &empty}) {
    const Tracer tracer(*s, glm::dvec3(0.0));
    EXPECT_EQ(tracer.triangle_count(), 0u);
    const auto c = sphere_case(tracer);
    const auto v = tracer.trace(c.receivers, sphere_light({0, 6, 0}, 0.8), {});
    for (float x : v.value) EXPECT_EQ(x, 1.0f);
  }
}

TEST(ReferenceBadInput, NonFiniteReceiversAndVerticesAreLeftOutNotTraced) {
  scene::Scene s = edge_scene({}, 1.0);
  scene::Mesh broken = quad(0, 1, 0, 1, 2.0);
  broken.vertices[1].position.x = std::numeric_limits<float>::quiet_NaN();
  broken.vertices[2].normal = glm::vec3(std::numeric_limits<float>::quiet_NaN());
  add(s, broken);
  const Tracer tracer(s, glm::dvec3(0.0));
  EXPECT_EQ(tracer.triangle_count(), 3u);  // the broken quad keeps the triangle without vertex 1
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<glm::dvec3> points{{1, 0, 0}, {nan, 0, 0}, {-1, 0, 0}, {0.5, 0, 0.5}};
  const std::vector<glm::dvec3> normals{{0, 1, 0}, {0, 1, 0}, {0, 0, 0}, {nan, 1, 0}};
  const auto r = receivers_from_points(points, normals, glm::dvec3(0.0));
  EXPECT_EQ(r.rejected, 3u);
  const auto v = tracer.trace(r, sun_light({0, 1, 0}, 0.53), {});
  EXPECT_EQ(v.value[0], 1.0f);
  for (size_t i : {1, 2, 3}) {
    EXPECT_TRUE(std::isnan(v.value[i])) << i;
    EXPECT_EQ(v.samples[i], 0u) << i;
  }
}

TEST(ReferenceBadInput, MismatchedSizesAndMissingLightsAreClearErrors) {
  const std::vector<glm::dvec3> one{{0, 0, 0}}, two{{0, 1, 0}, {0, 1, 0}};
  EXPECT_THROW(receivers_from_points(one, two, glm::dvec3(0.0)), Error);
  const std::vector<float> depth(3);
  const std::vector<glm::vec4> normals(4);
  EXPECT_THROW(receivers_from_gbuffer(2, 2, depth, normals, glm::dmat4(1.0), glm::dmat4(1.0),
                                      glm::dvec3(0.0)),
               Error);
  scene::Scene s;
  s.name = "dark";
  try {
    area_light(s, {LightKind::spot, 2});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("spot2"), std::string::npos) << e.what();
  }
  EXPECT_THROW(area_light(s, {LightKind::sun, 0}), Error);
  const Tracer tracer(s, glm::dvec3(0.0));
  EXPECT_THROW(tracer.trace(receivers_from_points(one, one, glm::dvec3(0.0)),
                            sun_light({0, 1, 0}, 1.0), TraceOptions{0}),
               Error);
}

TEST(ReferenceBadInput, GBufferReconstructionInvertsTheProjection) {
  // A camera at the origin looking down -z with a reverse-Z projection: a pixel's depth maps
  // back to the point that projects there.
  const double n = 0.1, f = 100.0, t = std::tan(glm::radians(30.0)), aspect = 2.0;
  glm::dmat4 proj(0.0);
  proj[0][0] = 1.0 / (aspect * t);
  proj[1][1] = -1.0 / t;
  proj[2][2] = n / (f - n);
  proj[3][2] = f * n / (f - n);
  proj[2][3] = -1.0;
  const uint32_t w = 4, h = 2;
  std::vector<float> depth(w * h);
  std::vector<glm::vec4> normals(w * h, glm::vec4(0, 0, 1, 1));
  normals[1].w = 0.0f;  // sky
  const double z = -7.5;
  for (auto& d : depth) d = float((proj[2][2] * z + proj[3][2]) / -z);
  const glm::dvec3 origin(1000.0, 0.0, 0.0);
  const auto r = receivers_from_gbuffer(w, h, depth, normals, glm::dmat4(1.0), proj, origin);
  EXPECT_EQ(r.valid[1], 0);
  for (uint32_t i : {0u, 2u, 5u, 7u}) {
    ASSERT_EQ(r.valid[i], 1);
    EXPECT_NEAR(r.position[i].z, z, 1e-5 * 7.5);
    const double x_ndc = ((i % w) + 0.5) / w * 2.0 - 1.0;
    EXPECT_NEAR(r.position[i].x, x_ndc * aspect * t * 7.5, 1e-5);
    EXPECT_NEAR(glm::length(r.normal[i] - glm::dvec3(0, 0, 1)), 0.0, 1e-12);
  }
  EXPECT_EQ(r.origin, origin);
}

}  // namespace
}  // namespace penumbra::reference
