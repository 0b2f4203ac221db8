// Extremes of shaders/penumbra/pcf.glsl: depths exactly 0 and 1 in both conventions, NaN and
// infinite coordinates (lit, never NaN), uvs outside [0, 1] (lit), receiver depths outside
// [0, 1] (clamped), every radius 0..5 and out-of-range radii and tap counts (clamped), a single
// lit texel (the footprint's exact extent), and degenerate radius / rotation / texel size.
//
// Tolerances: as in pcf_tests.cpp, 2 * 2^-subTexelPrecisionBits per normalized sum of bilinear
// compare taps (Vulkan spec, "Texel Filtering"); values that are exact sums of whole weights
// (every compare equal) get 1e-6 for float rounding of the weight sum.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <tuple>
#include <vector>

#include "reference/filter_ref.hpp"

namespace penumbra::testing {
namespace {

namespace ref = penumbra::filter_ref;

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

ref::DepthMap constant_map(int size, float depth) {
  return {size, size, std::vector<float>(static_cast<size_t>(size * size), depth)};
}

std::shared_ptr<Texture> compare_texture(const std::vector<ref::DepthMap>& layers, bool reverse_z) {
  DepthTextureDesc d;
  d.width = static_cast<uint32_t>(layers[0].width);
  d.height = static_cast<uint32_t>(layers[0].height);
  d.layers = static_cast<uint32_t>(layers.size());
  d.array = layers.size() > 1;
  d.sampler.filter = VK_FILTER_LINEAR;
  d.sampler.compare = true;
  d.sampler.compare_op = reverse_z ? VK_COMPARE_OP_GREATER_OR_EQUAL : VK_COMPARE_OP_LESS_OR_EQUAL;
  std::vector<float> all;
  for (const auto& l : layers) all.insert(all.end(), l.depth.begin(), l.depth.end());
  return make_depth_texture(d, all);
}

using GridFn = ShaderFunction<float(Sampler2DShadow, glm::vec3, int32_t, glm::vec2)>;
using GridArrayFn =
    ShaderFunction<float(Sampler2DArrayShadow, glm::vec3, int32_t, int32_t, glm::vec2)>;
using DiskFn = ShaderFunction<float(Sampler2DShadow, glm::vec3, int32_t, float, float, glm::vec2)>;
using DiskArrayFn = ShaderFunction<float(Sampler2DArrayShadow, glm::vec3, int32_t, int32_t, float,
                                         float, glm::vec2)>;

class PcfExtremesTest : public GpuTest {
 protected:
  static double tap_bound() {
    return 2.0 * std::ldexp(1.0, -static_cast<int>(ctx().info().limits.subTexelPrecisionBits));
  }

