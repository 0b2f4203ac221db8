// Function-level tests of shaders/penumbra/contact_shadows.glsl against the independent C++
// reference in reference/contact_ref.hpp: every pure piece of the march on its own, then the
// composed contact_shadow() on random block scenes, both depth conventions, finite and infinite
// far planes.
//
// Tolerances: the GPU evaluates in float (Vulkan: +, -, * correctly rounded in either direction,
// division 2.5 ULP), the reference in double. A chain of k such operations is within about
// k * 2^-23 relative; the bounds below allow a few times that. Decisions (step counts, which
// texel a tap reads, which side of the tolerance window a depth falls) are compared exactly
// except where the reference calls them marginal (see contact_ref.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <random>
#include <sstream>
#include <tuple>
#include <vector>

#include "reference/contact_ref.hpp"

// The GLSL parameter block, mirrored for the harness (which checks this layout against SPIR-V
// reflection of the wrapper). penumbra::render::ContactShadowGpu is the product's mirror; the
// render tests check that one.
struct ContactGpu {
  glm::vec4 light_dir{0.0f, 1.0f, 0.0f, 0.0f};
  glm::vec2 extent{64.0f, 48.0f};
  float tan_half_fov_y = 0.5f;
  float aspect = 4.0f / 3.0f;
  float near_plane = 0.1f;
  float far_plane = 100.0f;
  float max_distance = 0.5f;
  float thickness = 0.1f;
  float depth_bias = 0.002f;
  float intensity = 1.0f;
  float step_exponent = 2.0f;
  float edge_fade = 0.05f;
  uint32_t step_count = 16;
  uint32_t frame = 0;
  uint32_t reverse_z = 1;
  uint32_t caster_mask = 0;
};
PENUMBRA_GLSL_STRUCT(ContactGpu, "ContactShadowGpu", light_dir, extent, tan_half_fov_y, aspect,
                     near_plane, far_plane, max_distance, thickness, depth_bias, intensity,
                     step_exponent, edge_fade, step_count, frame, reverse_z, caster_mask);

