// Function-level tests of shaders/penumbra/pcf.glsl: the box-grid PCF (radius 0..5) and the
// rotated Poisson / Vogel disk PCF, for sampler2DShadow and sampler2DArrayShadow, in both depth
// conventions, against the independent references of reference/filter_ref.hpp; the half-plane
// coverage per radius; and the invariants (range, monotonic in receiver depth, symmetry).
//
// Tolerances. A compare tap's bilinear weights may be quantised to subTexelPrecisionBits (Vulkan
// spec, "Texel Filtering"): each axis' weight moves by at most 2^-bits and a tap's value (a
// bilinear blend of 0/1 compares, slope at most 1 per axis) by at most 2 * 2^-bits; a normalized
// weighted sum of taps keeps that bound. Tap positions are computed in float (uv ~ 1, so about
// 1e-5 texels at these sizes), moving a tap's value by at most 2 * 1e-5: the disk kernels get
// 1e-4 on top for that and for rounding of the sum. Texel selection exactly at a texel edge is
// implementation-defined, but with linear filtering both neighbours give the same (continuous)
// value, so the random cases need no margin.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <numbers>
#include <penumbra/shadow/types.hpp>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <tuple>
#include <vector>

#include "reference/filter_ref.hpp"
#include "vogel_offsets.hpp"

namespace penumbra::testing {
namespace {

namespace ref = penumbra::filter_ref;

constexpr float kTwoPi = 2.0f * std::numbers::pi_v<float>;

// Random depths in [0, 1], one per texel.
ref::DepthMap random_map(Rng& rng, int width, int height) {
  ref::DepthMap m{width, height, std::vector<float>(static_cast<size_t>(width * height))};
  for (float& d : m.depth) d = static_cast<float>(rng.next_unit());
  return m;
}

// A compare texture of one or more layers (array when layers.size() > 1 or array is set), linear
// filtering, clamp to edge, the convention's compare op.
std::shared_ptr<Texture> compare_texture(const std::vector<ref::DepthMap>& layers, bool reverse_z,
                                         bool array = false,
                                         VkSamplerAddressMode address =
                                             VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE) {
  DepthTextureDesc d;
  d.width = static_cast<uint32_t>(layers[0].width);
  d.height = static_cast<uint32_t>(layers[0].height);
  d.layers = static_cast<uint32_t>(layers.size());
  d.array = array || layers.size() > 1;
  d.sampler.filter = VK_FILTER_LINEAR;
  d.sampler.compare = true;
  d.sampler.compare_op = reverse_z ? VK_COMPARE_OP_GREATER_OR_EQUAL : VK_COMPARE_OP_LESS_OR_EQUAL;
  d.sampler.address = address;
  std::vector<float> all;
  for (const auto& l : layers) all.insert(all.end(), l.depth.begin(), l.depth.end());
  return make_depth_texture(d, all);
}

glm::vec2 texel_size_of(const ref::DepthMap& m) {
  return {1.0f / static_cast<float>(m.width), 1.0f / static_cast<float>(m.height)};
}

class PcfTest : public GpuTest {
 protected:
  // 2 * 2^-subTexelPrecisionBits: see the file comment.
  static double tap_bound() {
    return 2.0 * std::ldexp(1.0, -static_cast<int>(ctx().info().limits.subTexelPrecisionBits));
  }
  static double grid_bound() { return tap_bound() + 1e-5; }
  static double disk_bound() { return tap_bound() + 1e-4; }

