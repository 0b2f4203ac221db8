// Extreme inputs to shaders/penumbra/contact_shadows.glsl: NaN, infinities, denormals, zero and
// huge lengths, tiny and huge planes, degenerate vectors, 1x1 screens. Nothing may come back
// NaN or infinite, masks stay in [0, 1], step counts within the cap, and the documented
// special cases hold (sky and back faces are not marched, a degenerate normal gets the largest
// tolerance, a NaN length marches nothing).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <tuple>
#include <vector>

#include "reference/contact_ref.hpp"

struct ContactGpuX {
  glm::vec4 light_dir{0.0f, 1.0f, 0.0f, 0.0f};
  glm::vec2 extent{8.0f, 8.0f};
  float tan_half_fov_y = 0.5f;
  float aspect = 1.0f;
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
PENUMBRA_GLSL_STRUCT(ContactGpuX, "ContactShadowGpu", light_dir, extent, tan_half_fov_y, aspect,
                     near_plane, far_plane, max_distance, thickness, depth_bias, intensity,
                     step_exponent, edge_fade, step_count, frame, reverse_z, caster_mask);

namespace penumbra::testing {
namespace {

constexpr const char* kFile = "penumbra/contact_shadows.glsl";
constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kDenormal = 1e-40f;
constexpr float kMax = std::numeric_limits<float>::max();

bool finite(float v) {
  return std::isfinite(v);
}
bool finite(glm::vec2 v) {
  return std::isfinite(v.x) && std::isfinite(v.y);
}
bool finite(glm::vec4 v) {
  return finite(glm::vec2(v.x, v.y)) && finite(glm::vec2(v.z, v.w));
}

const std::vector<float> kDepths = {0.0f,  -0.0f,       kDenormal, 1e-30f,     1e-7f,
                                    0.5f,  0.99999994f, 1.0f,      1.0000001f, 2.0f,
                                    -1.0f, kMax,        kInf,      -kInf,      kNan};

class ContactExtremesTest : public GpuTest {};

TEST_F(ContactExtremesTest, SurfaceDepthIsPositiveAndFiniteOrNoSurface) {
  ShaderFunction<float(float, float, float, bool)> f(kFile, "contact_surface_depth");
  std::vector<std::tuple<float, float, float, bool>> cases;
  for (float d : kDepths)
    for (float near : {1e-6f, 0.1f, 1e4f})
      for (float far : {0.0f, near * 1.0001f, near * 1e6f, kMax})
        for (bool rz : {true, false}) cases.push_back({d, near, far, rz});
  const auto got = f.run(cases);
  for (size_t i = 0; i < got.size(); ++i) {
    const auto& [d, near, far, rz] = cases[i];
    SCOPED_TRACE(::testing::Message()
                 << "d " << d << " near " << near << " far " << far << " reverse_z " << rz);
    EXPECT_TRUE(got[i] == -1.0f || (finite(got[i]) && got[i] > 0.0f)) << got[i];
    if (reference::contact::is_sky(d, rz)) {
      EXPECT_EQ(got[i], -1.0f);
    }
  }
}

TEST_F(ContactExtremesTest, RayLengthStaysInZeroToMaxDistance) {
  ShaderFunction<float(glm::vec3, glm::vec3, float, float)> f(kFile, "contact_ray_length");
  std::vector<std::tuple<glm::vec3, glm::vec3, float, float>> cases;
  const std::vector<glm::vec3> dirs = {
      {0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0, 0, kDenormal}, {0, 0.6f, 0.8f}};
  const std::vector<float> lengths = {0.0f, -1.0f, 1e-30f, 0.5f, 1e30f, kMax};
  for (float near : {1e-6f, 0.1f, 10.0f})
    for (float z : {near, near * 0.5f, near * 2.0f, 1e6f})
      for (const glm::vec3& l : dirs)
        for (float len : lengths) cases.push_back({glm::vec3(0.3f, -0.2f, -z), l, len, near});
  const auto got = f.run(cases);
  for (size_t i = 0; i < got.size(); ++i) {
    const auto& [o, l, len, near] = cases[i];
    SCOPED_TRACE(::testing::Message()
                 << "origin z " << o.z << " dir z " << l.z << " max " << len << " near " << near);
    ASSERT_TRUE(finite(got[i])) << got[i];
    EXPECT_GE(got[i], 0.0f);
    EXPECT_LE(got[i], std::max(len, 0.0f));
    // A ray towards the camera never ends nearer than the near plane (up to rounding).
    if (l.z > 0.0f && -o.z >= near) {
      EXPECT_GE(-(o.z + l.z * got[i]), near * (1.0f - 1e-5f) - 1e-6f * -o.z);
    }
  }
}

TEST_F(ContactExtremesTest, ScreenExitOfDegenerateAndHugeSegments) {
  ShaderFunction<float(glm::vec2, glm::vec2)> f(kFile, "contact_screen_exit");
  std::vector<std::tuple<glm::vec2, glm::vec2>> cases;
  for (glm::vec2 a : {glm::vec2(0.0f), glm::vec2(1.0f), glm::vec2(0.5f), glm::vec2(0.0f, 1.0f)})
    for (glm::vec2 b : {a, glm::vec2(1e30f), glm::vec2(-1e30f), glm::vec2(kInf, 0.5f),
                        glm::vec2(0.5f, -kInf), glm::vec2(kDenormal), glm::vec2(2.0f, -3.0f)})
      cases.push_back({a, b});
  const auto got = f.run(cases);
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_TRUE(finite(got[i])) << i;
    EXPECT_GE(got[i], 0.0f) << i;
    EXPECT_LE(got[i], 1.0f) << i;
  }
  EXPECT_EQ(got[0], 1.0f);  // zero length: stays on the screen
}

TEST_F(ContactExtremesTest, StepCountAndStepParameterOfExtremeInputs) {
  ShaderFunction<uint32_t(float, uint32_t)> count(kFile, "contact_step_count");
  std::vector<std::tuple<float, uint32_t>> cc;
  for (float len :
       {kNan, kInf, -kInf, -1.0f, 0.0f, kDenormal, 0.9999999f, 1.0f, 2147483648.0f, kMax})
    for (uint32_t cap : {0u, 1u, 64u, 65u, 0xffffffffu}) cc.push_back({len, cap});
  const auto n = count.run(cc);
  for (size_t i = 0; i < n.size(); ++i) {
    const auto& [len, cap] = cc[i];
    EXPECT_LE(n[i], std::min(cap, 64u)) << len << " " << cap;
    if (!(len >= 1.0f)) {
      EXPECT_EQ(n[i], 0u) << len;
    }
    if (len >= 64.0f && cap >= 64u) {
      EXPECT_EQ(n[i], 64u) << len;
    }
  }

  ShaderFunction<float(uint32_t, uint32_t, float, float)> t(kFile, "contact_step_t");
  std::vector<std::tuple<uint32_t, uint32_t, float, float>> tc;
  for (uint32_t i : {0u, 1u, 63u, 0xffffffffu})
    for (uint32_t nn : {0u, 1u, 64u})
      for (float noise : {0.0f, 0.99999994f, 1.0f, -1.0f, kNan})
        for (float k : {kNan, 0.0f, -1.0f, 1.0f, 2.0f, 8.0f, kInf}) tc.push_back({i, nn, noise, k});
  const auto ts = t.run(tc);
  for (size_t i = 0; i < ts.size(); ++i) {
    // A NaN noise is outside the contract (contact_noise never returns one); clamp() of NaN is
    // undefined in GLSL, so only the finite noise values are held to [0, 1].
    if (std::isnan(std::get<2>(tc[i]))) continue;
    ASSERT_TRUE(finite(ts[i])) << i;
    EXPECT_GE(ts[i], 0.0f) << i;
    EXPECT_LE(ts[i], 1.0f) << i;
  }
}

TEST_F(ContactExtremesTest, DegenerateNormalsGetTheLargestTolerance) {
  ShaderFunction<float(glm::vec3, glm::vec3)> f(kFile, "contact_n_dot_l");
  std::vector<std::tuple<glm::vec3, glm::vec3>> cases;
  for (glm::vec3 n : {glm::vec3(0.0f), glm::vec3(kDenormal), glm::vec3(kNan, 0, 0),
                      glm::vec3(kInf, 0, 0), glm::vec3(1e30f), glm::vec3(0, 1e-20f, 0)})
    cases.push_back({n, glm::vec3(0, 1, 0)});
  const auto got = f.run(cases);
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_TRUE(finite(got[i])) << i;
    EXPECT_GE(got[i], -1.0001f);
    EXPECT_LE(got[i], 1.0001f);
  }
  EXPECT_EQ(got[0], 0.25f);
  EXPECT_EQ(got[1], 0.25f);
  EXPECT_EQ(got[2], 0.25f);
  EXPECT_EQ(got[3], 0.25f);
  EXPECT_NEAR(got[4], 0.57735f, 1e-6f);  // (1e30)^2 would overflow: still the cosine
  EXPECT_NEAR(got[5], 1.0f, 1e-6f);      // (1e-20)^2 would underflow: still the cosine
}

TEST_F(ContactExtremesTest, RaySetupOfExtremeCamerasAndLights) {
  ShaderFunction<uint32_t(glm::ivec2, float, glm::vec3, ContactGpuX, Out<glm::vec4>, Out<glm::vec2>,
                          Out<float>)>
      f(kFile, "contact_ray_setup");
  std::vector<std::tuple<glm::ivec2, float, glm::vec3, ContactGpuX>> cases;
  const std::vector<glm::vec4> lights = {
      {0, 0, 1, 0},    {0, 0, -1, 0},        {1, 0, 0, 0},         {0, 0, 0, 0},
      {kNan, 0, 0, 0}, {1e30f, 1e30f, 0, 0}, {0.6f, 0.0f, 0.8f, 0}};
  for (bool rz : {true, false})
    for (glm::vec2 extent : {glm::vec2(1, 1), glm::vec2(7, 3), glm::vec2(4096, 4096)})
      for (const glm::vec4& l : lights)
        for (float max_distance : {0.0f, 1e-6f, 1e6f})
          for (float near : {1e-6f, 0.1f})
            for (float far : {0.0f, 1e9f})
              for (float d : kDepths)
                for (glm::ivec2 px : {glm::ivec2(0), glm::ivec2(extent) - 1}) {
                  ContactGpuX g;
                  g.light_dir = l;
                  g.extent = extent;
                  g.aspect = extent.x / extent.y;
                  g.max_distance = max_distance;
                  g.near_plane = near;
                  g.far_plane = far;
                  g.reverse_z = rz;
                  g.step_count = 1000;  // beyond the cap
                  cases.push_back({px, d, glm::vec3(l), g});
                }
  const auto got = f.run(cases);
  size_t marched = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    const auto& [steps, seg, inv_z, tol] = got[i];
    const auto& [px, d, n, g] = cases[i];
    SCOPED_TRACE(::testing::Message()
                 << "case " << i << " depth " << d << " light " << g.light_dir.x << ","
                 << g.light_dir.y << "," << g.light_dir.z << " max " << g.max_distance);
    ASSERT_LE(steps, 64u);
    if (reference::contact::is_sky(d, g.reverse_z != 0)) {
      EXPECT_EQ(steps, 0u);
    }
    if (steps == 0) continue;
    ++marched;
    ASSERT_TRUE(finite(seg));
    ASSERT_TRUE(finite(inv_z));
    ASSERT_TRUE(finite(tol));
    EXPECT_GT(inv_z.x, 0.0f);
    EXPECT_GT(inv_z.y, 0.0f);
    EXPECT_GE(tol, 0.0f);
    for (int k = 0; k < 4; ++k) {
      EXPECT_GE(seg[k], -1e-6f);
      EXPECT_LE(seg[k], 1.0f + 1e-6f);
    }
  }
  EXPECT_GT(marched, 100u);
}