namespace penumbra::testing {
namespace {

namespace ref = penumbra::reference::contact;

constexpr const char* kFile = "penumbra/contact_shadows.glsl";
constexpr double kInf = std::numeric_limits<double>::infinity();

ref::Params to_ref(const ContactGpu& g) {
  ref::Params p;
  p.to_light = glm::dvec3(g.light_dir);
  p.tan_half_fov_y = g.tan_half_fov_y;
  p.aspect = g.aspect;
  p.near = g.near_plane;
  p.far = g.far_plane > 0.0f ? double{g.far_plane} : kInf;
  p.max_distance = g.max_distance;
  p.thickness = g.thickness;
  p.depth_bias = g.depth_bias;
  p.intensity = g.intensity;
  p.step_exponent = g.step_exponent;
  p.edge_fade = g.edge_fade;
  p.step_count = g.step_count;
  p.frame = g.frame;
  p.reverse_z = g.reverse_z != 0;
  p.positional = g.light_dir.w != 0.0f;
  return p;
}

// A log-uniform view distance in [lo, hi].
double log_uniform(std::mt19937& rng, double lo, double hi) {
  std::uniform_real_distribution<double> u(std::log(lo), std::log(hi));
  return std::exp(u(rng));
}

glm::dvec3 random_unit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  glm::dvec3 v(n(rng), n(rng), n(rng));
  return glm::normalize(v);
}

struct Projection {
  double near, far;  // far may be infinite
};
const Projection kProjections[] = {{0.1, 100.0}, {0.01, 1e4}, {0.1, kInf}, {1.0, 50.0}};

float far_param(const Projection& p) {
  return std::isinf(p.far) ? 0.0f : float(p.far);
}

class ContactShadowsTest : public GpuTest {};

TEST_F(ContactShadowsTest, SkyIsTheFarPlaneOrBeyondOrNotFinite) {
  ShaderFunction<bool(float, bool)> f(kFile, "contact_is_sky");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<float> values = {0.0f,       -0.0f, 1e-30f, 0.5f, 0.99999994f, 1.0f,
                                     1.0000001f, -1.0f, 2.0f,   nan,  inf,         -inf};
  std::vector<std::tuple<float, bool>> cases;
  std::vector<bool> want;
  for (bool reverse_z : {true, false}) {
    for (float v : values) {
      cases.push_back({v, reverse_z});
      want.push_back(ref::is_sky(v, reverse_z));
    }
  }
  EXPECT_EQ(f.run(cases), want);
}

TEST_F(ContactShadowsTest, SurfaceDepthInvertsTheProjectionInBothConventions) {
  ShaderFunction<float(float, float, float, bool)> f(kFile, "contact_surface_depth");
  std::mt19937 rng(11);
  std::vector<std::tuple<float, float, float, bool>> cases;
  std::vector<float> want;
  for (const Projection& p : kProjections) {
    for (bool reverse_z : {true, false}) {
      for (int i = 0; i < 500; ++i) {
        const double hi = std::isinf(p.far) ? 1e4 : p.far;
        const double z = log_uniform(rng, p.near, hi);
        const float d = static_cast<float>(ref::device_depth(z, p.near, p.far, reverse_z));
        if (ref::is_sky(d, reverse_z)) continue;
        cases.push_back({d, float(p.near), far_param(p), reverse_z});
        // The reference of the float depth the GPU sees (and of the float planes).
        const double far = std::isinf(p.far) ? kInf : double{float(p.far)};
        want.push_back(float(ref::surface_depth(d, double{float(p.near)}, far, reverse_z)));
      }
      // Sky values give kContactNoSurface.
      cases.push_back({reverse_z ? 0.0f : 1.0f, float(p.near), far_param(p), reverse_z});
      want.push_back(-1.0f);
    }
  }
  // linearize_depth: < 6.5 float roundings (depth.glsl); allow 16 ULP.
  PENUMBRA_EXPECT_ALL_NEAR(want, f.run(cases), Tolerance::ulps(16));
}

// The ray origin is built from the pixel's NDC and view distance with the projection's scale
// terms: relative error of a few float roundings at any distance, including 10 km under
// reverse-Z (where an inverse-matrix round trip of the hyperbolic depth would lose digits).
TEST_F(ContactShadowsTest, RayOriginFromNdcAndViewDistance) {
  ShaderFunction<glm::vec3(glm::ivec2, float, ContactGpu)> f(kFile, "contact_ray_origin");
  std::mt19937 rng(12);
  std::vector<std::tuple<glm::ivec2, float, ContactGpu>> cases;
  std::vector<glm::vec3> want;
  std::uniform_int_distribution<int> px(0, 1279), py(0, 719);
  for (int i = 0; i < 2000; ++i) {
    ContactGpu g;
    g.extent = {1280.0f, 720.0f};
    g.tan_half_fov_y = float(std::tan(0.5 * log_uniform(rng, 0.2, 2.5)));
    g.aspect = 16.0f / 9.0f;
    const glm::ivec2 pixel(px(rng), py(rng));
    const float z = float(log_uniform(rng, 0.05, 1e4));
    cases.push_back({pixel, z, g});
    want.push_back(glm::vec3(ref::view_position(ref::pixel_uv(pixel.x, pixel.y, 1280, 720), z,
                                                g.tan_half_fov_y, g.aspect)));
  }
  // Each component: NDC (2 roundings) times tan and aspect (2) times z (1): 8 ULP, plus a floor
  // for components near 0 (the NDC of a centre pixel): 4 ULP of |z| * tan.
  const auto got = f.run(cases);
  for (size_t i = 0; i < got.size(); ++i) {
    const float z = std::get<1>(cases[i]);
    const float scale = z * std::get<2>(cases[i]).tan_half_fov_y * 2.0f;
    const Tolerance tol = Tolerance::ulps(8, 4.0 * scale * 0x1p-23);
    ASSERT_THAT(got[i], NearTo(want[i], tol)) << "case " << i;
  }
}

TEST_F(ContactShadowsTest, ProjectUvInvertsTheOrigin) {
  ShaderFunction<glm::vec2(glm::vec3, float, float)> f(kFile, "contact_project_uv");
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-0.2, 1.2);
  std::vector<std::tuple<glm::vec3, float, float>> cases;
  std::vector<glm::vec2> want;
  for (int i = 0; i < 2000; ++i) {
    const double t = std::tan(0.5 * log_uniform(rng, 0.2, 2.5)), aspect = log_uniform(rng, 0.5, 3);
    const glm::dvec2 uv(u(rng), u(rng));
    const glm::dvec3 p = ref::view_position(uv, log_uniform(rng, 0.01, 1e4), t, aspect);
    const glm::vec3 pf(p);
    cases.push_back({pf, float(t), float(aspect)});
    want.push_back(
        glm::vec2(ref::project_uv(glm::dvec3(pf), double{float(t)}, double{float(aspect)})));
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, f.run(cases), Tolerance::absolute(4e-7));
}