  // Unit-disk offsets of the Poisson taps, read back from noise.glsl (tested there).
  static std::vector<std::vector<glm::dvec2>> poisson_offsets(
      const std::vector<std::pair<int, float>>& count_rotation) {
    ShaderFunction<glm::vec2(int32_t, float)> f("penumbra/noise.glsl", "rotated_poisson_sample");
    std::vector<std::tuple<int32_t, float>> in;
    for (auto [n, rot] : count_rotation)
      for (int i = 0; i < n; ++i) in.emplace_back(i, rot);
    const auto got = f.run(in);
    std::vector<std::vector<glm::dvec2>> out;
    size_t k = 0;
    for (auto [n, rot] : count_rotation) {
      out.emplace_back();
      for (int i = 0; i < n; ++i) out.back().push_back(glm::dvec2(got[k++]));
    }
    return out;
  }
};

// The filters' limits the host uses (shadow::kPcfMaxRadius and kPcfMaxPoissonTaps: the parameter
// table's ranges, a filter's reach) are the GLSL's own, read through macros the wrapper expands
// after pcf.glsl is included.
TEST_F(PcfTest, TheHostsFilterLimitsAreTheShadersConstants) {
  FunctionOptions o;
  o.prelude = "#define PCF_MAX_RADIUS() kPcfMaxRadius\n#define PCF_MAX_TAPS() kPcfMaxPoissonTaps\n";
  ShaderFunction<int32_t()> radius("penumbra/pcf.glsl", "PCF_MAX_RADIUS", o);
  ShaderFunction<int32_t()> taps("penumbra/pcf.glsl", "PCF_MAX_TAPS", o);
  EXPECT_EQ(radius(), shadow::kPcfMaxRadius);
  EXPECT_EQ(taps(), shadow::kPcfMaxPoissonTaps);
}

using GridFn = ShaderFunction<float(Sampler2DShadow, glm::vec3, int32_t, glm::vec2)>;
using GridArrayFn =
    ShaderFunction<float(Sampler2DArrayShadow, glm::vec3, int32_t, int32_t, glm::vec2)>;
using DiskFn = ShaderFunction<float(Sampler2DShadow, glm::vec3, int32_t, float, float, glm::vec2)>;
using DiskArrayFn = ShaderFunction<float(Sampler2DArrayShadow, glm::vec3, int32_t, int32_t, float,
                                         float, glm::vec2)>;

TEST_F(PcfTest, GridMatchesBoxReferenceBothConventions) {
  Rng rng(101);
  // Non-square, so a swapped axis fails.
  const ref::DepthMap map = random_map(rng, 64, 48);
  const glm::vec2 texel = texel_size_of(map);
  GridFn pcf("penumbra/pcf.glsl", "pcf_grid");
  for (bool reverse_z : {true, false}) {
    pcf.bind(0, compare_texture({map}, reverse_z));
    std::vector<std::tuple<glm::vec3, int32_t, glm::vec2>> cases;
    std::vector<float> want;
    for (int i = 0; i < 6000; ++i) {
      const glm::vec3 c(rng.next_unit(), rng.next_unit(), rng.next_unit());
      const int r = i % 6;
      cases.emplace_back(c, r, texel);
      want.push_back(
          static_cast<float>(ref::box_pcf(map, glm::dvec2(c.x, c.y), c.z, r, reverse_z)));
    }
    const auto got = pcf.run(cases);
    PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::absolute(grid_bound()),
                             [&](size_t i) { return format_tuple(cases[i]); })
        << "reverse_z " << reverse_z;
  }
}

TEST_F(PcfTest, GridArrayMatchesBoxReferencePerLayer) {
  Rng rng(102);
  std::vector<ref::DepthMap> layers;
  for (int l = 0; l < 3; ++l) layers.push_back(random_map(rng, 32, 40));
  const glm::vec2 texel = texel_size_of(layers[0]);
  GridArrayFn pcf("penumbra/pcf.glsl", "pcf_grid_array");
  for (bool reverse_z : {true, false}) {
    pcf.bind(0, compare_texture(layers, reverse_z));
    std::vector<std::tuple<glm::vec3, int32_t, int32_t, glm::vec2>> cases;
    std::vector<float> want;
    for (int i = 0; i < 6000; ++i) {
      const glm::vec3 c(rng.next_unit(), rng.next_unit(), rng.next_unit());
      const int layer = i % 3, r = (i / 3) % 6;
      cases.emplace_back(c, layer, r, texel);
      want.push_back(static_cast<float>(
          ref::box_pcf(layers[size_t(layer)], glm::dvec2(c.x, c.y), c.z, r, reverse_z)));
    }
    const auto got = pcf.run(cases);
    PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::absolute(grid_bound()),
                             [&](size_t i) { return format_tuple(cases[i]); })
        << "reverse_z " << reverse_z;
  }
}

