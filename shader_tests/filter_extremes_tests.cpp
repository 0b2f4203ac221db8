// Extremes of shaders/penumbra/pcss.glsl and vsm.glsl: PCSS with no blocker, all blockers and a
// single blocker; receivers at depth 0 and 1 in both conventions; NaN / infinite / out-of-map
// coordinates (lit, never NaN) and degenerate parameters; VSM with zero variance and a receiver
// exactly at the mean; EVSM exponent clamping for fp16 (and fp32) moment formats.
//
// Tolerances: early-outs and the lit-when-invalid rule are exact (1.0 / 0.0); filtered factors
// against the reference get 2 * 2^-subTexelPrecisionBits (bilinear compare weights quantised,
// Vulkan spec "Texel Filtering") plus 2e-4 for float tap positions (see pcss_tests.cpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <glm/gtc/packing.hpp>
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

PENUMBRA_GLSL_STRUCT(penumbra::filter_ref::PcssParams, "PcssParams", tan_half_angle,
                     texel_world_size, depth_near, depth_far, max_search_texels, min_filter_texels,
                     max_filter_texels, confidence_fraction);

namespace penumbra::testing {
namespace {

namespace ref = penumbra::filter_ref;
using Params = ref::PcssParams;

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kTwoPi = 2.0f * std::numbers::pi_v<float>;

std::shared_ptr<Texture> compare_texture(const ref::DepthMap& m, bool reverse_z) {
  DepthTextureDesc d;
  d.width = uint32_t(m.width);
  d.height = uint32_t(m.height);
  d.sampler.filter = VK_FILTER_LINEAR;
  d.sampler.compare = true;
  d.sampler.compare_op = reverse_z ? VK_COMPARE_OP_GREATER_OR_EQUAL : VK_COMPARE_OP_LESS_OR_EQUAL;
  return make_depth_texture(d, m.depth);
}

std::shared_ptr<Texture> raw_texture(const ref::DepthMap& m) {
  DepthTextureDesc d;
  d.width = uint32_t(m.width);
  d.height = uint32_t(m.height);
  d.sampler.compare = false;
  return make_depth_texture(d, m.depth);
}

ref::DepthMap constant_map(int size, float depth) {
  return {size, size, std::vector<float>(size_t(size * size), depth)};
}

// A sun-like light over a 100-unit depth range with 0.05-unit texels.
Params sun_params() {
  Params p;
  p.tan_half_angle = 0.02f;
  p.texel_world_size = 0.05f;
  p.depth_near = 0.0f;
  p.depth_far = 100.0f;
  p.max_search_texels = 24.0f;
  p.min_filter_texels = 0.5f;
  p.max_filter_texels = 16.0f;
  p.confidence_fraction = 0.25f;
  return p;
}

using PcssFn = ShaderFunction<float(Sampler2DShadow, Sampler2D, glm::vec3, glm::vec2, Params,
                                    int32_t, float, bool)>;
using SearchFn = ShaderFunction<void(Sampler2D, glm::vec3, float, int32_t, float, glm::vec2, bool,
                                     Out<float>, Out<int32_t>)>;
using PcssCase = std::tuple<glm::vec3, glm::vec2, Params, int32_t, float, bool>;

class FilterExtremesTest : public GpuTest {
 protected:
  static double filter_bound() {
    return 2.0 * std::ldexp(1.0, -int(ctx().info().limits.subTexelPrecisionBits)) + 2e-4;
  }
  static std::vector<float> run_pcss(const ref::DepthMap& map, bool reverse_z,
                                     const std::vector<PcssCase>& cases) {
    PcssFn pcss("penumbra/pcss.glsl", "pcss_shadow");
    pcss.bind(0, compare_texture(map, reverse_z)).bind(1, raw_texture(map));
    return pcss.run(cases);
  }
  static std::vector<glm::dvec2> vogel(int n, float rotation) {
    ShaderFunction<glm::vec2(int32_t, int32_t, float)> f("penumbra/noise.glsl",
                                                         "vogel_disk_sample");
    std::vector<std::tuple<int32_t, int32_t, float>> in;
    for (int i = 0; i < n; ++i) in.emplace_back(i, n, rotation);
    std::vector<glm::dvec2> out;
    for (const auto& v : f.run(in)) out.emplace_back(v);
    return out;
  }
};

// ---- PCSS -----------------------------------------------------------------------------------

// Nothing closer to the light than the receiver (the map at the receiver's depth, or farther):
// the search finds no blocker and the factor is exactly 1, with no filtering, for every tier.
TEST_F(FilterExtremesTest, PcssWithNoBlockerIsExactlyLit) {
  Rng rng(501);
  for (bool reverse_z : {true, false}) {
    for (float stored : {0.5f, reverse_z ? 0.1f : 0.9f, reverse_z ? 0.0f : 1.0f}) {
      const ref::DepthMap map = constant_map(32, stored);
      std::vector<PcssCase> cases;
      for (int i = 0; i < 300; ++i) {
        cases.emplace_back(glm::vec3(rng.next_unit(), rng.next_unit(), 0.5f), glm::vec2(1.0f / 32),
                           sun_params(), i % 3, float(kTwoPi * rng.next_unit()), reverse_z);
      }
      PENUMBRA_EXPECT_ALL_NEAR(std::vector<float>(cases.size(), 1.0f),
                               run_pcss(map, reverse_z, cases), Tolerance::exact())
          << "reverse_z " << reverse_z << " stored " << stored;
      SearchFn search("penumbra/pcss.glsl", "pcss_blocker_search");
      search.bind(0, raw_texture(map));
      const auto [avg, count] =
          search(glm::vec3(0.5f, 0.5f, 0.5f), 8.0f, 32, 0.3f, glm::vec2(1.0f / 32), reverse_z);
      EXPECT_EQ(count, 0);
      EXPECT_EQ(avg, 0.5f);  // the receiver depth when there is no blocker
    }
  }
}

// Everything closer to the light: every search tap is a blocker and the filter disk lies inside
// the search disk, so the early-out returns exactly 0. With the search clamped below the filter
// radius (min filter 3 > max search 0.5) the filter runs instead and also gives 0.
TEST_F(FilterExtremesTest, PcssWithAllBlockersIsExactlyShadowed) {
  Rng rng(502);
  for (bool reverse_z : {true, false}) {
    const ref::DepthMap map = constant_map(32, reverse_z ? 0.9f : 0.1f);
    for (bool clamp_search : {false, true}) {
      Params p = sun_params();
      if (clamp_search) {
        p.max_search_texels = 0.5f;
        p.min_filter_texels = 3.0f;
      }
      std::vector<PcssCase> cases;
      for (int i = 0; i < 300; ++i) {
        cases.emplace_back(glm::vec3(rng.next_unit(), rng.next_unit(), 0.5f), glm::vec2(1.0f / 32),
                           p, i % 3, float(kTwoPi * rng.next_unit()), reverse_z);
      }
      PENUMBRA_EXPECT_ALL_NEAR(std::vector<float>(cases.size(), 0.0f),
                               run_pcss(map, reverse_z, cases), Tolerance::exact())
          << "reverse_z " << reverse_z << " clamp_search " << clamp_search;
    }
  }
}

// A single blocker texel over a lit plane. The search finds it (with one tap, or two that land
// in the same texel; the mean is exactly its depth) or misses it (count 0: exactly lit). With k
// blocker taps the confidence is k / max(0.25 * 32, 1) = k / 8, so the factor is
// 1 - k (1 - filtered) / 8 >= 1 - k / 8, checked against the reference; without the fade
// (fraction 0) the full filtered value.
TEST_F(FilterExtremesTest, PcssWithASingleBlockerFadesByConfidence) {
  const int size = 64, bx = 30, by = 33;
  for (bool reverse_z : {true, false}) {
    const float ground = reverse_z ? 0.3f : 0.7f, blocker = reverse_z ? 0.32f : 0.68f;
    ref::DepthMap map = constant_map(size, ground);
    map.depth[size_t(by * size + bx)] = blocker;
    for (float fraction : {0.25f, 0.0f}) {
      Params p = sun_params();
      p.confidence_fraction = fraction;
      p.max_search_texels = 4.0f;
      p.min_filter_texels = 1.0f;
      const int tier = 2;  // 32 search taps, 64 filter taps
      const float rotation = 0.7f;
      const auto search_offsets = vogel(32, rotation), filter_offsets = vogel(64, rotation);
      std::vector<PcssCase> cases;
      std::vector<std::tuple<glm::vec3, float, int32_t, float, glm::vec2, bool>> search_cases;
      for (int j = 0; j < 40; ++j)
        for (int i = 0; i < 40; ++i) {
          const glm::vec3 c(float((bx - 4.5 + 0.2345 * i) / size),
                            float((by - 4.5 + 0.2345 * j) / size), ground);
          cases.emplace_back(c, glm::vec2(1.0f / size), p, tier, rotation, reverse_z);
          search_cases.emplace_back(c, 4.0f, 32, rotation, glm::vec2(1.0f / size), reverse_z);
        }
      const auto got = run_pcss(map, reverse_z, cases);
      SearchFn search("penumbra/pcss.glsl", "pcss_blocker_search");
      search.bind(0, raw_texture(map));
      const auto found = search.run(search_cases);
      std::vector<float> want, got_checked;
      size_t singles = 0;
      for (size_t i = 0; i < cases.size(); ++i) {
        const auto& c = std::get<0>(cases[i]);
        const auto r =
            ref::pcss(map, {c.x, c.y}, c.z, p, search_offsets, filter_offsets, reverse_z);
        if (r.ambiguous) continue;
        ASSERT_LE(r.blockers, 3);
        EXPECT_EQ(std::get<1>(found[i]), r.blockers) << format_value(c);
        if (r.blockers >= 1) {
          singles += r.blockers == 1;
          EXPECT_EQ(std::get<0>(found[i]), blocker);
          // The fade: k blocker taps darken by at most k / 8 with the 0.25 fraction.
          if (fraction > 0.0f) {
            EXPECT_GE(r.shadow, 1.0 - r.blockers / 8.0);
          }
        } else {
          EXPECT_EQ(got[i], 1.0f);
        }
        want.push_back(float(r.shadow));
        got_checked.push_back(got[i]);
      }
      EXPECT_GT(singles, 50u);
      PENUMBRA_EXPECT_ALL_NEAR(want, got_checked, Tolerance::absolute(filter_bound()))
          << "reverse_z " << reverse_z << " fraction " << fraction;
    }
  }
}

// Receivers exactly at depth 0 and 1 over maps of 0 and 1. Reverse-Z: a receiver at 1 is on the
// near plane (search radius 0, nothing can be closer): lit; at 0 it is lit over a map of 0
// (equal) and shadowed under a map of 1. Standard depth mirrors it.
TEST_F(FilterExtremesTest, PcssAtDepthZeroAndOneBothConventions) {
  for (bool reverse_z : {true, false}) {
    for (float stored : {0.0f, 1.0f}) {
      for (float receiver : {0.0f, 1.0f}) {
        const ref::DepthMap map = constant_map(16, stored);
        std::vector<PcssCase> cases;
        for (float u : {0.0f, 0.3f, 0.5f, 1.0f})
          for (int tier = 0; tier < 3; ++tier)
            cases.emplace_back(glm::vec3(u, 0.6f, receiver), glm::vec2(1.0f / 16), sun_params(),
                               tier, 1.0f, reverse_z);
        const bool lit = reverse_z ? receiver >= stored : receiver <= stored;
        PENUMBRA_EXPECT_ALL_NEAR(std::vector<float>(cases.size(), lit ? 1.0f : 0.0f),
                                 run_pcss(map, reverse_z, cases), Tolerance::exact())
            << "reverse_z " << reverse_z << " stored " << stored << " receiver " << receiver;
      }
    }
  }
}

// NaN / infinite coordinates and uvs outside [0, 1]: lit (exactly 1), for every tier, over a map
// of blockers.
TEST_F(FilterExtremesTest, PcssInvalidCoordinatesAreLit) {
  for (bool reverse_z : {true, false}) {
    const ref::DepthMap map = constant_map(16, reverse_z ? 1.0f : 0.0f);
    std::vector<glm::vec3> coords;
    for (float bad : {kNan, kInf, -kInf}) {
      coords.emplace_back(bad, 0.5f, 0.5f);
      coords.emplace_back(0.5f, bad, 0.5f);
      coords.emplace_back(0.5f, 0.5f, bad);
    }
    for (float out :
         {-std::numeric_limits<float>::min(), std::nextafter(1.0f, 2.0f), -3.0f, 7.0f}) {
      coords.emplace_back(out, 0.5f, 0.5f);
      coords.emplace_back(0.5f, out, 0.5f);
    }
    std::vector<PcssCase> cases;
    for (const auto& c : coords)
      for (int tier = 0; tier < 3; ++tier)
        cases.emplace_back(c, glm::vec2(1.0f / 16), sun_params(), tier, 0.5f, reverse_z);
    PENUMBRA_EXPECT_ALL_NEAR(std::vector<float>(cases.size(), 1.0f),
                             run_pcss(map, reverse_z, cases), Tolerance::exact());
  }
}

// Degenerate parameters never give NaN: NaN / infinite rotation (as 0), zero angular size (hard
// shadow: the search radius is 0), zero / NaN / infinite texel world size, NaN filter bounds,
// out-of-range tiers.
TEST_F(FilterExtremesTest, PcssDegenerateParametersStayInUnitInterval) {
  Rng rng(506);
  for (bool reverse_z : {true, false}) {
    ref::DepthMap map{48, 48, std::vector<float>(48 * 48)};
    for (float& d : map.depth) d = float(rng.next_unit());
    std::vector<PcssCase> cases, zero_rotation;
    for (int i = 0; i < 600; ++i) {
      Params p = sun_params();
      switch (i % 6) {
        case 0:
          p.tan_half_angle = 0.0f;
          break;
        case 1:
          p.texel_world_size = std::array{0.0f, kNan, kInf}[(i / 6) % 3];
          break;
        case 2:
          p.min_filter_texels = kNan;
          p.max_filter_texels = kNan;
          break;
        case 3:
          p.depth_far = p.depth_near;
          break;
        case 4:
          p.confidence_fraction = std::array{kNan, -1.0f, 5.0f}[(i / 6) % 3];
          break;
        default:
          p.max_search_texels = kInf;
          break;
      }
      const glm::vec3 c(rng.next_unit(), rng.next_unit(), rng.next_unit());
      const float rotation = std::array{kNan, kInf, -kInf, 1e30f}[(i / 6) % 4];
      const int tier = std::array{-5, 0, 1, 2, 99}[i % 5];
      cases.emplace_back(c, glm::vec2(1.0f / 48), p, tier, rotation, reverse_z);
      zero_rotation.emplace_back(c, glm::vec2(1.0f / 48), p, tier,
                                 std::isfinite(rotation) ? rotation : 0.0f, reverse_z);
    }
    const auto got = run_pcss(map, reverse_z, cases);
    for (float v : got) ASSERT_TRUE(v >= 0.0f && v <= 1.0f) << v;
    // Non-finite rotations act as 0 (1e30 is finite and stays as it is).
    PENUMBRA_EXPECT_ALL_NEAR(run_pcss(map, reverse_z, zero_rotation), got, Tolerance::exact());
  }
}

// ---- VSM / EVSM -----------------------------------------------------------------------------

using VsmFn = ShaderFunction<float(glm::vec2, float, float, float, bool)>;
using Evsm2Fn = ShaderFunction<float(glm::vec2, float, float, float, float, bool, bool)>;
using Evsm4Fn = ShaderFunction<float(glm::vec4, float, glm::vec2, float, float, bool, bool)>;

// Zero variance (a single depth m: moments (m, m*m), the same float product the GPU forms):
// a receiver at or in front of m is lit (exactly 1); one D behind it gets exactly the minimum
// variance's bound mv / (mv + D^2), which is 0 with no minimum variance.
TEST_F(FilterExtremesTest, VsmZeroVarianceAndReceiverAtTheMean) {
  Rng rng(507);
  VsmFn vsm("penumbra/vsm.glsl", "vsm_shadow");
  std::vector<std::tuple<glm::vec2, float, float, float, bool>> cases;
  std::vector<float> want;
  for (int i = 0; i < 2000; ++i) {
    const bool reverse_z = i % 2 == 0;
    const float m = i < 8 ? float((i / 2) % 2) : float(rng.next_unit());
    const float mv = std::array{0.0f, 1e-5f, 1e-3f}[i % 3];
    const float bleed = i % 4 == 0 ? 0.3f : 0.0f;
    const int kind = (i / 3) % 3;  // 0: at the mean, 1: in front, 2: behind
    float t = m;
    const float step = float(0.5 * rng.next_unit());
    const float towards_light = reverse_z ? step : -step;
    if (kind == 1) t = std::clamp(m + towards_light, 0.0f, 1.0f);
    if (kind == 2) t = std::clamp(m - towards_light, 0.0f, 1.0f);
    cases.emplace_back(glm::vec2(m, m * m), t, mv, bleed, reverse_z);
    const double dist = std::abs(double(t) - m);
    const bool behind = reverse_z ? t < m : t > m;
    want.push_back(behind ? float(ref::reduce_light_bleeding(mv / (mv + dist * dist), bleed))
                          : 1.0f);
  }
  // Exactly 1 at and in front of the mean (the branch t <= mean is exact); the bound itself to
  // a few float roundings.
  const auto got = vsm.run(cases);
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::absolute(1e-6).with_rel(1e-5),
                           [&](size_t i) { return format_tuple(cases[i]); });
  size_t lit = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    if (want[i] != 1.0f) continue;
    ++lit;
    EXPECT_EQ(got[i], 1.0f) << format_tuple(cases[i]);
  }
  EXPECT_GT(lit, cases.size() / 2);
}