TEST_F(ContactShadowsTest, RayLengthStopsAtTheNearPlaneWhenTheLightIsBehindTheCamera) {
  ShaderFunction<float(glm::vec3, glm::vec3, float, float)> f(kFile, "contact_ray_length");
  ShaderFunction<glm::vec3(glm::vec3, glm::vec3, float, float)> end(kFile, "contact_ray_end");
  std::mt19937 rng(14);
  std::uniform_real_distribution<double> u(-1.0, 1.0), md(0.0, 5.0);
  std::vector<std::tuple<glm::vec3, glm::vec3, float, float>> cases;
  std::vector<float> want;
  int clamped = 0;
  for (int i = 0; i < 4000; ++i) {
    const float near = float(log_uniform(rng, 0.01, 1.0));
    const double z = log_uniform(rng, near, 20.0);
    const glm::vec3 origin(float(u(rng) * z), float(u(rng) * z), float(-z));
    glm::vec3 l(random_unit(rng));
    if (i % 2 == 0) l.z = std::fabs(l.z);  // half the rays head towards the camera
    l = glm::normalize(l);
    const float max_distance = float(md(rng));
    cases.push_back({origin, l, max_distance, near});
    const double len = ref::ray_length(glm::dvec3(origin), glm::dvec3(l), max_distance, near);
    clamped += len < max_distance;
    want.push_back(float(len));
  }
  EXPECT_GT(clamped, 500);
  // (-z - near) / l.z: a subtraction that may cancel (absolute error ~ 2^-23 |z|) and a
  // division: relative 2e-6 plus 2^-21 |z| / l.z absolute.
  const auto got = f.run(cases);
  for (size_t i = 0; i < got.size(); ++i) {
    const auto& [o, l, md_i, near] = cases[i];
    const double abs = 0x1p-21 * std::fabs(o.z) / std::max(std::fabs(double{l.z}), 1e-3);
    ASSERT_THAT(got[i], NearTo(want[i], Tolerance::relative(2e-6, abs))) << "case " << i;
  }
  // The end never comes nearer than the near plane (up to the same rounding).
  const auto ends = end.run(cases);
  for (size_t i = 0; i < ends.size(); ++i) {
    const auto& [o, l, md_i, near] = cases[i];
    EXPECT_GE(-ends[i].z, near - 4e-6 * std::fabs(o.z) - 1e-7) << "case " << i;
  }
}

TEST_F(ContactShadowsTest, ScreenExitClipsTheSegmentToTheScreen) {
  ShaderFunction<float(glm::vec2, glm::vec2)> f(kFile, "contact_screen_exit");
  std::mt19937 rng(15);
  std::uniform_real_distribution<double> in(0.0, 1.0), out(-2.0, 3.0);
  std::vector<std::tuple<glm::vec2, glm::vec2>> cases;
  std::vector<float> want;
  for (int i = 0; i < 4000; ++i) {
    const glm::vec2 a(float(in(rng)), float(in(rng)));
    const glm::vec2 b = i % 4 == 0 ? glm::vec2(float(in(rng)), float(in(rng)))
                                   : glm::vec2(float(out(rng)), float(out(rng)));
    cases.push_back({a, b});
    want.push_back(float(ref::screen_exit(glm::dvec2(a), glm::dvec2(b))));
  }
  cases.push_back({glm::vec2(0.5f), glm::vec2(0.5f)});  // a zero-length segment
  want.push_back(1.0f);
  PENUMBRA_EXPECT_ALL_NEAR(want, f.run(cases), Tolerance::relative(4e-7, 1e-7));
}

TEST_F(ContactShadowsTest, StepCountNeverExceedsThePixelsCrossed) {
  ShaderFunction<uint32_t(float, uint32_t)> f(kFile, "contact_step_count");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<std::tuple<float, uint32_t>> cases = {
      {0.0f, 16},     {0.99f, 16}, {1.0f, 16},  {1.5f, 16}, {7.9999f, 16}, {8.0f, 16},
      {15.5f, 16},    {16.0f, 16}, {16.5f, 16}, {1e6f, 16}, {100.0f, 64},  {100.0f, 65},
      {100.0f, 1000}, {40.0f, 0},  {-3.0f, 16}, {nan, 16},  {inf, 16},     {63.7f, 64}};
  std::vector<uint32_t> want;
  for (const auto& [len, cap] : cases) want.push_back(ref::step_count(len, cap));
  EXPECT_EQ(f.run(cases), want);
  EXPECT_EQ(want[2], 1u);    // one pixel: one step
  EXPECT_EQ(want[5], 8u);    // eight pixels, cap 16: eight steps
  EXPECT_EQ(want[12], 64u);  // the cap is itself capped
}