  // Every filter (grid radius 0..5, Poisson, Vogel, and their array variants on layer 1 of a
  // two-layer copy) at each coord, on `map`: one result vector per function.
  static std::vector<std::vector<float>> all_filters(const ref::DepthMap& map, bool reverse_z,
                                                     const std::vector<glm::vec3>& coords) {
    const glm::vec2 texel(1.0f / float(map.width), 1.0f / float(map.height));
    GridFn grid("penumbra/pcf.glsl", "pcf_grid");
    GridArrayFn grid_array("penumbra/pcf.glsl", "pcf_grid_array");
    DiskFn poisson("penumbra/pcf.glsl", "pcf_poisson");
    DiskFn vogel("penumbra/pcf.glsl", "pcf_vogel");
    DiskArrayFn poisson_array("penumbra/pcf.glsl", "pcf_poisson_array");
    DiskArrayFn vogel_array("penumbra/pcf.glsl", "pcf_vogel_array");
    auto tex = compare_texture({map}, reverse_z);
    // Layer 0 is the opposite extreme, so reading the wrong layer shows.
    ref::DepthMap other = map;
    for (float& d : other.depth) d = 1.0f - d;
    auto arr = compare_texture({other, map}, reverse_z);
    grid.bind(0, tex);
    poisson.bind(0, tex);
    vogel.bind(0, tex);
    grid_array.bind(0, arr);
    poisson_array.bind(0, arr);
    vogel_array.bind(0, arr);
    std::vector<std::vector<float>> out;
    for (int r = 0; r <= 5; ++r) {
      std::vector<std::tuple<glm::vec3, int32_t, glm::vec2>> g;
      std::vector<std::tuple<glm::vec3, int32_t, int32_t, glm::vec2>> ga;
      for (const auto& c : coords) {
        g.emplace_back(c, r, texel);
        ga.emplace_back(c, 1, r, texel);
      }
      out.push_back(grid.run(g));
      out.push_back(grid_array.run(ga));
    }
    std::vector<std::tuple<glm::vec3, int32_t, float, float, glm::vec2>> d;
    std::vector<std::tuple<glm::vec3, int32_t, int32_t, float, float, glm::vec2>> da;
    for (const auto& c : coords) {
      d.emplace_back(c, 16, 3.5f, 1.25f, texel);
      da.emplace_back(c, 1, 16, 3.5f, 1.25f, texel);
    }
    out.push_back(poisson.run(d));
    out.push_back(vogel.run(d));
    out.push_back(poisson_array.run(da));
    out.push_back(vogel_array.run(da));
    return out;
  }
};

// Stored depths exactly 0 and 1 against receivers exactly 0 and 1: equal depths are lit in both
// conventions (GREATER_OR_EQUAL / LESS_OR_EQUAL); otherwise the near-plane value (1 under
// reverse-Z, 0 under standard) is the blocker.
TEST_F(PcfExtremesTest, DepthZeroAndOneInBothConventions) {
  for (bool reverse_z : {true, false}) {
    for (float stored : {0.0f, 1.0f}) {
      for (float receiver : {0.0f, 1.0f}) {
        const ref::DepthMap map = constant_map(16, stored);
        std::vector<glm::vec3> coords;
        for (float u : {0.0f, 0.03125f, 0.5f, 0.77f, 1.0f})
          for (float v : {0.0f, 0.4f, 1.0f}) coords.emplace_back(u, v, receiver);
        const bool lit = reverse_z ? receiver >= stored : receiver <= stored;
        const std::vector<float> want(coords.size(), lit ? 1.0f : 0.0f);
        for (const auto& got : all_filters(map, reverse_z, coords)) {
          PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::absolute(1e-6))
              << "reverse_z " << reverse_z << " stored " << stored << " receiver " << receiver;
        }
      }
    }
  }
}

// A receiver depth beyond the planes is clamped to [0, 1]: the same as 0 or 1 exactly.
TEST_F(PcfExtremesTest, ReceiverDepthOutsideUnitRangeIsClamped) {
  Rng rng(201);
  ref::DepthMap map{24, 24, std::vector<float>(24 * 24)};
  for (float& d : map.depth) d = rng.bernoulli(0.5) ? 0.0f : (rng.bernoulli(0.5) ? 1.0f : 0.5f);
  for (bool reverse_z : {true, false}) {
    std::vector<glm::vec3> beyond, clamped;
    for (int i = 0; i < 64; ++i) {
      const glm::vec2 uv(rng.next_unit(), rng.next_unit());
      for (float z : {-0.5f, -1e30f, 1.5f, 3e20f}) {
        beyond.emplace_back(uv, z);
        clamped.emplace_back(uv, z < 0.0f ? 0.0f : 1.0f);
      }
    }
    const auto got = all_filters(map, reverse_z, beyond);
    const auto want = all_filters(map, reverse_z, clamped);
    for (size_t f = 0; f < got.size(); ++f) {
      PENUMBRA_EXPECT_ALL_NEAR(want[f], got[f], Tolerance::exact()) << "function " << f;
    }
  }
}

// NaN or infinite u, v or depth: the point is lit (1.0 exactly), never NaN, for every filter.
TEST_F(PcfExtremesTest, NonFiniteCoordinatesAreLitNeverNan) {
  // Every texel a blocker for the finite receivers used below, so a lit result is the rule's.
  for (bool reverse_z : {true, false}) {
    const ref::DepthMap map = constant_map(16, reverse_z ? 1.0f : 0.0f);
    std::vector<glm::vec3> coords;
    for (float bad : {kNan, kInf, -kInf, -kNan}) {
      coords.emplace_back(bad, 0.5f, 0.5f);
      coords.emplace_back(0.5f, bad, 0.5f);
      coords.emplace_back(0.5f, 0.5f, bad);
      coords.emplace_back(bad, bad, bad);
    }
    const std::vector<float> want(coords.size(), 1.0f);
    for (const auto& got : all_filters(map, reverse_z, coords)) {
      PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact()) << "reverse_z " << reverse_z;
    }
  }
}