// EVSM with a receiver exactly at the stored depth (moments from evsm_moments of that depth):
// lit. The GPU forms both warps with the same code; with a positive minimum variance a one-ULP
// difference between them still leaves the factor within 1e-3 of 1.
TEST_F(FilterExtremesTest, EvsmReceiverAtTheStoredDepthIsLit) {
  Rng rng(508);
  ShaderFunction<glm::vec4(float, glm::vec2, bool, bool)> moments("penumbra/vsm.glsl",
                                                                  "evsm_moments");
  Evsm2Fn evsm2("penumbra/vsm.glsl", "evsm2_shadow");
  Evsm4Fn evsm4("penumbra/vsm.glsl", "evsm4_shadow");
  std::vector<std::tuple<float, glm::vec2, bool, bool>> in;
  for (int i = 0; i < 1000; ++i) {
    const bool fp16 = i % 2 == 0;
    const double cmax = ref::evsm_max_exponent(fp16);
    in.emplace_back(i < 4 ? float(i % 2) : float(rng.next_unit()),
                    glm::vec2(float(cmax * rng.next_unit()), float(cmax * rng.next_unit())),
                    i % 4 < 2, fp16);
  }
  const auto m = moments.run(in);
  std::vector<std::tuple<glm::vec2, float, float, float, float, bool, bool>> c2;
  std::vector<std::tuple<glm::vec4, float, glm::vec2, float, float, bool, bool>> c4;
  for (size_t i = 0; i < in.size(); ++i) {
    const auto& [d, c, rz, fp16] = in[i];
    c2.emplace_back(glm::vec2(m[i]), d, c.x, 1e-5f, 0.0f, rz, fp16);
    c4.emplace_back(m[i], d, c, 1e-5f, 0.0f, rz, fp16);
  }
  const std::vector<float> ones(in.size(), 1.0f);
  PENUMBRA_EXPECT_ALL_NEAR(ones, evsm2.run(c2), Tolerance::absolute(1e-3));
  PENUMBRA_EXPECT_ALL_NEAR(ones, evsm4.run(c4), Tolerance::absolute(1e-3));
}