TEST_F(ContactShadowsTest, NoiseIsInterleavedGradientNoisePlusTheGoldenRatioOffset) {
  ShaderFunction<float(glm::ivec2, uint32_t)> f(kFile, "contact_noise");
  std::mt19937 rng(16);
  std::uniform_int_distribution<int> p(0, 4095);
  std::uniform_int_distribution<uint32_t> fr(0, 0xffffffffu);
  std::vector<std::tuple<glm::ivec2, uint32_t>> cases;
  for (int i = 0; i < 5000; ++i)
    cases.push_back({glm::ivec2(p(rng), p(rng)), i < 100 ? 0u : fr(rng)});
  const auto got = f.run(cases);
  int exact = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    const auto& [px, frame] = cases[i];
    const double want = ref::noise(px.x, px.y, frame);
    ASSERT_GE(got[i], 0.0f);
    ASSERT_LT(got[i], 1.0f);
    // The IGN is `precise`: devices that round to nearest agree bit for bit; others may land a
    // rounding away (a circular error of at most ~2^-17 at 4096 pixels).
    const double d = std::fabs(got[i] - want);
    EXPECT_LE(std::min(d, 1.0 - d), 1e-5) << "pixel " << px.x << "," << px.y << " frame " << frame;
    exact += got[i] == float(want);
  }
  std::cout << "[ noise    ] " << exact << " of " << got.size() << " noise values bit-exact\n";
  // A different frame moves the noise.
  const auto a = f(glm::ivec2(10, 20), 0u), b = f(glm::ivec2(10, 20), 1u);
  EXPECT_NE(a, b);
}

TEST_F(ContactShadowsTest, StepsAreQuadraticByDefaultAndStayInTheUnitInterval) {
  ShaderFunction<float(uint32_t, uint32_t, float, float)> f(kFile, "contact_step_t");
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> noise(0.0f, 0.99999994f);
  std::vector<std::tuple<uint32_t, uint32_t, float, float>> cases;
  std::vector<float> want;
  for (float k : {1.0f, 2.0f, 3.0f, 1.5f}) {
    for (uint32_t n : {1u, 2u, 7u, 16u, 64u}) {
      const float nz = noise(rng);
      for (uint32_t i = 0; i < n; ++i) {
        cases.push_back({i, n, nz, k});
        want.push_back(float(ref::step_t(i, n, nz, k)));
      }
    }
  }
  const auto got = f.run(cases);
  // pow: 3 + 2 |k log2 x| ULP by the Vulkan rules; x * x for k = 2. Allow 64 ULP, floor 1e-7.
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::ulps(64, 1e-7));
  // Strictly increasing within a ray, in [0, 1).
  for (size_t i = 0; i < cases.size(); ++i) {
    EXPECT_GE(got[i], 0.0f);
    EXPECT_LT(got[i], 1.0f);
    if (std::get<0>(cases[i]) > 0) {
      EXPECT_GT(got[i], got[i - 1]) << i;
    }
  }
  // k = 2: t_i = ((i + 0.5) / 4)^2.
  EXPECT_EQ(f(2u, 4u, 0.5f, 2.0f), 0.390625f);
}

TEST_F(ContactShadowsTest, NdotLAndTheSlopeScaledTolerance) {
  ShaderFunction<float(glm::vec3, glm::vec3)> ndl(kFile, "contact_n_dot_l");
  ShaderFunction<float(float, float, float)> tol(kFile, "contact_bias_tolerance");
  std::mt19937 rng(18);
  std::uniform_real_distribution<double> s(0.01, 100.0);
  std::vector<std::tuple<glm::vec3, glm::vec3>> ncases;
  std::vector<float> nwant;
  std::vector<std::tuple<float, float, float>> tcases;
  std::vector<float> twant;
  for (int i = 0; i < 2000; ++i) {
    const glm::vec3 n(random_unit(rng) * s(rng));  // not unit length
    const glm::vec3 l(random_unit(rng));
    ncases.push_back({n, l});
    nwant.push_back(float(ref::n_dot_l(glm::dvec3(n), glm::dvec3(l))));
    const float bias = float(log_uniform(rng, 1e-5, 0.1)), z = float(log_uniform(rng, 0.1, 1e3));
    const float d = nwant.back();
    tcases.push_back({bias, z, d});
    twant.push_back(float(ref::tolerance(bias, z, d)));
  }
  ncases.push_back({glm::vec3(0.0f), glm::vec3(0, 1, 0)});  // degenerate: the floor
  nwant.push_back(0.25f);
  PENUMBRA_EXPECT_ALL_NEAR(nwant, ndl.run(ncases), Tolerance::absolute(2e-6));
  PENUMBRA_EXPECT_ALL_NEAR(twant, tol.run(tcases), Tolerance::ulps(8));
  // Grazing and back-facing receivers get 4x the tolerance of a receiver facing the light.
  EXPECT_EQ(tol(0.01f, 2.0f, 1.0f) * 4.0f, tol(0.01f, 2.0f, 0.1f));
  EXPECT_EQ(tol(0.01f, 2.0f, -1.0f), tol(0.01f, 2.0f, 0.25f));
}