// The whole march on tiny textures full of extreme depths: every result is a mask in [0, 1];
// pixels outside the screen are lit.
TEST_F(ContactExtremesTest, MarchOnExtremeBuffersReturnsMasksInTheUnitInterval) {
  ShaderFunction<float(Sampler2D, Sampler2D, glm::ivec2, glm::vec3, ContactGpuX, bool, bool)> f(
      kFile, "contact_shadow");
  for (uint32_t size : {1u, 2u, 5u}) {
    std::vector<float> depth;
    for (uint32_t i = 0; i < size * size; ++i) depth.push_back(kDepths[i % kDepths.size()]);
    FloatTextureDesc fd;
    fd.width = fd.height = size;
    fd.sampler.filter = VK_FILTER_LINEAR;
    f.bind(0, make_float_texture(fd, depth));
    DepthTextureDesc dd;
    dd.width = dd.height = size;
    dd.sampler.compare = false;
    // D32_SFLOAT holds any float, NaN and infinities included.
    f.bind(1, make_depth_texture(dd, depth));
    std::vector<std::tuple<glm::ivec2, glm::vec3, ContactGpuX, bool, bool>> cases;
    for (int y = -1; y <= int(size); ++y)
      for (int x = -1; x <= int(size); ++x)
        for (glm::vec3 n : {glm::vec3(0, 0, 1), glm::vec3(kNan), glm::vec3(0.0f)})
          for (glm::vec4 l :
               {glm::vec4(0.3f, 0.4f, 0.866f, 0), glm::vec4(0, 0, -1, 0), glm::vec4(kNan, 0, 1, 0)})
            for (float thickness : {1e-30f, 0.1f, 1e30f})
              for (bool rz : {true, false}) {
                ContactGpuX g;
                g.extent = glm::vec2(float(size));
                g.light_dir = l;
                g.thickness = thickness;
                g.max_distance = 1e4f;
                g.reverse_z = rz;
                cases.push_back({glm::ivec2(x, y), n, g, true, true});
              }
    const auto got = f.run(cases);
    for (size_t i = 0; i < got.size(); ++i) {
      const glm::ivec2 px = std::get<0>(cases[i]);
      ASSERT_TRUE(finite(got[i])) << "size " << size << " case " << i;
      EXPECT_GE(got[i], 0.0f);
      EXPECT_LE(got[i], 1.0f);
      if (px.x < 0 || px.y < 0 || px.x >= int(size) || px.y >= int(size)) {
        EXPECT_EQ(got[i], 1.0f);
      }
    }
  }
}