// The moment format is part of every EVSM call. Exponents asked for beyond what 16-bit floats
// hold (c = 40, 20, 10) are clamped to 5.54 when the moments are written and when they are read,
// so a receiver at the stored depth of an fp16 map is lit. Told fp32 instead (what a caller who
// forgets the format gets), the same depths' moments rounded to halves lose their variance to
// the rounding and leave receivers in the dark (78 of these 90 come out lit).
TEST_F(FilterExtremesTest, EvsmMomentsInAnFp16MapKeepAReceiverAtTheStoredDepthLit) {
  ShaderFunction<glm::vec4(float, glm::vec2, bool, bool)> moments("penumbra/vsm.glsl",
                                                                  "evsm_moments");
  Evsm2Fn evsm2("penumbra/vsm.glsl", "evsm2_shadow");
  Evsm4Fn evsm4("penumbra/vsm.glsl", "evsm4_shadow");
  auto lit_counts = [&](bool fp16) {
    std::vector<std::tuple<float, glm::vec2, bool, bool>> in;
    for (float c : {40.0f, 20.0f, 10.0f})
      for (bool rz : {true, false})
        for (int k = 0; k < 15; ++k) in.emplace_back(float(k) / 14.0f, glm::vec2(c), rz, fp16);
    const auto m = moments.run(in);
    std::vector<std::tuple<glm::vec2, float, float, float, float, bool, bool>> c2;
    std::vector<std::tuple<glm::vec4, float, glm::vec2, float, float, bool, bool>> c4;
    for (size_t i = 0; i < in.size(); ++i) {
      glm::vec4 half;  // stored in an RG16F / RGBA16F map
      for (int k = 0; k < 4; ++k) half[k] = glm::unpackHalf1x16(glm::packHalf1x16(m[i][k]));
      const auto& [d, c, rz, f16] = in[i];
      c2.emplace_back(glm::vec2(half), d, c.x, 1e-5f, 0.0f, rz, f16);
      c4.emplace_back(half, d, c, 1e-5f, 0.0f, rz, f16);
    }
    const auto got2 = evsm2.run(c2), got4 = evsm4.run(c4);
    std::pair<size_t, size_t> lit{0, 0};
    for (size_t i = 0; i < in.size(); ++i) {
      lit.first += got2[i] >= 0.999f;
      lit.second += got4[i] >= 0.999f;
    }
    return std::pair{lit, in.size()};
  };
  const auto [with_format, n] = lit_counts(true);
  EXPECT_EQ(with_format.first, n) << "EVSM2, fp16 moments read as fp16";
  EXPECT_EQ(with_format.second, n) << "EVSM4, fp16 moments read as fp16";
  const auto [without_format, n32] = lit_counts(false);
  EXPECT_LT(without_format.first, n32)
      << "EVSM2: fp16 moments written and read as fp32: " << without_format.first << " of " << n32
      << " lit";
  // (EVSM4 hides it here: its moments overflow fp16 to infinity, and non-finite moments count
  // as lit.)
  std::printf("fp16 moments told fp32: EVSM2 %zu of %zu lit, EVSM4 %zu\n", without_format.first,
              n32, without_format.second);
}