// 1 / mix(1 / z0, 1 / z1, t) is the depth of the 3D point on the segment that projects to
// mix(uv0, uv1, t): checked against a bisection on the 3D segment (no 1/z anywhere).
TEST_F(ContactShadowsTest, RayDepthIsPerspectiveCorrect) {
  ShaderFunction<float(float, float, float)> f(kFile, "contact_ray_depth");
  std::mt19937 rng(19);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::tuple<float, float, float>> cases;
  std::vector<float> want;
  const double t_half = 0.5, aspect = 1.5;
  for (int i = 0; i < 2000; ++i) {
    const glm::dvec3 p0 =
        ref::view_position({u(rng), u(rng)}, log_uniform(rng, 0.2, 50.0), t_half, aspect);
    const glm::dvec3 p1 = p0 + random_unit(rng) * log_uniform(rng, 0.01, 5.0);
    if (-p1.z < 0.1) continue;
    const glm::dvec2 uv0 = ref::project_uv(p0, t_half, aspect),
                     uv1 = ref::project_uv(p1, t_half, aspect);
    const double t = u(rng);
    const glm::dvec2 target = uv0 + t * (uv1 - uv0);
    // Bisection on s in [0, 1] along the axis of larger screen motion (monotonic in s).
    const int axis = std::fabs(uv1.x - uv0.x) > std::fabs(uv1.y - uv0.y) ? 0 : 1;
    if (std::fabs(uv1[axis] - uv0[axis]) < 1e-6) continue;
    double lo = 0.0, hi = 1.0;
    const bool increasing = uv1[axis] > uv0[axis];
    for (int k = 0; k < 200; ++k) {
      const double mid = 0.5 * (lo + hi);
      const double at = ref::project_uv(p0 + mid * (p1 - p0), t_half, aspect)[axis];
      ((at < target[axis]) == increasing ? lo : hi) = mid;
    }
    const double z = -(p0 + 0.5 * (lo + hi) * (p1 - p0)).z;
    cases.push_back({float(1.0 / -p0.z), float(1.0 / -p1.z), float(t)});
    want.push_back(float(z));
  }
  ASSERT_GT(cases.size(), 1500u);
  PENUMBRA_EXPECT_ALL_NEAR(want, f.run(cases), Tolerance::relative(2e-6));
}

TEST_F(ContactShadowsTest, TheOcclusionWindowAndTheDualTest) {
  ShaderFunction<bool(float, float, float, float)> behind(kFile, "contact_ray_behind");
  ShaderFunction<bool(float, float, float, float, float, bool, bool)> dual(kFile,
                                                                           "contact_dual_test");
  // Window (tolerance, tolerance + thickness) = (0.01, 0.11) behind the surface at 5.
  std::vector<std::tuple<float, float, float, float>> bc;
  std::vector<bool> bw;
  for (float ray : {4.9f, 5.0f, 5.005f, 5.0101f, 5.05f, 5.1099f, 5.2f}) {
    bc.push_back({ray, 5.0f, 0.01f, 0.1f});
    bw.push_back(ref::behind(ray, 5.0f, 0.01f, 0.1f));
  }
  bc.push_back({5.05f, -1.0f, 0.01f, 0.1f});  // no surface (sky)
  bw.push_back(false);
  EXPECT_EQ(behind.run(bc), bw);
  EXPECT_EQ(bw, (std::vector<bool>{false, false, false, true, true, true, false, false}));

  // Both reads must agree; a single read decides alone when the other is off.
  std::vector<std::tuple<float, float, float, float, float, bool, bool>> dc;
  std::vector<bool> dw;
  const float ray = 5.05f;
  for (float bil : {5.0f, 4.0f, -1.0f}) {
    for (float nea : {5.0f, 4.0f, -1.0f}) {
      for (int mode = 0; mode < 4; ++mode) {
        const bool ub = mode & 1, un = mode & 2;
        dc.push_back({ray, bil, nea, 0.01f, 0.1f, ub, un});
        bool hit = ub || un;
        if (ub) hit = hit && ref::behind(ray, bil, 0.01, 0.1);
        if (un) hit = hit && ref::behind(ray, nea, 0.01, 0.1);
        dw.push_back(hit);
      }
    }
  }
  EXPECT_EQ(dual.run(dc), dw);
}