// uv outside [0, 1]^2, even by one float step above 1 or by the smallest normal float below 0,
// is lit; exactly 0 and 1 are inside. (A negative denormal u is not tested: Vulkan lets a device
// flush it to -0, which is inside, and NVIDIA does.)
TEST_F(PcfExtremesTest, UvOutsideUnitSquareIsLit) {
  for (bool reverse_z : {true, false}) {
    const float receiver = 0.5f;
    const ref::DepthMap map = constant_map(16, reverse_z ? 1.0f : 0.0f);  // all blockers
    const float below = -std::numeric_limits<float>::min(), above = std::nextafter(1.0f, 2.0f);
    std::vector<glm::vec3> outside, inside;
    for (float bad : {below, above, -0.25f, 1.5f, -1e30f, 1e30f}) {
      outside.emplace_back(bad, 0.5f, receiver);
      outside.emplace_back(0.5f, bad, receiver);
      outside.emplace_back(bad, bad, receiver);
    }
    for (float edge : {0.0f, 1.0f}) {
      inside.emplace_back(edge, 0.5f, receiver);
      inside.emplace_back(0.5f, edge, receiver);
      inside.emplace_back(edge, edge, receiver);
    }
    for (const auto& got : all_filters(map, reverse_z, outside)) {
      PENUMBRA_EXPECT_ALL_NEAR(std::vector<float>(outside.size(), 1.0f), got, Tolerance::exact());
    }
    for (const auto& got : all_filters(map, reverse_z, inside)) {
      PENUMBRA_EXPECT_ALL_NEAR(std::vector<float>(inside.size(), 0.0f), got,
                               Tolerance::absolute(1e-6));
    }
  }
}

// One lit texel in an all-blocker map, for each radius 0..5: centred on it the box covers the
// whole texel (factor 1 / (2r+1)^2); moved r + 0.25 texels right (or down), the box's edge cuts
// off a quarter of it (0.75 / (2r+1)^2; both: 0.75^2); moved r + 0.75 left, only a quarter stays
// inside (0.25 / (2r+1)^2); moved r + 1.5 texels, the box misses it (0). An exact statement of
// the footprint's extent and weights.
TEST_F(PcfExtremesTest, SingleLitTexelGivesExactFootprintPerRadius) {
  const int size = 32, tx = 15, ty = 17;
  for (bool reverse_z : {true, false}) {
    const float blocker = reverse_z ? 0.9f : 0.1f, receiver = 0.5f;
    ref::DepthMap map = constant_map(size, blocker);
    map.depth[size_t(ty * size + tx)] = reverse_z ? 0.2f : 0.8f;
    GridFn grid("penumbra/pcf.glsl", "pcf_grid");
    grid.bind(0, compare_texture({map}, reverse_z));
    std::vector<std::tuple<glm::vec3, int32_t, glm::vec2>> cases;
    std::vector<float> want;
    for (int r = 0; r <= 5; ++r) {
      const double n2 = (2.0 * r + 1) * (2.0 * r + 1);
      for (auto [dx, dy, w] : {std::tuple{0.0, 0.0, 1.0},
                               {r + 0.25, 0.0, 0.75},
                               {0.0, -(r + 0.25), 0.75},
                               {r + 0.25, r + 0.25, 0.5625},
                               {-(r + 0.75), 0.0, 0.25},
                               {r + 1.5, 0.0, 0.0},
                               {0.0, r + 1.5, 0.0}}) {
        const glm::vec3 c(float((tx + 0.5 + dx) / size), float((ty + 0.5 + dy) / size), receiver);
        cases.emplace_back(c, r, glm::vec2(1.0f / size));
        want.push_back(float(w / n2));
      }
    }
    PENUMBRA_EXPECT_ALL_NEAR(want, grid.run(cases), Tolerance::absolute(tap_bound() + 1e-6),
                             [&](size_t i) { return format_tuple(cases[i]); })
        << "reverse_z " << reverse_z;
  }
}

// Radii below 0 act as 0 and above 5 as 5; disk tap counts below 1 as 1 and above the maximum as
// the maximum (32 Poisson, 64 Vogel); identical results, bit for bit.
TEST_F(PcfExtremesTest, RadiusAndTapCountsAreClamped) {
  Rng rng(202);
  ref::DepthMap map{40, 40, std::vector<float>(40 * 40)};
  for (float& d : map.depth) d = float(rng.next_unit());
  const glm::vec2 texel(1.0f / 40);
  for (bool reverse_z : {true, false}) {
    auto tex = compare_texture({map}, reverse_z);
    GridFn grid("penumbra/pcf.glsl", "pcf_grid");
    grid.bind(0, tex);
    std::vector<std::tuple<glm::vec3, int32_t, glm::vec2>> low, zero, high, five;
    for (int i = 0; i < 500; ++i) {
      const glm::vec3 c(rng.next_unit(), rng.next_unit(), rng.next_unit());
      low.emplace_back(c, i % 2 ? -1 : std::numeric_limits<int32_t>::min(), texel);
      zero.emplace_back(c, 0, texel);
      high.emplace_back(c, i % 2 ? 6 : std::numeric_limits<int32_t>::max(), texel);
      five.emplace_back(c, 5, texel);
    }
    PENUMBRA_EXPECT_ALL_NEAR(grid.run(zero), grid.run(low), Tolerance::exact());
    PENUMBRA_EXPECT_ALL_NEAR(grid.run(five), grid.run(high), Tolerance::exact());

    for (auto [name, max_taps] : {std::pair{"pcf_poisson", 32}, {"pcf_vogel", 64}}) {
      DiskFn disk("penumbra/pcf.glsl", name);
      disk.bind(0, tex);
      std::vector<std::tuple<glm::vec3, int32_t, float, float, glm::vec2>> few, one, many, max;
      for (int i = 0; i < 500; ++i) {
        const glm::vec3 c(rng.next_unit(), rng.next_unit(), rng.next_unit());
        const float radius = float(rng.next_unit() * 4), rot = float(rng.next_unit() * 6.28);
        few.emplace_back(c, i % 2 ? 0 : -7, radius, rot, texel);
        one.emplace_back(c, 1, radius, rot, texel);
        many.emplace_back(c, i % 2 ? max_taps + 1 : 100000, radius, rot, texel);
        max.emplace_back(c, max_taps, radius, rot, texel);
      }
      PENUMBRA_EXPECT_ALL_NEAR(disk.run(one), disk.run(few), Tolerance::exact()) << name;
      PENUMBRA_EXPECT_ALL_NEAR(disk.run(max), disk.run(many), Tolerance::exact()) << name;
    }
  }
}