// A half-plane occluder: texels x < 32 hold a blocker, the rest the background, and the receiver
// lies between them. The box of width 2r+1 texels centred s texels right of the edge is lit over
// the part right of the edge: coverage clamp((s + r + 0.5) / (2r + 1), 0, 1), a linear ramp.
// Windowed lookups (pcf.glsl): each layer held at an offset of a toroidal image of its size,
// sampled with repeat addressing through window = (offset, 1, 0), reads what the layer itself
// gives with clamp-to-edge addressing, taps beyond its edges included. The two sides quantise
// their tap weights apart, so they agree within twice the tap bound (as the 2D and array views
// of pcss_tests do). A power-of-two size and one that is not.
TEST_F(PcfTest, WindowedArrayLookupsReadTheLayerThroughItsToroidalImage) {
  using GridWindowFn = ShaderFunction<float(Sampler2DArrayShadow, glm::vec3, int32_t, int32_t,
                                            glm::vec2, glm::vec4)>;
  using DiskWindowFn = ShaderFunction<float(Sampler2DArrayShadow, glm::vec3, int32_t, int32_t,
                                            float, float, glm::vec2, glm::vec4)>;
  Rng rng(107);
  for (int size : {32, 24}) {
    std::vector<ref::DepthMap> layers, rolled;
    std::vector<glm::vec4> windows;
    for (int l = 0; l < 3; ++l) {
      layers.push_back(random_map(rng, size, size));
      const int ox = (7 + 11 * l) % size, oy = (size - 5 - 3 * l) % size;
      rolled.push_back(layers.back().rolled(ox, oy));
      windows.emplace_back(float(ox), float(oy), 1.0f, 0.0f);
    }
    const glm::vec2 texel = texel_size_of(layers[0]);
    GridArrayFn grid("penumbra/pcf.glsl", "pcf_grid_array");
    GridWindowFn grid_window("penumbra/pcf.glsl", "pcf_grid_array");
    DiskArrayFn poisson("penumbra/pcf.glsl", "pcf_poisson_array"),
        vogel("penumbra/pcf.glsl", "pcf_vogel_array");
    DiskWindowFn poisson_window("penumbra/pcf.glsl", "pcf_poisson_array"),
        vogel_window("penumbra/pcf.glsl", "pcf_vogel_array");
    for (bool reverse_z : {true, false}) {
      SCOPED_TRACE("size " + std::to_string(size) + ", reverse_z " + std::to_string(reverse_z));
      const auto map = compare_texture(layers, reverse_z);
      const auto image = compare_texture(rolled, reverse_z, true, VK_SAMPLER_ADDRESS_MODE_REPEAT);
      grid.bind(0, map);
      poisson.bind(0, map);
      vogel.bind(0, map);
      grid_window.bind(0, image);
      poisson_window.bind(0, image);
      vogel_window.bind(0, image);
      std::vector<std::tuple<glm::vec3, int32_t, int32_t, glm::vec2>> g;
      std::vector<std::tuple<glm::vec3, int32_t, int32_t, glm::vec2, glm::vec4>> gw;
      std::vector<std::tuple<glm::vec3, int32_t, int32_t, float, float, glm::vec2>> d;
      std::vector<std::tuple<glm::vec3, int32_t, int32_t, float, float, glm::vec2, glm::vec4>> dw;
      for (int i = 0; i < 4000; ++i) {
        // Half the cases within three texels of an edge, where the taps leave the layer.
        const bool edge = i % 2 == 0;
        const auto near_edge = [&] {
          const double t = 3.0 * rng.next_unit() / size;
          return rng.next_unit() < 0.5 ? t : 1.0 - t;
        };
        const glm::vec3 c(float(edge ? near_edge() : rng.next_unit()),
                          float(i % 4 == 0 ? near_edge() : rng.next_unit()),
                          float(rng.next_unit()));
        const int layer = i % 3, r = (i / 3) % 6;
        const float radius = float(4.0 * rng.next_unit()), rot = float(kTwoPi * rng.next_unit());
        const int taps = 1 + (i / 7) % 32;
        g.emplace_back(c, layer, r, texel);
        gw.emplace_back(c, layer, r, texel, windows[size_t(layer)]);
        d.emplace_back(c, layer, taps, radius, rot, texel);
        dw.emplace_back(c, layer, taps, radius, rot, texel, windows[size_t(layer)]);
      }
      PENUMBRA_EXPECT_ALL_NEAR(grid.run(g), grid_window.run(gw),
                               Tolerance::absolute(2 * grid_bound()),
                               [&](size_t i) { return format_tuple(gw[i]); });
      PENUMBRA_EXPECT_ALL_NEAR(poisson.run(d), poisson_window.run(dw),
                               Tolerance::absolute(2 * disk_bound()),
                               [&](size_t i) { return format_tuple(dw[i]); });
      PENUMBRA_EXPECT_ALL_NEAR(vogel.run(d), vogel_window.run(dw),
                               Tolerance::absolute(2 * disk_bound()),
                               [&](size_t i) { return format_tuple(dw[i]); });
    }
  }
}

