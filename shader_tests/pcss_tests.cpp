// Function-level tests of shaders/penumbra/pcss.glsl: tiers, the blocker-search radius and the
// penumbra estimate against the geometry, the blocker search and the whole PCSS against the
// reference of reference/filter_ref.hpp (both depth conventions, every tier), the array variants,
// and the known configuration: a planar blocker at height h over a receiver plane under an
// orthographic light gives a penumbra 2 h tan(theta / 2) wide, measured from the shadow-factor
// profile across the edge and read from the estimate function.
//
// Tolerances. Filtered factors: 2 * 2^-subTexelPrecisionBits for the bilinear compare taps
// (Vulkan spec, "Texel Filtering": a normalized sum of taps whose weights are quantised keeps
// that bound), plus 2e-4 for float tap positions and the float mean blocker depth (it moves the
// filter radius by ~1e-6 relative, a few 1e-5 texels, and a tap's value by at most twice its
// displacement in texels). Radii and widths: 1e-5 relative (a handful of float operations on
// exact float inputs). Blocker searches read texels with texelFetch at floor(uv * size): the
// texel is exact except where a float-rounded tap lands within 1e-3 texels of a texel edge, where
// either neighbour is right; the reference flags those cases when the neighbours differ and they
// are skipped (a few percent; the test checks that most cases are compared).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <limits>
#include <memory>
#include <numbers>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <tuple>
#include <vector>

#include "reference/filter_ref.hpp"
#include "vogel_offsets.hpp"

PENUMBRA_GLSL_STRUCT(penumbra::filter_ref::PcssParams, "PcssParams", tan_half_angle,
                     texel_world_size, depth_near, depth_far, max_search_texels, min_filter_texels,
                     max_filter_texels, confidence_fraction);