TEST_F(ContactShadowsTest, EdgeFade) {
  ShaderFunction<float(glm::vec2, float)> f(kFile, "contact_edge_fade");
  std::mt19937 rng(20);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::tuple<glm::vec2, float>> cases;
  std::vector<float> want;
  for (int i = 0; i < 2000; ++i) {
    const glm::vec2 uv(float(u(rng)), float(u(rng)));
    const float w = i % 5 == 0 ? 0.0f : float(0.2 * u(rng));
    cases.push_back({uv, w});
    want.push_back(float(ref::edge_fade(glm::dvec2(uv), w)));
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, f.run(cases), Tolerance::absolute(1e-6));
  EXPECT_EQ(f(glm::vec2(0.5f), 0.05f), 1.0f);
  EXPECT_EQ(f(glm::vec2(0.0f, 0.5f), 0.05f), 0.0f);
  EXPECT_NEAR(f(glm::vec2(0.025f, 0.5f), 0.05f), 0.5f, 1e-6f);
}

// A random receiver, light and camera.
ContactGpu random_params(std::mt19937& rng, const Projection& proj, bool reverse_z) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  ContactGpu g;
  g.extent = {float(32 + int(u(rng) * 200)), float(24 + int(u(rng) * 150))};
  g.tan_half_fov_y = float(std::tan(0.5 * (0.3 + 1.8 * u(rng))));
  g.aspect = g.extent.x / g.extent.y;
  g.near_plane = float(proj.near);
  g.far_plane = far_param(proj);
  g.light_dir = glm::vec4(glm::vec3(random_unit(rng)), 0.0f);
  g.max_distance = float(log_uniform(rng, 0.01, 5.0));
  g.depth_bias = float(0.005 * u(rng));
  g.step_count = 1 + uint32_t(u(rng) * 64.0);
  g.step_exponent = u(rng) < 0.5 ? 2.0f : float(1.0 + 3.0 * u(rng));
  g.frame = uint32_t(u(rng) * 1000.0);
  g.reverse_z = reverse_z;
  return g;
}

TEST_F(ContactShadowsTest, RaySetupMatchesTheReference) {
  using Setup = std::tuple<uint32_t, glm::vec4, glm::vec2, float>;
  ShaderFunction<uint32_t(glm::ivec2, float, glm::vec3, ContactGpu, Out<glm::vec4>, Out<glm::vec2>,
                          Out<float>)>
      f(kFile, "contact_ray_setup");
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::tuple<glm::ivec2, float, glm::vec3, ContactGpu>> cases;
  std::vector<ref::Ray> want;
  for (const Projection& proj : kProjections) {
    for (bool reverse_z : {true, false}) {
      for (int i = 0; i < 400; ++i) {
        ContactGpu g = random_params(rng, proj, reverse_z);
        // One in five lights is positional: a point 0.3 to 30 units away in view space.
        if (i % 5 == 1) {
          const double dist = log_uniform(rng, 0.3, 30.0);
          g.light_dir = glm::vec4(glm::vec3(random_unit(rng) * dist) +
                                      glm::vec3(0.0f, 0.0f, float(-log_uniform(rng, 0.5, 20.0))),
                                  1.0f);
        }
        const glm::ivec2 pixel(int(u(rng) * g.extent.x), int(u(rng) * g.extent.y));
        const double hi = std::isinf(proj.far) ? 200.0 : proj.far;
        const double z = log_uniform(rng, proj.near * 1.01, hi);
        const float d = float(ref::device_depth(z, proj.near, proj.far, reverse_z));
        glm::vec3 n(random_unit(rng));
        // Three in four receivers face the light; the rest are back faces (not marched).
        if (i % 4 != 0 && glm::dot(n, glm::vec3(g.light_dir)) < 0.0f) n = -n;
        cases.push_back({pixel, d, n, g});
        want.push_back(ref::setup_ray(pixel.x, pixel.y, d, glm::dvec3(n), to_ref(g),
                                      int(g.extent.x), int(g.extent.y)));
      }
    }
  }
  const std::vector<Setup> got = f.run(cases);
  int marched = 0, clamped = 0, clipped = 0, positional = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    const auto& [steps, seg, inv_z, tol] = got[i];
    positional += std::get<3>(cases[i]).light_dir.w != 0.0f && steps > 0;
    const ref::Ray& r = want[i];
    const ContactGpu& g = std::get<3>(cases[i]);
    std::ostringstream where;
    where << "case " << i << ": pixel " << std::get<0>(cases[i]).x << "," << std::get<0>(cases[i]).y
          << " depth " << std::get<1>(cases[i]) << " length_px " << r.length_px << " ref steps "
          << r.steps;
    const double frac = r.length_px - std::floor(r.length_px);
    const bool marginal_count = frac < 1e-3 || frac > 1.0 - 1e-3 || std::fabs(r.n_dot_l) < 1e-5;
    if (!marginal_count) {
      ASSERT_EQ(steps, r.steps) << where.str();
    }
    if (steps == 0 || r.steps == 0) continue;
    ++marched;
    clamped += r.clamped;
    clipped += r.clipped;
    // The segment: uv within float rounding of quantities up to ~|uv1| (unclipped end).
    const double uv_tol = 2e-5 * std::max(1.0, r.length_px / double(g.extent.x));
    EXPECT_NEAR(seg.x, r.uv0.x, 1e-6) << where.str();
    EXPECT_NEAR(seg.y, r.uv0.y, 1e-6) << where.str();
    EXPECT_NEAR(seg.z, r.uv1.x, uv_tol) << where.str();
    EXPECT_NEAR(seg.w, r.uv1.y, uv_tol) << where.str();
    EXPECT_NEAR(inv_z.x, 1.0 / r.z0, 4e-6 / r.z0) << where.str();
    EXPECT_NEAR(inv_z.y, 1.0 / r.z1, 2e-5 / r.z1) << where.str();
    EXPECT_NEAR(tol, r.tolerance, 1e-5 * r.tolerance + 1e-12) << where.str();
  }
  EXPECT_GT(positional, 200) << "positional lights marched";
  std::cout << "[ setup    ] " << got.size() << " rays (" << positional
            << " marched towards a positional light): " << marched << " marched, " << clamped
            << " clamped at the near plane, " << clipped << " clipped at the screen edge\n";
  EXPECT_GT(marched, 1000);
  EXPECT_GT(clamped, 100);
  EXPECT_GT(clipped, 100);
}