TEST_F(PcfTest, HalfPlaneOccluderGivesLinearCoverageRampPerRadius) {
  const int size = 64, edge = 32;
  GridFn pcf("penumbra/pcf.glsl", "pcf_grid");
  for (bool reverse_z : {true, false}) {
    // Reverse-Z: closer to the light is larger.
    const float blocker = reverse_z ? 0.8f : 0.2f, background = reverse_z ? 0.1f : 0.9f;
    const float receiver = 0.5f;
    ref::DepthMap map{size, size, std::vector<float>(size * size)};
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x)
        map.depth[size_t(y * size + x)] = x < edge ? blocker : background;
    pcf.bind(0, compare_texture({map}, reverse_z));
    std::vector<std::tuple<glm::vec3, int32_t, glm::vec2>> cases;
    std::vector<float> want;
    for (int r = 0; r <= 5; ++r) {
      for (double s = -(r + 2.0); s <= r + 2.0; s += 1.0 / 32.0) {
        for (double v : {0.23, 0.5, 0.77}) {
          cases.emplace_back(glm::vec3(float((edge + s) / size), float(v), receiver), r,
                             glm::vec2(1.0f / size));
          want.push_back(float(std::clamp((s + r + 0.5) / (2 * r + 1), 0.0, 1.0)));
        }
      }
    }
    const auto got = pcf.run(cases);
    PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::absolute(grid_bound()),
                             [&](size_t i) { return format_tuple(cases[i]); })
        << "reverse_z " << reverse_z;
  }
}

// Shadow factors lie in [0, 1], and moving the receiver towards the light never darkens it: the
// taps' weights do not depend on the depth and every compare is monotonic, so this holds
// exactly (float sums of larger terms are never smaller).
TEST_F(PcfTest, FactorsInUnitIntervalAndMonotonicInReceiverDepth) {
  Rng rng(103);
  const ref::DepthMap map = random_map(rng, 48, 48);
  const glm::vec2 texel = texel_size_of(map);
  GridFn grid("penumbra/pcf.glsl", "pcf_grid");
  DiskFn poisson("penumbra/pcf.glsl", "pcf_poisson");
  DiskFn vogel("penumbra/pcf.glsl", "pcf_vogel");
  constexpr int kSteps = 24;
  for (bool reverse_z : {true, false}) {
    auto tex = compare_texture({map}, reverse_z);
    grid.bind(0, tex);
    poisson.bind(0, tex);
    vogel.bind(0, tex);
    std::vector<std::tuple<glm::vec3, int32_t, glm::vec2>> grid_cases;
    std::vector<std::tuple<glm::vec3, int32_t, float, float, glm::vec2>> disk_cases;
    for (int p = 0; p < 300; ++p) {
      const glm::vec2 uv(rng.next_unit(), rng.next_unit());
      const int r = p % 6;
      const float radius = float(rng.next_unit() * 6.0), rot = float(rng.next_unit() * kTwoPi);
      const int taps = 1 + int(rng.below(32));
      // Receiver depths from far to near the light (increasing closeness).
      for (int k = 0; k < kSteps; ++k) {
        const float t = float(k) / (kSteps - 1);
        const float depth = reverse_z ? t : 1.0f - t;
        grid_cases.emplace_back(glm::vec3(uv, depth), r, texel);
        disk_cases.emplace_back(glm::vec3(uv, depth), taps, radius, rot, texel);
      }
    }
    const std::vector<std::vector<float>> results = {grid.run(grid_cases), poisson.run(disk_cases),
                                                     vogel.run(disk_cases)};
    const char* names[] = {"pcf_grid", "pcf_poisson", "pcf_vogel"};
    for (size_t f = 0; f < results.size(); ++f) {
      const auto& got = results[f];
      size_t bad_range = 0, bad_order = 0;
      for (size_t i = 0; i < got.size(); ++i) {
        if (!(got[i] >= 0.0f && got[i] <= 1.0f)) ++bad_range;
        if (i % kSteps != 0 && got[i] < got[i - 1]) ++bad_order;
      }
      EXPECT_EQ(bad_range, 0u) << names[f] << " reverse_z " << reverse_z;
      EXPECT_EQ(bad_order, 0u) << names[f] << " reverse_z " << reverse_z;
    }
    // The sweep crosses both ends: fully shadowed (receiver at the far plane, most texels
    // closer) and fully lit (receiver at the near plane).
    EXPECT_NEAR(results[0][kSteps - 1], 1.0f, 1e-6);
  }
}