namespace penumbra::testing {
namespace {

namespace ref = penumbra::filter_ref;
using Params = ref::PcssParams;

constexpr float kTwoPi = 2.0f * std::numbers::pi_v<float>;

// A light-space scene: ground at depth `ground` plus `boxes` rectangles of blockers closer to
// the light (larger depths under reverse-Z); standard depth mirrors every depth (1 - d). Large
// constant regions keep most blocker-search taps away from texels that differ from their
// neighbours.
ref::DepthMap scene_map(Rng& rng, int width, int height, int boxes, bool reverse_z) {
  const float ground = 0.2f;
  ref::DepthMap m{width, height, std::vector<float>(size_t(width * height), ground)};
  for (int b = 0; b < boxes; ++b) {
    const int w = 2 + int(rng.below(18)), h = 2 + int(rng.below(18));
    const int x0 = int(rng.below(uint64_t(width))), y0 = int(rng.below(uint64_t(height)));
    const float depth = float(0.25 + 0.65 * rng.next_unit());
    for (int y = y0; y < std::min(height, y0 + h); ++y)
      for (int x = x0; x < std::min(width, x0 + w); ++x) m.depth[size_t(y * width + x)] = depth;
  }
  if (!reverse_z)
    for (float& d : m.depth) d = 1.0f - d;
  return m;
}

std::shared_ptr<Texture> compare_texture(const std::vector<ref::DepthMap>& layers, bool reverse_z,
                                         bool array = false,
                                         VkSamplerAddressMode address =
                                             VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE) {
  DepthTextureDesc d;
  d.width = uint32_t(layers[0].width);
  d.height = uint32_t(layers[0].height);
  d.layers = uint32_t(layers.size());
  d.array = array || layers.size() > 1;
  d.sampler.filter = VK_FILTER_LINEAR;
  d.sampler.compare = true;
  d.sampler.compare_op = reverse_z ? VK_COMPARE_OP_GREATER_OR_EQUAL : VK_COMPARE_OP_LESS_OR_EQUAL;
  d.sampler.address = address;
  std::vector<float> all;
  for (const auto& l : layers) all.insert(all.end(), l.depth.begin(), l.depth.end());
  return make_depth_texture(d, all);
}

// The same image through a non-compare sampler, for raw reads.
std::shared_ptr<Texture> raw_texture(const std::vector<ref::DepthMap>& layers, bool array = false) {
  DepthTextureDesc d;
  d.width = uint32_t(layers[0].width);
  d.height = uint32_t(layers[0].height);
  d.layers = uint32_t(layers.size());
  d.array = array || layers.size() > 1;
  d.sampler.compare = false;
  std::vector<float> all;
  for (const auto& l : layers) all.insert(all.end(), l.depth.begin(), l.depth.end());
  return make_depth_texture(d, all);
}

glm::vec2 texel_size_of(const ref::DepthMap& m) {
  return {1.0f / float(m.width), 1.0f / float(m.height)};
}

// Receiver depth for a "distance from the light" fraction f (0 at the near plane).
float depth_at(double f, bool reverse_z) {
  return float(reverse_z ? 1.0 - f : f);
}

Params random_params(Rng& rng) {
  Params p;
  p.tan_half_angle = float(0.002 + 0.05 * rng.next_unit());
  p.texel_world_size = float(0.01 + 0.1 * rng.next_unit());
  p.depth_near = float(-20.0 + 40.0 * rng.next_unit());
  p.depth_far = p.depth_near + float(5.0 + 100.0 * rng.next_unit());
  p.max_search_texels = float(4.0 + 28.0 * rng.next_unit());
  p.min_filter_texels = float(rng.next_unit());
  p.max_filter_texels = float(4.0 + 20.0 * rng.next_unit());
  p.confidence_fraction = float(0.5 * rng.next_unit());
  return p;
}

using SearchFn = ShaderFunction<void(Sampler2D, glm::vec3, float, int32_t, float, glm::vec2, bool,
                                     Out<float>, Out<int32_t>)>;
using SearchArrayFn = ShaderFunction<void(Sampler2DArray, glm::vec3, int32_t, float, int32_t, float,
                                          glm::vec2, bool, Out<float>, Out<int32_t>)>;
using PcssFn = ShaderFunction<float(Sampler2DShadow, Sampler2D, glm::vec3, glm::vec2, Params,
                                    int32_t, float, bool)>;
using PcssArrayFn = ShaderFunction<float(Sampler2DArrayShadow, Sampler2DArray, glm::vec3, int32_t,
                                         glm::vec2, Params, int32_t, float, bool)>;

class PcssTest : public GpuTest {
 protected:
  static double tap_bound() {
    return 2.0 * std::ldexp(1.0, -static_cast<int>(ctx().info().limits.subTexelPrecisionBits));
  }
  static double filter_bound() { return tap_bound() + 2e-4; }
};

TEST_F(PcssTest, TiersGiveTheirTapCountsAndClamp) {
  ShaderFunction<int32_t(int32_t)> search("penumbra/pcss.glsl", "pcss_search_tap_count");
  ShaderFunction<int32_t(int32_t)> filter("penumbra/pcss.glsl", "pcss_filter_tap_count");
  const std::vector<std::tuple<int32_t>> tiers = {
      {std::numeric_limits<int32_t>::min()}, {-1}, {0}, {1}, {2}, {3},
      {std::numeric_limits<int32_t>::max()}};
  EXPECT_EQ(search.run(tiers), (std::vector<int32_t>{8, 8, 8, 16, 32, 32, 32}));
  EXPECT_EQ(filter.run(tiers), (std::vector<int32_t>{16, 16, 16, 32, 64, 64, 64}));
}

// Search radius = (distance from the receiver to the near plane) * tan(theta / 2) / texel world
// size, clamped to [0, max_search_texels].
TEST_F(PcssTest, SearchRadiusFollowsTheLightCone) {
  Rng rng(301);
  ShaderFunction<float(float, Params, bool)> f("penumbra/pcss.glsl", "pcss_search_radius_texels");
  std::vector<std::tuple<float, Params, bool>> cases;
  std::vector<float> want;
  for (int i = 0; i < 4000; ++i) {
    Params p = random_params(rng);
    if (i % 2) p.max_search_texels = 1e6f;  // half unclamped
    const bool reverse_z = i % 4 < 2;
    const float d = float(rng.next_unit());
    cases.emplace_back(d, p, reverse_z);
    const double to_near = (reverse_z ? 1.0 - d : double(d)) * (double(p.depth_far) - p.depth_near);
    want.push_back(float(
        std::min(to_near * p.tan_half_angle / p.texel_world_size, double(p.max_search_texels))));
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, f.run(cases), Tolerance::relative(1e-5, 1e-6),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

// The estimate: w = 2 d tan(theta / 2) world units for a blocker d above the receiver, d the
// depth difference times the depth range; in texels w / texel_world_size; filter radius w / 2
// clamped to [min, max] filter texels.
TEST_F(PcssTest, PenumbraEstimateIsTwoDTanHalfTheta) {
  Rng rng(302);
  ShaderFunction<float(float, float)> width("penumbra/pcss.glsl", "pcss_penumbra_width");
  ShaderFunction<float(float, float, Params, bool)> texels("penumbra/pcss.glsl",
                                                           "pcss_penumbra_width_texels");
  ShaderFunction<float(float, float, Params, bool)> radius("penumbra/pcss.glsl",
                                                           "pcss_filter_radius_texels");
  std::vector<std::tuple<float, float>> wc;
  std::vector<float> ww;
  std::vector<std::tuple<float, float, Params, bool>> tc;
  std::vector<float> tw, rw;
  for (int i = 0; i < 4000; ++i) {
    const float d = float(100.0 * rng.next_unit()), t = float(0.1 * rng.next_unit());
    wc.emplace_back(i % 10 == 0 ? -d : d, t);
    ww.push_back(i % 10 == 0 ? 0.0f : float(2.0 * d * t));

    const Params p = random_params(rng);
    const bool reverse_z = i % 2 == 0;
    const float receiver = float(rng.next_unit()), blocker = float(rng.next_unit());
    tc.emplace_back(receiver, blocker, p, reverse_z);
    const double closer =
        std::max(reverse_z ? double(blocker) - receiver : double(receiver) - blocker, 0.0);
    const double w =
        2.0 * closer * (double(p.depth_far) - p.depth_near) * p.tan_half_angle / p.texel_world_size;
    tw.push_back(float(w));
    rw.push_back(
        float(std::clamp(w / 2, double(p.min_filter_texels), double(p.max_filter_texels))));
  }
  PENUMBRA_EXPECT_ALL_NEAR(ww, width.run(wc), Tolerance::relative(1e-6));
  const auto describe = [&](size_t i) { return format_tuple(tc[i]); };
  PENUMBRA_EXPECT_ALL_NEAR(tw, texels.run(tc), Tolerance::relative(1e-5, 1e-6), describe);
  PENUMBRA_EXPECT_ALL_NEAR(rw, radius.run(tc), Tolerance::relative(1e-5, 1e-6), describe);
}

TEST_F(PcssTest, BlockerSearchMatchesReference) {
  Rng rng(303);
  SearchFn search("penumbra/pcss.glsl", "pcss_blocker_search");
  for (bool reverse_z : {true, false}) {
    const ref::DepthMap map = scene_map(rng, 96, 80, 40, reverse_z);
    search.bind(0, raw_texture({map}));
    const glm::vec2 texel = texel_size_of(map);
    std::vector<std::tuple<glm::vec3, float, int32_t, float, glm::vec2, bool>> cases;
    std::vector<std::pair<int, float>> sets;
    for (int i = 0; i < 5000; ++i) {
      const glm::vec3 c(rng.next_unit(), rng.next_unit(),
                        depth_at(0.45 + 0.5 * rng.next_unit(), reverse_z));
      const int taps = 1 + int(rng.below(64));
      const float radius = float(20.0 * rng.next_unit()), rot = float(kTwoPi * rng.next_unit());
      cases.emplace_back(c, radius, taps, rot, texel, reverse_z);
      sets.emplace_back(taps, rot);
    }
    const auto offsets = vogel_offsets(sets);
    const auto got = search.run(cases);
    std::vector<std::tuple<float, int32_t>> want, got_checked;
    size_t skipped = 0, with_blockers = 0, all_blockers = 0;
    for (size_t i = 0; i < cases.size(); ++i) {
      const auto& [c, radius, taps, rot, ts, rz] = cases[i];
      const auto s = ref::blocker_search(map, {c.x, c.y}, c.z, offsets[i], radius, reverse_z);
      if (s.ambiguous) {
        ++skipped;
        continue;
      }
      with_blockers += s.count > 0;
      all_blockers += s.count == taps;
      want.emplace_back(float(s.average), s.count);
      got_checked.push_back(got[i]);
    }
    // The mean of up to 64 depths <= 1 summed in float: within 64 * 2^-24 of exact.
    PENUMBRA_EXPECT_ALL_NEAR(want, got_checked, Tolerance::absolute(1e-5))
        << "reverse_z " << reverse_z;
    std::cout << "[ search ] reverse_z " << reverse_z << ": compared " << want.size() << " of "
              << cases.size() << " cases (" << skipped
              << " with a tap within 1e-3 texel of an edge "
              << "between differing texels)\n";
    EXPECT_LT(skipped, cases.size() / 10) << "too many cases near texel edges";
    // The cases exercise both outcomes.
    EXPECT_GT(with_blockers, cases.size() / 4);
    EXPECT_GT(all_blockers, cases.size() / 50);
    EXPECT_LT(with_blockers, cases.size() - cases.size() / 10);
  }
}

TEST_F(PcssTest, PcssMatchesReferenceEveryTierBothConventions) {
  Rng rng(304);
  PcssFn pcss("penumbra/pcss.glsl", "pcss_shadow");
  for (bool reverse_z : {true, false}) {
    const ref::DepthMap map = scene_map(rng, 128, 96, 50, reverse_z);
    pcss.bind(0, compare_texture({map}, reverse_z)).bind(1, raw_texture({map}));
    const glm::vec2 texel = texel_size_of(map);
    std::vector<std::tuple<glm::vec3, glm::vec2, Params, int32_t, float, bool>> cases;
    std::vector<std::pair<int, float>> sets;
    for (int i = 0; i < 6000; ++i) {
      const glm::vec3 c(rng.next_unit(), rng.next_unit(),
                        depth_at(0.45 + 0.5 * rng.next_unit(), reverse_z));
      Params p = random_params(rng);
      if (i % 5 == 0) p.confidence_fraction = 0.0f;  // no fade
      const int tier = i % 3;
      const float rot = float(kTwoPi * rng.next_unit());
      cases.emplace_back(c, texel, p, tier, rot, reverse_z);
      sets.emplace_back(ref::pcss_search_taps(tier), rot);
      sets.emplace_back(ref::pcss_filter_taps(tier), rot);
    }
    const auto offsets = vogel_offsets(sets);
    const auto got = pcss.run(cases);
    std::vector<float> want, got_checked;
    std::vector<size_t> index;
    size_t skipped = 0, lit_early = 0, dark_early = 0, filtered = 0;
    for (size_t i = 0; i < cases.size(); ++i) {
      const auto& [c, ts, p, tier, rot, rz] = cases[i];
      const auto r =
          ref::pcss(map, {c.x, c.y}, c.z, p, offsets[2 * i], offsets[2 * i + 1], reverse_z);
      if (r.ambiguous) {
        ++skipped;
        continue;
      }
      lit_early += r.blockers == 0;
      dark_early += r.blockers == ref::pcss_search_taps(tier) && r.filter_radius <= r.search_radius;
      filtered += r.shadow > 0.0 && r.shadow < 1.0;
      want.push_back(float(r.shadow));
      got_checked.push_back(got[i]);
      index.push_back(i);
    }
    PENUMBRA_EXPECT_ALL_NEAR(want, got_checked, Tolerance::absolute(filter_bound()),
                             [&](size_t k) { return format_tuple(cases[index[k]]); })
        << "reverse_z " << reverse_z;
    std::cout << "[ pcss ] reverse_z " << reverse_z << ": compared " << want.size() << " of "
              << cases.size() << " cases (" << lit_early << " no-blocker, " << dark_early
              << " all-blocker early-outs, " << filtered << " partially lit)\n";
    EXPECT_LT(skipped, cases.size() / 10);
    // Every path is exercised.
    EXPECT_GT(lit_early, cases.size() / 20);
    EXPECT_GT(dark_early, cases.size() / 50);
    EXPECT_GT(filtered, cases.size() / 5);
    for (float v : got) ASSERT_TRUE(v >= 0.0f && v <= 1.0f) << v;
  }
}

// The array variants on layer 1 of a three-layer map equal the 2D functions on that layer's data.
TEST_F(PcssTest, ArrayVariantsMatchThe2DFunctionsPerLayer) {
  Rng rng(305);
  for (bool reverse_z : {true, false}) {
    std::vector<ref::DepthMap> layers;
    for (int l = 0; l < 3; ++l) layers.push_back(scene_map(rng, 64, 64, 20, reverse_z));
    const glm::vec2 texel = texel_size_of(layers[0]);
    for (int layer = 0; layer < 3; ++layer) {
      PcssFn pcss("penumbra/pcss.glsl", "pcss_shadow");
      PcssArrayFn pcss_array("penumbra/pcss.glsl", "pcss_shadow_array");
      SearchFn search("penumbra/pcss.glsl", "pcss_blocker_search");
      SearchArrayFn search_array("penumbra/pcss.glsl", "pcss_blocker_search_array");
      pcss.bind(0, compare_texture({layers[size_t(layer)]}, reverse_z))
          .bind(1, raw_texture({layers[size_t(layer)]}));
      pcss_array.bind(0, compare_texture(layers, reverse_z)).bind(1, raw_texture(layers));
      search.bind(0, raw_texture({layers[size_t(layer)]}));
      search_array.bind(0, raw_texture(layers));
      std::vector<std::tuple<glm::vec3, glm::vec2, Params, int32_t, float, bool>> flat;
      std::vector<std::tuple<glm::vec3, int32_t, glm::vec2, Params, int32_t, float, bool>> arr;
      std::vector<std::tuple<glm::vec3, float, int32_t, float, glm::vec2, bool>> sflat;
      std::vector<std::tuple<glm::vec3, int32_t, float, int32_t, float, glm::vec2, bool>> sarr;
      for (int i = 0; i < 1000; ++i) {
        const glm::vec3 c(rng.next_unit(), rng.next_unit(),
                          depth_at(0.5 + 0.45 * rng.next_unit(), reverse_z));
        const Params p = random_params(rng);
        const float rot = float(kTwoPi * rng.next_unit()), radius = float(12 * rng.next_unit());
        flat.emplace_back(c, texel, p, i % 3, rot, reverse_z);
        arr.emplace_back(c, layer, texel, p, i % 3, rot, reverse_z);
        sflat.emplace_back(c, radius, 1 + i % 64, rot, texel, reverse_z);
        sarr.emplace_back(c, layer, radius, 1 + i % 64, rot, texel, reverse_z);
      }
      PENUMBRA_EXPECT_ALL_NEAR(search.run(sflat), search_array.run(sarr), Tolerance::exact());
      // The same taps through a 2D and an array view: within twice the tap bound of each other.
      PENUMBRA_EXPECT_ALL_NEAR(pcss.run(flat), pcss_array.run(arr),
                               Tolerance::absolute(2 * tap_bound()));
    }
  }
}

// Windowed lookups (pcf.glsl): each layer held at an offset of a toroidal image of its size,
// read through window = (offset, 1, 0) with repeat addressing: the blocker search finds exactly
// what it finds in the layer itself (texelFetch), and PCSS agrees within twice the tap bound (its
// taps quantise their weights apart), search disks crossing the edges included.
TEST_F(PcssTest, WindowedArrayLookupsReadTheLayerThroughItsToroidalImage) {
  using SearchWindowFn =
      ShaderFunction<void(Sampler2DArray, glm::vec3, int32_t, float, int32_t, float, glm::vec2,
                          bool, glm::vec4, Out<float>, Out<int32_t>)>;
  using PcssWindowFn = ShaderFunction<float(Sampler2DArrayShadow, Sampler2DArray, glm::vec3, int32_t,
                                            glm::vec2, Params, int32_t, float, bool, glm::vec4)>;
  Rng rng(306);
  for (bool reverse_z : {true, false}) {
    SCOPED_TRACE("reverse_z " + std::to_string(reverse_z));
    std::vector<ref::DepthMap> layers, rolled;
    std::vector<glm::vec4> windows;
    for (int l = 0; l < 3; ++l) {
      layers.push_back(scene_map(rng, 64, 64, 20, reverse_z));
      rolled.push_back(layers.back().rolled(13 + 20 * l, 63 - 9 * l));
      windows.emplace_back(float(13 + 20 * l), float(63 - 9 * l), 1.0f, 0.0f);
    }
    const glm::vec2 texel = texel_size_of(layers[0]);
    SearchArrayFn search("penumbra/pcss.glsl", "pcss_blocker_search_array");
    SearchWindowFn search_window("penumbra/pcss.glsl", "pcss_blocker_search_array");
    PcssArrayFn pcss("penumbra/pcss.glsl", "pcss_shadow_array");
    PcssWindowFn pcss_window("penumbra/pcss.glsl", "pcss_shadow_array");
    search.bind(0, raw_texture(layers));
    pcss.bind(0, compare_texture(layers, reverse_z)).bind(1, raw_texture(layers));
    search_window.bind(0, raw_texture(rolled));
    pcss_window.bind(0, compare_texture(rolled, reverse_z, true, VK_SAMPLER_ADDRESS_MODE_REPEAT))
        .bind(1, raw_texture(rolled));
    std::vector<std::tuple<glm::vec3, int32_t, float, int32_t, float, glm::vec2, bool>> s;
    std::vector<std::tuple<glm::vec3, int32_t, float, int32_t, float, glm::vec2, bool, glm::vec4>>
        sw;
    std::vector<std::tuple<glm::vec3, int32_t, glm::vec2, Params, int32_t, float, bool>> p;
    std::vector<std::tuple<glm::vec3, int32_t, glm::vec2, Params, int32_t, float, bool, glm::vec4>>
        pw;
    for (int i = 0; i < 2000; ++i) {
      // Half the cases within eight texels of an edge.
      const auto coordinate = [&](bool edge) {
        if (!edge) return rng.next_unit();
        const double t = 8.0 * rng.next_unit() / 64.0;
        return rng.next_unit() < 0.5 ? t : 1.0 - t;
      };
      const glm::vec3 c(float(coordinate(i % 2 == 0)), float(coordinate(i % 4 == 0)),
                        depth_at(0.5 + 0.45 * rng.next_unit(), reverse_z));
      const int layer = i % 3;
      const Params params = random_params(rng);
      const float rot = float(kTwoPi * rng.next_unit()), radius = float(12 * rng.next_unit());
      const glm::vec4 w = windows[size_t(layer)];
      s.emplace_back(c, layer, radius, 1 + i % 64, rot, texel, reverse_z);
      sw.emplace_back(c, layer, radius, 1 + i % 64, rot, texel, reverse_z, w);
      p.emplace_back(c, layer, texel, params, i % 3, rot, reverse_z);
      pw.emplace_back(c, layer, texel, params, i % 3, rot, reverse_z, w);
    }
    PENUMBRA_EXPECT_ALL_NEAR(search.run(s), search_window.run(sw), Tolerance::exact());
    PENUMBRA_EXPECT_ALL_NEAR(pcss.run(p), pcss_window.run(pw), Tolerance::absolute(2 * tap_bound()));
  }
}

// The lit fraction of a uniformly weighted disk of radius 1 whose centre is u (in radii) on the
// lit side of a straight edge: 1 - segment area beyond the edge.
double disk_lit_fraction(double u) {
  if (u >= 1.0) return 1.0;
  if (u <= -1.0) return 0.0;
  return 1.0 - (std::acos(u) - u * std::sqrt(1.0 - u * u)) / std::numbers::pi;
}

// Positions (in the profile's own units) where a monotonic sampled profile first reaches 0.05
// and 0.95, linearly interpolated.
std::pair<double, double> crossings(const std::vector<double>& s, const std::vector<double>& f) {
  auto first = [&](double level) {
    for (size_t i = 1; i < f.size(); ++i) {
      if (f[i - 1] < level && f[i] >= level) {
        return s[i - 1] + (level - f[i - 1]) / (f[i] - f[i - 1]) * (s[i] - s[i - 1]);
      }
    }
    return std::numeric_limits<double>::quiet_NaN();
  };
  return {first(0.05), first(0.95)};
}

// The known configuration. An orthographic light looks straight down on a receiver plane; a
// planar blocker h world units above it covers the half-plane x < edge. The penumbra across the
// blocker's edge must be w = 2 h tan(theta / 2) wide (full width, on the receiver, perpendicular
// to the light). The filter is a uniform disk of radius w / 2, so the profile across the edge is
// the disk's lit fraction, whose 5% .. 95% crossings are 2 u* (w / 2) = 0.8054 w apart (u*:
// segment area 5%). The measured width is (x95 - x05) / 0.8054. The compare taps add their
// one-texel bilinear tent and the 64-tap Vogel disk samples the disk, so the measurement is
// checked against the exact profile of disk (x) tent, within 3% plus 0.1 texel (rotation
// averaging leaves that much sampling noise), and against w within 6% + 0.25 texel.
TEST_F(PcssTest, PlanarBlockerPenumbraWidthIsTwoHTanHalfTheta) {
  const int width = 512, height = 8, edge = 256;  // rows are identical: clamping in v is exact
  const double texel_world = 0.05;
  const double near = 0.0, far = 100.0, receiver_distance = 60.0;  // from the near plane
  // u*: the disk's lit fraction is 0.05 at -u* and 0.95 at +u*.
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (disk_lit_fraction(mid) < 0.95 ? lo : hi) = mid;
  }
  const double u_star = 0.5 * (lo + hi);
  const double ideal_ratio = u_star;  // (x95 - x05) / w for the ideal disk

  struct Config {
    double theta_deg, h;
  };
  // The sun (0.53 degrees) and larger area lights; widths from ~7 to ~56 texels.
  const std::vector<Config> configs = {{0.53, 40.0}, {2.0, 20.0}, {5.0, 10.0}, {8.0, 20.0}};
  PcssFn pcss("penumbra/pcss.glsl", "pcss_shadow");
  ShaderFunction<float(float, float, Params, bool)> estimate("penumbra/pcss.glsl",
                                                             "pcss_penumbra_width_texels");
  for (bool reverse_z : {true, false}) {
    for (const Config& cfg : configs) {
      const double tan_half = std::tan(cfg.theta_deg * std::numbers::pi / 360.0);
      const double w_texels = 2.0 * cfg.h * tan_half / texel_world;
      const double f_receiver = receiver_distance / (far - near);
      const double f_blocker = (receiver_distance - cfg.h) / (far - near);
      const float d_receiver = depth_at(f_receiver, reverse_z);
      const float d_blocker = depth_at(f_blocker, reverse_z);
      ref::DepthMap map{width, height, std::vector<float>(size_t(width * height))};
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
          map.depth[size_t(y * width + x)] = x < edge ? d_blocker : d_receiver;
      pcss.bind(0, compare_texture({map}, reverse_z)).bind(1, raw_texture({map}));

      Params p;
      p.tan_half_angle = float(tan_half);
      p.texel_world_size = float(texel_world);
      p.depth_near = float(near);
      p.depth_far = float(far);
      p.max_search_texels = 200.0f;
      p.min_filter_texels = 0.0f;
      p.max_filter_texels = 200.0f;
      p.confidence_fraction = 0.0f;

      // The estimate, directly.
      const float est = estimate(d_receiver, d_blocker, p, reverse_z);
      EXPECT_NEAR(est, w_texels, 1e-4 * w_texels) << cfg.theta_deg << " deg, h " << cfg.h;

      // The profile across the edge, averaged over 32 rotations of the tap sets.
      const double half = 0.5 * w_texels + 3.0;
      const double step = std::max(0.02, w_texels / 800.0);
      std::vector<double> s;
      for (double x = -half; x <= half; x += step) s.push_back(x);
      constexpr int kRotations = 32;
      std::vector<std::tuple<glm::vec3, glm::vec2, Params, int32_t, float, bool>> cases;
      for (double x : s)
        for (int k = 0; k < kRotations; ++k)
          cases.emplace_back(glm::vec3(float((edge + x) / width), 0.5f, d_receiver),
                             glm::vec2(1.0f / width, 1.0f / height), p, 2,
                             float(kTwoPi * (k + 0.5) / kRotations), reverse_z);
      const auto got = pcss.run(cases);
      std::vector<double> profile(s.size(), 0.0);
      for (size_t i = 0; i < s.size(); ++i) {
        for (int k = 0; k < kRotations; ++k) profile[i] += got[i * kRotations + k];
        profile[i] /= kRotations;
      }
      // Fully shadowed and fully lit outside the penumbra (plus the taps' one texel).
      for (size_t i = 0; i < s.size(); ++i) {
        if (s[i] < -(0.5 * w_texels + 1.0)) {
          EXPECT_EQ(profile[i], 0.0) << s[i];
        }
        if (s[i] > 0.5 * w_texels + 1.0) {
          EXPECT_NEAR(profile[i], 1.0, 1e-6) << s[i];
        }
      }
      const auto [x05, x95] = crossings(s, profile);
      const double measured = (x95 - x05) / ideal_ratio;

      // The exact expected profile of the uniform disk (radius w / 2) convolved with the
      // one-texel tent of a bilinear tap, and its crossings.
      const double radius = 0.5 * w_texels;
      std::vector<double> expected(s.size());
      for (size_t i = 0; i < s.size(); ++i) {
        double sum = 0.0, wsum = 0.0;
        for (int k = -200; k <= 200; ++k) {
          const double t = k / 200.0, wt = 1.0 - std::abs(t);
          sum += wt * disk_lit_fraction((s[i] + t) / radius);
          wsum += wt;
        }
        expected[i] = sum / wsum;
      }
      const auto [e05, e95] = crossings(s, expected);
      std::cout << "[ penumbra ] " << (reverse_z ? "reverse-Z" : "standard ") << " theta "
                << cfg.theta_deg << " deg, h " << cfg.h
                << ": expected w = 2 h tan(theta/2) = " << w_texels << " texels ("
                << w_texels * texel_world << " world); estimate " << est << "; profile 5-95% "
                << (x95 - x05) << " texels (disk x tent predicts " << (e95 - e05)
                << ") -> measured w " << measured << " (" << 100.0 * (measured / w_texels - 1.0)
                << "%)\n";
      EXPECT_NEAR(x95 - x05, e95 - e05, 0.03 * (e95 - e05) + 0.1) << cfg.theta_deg;
      EXPECT_NEAR(measured, w_texels, 0.06 * w_texels + 0.25) << cfg.theta_deg;
      // The edge's centre stays at the blocker edge (symmetric penumbra).
      EXPECT_NEAR(0.5 * (x05 + x95), 0.0, 0.03 * w_texels + 0.1) << cfg.theta_deg;
    }
  }
}

// Texel reads out of range. The compare taps go through texture(), which clamps the array layer
// to [0, layers - 1]; texelFetch past the last layer is undefined (lavapipe returns 0, so PCSS
// said lit where PCF said shadowed). pcss_fetch_depth_array clamps the layer the same way, so
// both read the same layer for any layer argument, and PCSS agrees with PCF on a layer past the
// end.
TEST_F(PcssTest, ArrayLayersOutOfRangeReadTheClampedLayerLikeTheCompareTaps) {
  const std::vector<float> layer_depth = {0.2f, 0.5f, 0.8f};
  std::vector<ref::DepthMap> layers;
  for (float d : layer_depth) layers.push_back({16, 16, std::vector<float>(256, d)});
  ShaderFunction<float(Sampler2DArray, glm::vec2, int32_t)> fetch("penumbra/pcss.glsl",
                                                                  "pcss_fetch_depth_array");
  fetch.bind(0, raw_texture(layers, true));
  const std::vector<std::tuple<glm::vec2, int32_t>> cases = {
      {{0.5f, 0.5f}, -5}, {{0.5f, 0.5f}, -1}, {{0.5f, 0.5f}, 0},  {{0.5f, 0.5f}, 1},
      {{0.5f, 0.5f}, 2},  {{0.5f, 0.5f}, 3},  {{0.5f, 0.5f}, 100}};
  EXPECT_EQ(fetch.run(cases), (std::vector<float>{0.2f, 0.2f, 0.2f, 0.5f, 0.8f, 0.8f, 0.8f}));

  // Reverse-Z: the last layer's blockers (0.8) cover a receiver at 0.6; PCF (texture(), clamped)
  // and PCSS read that layer for layer 7 alike.
  ShaderFunction<float(Sampler2DArrayShadow, glm::vec3, int32_t, int32_t, glm::vec2)> pcf(
      "penumbra/pcf.glsl", "pcf_grid_array");
  pcf.bind(0, compare_texture(layers, true, true));
  PcssArrayFn pcss("penumbra/pcss.glsl", "pcss_shadow_array");
  pcss.bind(0, compare_texture(layers, true, true)).bind(1, raw_texture(layers, true));
  Params p;
  p.tan_half_angle = 0.01f;
  p.texel_world_size = 0.1f;
  p.depth_far = 100.0f;
  p.max_search_texels = 8.0f;
  p.min_filter_texels = 1.0f;
  p.max_filter_texels = 8.0f;
  const glm::vec3 c(0.5f, 0.5f, 0.6f);
  const glm::vec2 texel(1.0f / 16.0f);
  for (int32_t layer : {2, 7}) {
    EXPECT_EQ(pcf(c, layer, 1, texel), 0.0f) << "layer " << layer;
    EXPECT_EQ(pcss(c, layer, texel, p, 1, 0.0f, true), 0.0f) << "layer " << layer;
  }
}

// A receiver on a tilted plane: the map stores the plane (depth = 0.5 + g . (uv - c), standard
// depth), the receiver sits on it, moved 0.001 towards the light. The flat search finds the
// plane's near half as blockers; the search against the receiver's plane, given the plane's
// gradient, finds none, and still finds a real blocker (a square nearer the light) inside the
// disk. The nearest read quantizes the plane by half a texel, |g| / 128 < 0.0006 here, within
// the receiver's 0.001.
TEST_F(PcssTest, BlockerSearchAgainstTheReceiversPlaneIgnoresTheReceiversOwnSurface) {
  constexpr int n = 64;
  const glm::vec2 g(0.06f, -0.04f), c(0.5f, 0.5f);
  ref::DepthMap plane{n, n, {}}, blocked{n, n, {}};
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const glm::vec2 uv((float(x) + 0.5f) / float(n), (float(y) + 0.5f) / float(n));
      const float d = 0.5f + glm::dot(g, uv - c);
      plane.depth.push_back(d);
      const bool square = x >= 36 && x < 40 && y >= 30 && y < 34;  // 4-8 texels right of c
      blocked.depth.push_back(square ? 0.3f : d);
    }
  ShaderFunction<void(Sampler2DArray, glm::vec3, int32_t, float, int32_t, float, glm::vec2, bool,
                      glm::vec2, Out<float>, Out<int32_t>)>
      search("penumbra/pcss.glsl", "pcss_blocker_search_plane_array");
  search.bind(0, raw_texture({plane, blocked}, true));
  const glm::vec3 coord(c, 0.5f - 0.001f);
  const glm::vec2 texel(1.0f / float(n));
  for (float radius : {6.0f, 10.0f}) {
    SCOPED_TRACE("radius " + std::to_string(radius));
    const auto [flat_avg, flat_count] =
        search(coord, 0, radius, 64, 0.2f, texel, false, glm::vec2(0.0f));
    EXPECT_GT(flat_count, 20) << "the plane's near half";
    const auto [avg, count] = search(coord, 0, radius, 64, 0.2f, texel, false, g);
    EXPECT_EQ(count, 0);
    EXPECT_EQ(avg, coord.z);
    const auto [square_avg, square_count] = search(coord, 1, radius, 64, 0.2f, texel, false, g);
    EXPECT_GT(square_count, 0);
    EXPECT_EQ(square_avg, 0.3f);
  }
  // A gradient that is not finite gives the flat search; so does vec2(0) in the old entry point.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(search(coord, 0, 10.0f, 64, 0.2f, texel, false, glm::vec2(nan, 0.0f)),
            search(coord, 0, 10.0f, 64, 0.2f, texel, false, glm::vec2(0.0f)));
  SearchArrayFn flat("penumbra/pcss.glsl", "pcss_blocker_search_array");
  flat.bind(0, raw_texture({plane, blocked}, true));
  EXPECT_EQ(flat(coord, 0, 10.0f, 64, 0.2f, texel, false),
            search(coord, 0, 10.0f, 64, 0.2f, texel, false, glm::vec2(0.0f)));
}

// The guards for parameters outside their ranges, each against what the header promises: a NaN
// search bound gives radius 0; a NaN confidence fraction counts as 0 (one blocker is full
// confidence); no blocker never needs the filter; a receiver beyond the far plane searches as
// one on it; a rotation that is not finite is no rotation.
TEST_F(PcssTest, ParametersOutsideTheirRangesFollowTheHeader) {
  ShaderFunction<float(float, Params, bool)> radius("penumbra/pcss.glsl",
                                                    "pcss_search_radius_texels");
  Params p;
  p.tan_half_angle = 0.02f;
  p.texel_world_size = 0.05f;
  p.depth_near = 0.0f;
  p.depth_far = 50.0f;
  p.max_search_texels = std::numeric_limits<float>::quiet_NaN();
  p.min_filter_texels = 1.0f;
  p.max_filter_texels = 8.0f;
  p.confidence_fraction = 0.25f;
  EXPECT_EQ(radius(0.5f, p, false), 0.0f);
  p.max_search_texels = -3.0f;  // a negative bound counts as 0
  EXPECT_EQ(radius(0.5f, p, false), 0.0f);
  p.max_search_texels = 16.0f;
  EXPECT_GT(radius(0.5f, p, false), 0.0f);
  // A receiver beyond the depth range searches as one at its end; a zero texel (an infinite
  // radius) searches nothing.
  Params wide = p;
  wide.max_search_texels = 1000.0f;  // the radius below the bound: 20 texels at the far end
  EXPECT_EQ(radius(1.5f, wide, false), radius(1.0f, wide, false));
  EXPECT_EQ(radius(-0.5f, wide, true), radius(0.0f, wide, true));
  EXPECT_LT(radius(1.0f, wide, false), 1000.0f);
  Params zero_texel = p;
  zero_texel.texel_world_size = 0.0f;
  EXPECT_EQ(radius(0.5f, zero_texel, false), 0.0f);

  ShaderFunction<float(float, float, float)> bounded("penumbra/pcss.glsl",
                                                     "pcss_search_radius_bounded");
  EXPECT_EQ(bounded(0.0f, std::numeric_limits<float>::quiet_NaN(), 16.0f), 1.0f);
  ShaderFunction<float(float, float, Params, bool)> filter("penumbra/pcss.glsl",
                                                           "pcss_filter_radius_texels");
  Params nan_min = p;
  nan_min.min_filter_texels = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(filter(0.5f, 0.5f, nan_min, false), 0.0f);  // no blocker distance: the minimum, 0

  ShaderFunction<float(int32_t, int32_t, float)> confidence("penumbra/pcss.glsl",
                                                            "pcss_confidence");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(confidence(1, 16, nan), 1.0f);
  EXPECT_EQ(confidence(1, 16, 0.0f), 1.0f);
  EXPECT_EQ(confidence(2, 16, 0.25f), 0.5f);
  EXPECT_EQ(confidence(8, 16, 2.0f), 0.5f);  // a fraction above 1 counts as 1

  ShaderFunction<bool(int32_t, int32_t, float, float)> needs("penumbra/pcss.glsl",
                                                             "pcss_needs_filter");
  EXPECT_FALSE(needs(0, 16, 4.0f, 2.0f));
  EXPECT_TRUE(needs(3, 16, 4.0f, 2.0f));
  EXPECT_FALSE(needs(16, 16, 4.0f, 2.0f));

  // Standard depth: the left half cleared to the far plane (1), the right half a sloped caster
  // (0.3 to 0.55: the mean depth of the blockers depends on where the taps fall).
  constexpr int n = 32;
  ref::DepthMap map{n, n, {}};
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      map.depth.push_back(x < n / 2 ? 1.0f : 0.3f + 0.005f * float(x - n / 2 + 2 * y));
  SearchFn search("penumbra/pcss.glsl", "pcss_blocker_search");
  search.bind(0, raw_texture({map}));
  const glm::vec2 texel(1.0f / float(n));
  const auto at_far = search(glm::vec3(0.5f, 0.5f, 1.0f), 8.0f, 32, 0.3f, texel, false);
  EXPECT_GT(std::get<1>(at_far), 0);
  EXPECT_EQ(search(glm::vec3(0.5f, 0.5f, 1.5f), 8.0f, 32, 0.3f, texel, false), at_far);
  EXPECT_EQ(search(glm::vec3(0.5f, 0.5f, 1.0f), 8.0f, 32, nan, texel, false),
            search(glm::vec3(0.5f, 0.5f, 1.0f), 8.0f, 32, 0.0f, texel, false));
  ShaderFunction<void(Sampler2DArray, glm::vec3, int32_t, float, int32_t, float, glm::vec2, bool,
                      glm::vec2, Out<float>, Out<int32_t>)>
      plane("penumbra/pcss.glsl", "pcss_blocker_search_plane_array");
  plane.bind(0, raw_texture({map}, true));
  const glm::vec3 c(0.5f, 0.5f, 1.0f);
  const auto unrotated = plane(c, 0, 8.0f, 32, 0.0f, texel, false, glm::vec2(0.0f));
  EXPECT_NE(plane(c, 0, 8.0f, 32, 1.0f, texel, false, glm::vec2(0.0f)), unrotated)
      << "a rotation of 1 rad moves the taps (else the NaN check below proves nothing)";
  EXPECT_EQ(plane(c, 0, 8.0f, 32, nan, texel, false, glm::vec2(0.0f)), unrotated);
  EXPECT_EQ(plane(glm::vec3(0.5f, 0.5f, 1.5f), 0, 8.0f, 32, 0.0f, texel, false, glm::vec2(0.0f)),
            unrotated);
  // Tap counts are clamped to [1, 64].
  for (const glm::vec3& at : {glm::vec3(0.5f, 0.5f, 1.0f), glm::vec3(0.6f, 0.3f, 0.5f)}) {
    EXPECT_EQ(search(at, 8.0f, 0, 0.3f, texel, false), search(at, 8.0f, 1, 0.3f, texel, false));
    EXPECT_EQ(search(at, 8.0f, 500, 0.3f, texel, false), search(at, 8.0f, 64, 0.3f, texel, false));
    EXPECT_EQ(plane(at, 0, 8.0f, -2, 0.3f, texel, false, glm::vec2(0.0f)),
              plane(at, 0, 8.0f, 1, 0.3f, texel, false, glm::vec2(0.0f)));
    EXPECT_EQ(plane(at, 0, 8.0f, 500, 0.3f, texel, false, glm::vec2(0.0f)),
              plane(at, 0, 8.0f, 64, 0.3f, texel, false, glm::vec2(0.0f)));
  }
  // A coordinate off the map finds no blocker (its average is the receiver's depth).
  EXPECT_EQ(search(glm::vec3(1.5f, 0.5f, 0.7f), 8.0f, 32, 0.3f, texel, false),
            (std::tuple<float, int32_t>{0.7f, 0}));
  EXPECT_EQ(plane(glm::vec3(0.5f, -0.5f, 0.7f), 0, 8.0f, 32, 0.3f, texel, false, glm::vec2(0.0f)),
            (std::tuple<float, int32_t>{0.7f, 0}));
  // The full filter: a coordinate off the map is lit.
  PcssArrayFn pcss("penumbra/pcss.glsl", "pcss_shadow_array");
  pcss.bind(0, compare_texture({map}, false, true));
  pcss.bind(1, raw_texture({map}, true));
  EXPECT_EQ(pcss(glm::vec3(1.5f, 0.5f, 1.0f), 0, texel, p, 1, 0.0f, false), 1.0f);
  EXPECT_LT(pcss(glm::vec3(0.9f, 0.5f, 1.0f), 0, texel, p, 1, 0.0f, false), 1.0f);
}

}  // namespace
}  // namespace penumbra::testing