// Depths 0 and 1 in both conventions (zero variance): lit at or in front of the stored depth,
// else mv / (mv + 1).
TEST_F(FilterExtremesTest, VsmAtDepthZeroAndOne) {
  VsmFn vsm("penumbra/vsm.glsl", "vsm_shadow");
  const float mv = 1e-4f;
  std::vector<std::tuple<glm::vec2, float, float, float, bool>> cases;
  std::vector<float> want;
  for (bool reverse_z : {true, false})
    for (float stored : {0.0f, 1.0f})
      for (float receiver : {0.0f, 1.0f}) {
        cases.emplace_back(glm::vec2(stored, stored * stored), receiver, mv, 0.0f, reverse_z);
        const bool lit = reverse_z ? receiver >= stored : receiver <= stored;
        want.push_back(lit ? 1.0f : mv / (mv + 1.0f));
      }
  PENUMBRA_EXPECT_ALL_NEAR(want, vsm.run(cases), Tolerance::relative(1e-5),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

// The exponent limits: exp(2c) must fit the moment format. 5.54 keeps exp(2c) = 64889 below
// fp16's 65504 (and 5.6 would not); 42 keeps exp(84) ~ 3e36 below FLT_MAX. Clamping maps
// larger, negative, NaN and infinite exponents into [0, limit], and the moments of the farthest
// depth with clamped exponents convert to finite halves.
TEST_F(FilterExtremesTest, EvsmExponentsClampPerMomentFormat) {
  ShaderFunction<float(bool)> max_exponent("penumbra/vsm.glsl", "evsm_max_exponent");
  EXPECT_EQ(max_exponent(true), 5.54f);
  EXPECT_EQ(max_exponent(false), 42.0f);
  EXPECT_LE(std::exp(2.0 * 5.54f), 65504.0);
  EXPECT_GT(std::exp(2.0 * 5.6), 65504.0);
  EXPECT_LT(std::exp(2.0 * 42.0), double(std::numeric_limits<float>::max()));

  ShaderFunction<glm::vec2(glm::vec2, bool)> clamp_fn("penumbra/vsm.glsl", "evsm_clamp_exponents");
  const std::vector<std::tuple<glm::vec2, bool>> in = {
      {{100.0f, 7.0f}, true}, {{100.0f, 7.0f}, false}, {{-1.0f, 3.0f}, true},
      {{kNan, kInf}, true},   {{-kInf, kNan}, false},  {{5.0f, 41.0f}, false}};
  const std::vector<glm::vec2> want = {{5.54f, 5.54f}, {42.0f, 7.0f}, {0.0f, 3.0f},
                                       {0.0f, 5.54f},  {0.0f, 0.0f},  {5.0f, 41.0f}};
  PENUMBRA_EXPECT_ALL_NEAR(want, clamp_fn.run(in), Tolerance::exact());

  // Moments at the far plane (the warp's maximum) and the near plane (the negative warp's).
  ShaderFunction<glm::vec4(float, glm::vec2, bool, bool)> moments("penumbra/vsm.glsl",
                                                                  "evsm_moments");
  std::vector<std::tuple<float, glm::vec2, bool, bool>> mc;
  for (bool rz : {true, false})
    for (float d : {0.0f, 1.0f}) mc.emplace_back(d, glm::vec2(5.54f), rz, true);
  for (const auto& m : moments.run(mc)) {
    for (int k = 0; k < 4; ++k) {
      const float half = glm::unpackHalf1x16(glm::packHalf1x16(m[k]));
      EXPECT_TRUE(std::isfinite(half)) << format_value(m);
    }
  }
  // Unclamped exponents are clamped to 42 inside: finite fp32 moments even for 1e6 or +Inf.
  std::vector<std::tuple<float, glm::vec2, bool, bool>> huge;
  for (bool rz : {true, false})
    for (float d : {0.0f, 1.0f})
      for (float c : {1e6f, kInf}) huge.emplace_back(d, glm::vec2(c), rz, false);
  for (const auto& m : moments.run(huge)) {
    for (int k = 0; k < 4; ++k) EXPECT_TRUE(std::isfinite(m[k])) << format_value(m);
    EXPECT_NEAR(std::max(m.y, m.w), std::exp(84.0), std::exp(84.0) * 1e-4);
  }
}

// NaN / infinite receiver depths and moments give 1 (lit); NaN bleed amounts and minimum
// variances act as 0; the sampling functions are lit outside the map.
TEST_F(FilterExtremesTest, VsmNonFiniteInputsAreLitNeverNan) {
  VsmFn vsm("penumbra/vsm.glsl", "vsm_shadow");
  Evsm2Fn evsm2("penumbra/vsm.glsl", "evsm2_shadow");
  Evsm4Fn evsm4("penumbra/vsm.glsl", "evsm4_shadow");
  std::vector<std::tuple<glm::vec2, float, float, float, bool>> v;
  std::vector<std::tuple<glm::vec2, float, float, float, float, bool, bool>> e2;
  std::vector<std::tuple<glm::vec4, float, glm::vec2, float, float, bool, bool>> e4;
  for (bool rz : {true, false})
    for (float bad : {kNan, kInf, -kInf}) {
      v.emplace_back(glm::vec2(0.5f, 0.25f), bad, 1e-4f, 0.0f, rz);
      v.emplace_back(glm::vec2(bad, 0.25f), 0.2f, 1e-4f, 0.0f, rz);
      v.emplace_back(glm::vec2(0.5f, bad), 0.2f, 1e-4f, 0.0f, rz);
      e2.emplace_back(glm::vec2(2.0f, 4.0f), bad, 5.0f, 1e-4f, 0.0f, rz, rz);
      e2.emplace_back(glm::vec2(bad, 4.0f), 0.2f, 5.0f, 1e-4f, 0.0f, rz, !rz);
      e4.emplace_back(glm::vec4(2.0f, 4.0f, -2.0f, 4.0f), bad, glm::vec2(5.0f), 1e-4f, 0.0f, rz,
                      rz);
      e4.emplace_back(glm::vec4(2.0f, 4.0f, bad, 4.0f), 0.2f, glm::vec2(5.0f), 1e-4f, 0.0f, rz,
                      !rz);
    }
  PENUMBRA_EXPECT_ALL_NEAR(std::vector<float>(v.size(), 1.0f), vsm.run(v), Tolerance::exact());
  PENUMBRA_EXPECT_ALL_NEAR(std::vector<float>(e2.size(), 1.0f), evsm2.run(e2), Tolerance::exact());
  PENUMBRA_EXPECT_ALL_NEAR(std::vector<float>(e4.size(), 1.0f), evsm4.run(e4), Tolerance::exact());

  // NaN parameters: finite factors, the same as with 0.
  std::vector<std::tuple<glm::vec2, float, float, float, bool>> nan_params, zero_params;
  for (bool rz : {true, false})
    for (float t : {0.1f, 0.5f, 0.9f}) {
      nan_params.emplace_back(glm::vec2(0.5f, 0.3f), t, kNan, kNan, rz);
      zero_params.emplace_back(glm::vec2(0.5f, 0.3f), t, 0.0f, 0.0f, rz);
    }
  const auto got = vsm.run(nan_params);
  for (float g : got) EXPECT_TRUE(g >= 0.0f && g <= 1.0f) << g;
  PENUMBRA_EXPECT_ALL_NEAR(vsm.run(zero_params), got, Tolerance::exact());

  // Light-bleed reduction at its ends: amount 0 is the identity, 1 keeps only p = 1.
  ShaderFunction<float(float, float)> bleed("penumbra/vsm.glsl", "vsm_reduce_light_bleeding");
  const std::vector<std::tuple<float, float>> bc = {{0.3f, 0.0f}, {1.0f, 0.0f}, {0.999f, 1.0f},
                                                    {1.0f, 1.0f}, {0.5f, kNan}, {0.5f, 2.0f}};
  PENUMBRA_EXPECT_ALL_NEAR((std::vector<float>{0.3f, 1.0f, 0.0f, 1.0f, 0.5f, 0.0f}), bleed.run(bc),
                           Tolerance::exact());

  // Sampling outside the map (or with a non-finite coord) is lit, over moments that shadow.
  FloatTextureDesc desc;
  desc.width = 4;
  desc.height = 4;
  desc.channels = 4;
  const std::vector<float> texels(64, 0.0f);  // mean 0, variance 0
  auto tex = make_float_texture(desc, texels);
  ShaderFunction<float(Sampler2D, glm::vec3, float, float, bool)> sample("penumbra/vsm.glsl",
                                                                         "vsm_sample_shadow");
  sample.bind(0, tex);
  std::vector<std::tuple<glm::vec3, float, float, bool>> sc;
  for (float u : {-0.01f, 1.01f, kNan, kInf})
    sc.emplace_back(glm::vec3(u, 0.5f, 0.5f), 0.0f, 0.0f, false);
  sc.emplace_back(glm::vec3(0.5f, 0.5f, 0.5f), 0.0f, 0.0f, false);  // inside: shadowed
  PENUMBRA_EXPECT_ALL_NEAR((std::vector<float>{1.0f, 1.0f, 1.0f, 1.0f, 0.0f}), sample.run(sc),
                           Tolerance::exact());
}

}  // namespace
}  // namespace penumbra::testing