// The box kernel is symmetric: mirroring the map left-right and the point (u -> 1 - u), or
// transposing both, gives the same factor. Each side is within grid_bound of the exact value.
TEST_F(PcfTest, GridKernelIsSymmetricUnderMirrorAndTranspose) {
  Rng rng(104);
  const ref::DepthMap map = random_map(rng, 40, 56);
  const ref::DepthMap mirrored = map.mirrored_x();
  const ref::DepthMap transposed = map.transposed();
  GridFn pcf("penumbra/pcf.glsl", "pcf_grid");
  for (bool reverse_z : {true, false}) {
    std::vector<std::tuple<glm::vec3, int32_t, glm::vec2>> cases, mirror_cases, transpose_cases;
    for (int i = 0; i < 3000; ++i) {
      const glm::vec3 c(rng.next_unit(), rng.next_unit(), rng.next_unit());
      const int r = i % 6;
      cases.emplace_back(c, r, texel_size_of(map));
      mirror_cases.emplace_back(glm::vec3(1.0f - c.x, c.y, c.z), r, texel_size_of(mirrored));
      transpose_cases.emplace_back(glm::vec3(c.y, c.x, c.z), r, texel_size_of(transposed));
    }
    pcf.bind(0, compare_texture({map}, reverse_z));
    const auto got = pcf.run(cases);
    pcf.bind(0, compare_texture({mirrored}, reverse_z));
    const auto got_mirror = pcf.run(mirror_cases);
    pcf.bind(0, compare_texture({transposed}, reverse_z));
    const auto got_transpose = pcf.run(transpose_cases);
    const auto describe = [&](size_t i) { return format_tuple(cases[i]); };
    PENUMBRA_EXPECT_ALL_NEAR(got, got_mirror, Tolerance::absolute(2 * grid_bound()), describe);
    PENUMBRA_EXPECT_ALL_NEAR(got, got_transpose, Tolerance::absolute(2 * grid_bound()), describe);
  }
}

TEST_F(PcfTest, PoissonMatchesReference) {
  Rng rng(105);
  const ref::DepthMap map = random_map(rng, 64, 64);
  const glm::vec2 texel = texel_size_of(map);
  DiskFn pcf("penumbra/pcf.glsl", "pcf_poisson");
  for (bool reverse_z : {true, false}) {
    pcf.bind(0, compare_texture({map}, reverse_z));
    std::vector<std::tuple<glm::vec3, int32_t, float, float, glm::vec2>> cases;
    std::vector<std::pair<int, float>> sets;
    for (int i = 0; i < 4000; ++i) {
      const glm::vec3 c(rng.next_unit(), rng.next_unit(), rng.next_unit());
      const int taps = 1 + int(rng.below(32));
      const float radius = float(rng.next_unit() * 8.0), rot = float(rng.next_unit() * kTwoPi);
      cases.emplace_back(c, taps, radius, rot, texel);
      sets.emplace_back(taps, rot);
    }
    const auto offsets = poisson_offsets(sets);
    std::vector<float> want;
    for (size_t i = 0; i < cases.size(); ++i) {
      const auto& [c, taps, radius, rot, ts] = cases[i];
      want.push_back(
          float(ref::disk_pcf(map, glm::dvec2(c.x, c.y), c.z, offsets[i], radius, reverse_z)));
    }
    const auto got = pcf.run(cases);
    PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::absolute(disk_bound()),
                             [&](size_t i) { return format_tuple(cases[i]); })
        << "reverse_z " << reverse_z;
  }
}