// The depth buffer's own resolution floors the occlusion tolerance. Standard depth with near
// 1e-4 and far 1e6 stores a surface 10 m away as d = 1 - 1e-5, whose float step (2^-24) spans
// 6 cm of view distance: more than the 2 cm that depth_bias 0.002 allows there, which is what
// scattered false contact shadows over the default scene (2,304 pixels at 1280x720; 563 with
// the floor). Reverse-Z stores d ~ 1e-5 with steps of 2^-40: 1e-6 m.
TEST_F(ContactExtremesTest, DepthStepIsTheViewDistanceOfOneStoredDepthStep) {
  ShaderFunction<float(float, float, float, float)> step(kFile, "contact_depth_step");
  const double n = 1e-4, f = 1e6, z = 10.0;
  const float d_std = float(f * (z - n) / (z * (f - n)));
  const float d_rev = float(n * (f - z) / (z * (f - n)));
  const double scale = (f - n) / (f * n);
  EXPECT_NEAR(step(d_std, float(z), float(n), float(f)), z * z * scale * std::ldexp(1.0, -24),
              1e-6);
  EXPECT_NEAR(step(d_std, float(z), float(n), float(f)), 0.0596, 0.001);
  EXPECT_NEAR(step(d_rev, float(z), float(n), float(f)), z * z * scale * std::ldexp(1.0, -40),
              1e-12);
  // An infinite far plane (0): z^2 / near.
  EXPECT_NEAR(step(0.5f, 2.0f, 0.1f, 0.0f), 4.0 / 0.1 * std::ldexp(1.0, -24), 1e-9);
  // No depth, NaN and infinity: no floor; a depth the buffer cannot resolve: +Inf, never NaN.
  EXPECT_EQ(step(0.0f, 10.0f, 0.1f, 100.0f), 0.0f);
  EXPECT_EQ(step(kNan, 10.0f, 0.1f, 100.0f), 0.0f);
  EXPECT_EQ(step(kInf, 10.0f, 0.1f, 100.0f), 0.0f);
  const float huge = step(0.99f, 1e30f, 1e-6f, 1e9f);
  EXPECT_TRUE(huge > 1e30f) << huge;
}