// Degenerate disk parameters: a radius of 0 is one tap at the point (radius 0 grid); negative,
// NaN or infinite radii act as 0 and NaN / infinite rotations as 0; a zero texel size gives a
// finite factor. Nothing turns into NaN.
TEST_F(PcfExtremesTest, DegenerateDiskParametersStayFinite) {
  Rng rng(203);
  ref::DepthMap map{32, 32, std::vector<float>(32 * 32)};
  for (float& d : map.depth) d = float(rng.next_unit());
  const glm::vec2 texel(1.0f / 32);
  for (bool reverse_z : {true, false}) {
    auto tex = compare_texture({map}, reverse_z);
    GridFn grid("penumbra/pcf.glsl", "pcf_grid");
    grid.bind(0, tex);
    for (const char* name : {"pcf_poisson", "pcf_vogel"}) {
      DiskFn disk("penumbra/pcf.glsl", name);
      disk.bind(0, tex);
      std::vector<std::tuple<glm::vec3, int32_t, float, float, glm::vec2>> degenerate, zero;
      std::vector<std::tuple<glm::vec3, int32_t, glm::vec2>> one_tap;
      for (int i = 0; i < 200; ++i) {
        const glm::vec3 c(rng.next_unit(), rng.next_unit(), rng.next_unit());
        const float bad_radius = std::array{0.0f, -2.0f, kNan, kInf, -kInf}[i % 5];
        const float bad_rotation = std::array{0.0f, kNan, kInf, -kInf, 1e30f}[(i / 5) % 5];
        degenerate.emplace_back(c, 1 + i % 32, bad_radius, bad_rotation, texel);
        zero.emplace_back(c, 1 + i % 32, 0.0f, 0.0f, texel);
        one_tap.emplace_back(c, 0, texel);
      }
      const auto got = disk.run(degenerate);
      PENUMBRA_EXPECT_ALL_NEAR(disk.run(zero), got, Tolerance::absolute(1e-6)) << name;
      // Radius 0: every tap sits at the point, i.e. the radius-0 grid (one bilinear tap).
      PENUMBRA_EXPECT_ALL_NEAR(grid.run(one_tap), got, Tolerance::absolute(1e-6)) << name;

      std::vector<std::tuple<glm::vec3, int32_t, float, float, glm::vec2>> zero_texel;
      for (int i = 0; i < 64; ++i) {
        zero_texel.emplace_back(glm::vec3(rng.next_unit(), rng.next_unit(), rng.next_unit()), 8,
                                2.0f, 0.5f, std::array{glm::vec2(0.0f), glm::vec2(kNan)}[i % 2]);
      }
      for (float v : disk.run(zero_texel)) EXPECT_TRUE(v >= 0.0f && v <= 1.0f) << name << " " << v;
    }
    std::vector<std::tuple<glm::vec3, int32_t, glm::vec2>> zero_texel;
    for (int i = 0; i < 64; ++i) {
      zero_texel.emplace_back(glm::vec3(rng.next_unit(), rng.next_unit(), rng.next_unit()), i % 6,
                              std::array{glm::vec2(0.0f), glm::vec2(kNan)}[i % 2]);
    }
    for (float v : grid.run(zero_texel)) EXPECT_TRUE(v >= 0.0f && v <= 1.0f) << v;
  }
}

}  // namespace
}  // namespace penumbra::testing