TEST_F(PcfTest, VogelMatchesReference) {
  Rng rng(106);
  const ref::DepthMap map = random_map(rng, 64, 64);
  const glm::vec2 texel = texel_size_of(map);
  DiskFn pcf("penumbra/pcf.glsl", "pcf_vogel");
  for (bool reverse_z : {true, false}) {
    pcf.bind(0, compare_texture({map}, reverse_z));
    std::vector<std::tuple<glm::vec3, int32_t, float, float, glm::vec2>> cases;
    std::vector<std::pair<int, float>> sets;
    for (int i = 0; i < 4000; ++i) {
      const glm::vec3 c(rng.next_unit(), rng.next_unit(), rng.next_unit());
      const int taps = 1 + int(rng.below(64));
      const float radius = float(rng.next_unit() * 12.0), rot = float(rng.next_unit() * kTwoPi);
      cases.emplace_back(c, taps, radius, rot, texel);
      sets.emplace_back(taps, rot);
    }
    const auto offsets = vogel_offsets(sets);
    std::vector<float> want;
    for (size_t i = 0; i < cases.size(); ++i) {
      const auto& [c, taps, radius, rot, ts] = cases[i];
      want.push_back(
          float(ref::disk_pcf(map, glm::dvec2(c.x, c.y), c.z, offsets[i], radius, reverse_z)));
    }
    const auto got = pcf.run(cases);
    PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::absolute(disk_bound()),
                             [&](size_t i) { return format_tuple(cases[i]); })
        << "reverse_z " << reverse_z;
  }
}

TEST_F(PcfTest, DiskArrayVariantsMatchReferencePerLayer) {
  Rng rng(107);
  std::vector<ref::DepthMap> layers;
  for (int l = 0; l < 4; ++l) layers.push_back(random_map(rng, 32, 32));
  const glm::vec2 texel = texel_size_of(layers[0]);
  DiskArrayFn poisson("penumbra/pcf.glsl", "pcf_poisson_array");
  DiskArrayFn vogel("penumbra/pcf.glsl", "pcf_vogel_array");
  for (bool reverse_z : {true, false}) {
    auto tex = compare_texture(layers, reverse_z);
    poisson.bind(0, tex);
    vogel.bind(0, tex);
    std::vector<std::tuple<glm::vec3, int32_t, int32_t, float, float, glm::vec2>> cases;
    std::vector<std::pair<int, float>> sets;
    for (int i = 0; i < 3000; ++i) {
      const glm::vec3 c(rng.next_unit(), rng.next_unit(), rng.next_unit());
      const int taps = 1 + int(rng.below(32));
      const float radius = float(rng.next_unit() * 5.0), rot = float(rng.next_unit() * kTwoPi);
      cases.emplace_back(c, i % 4, taps, radius, rot, texel);
      sets.emplace_back(taps, rot);
    }
    const auto p_off = poisson_offsets(sets);
    const auto v_off = vogel_offsets(sets);
    std::vector<float> want_p, want_v;
    for (size_t i = 0; i < cases.size(); ++i) {
      const auto& [c, layer, taps, radius, rot, ts] = cases[i];
      const auto& m = layers[size_t(layer)];
      want_p.push_back(
          float(ref::disk_pcf(m, glm::dvec2(c.x, c.y), c.z, p_off[i], radius, reverse_z)));
      want_v.push_back(
          float(ref::disk_pcf(m, glm::dvec2(c.x, c.y), c.z, v_off[i], radius, reverse_z)));
    }
    const auto describe = [&](size_t i) { return format_tuple(cases[i]); };
    PENUMBRA_EXPECT_ALL_NEAR(want_p, poisson.run(cases), Tolerance::absolute(disk_bound()),
                             describe)
        << "pcf_poisson_array reverse_z " << reverse_z;
    PENUMBRA_EXPECT_ALL_NEAR(want_v, vogel.run(cases), Tolerance::absolute(disk_bound()), describe)
        << "pcf_vogel_array reverse_z " << reverse_z;
  }
}