// A receiver edge-on to the light (N.L exactly 0) is not marched: its ray would run along its
// own surface.
TEST_F(ContactShadowsTest, EdgeOnReceiversAreNotMarched) {
  ShaderFunction<uint32_t(glm::ivec2, float, glm::vec3, ContactGpu, Out<glm::vec4>, Out<glm::vec2>,
                          Out<float>)>
      f(kFile, "contact_ray_setup");
  std::mt19937 rng(22);
  ContactGpu g = random_params(rng, kProjections[0], true);
  g.light_dir = glm::vec4(1.0f, 0.0f, 0.0f, 0.0f);
  g.max_distance = 2.0f;
  g.step_count = 32;
  const glm::ivec2 pixel(int(g.extent.x) / 2, int(g.extent.y) / 2);
  const float d = float(ref::device_depth(5.0, kProjections[0].near, kProjections[0].far, true));
  EXPECT_GT(std::get<0>(f(pixel, d, glm::vec3(0.6f, 0.8f, 0.0f), g)), 0u);
  EXPECT_EQ(std::get<0>(f(pixel, d, glm::vec3(0.0f, 1.0f, 0.0f), g)), 0u);
}

// A random scene of blocks over a background plane, as a depth buffer (no geometry: depth
// values straight from view distances), marched by contact_shadow() on the GPU with both reads
// and compared per pixel with the reference march.
struct BlockScene {
  ref::Buffers buffers;
  ContactGpu params;
};

BlockScene block_scene(std::mt19937& rng, bool reverse_z, const Projection& proj) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  BlockScene s;
  const int w = 48, h = 36;
  s.buffers.width = w;
  s.buffers.height = h;
  s.params.extent = {float(w), float(h)};
  s.params.tan_half_fov_y = 0.5f;
  s.params.aspect = float(w) / float(h);
  s.params.near_plane = float(proj.near);
  s.params.far_plane = far_param(proj);
  s.params.reverse_z = reverse_z;
  s.params.max_distance = 1.0f;
  s.params.thickness = 0.3f;
  s.params.step_count = 24;
  // The light comes from the upper left and a little towards the camera.
  s.params.light_dir = glm::vec4(glm::normalize(glm::vec3(-0.6f, 0.5f, 0.35f)), 0.0f);
  std::vector<double> z(static_cast<size_t>(w) * h, 5.0);
  for (int b = 0; b < 6; ++b) {
    const int x0 = int(u(rng) * w), y0 = int(u(rng) * h);
    const int bw = 2 + int(u(rng) * 8), bh = 2 + int(u(rng) * 8);
    const double bz = 4.2 + 0.7 * u(rng);
    for (int y = y0; y < std::min(h, y0 + bh); ++y)
      for (int x = x0; x < std::min(w, x0 + bw); ++x) z[static_cast<size_t>(y) * w + x] = bz;
  }
  for (int i = 0; i < w * h; ++i) {
    // A few sky pixels.
    const bool sky = u(rng) < 0.02;
    s.buffers.depth.push_back(sky ? (reverse_z ? 0.0f : 1.0f)
                                  : float(ref::device_depth(z[i], proj.near, proj.far, reverse_z)));
    s.buffers.normals.push_back(glm::vec3(0.0f, 0.0f, 1.0f));  // facing the camera
  }
  return s;
}