// Boundaries of the ray setup's guards: a light direction with an infinite z leaves the length
// alone (only finite, non-zero z is clipped at the near plane); the smallest normal float is a
// normal, not a degenerate one; step exponent 4 is x^4 (only 2 takes the x * x shortcut).
TEST_F(ContactExtremesTest, GuardsHoldAtTheirBoundaries) {
  ShaderFunction<float(glm::vec3, glm::vec3, float, float)> len(kFile, "contact_ray_length");
  EXPECT_EQ(len(glm::vec3(0.0f, 0.0f, -1.0f), glm::vec3(0.0f, 0.0f, kInf), 2.0f, 0.1f), 2.0f);
  EXPECT_EQ(len(glm::vec3(0.0f, 0.0f, -1.0f), glm::vec3(0.0f, 0.0f, 1.0f), 2.0f, 0.1f), 0.9f);
  ShaderFunction<float(glm::vec3, glm::vec3)> ndl(kFile, "contact_n_dot_l");
  const float smallest = std::numeric_limits<float>::min();
  EXPECT_EQ(ndl(glm::vec3(smallest, 0.0f, 0.0f), glm::vec3(1.0f, 0.0f, 0.0f)), 1.0f);
  ShaderFunction<float(uint32_t, uint32_t, float, float)> t(kFile, "contact_step_t");
  EXPECT_NEAR(t(1u, 2u, 0.0f, 4.0f), 0.0625f, 1e-6f);
  EXPECT_EQ(t(1u, 2u, 0.0f, 2.0f), 0.25f);
  // Below 1 an exponent counts as 1; the first step without noise is at 0 whatever the exponent.
  EXPECT_EQ(t(1u, 2u, 0.0f, 0.5f), 0.5f);
  EXPECT_EQ(t(0u, 4u, 0.0f, 3.0f), 0.0f);
  // A ray shorter than max_distance is not lengthened; a direction with z = 0 is never clipped,
  // even from a receiver nearer than the near plane.
  EXPECT_EQ(len(glm::vec3(0.0f, 0.0f, -1.0f), glm::vec3(1.0f, 0.0f, 0.0f), 0.5f, 0.1f), 0.5f);
  EXPECT_EQ(len(glm::vec3(0.0f, 0.0f, -0.05f), glm::vec3(1.0f, 0.0f, 0.0f), 2.0f, 0.1f), 2.0f);
  // The screen exit stays in [0, 1] even from a start off the screen.
  ShaderFunction<float(glm::vec2, glm::vec2)> exit(kFile, "contact_screen_exit");
  EXPECT_EQ(exit(glm::vec2(1.5f, 0.5f), glm::vec2(2.0f, 0.5f)), 0.0f);
  // The occlusion window is open at both ends, and no surface (0) never occludes.
  ShaderFunction<bool(float, float, float, float)> behind(kFile, "contact_ray_behind");
  EXPECT_FALSE(behind(2.0f, 1.5f, 0.5f, 0.5f));  // delta = tolerance
  EXPECT_FALSE(behind(2.0f, 1.0f, 0.5f, 0.5f));  // delta = tolerance + thickness
  EXPECT_TRUE(behind(2.0f, 1.25f, 0.5f, 0.5f));
  EXPECT_TRUE(behind(1.0f, 0.5f, 0.1f, 1.0f));
  EXPECT_FALSE(behind(0.3f, 0.0f, 0.1f, 1.0f));
  // A fade width of 0 is no fade, at the border too.
  ShaderFunction<float(glm::vec2, float)> fade(kFile, "contact_edge_fade");
  EXPECT_EQ(fade(glm::vec2(0.0f, 0.5f), 0.0f), 1.0f);
}

}  // namespace
}  // namespace penumbra::testing