// The umbrella shadow.glsl (cascade, bias and the filters together) compiles and exposes the
// same filter functions: identical results through either include.
TEST_F(PcfTest, UmbrellaShadowGlslExposesTheFilters) {
  Rng rng(109);
  const ref::DepthMap map = random_map(rng, 32, 32);
  auto tex = compare_texture({map}, true);
  GridFn direct("penumbra/pcf.glsl", "pcf_grid");
  GridFn umbrella("penumbra/shadow.glsl", "pcf_grid");
  direct.bind(0, tex);
  umbrella.bind(0, tex);
  std::vector<std::tuple<glm::vec3, int32_t, glm::vec2>> cases;
  for (int i = 0; i < 500; ++i) {
    cases.emplace_back(glm::vec3(rng.next_unit(), rng.next_unit(), rng.next_unit()), i % 6,
                       texel_size_of(map));
  }
  PENUMBRA_EXPECT_ALL_NEAR(direct.run(cases), umbrella.run(cases), Tolerance::exact());
  ShaderFunction<float(glm::vec2, float, float, float, bool)> vsm("penumbra/shadow.glsl",
                                                                  "vsm_shadow");
  EXPECT_EQ(vsm(glm::vec2(0.5f, 0.25f), 0.5f, 1e-4f, 0.0f, true), 1.0f);
  ShaderFunction<int32_t(int32_t)> taps("penumbra/shadow.glsl", "pcss_filter_tap_count");
  EXPECT_EQ(taps(1), 32);
}

// The reference itself can tell a wrong kernel apart: a grid filter that forgot the half-texel
// shift (boxes centred on texel corners) differs from it by far more than the bound.
TEST_F(PcfTest, ReferenceDetectsAHalfTexelShift) {
  Rng rng(108);
  const ref::DepthMap map = random_map(rng, 32, 32);
  size_t far_off = 0;
  for (int i = 0; i < 500; ++i) {
    const glm::dvec2 uv(0.1 + 0.8 * rng.next_unit(), 0.1 + 0.8 * rng.next_unit());
    const float d = float(rng.next_unit());
    const double a = ref::box_pcf(map, uv, d, 1, true);
    const double b = ref::box_pcf(map, uv + glm::dvec2(0.5 / 32.0), d, 1, true);
    if (std::abs(a - b) > 10 * grid_bound()) ++far_off;
  }
  EXPECT_GT(far_off, 100u);
}

// The guards every PCF filter shares: the last step is lit for a non-finite value; a rotation
// that is not finite is no rotation; tap counts are clamped to [1, the table's size].
TEST_F(PcfTest, GuardsOfTheFilters) {
  ShaderFunction<float(float)> saturate("penumbra/pcf.glsl", "pcf_saturate_or_lit");
  EXPECT_EQ(saturate(std::numeric_limits<float>::quiet_NaN()), 1.0f);
  EXPECT_EQ(saturate(-0.5f), 0.0f);
  ShaderFunction<glm::vec2(float)> rotation("penumbra/pcf.glsl", "pcf_rotation_cos_sin");
  EXPECT_EQ(rotation(std::numeric_limits<float>::quiet_NaN()), glm::vec2(1.0f, 0.0f));
  EXPECT_EQ(rotation(std::numeric_limits<float>::infinity()), glm::vec2(1.0f, 0.0f));
  Rng rng(108);
  const std::vector<ref::DepthMap> layers{random_map(rng, 32, 32), random_map(rng, 32, 32)};
  const glm::vec2 texel = texel_size_of(layers[0]);
  DiskArrayFn poisson("penumbra/pcf.glsl", "pcf_poisson_array");
  DiskArrayFn vogel("penumbra/pcf.glsl", "pcf_vogel_array");
  const auto tex = compare_texture(layers, true);
  poisson.bind(0, tex);
  vogel.bind(0, tex);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int k = 0; k < 16; ++k) {
    const glm::vec3 c(rng.next_unit(), rng.next_unit(), rng.next_unit());
    SCOPED_TRACE(format_value(c));
    for (DiskArrayFn* f : {&poisson, &vogel}) {
      const int most = f == &poisson ? 32 : 64;
      EXPECT_EQ((*f)(c, 1, 0, 3.0f, 0.5f, texel), (*f)(c, 1, 1, 3.0f, 0.5f, texel));
      EXPECT_EQ((*f)(c, 1, -5, 3.0f, 0.5f, texel), (*f)(c, 1, 1, 3.0f, 0.5f, texel));
      EXPECT_EQ((*f)(c, 1, 1000, 3.0f, 0.5f, texel), (*f)(c, 1, most, 3.0f, 0.5f, texel));
      EXPECT_EQ((*f)(c, 1, 12, 3.0f, nan, texel), (*f)(c, 1, 12, 3.0f, 0.0f, texel));
    }
  }
}

}  // namespace
}  // namespace penumbra::testing