TEST_F(ContactShadowsTest, MarchMatchesTheReferenceOnRandomBlockScenes) {
  ShaderFunction<float(Sampler2D, Sampler2D, glm::ivec2, glm::vec3, ContactGpu, bool, bool)> f(
      kFile, "contact_shadow");
  std::mt19937 rng(22);
  int total = 0, shadowed = 0, mismatched = 0, marginal = 0, at_texel_edge = 0, at_window = 0,
      at_weight = 0, at_discontinuity = 0, filter_range = 0;
  // Vulkan lets the device quantise the bilinear weights to subTexelPrecisionBits.
  const double weight_error = std::ldexp(1.0, -int(ctx().info().limits.subTexelPrecisionBits));
  for (const Projection& proj : kProjections) {
    for (bool reverse_z : {true, false}) {
      for (int scene = 0; scene < 3; ++scene) {
        const BlockScene s = block_scene(rng, reverse_z, proj);
        const auto& b = s.buffers;
        ref::Params rp = to_ref(s.params);
        rp.bilinear_weight_error = weight_error;
        FloatTextureDesc fd;
        fd.width = b.width;
        fd.height = b.height;
        fd.sampler.filter = VK_FILTER_LINEAR;
        f.bind(0, make_float_texture(fd, b.depth));
        DepthTextureDesc dd;
        dd.width = b.width;
        dd.height = b.height;
        dd.sampler.compare = false;
        f.bind(1, make_depth_texture(dd, b.depth));
        for (ref::Reads reads :
             {ref::Reads::dual, ref::Reads::bilinear_only, ref::Reads::nearest_only}) {
          std::vector<std::tuple<glm::ivec2, glm::vec3, ContactGpu, bool, bool>> cases;
          for (int y = 0; y < b.height; ++y)
            for (int x = 0; x < b.width; ++x)
              cases.push_back({glm::ivec2(x, y), b.normals[size_t(y) * b.width + x], s.params,
                               reads != ref::Reads::nearest_only,
                               reads != ref::Reads::bilinear_only});
          const auto got = f.run(cases);
          const auto want = ref::march(b, rp, reads);
          for (size_t i = 0; i < got.size(); ++i) {
            ++total;
            shadowed += got[i] < 0.5f;
            marginal += want[i].marginal;
            filter_range += want[i].mask_lo != want[i].mask_hi;
            // Any mask in the interval the filter precision allows is right (contact_ref.hpp).
            if (got[i] < want[i].mask_lo - 1e-4 || got[i] > want[i].mask_hi + 1e-4) {
              ++mismatched;
              at_texel_edge += (want[i].reasons & ref::kTexelEdge) != 0;
              at_window += (want[i].reasons & ref::kDepthWindow) != 0;
              at_weight += (want[i].reasons & ref::kBilinearWeight) != 0;
              at_discontinuity += (want[i].reasons & ref::kDiscontinuity) != 0;
              EXPECT_TRUE(want[i].marginal)
                  << "pixel " << i % b.width << "," << i / b.width << ": gpu " << got[i] << " ref "
                  << want[i].mask << " [" << want[i].mask_lo << ", " << want[i].mask_hi
                  << "] (reverse_z " << reverse_z << ", far " << proj.far << ", reads "
                  << int(reads) << ")";
            }
          }
        }
      }
    }
  }
  std::cout << "[ march    ] " << total << " pixels: " << shadowed << " shadowed, " << mismatched
            << " differ from the reference (all marginal: " << at_texel_edge
            << " with a tap at a texel edge, " << at_window << " with a depth at the window's end, "
            << at_weight << " with a bilinear read within the filter precision of it; "
            << at_discontinuity << " of them on a depth discontinuity), " << marginal
            << " marginal, " << filter_range << " left open by the filter precision\n";
  EXPECT_GT(shadowed, total / 50);
  EXPECT_LE(mismatched, total / 1000);
}

}  // namespace
}  // namespace penumbra::testing
