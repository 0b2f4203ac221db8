// Function-level tests of shaders/penumbra/vsm.glsl: stored moments, the Chebyshev bound,
// light-bleed reduction, VSM, EVSM2 and EVSM4 against the double-precision reference of
// reference/filter_ref.hpp in both depth conventions; invariants (range, monotonic in receiver
// depth); a known configuration through a filtered moment texture built from host depths; and the
// renderer's EVSM2 reads: the mip level of a pixel's footprint and a point light's cube array.
//
// Tolerances. The Chebyshev bound is ill-conditioned where the variance and the distance to the
// mean are both small, so a fixed tolerance would be either loose or wrong. Each case gets an
// interval instead: the reference is evaluated at the ends of the input ranges that the GPU's
// rounding can reach, and the bound is monotonic in each (increasing in the variance, decreasing
// in the distance to the mean; light-bleed reduction is monotonic), so the interval is rigorous.
// The rounding follows the Vulkan spec's precision table: +, -, * correctly rounded (a variance
// m2 - m1^2 off by at most 2^-23 (m1^2 + |m2|)), sqrt about 5 ULP (inherited from inversesqrt
// and division), exp(x) within 3 + 2|x| ULP plus the rounding of its argument c * (2 f - 1)
// (|c| * 2^-22 absolute, i.e. that many ULP of the result); the final 1 / (1 + (d / sigma)^2)
// and the bleed step (divisions, 2.5 ULP each) get 2e-6 absolute on top.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/resources.hpp>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <span>
#include <tuple>
#include <vector>

#include "reference/filter_ref.hpp"

namespace penumbra::testing {
namespace {

namespace ref = penumbra::filter_ref;

constexpr double kUlp = 0x1p-23;  // float ULP at 1 (relative spacing bound)
constexpr double kTwoPi = 2.0 * std::numbers::pi;

struct Interval {
  double lo, hi;
};

// f(v, d) = v / (v + d^2) for d > 0, 1 for d <= 0.
double bound_at(double v, double d) {
  if (d <= 0.0) return 1.0;
  const double den = v + d * d;
  return den <= 0.0 ? 0.0 : v / den;
}

// The interval of the Chebyshev bound when the variance may be off by dv, the distance to the
// mean by dd, and the minimum variance lies in [mv_lo, mv_hi].
Interval chebyshev_interval(double m1, double m2, double t, double mv_lo, double mv_hi, double dd) {
  const double d = t - m1;
  if (d <= 0.0) return {1.0, 1.0};  // float subtraction keeps the sign: this branch is exact
  const double raw = m2 - m1 * m1;
  // The float product and difference, then sqrt (about 5 ULP, i.e. 10 ULP of the variance) on
  // the way to d / sigma.
  const double dv = 2.0 * kUlp * (m1 * m1 + std::abs(m2)) + 12.0 * kUlp * std::abs(raw);
  const double v_lo = std::max(raw - dv, std::max(mv_lo, 0.0));
  const double v_hi = std::max(raw + dv, std::max(mv_hi, 0.0));
  return {bound_at(v_lo, d + dd), bound_at(v_hi, std::max(d - dd, 0.0))};
}

Interval bleed_interval(Interval p, double amount) {
  return {ref::reduce_light_bleeding(p.lo, amount), ref::reduce_light_bleeding(p.hi, amount)};
}

// expected[i] = actual[i] clamped into [lo - slack, hi + slack] (the midpoint for a NaN actual),
// so an exact comparison passes inside the interval and a failure reports the violated end.
std::vector<float> clamp_into(const std::vector<Interval>& iv, const std::vector<float>& got,
                              double slack) {
  std::vector<float> out;
  for (size_t i = 0; i < iv.size(); ++i) {
    const double lo = iv[i].lo - slack, hi = iv[i].hi + slack;
    out.push_back(std::isnan(got[i]) ? float(0.5 * (lo + hi))
                                     : float(std::clamp(double(got[i]), lo, hi)));
  }
  return out;
}

// The warp of a receiver on the GPU: relative error of exp(c x) with its argument's rounding.
double warp_rel_error(double c) {
  return (3.0 + 2.0 * c + 2.0 * c + 4.0) * kUlp;
}

using VsmFn = ShaderFunction<float(glm::vec2, float, float, float, bool)>;
using Evsm2Fn = ShaderFunction<float(glm::vec2, float, float, float, float, bool, bool)>;
using Evsm4Fn = ShaderFunction<float(glm::vec4, float, glm::vec2, float, float, bool, bool)>;

class VsmTest : public GpuTest {};

TEST_F(VsmTest, MomentsAreDepthAndDepthSquared) {
  Rng rng(401);
  ShaderFunction<glm::vec2(float)> f("penumbra/vsm.glsl", "vsm_moments");
  std::vector<std::tuple<float>> cases = {{0.0f}, {1.0f}, {0.5f}, {-0.25f}, {1.5f}};
  for (int i = 0; i < 4000; ++i) cases.emplace_back(float(rng.next_unit()));
  std::vector<glm::vec2> want;
  for (auto [d] : cases) {
    const float c = std::clamp(d, 0.0f, 1.0f);
    want.emplace_back(c, c * c);  // float multiply: correctly rounded on the GPU too
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, f.run(cases), Tolerance::ulps(0, 1e-37));
}

// EVSM moments: (w+, w+^2, w-, w-^2) with w+ = exp(c+ x), w- = -exp(-c- x), x = 2 f - 1 and f
// the distance from the light (1 - depth under reverse-Z). exp is within 3 + 2|x| ULP and its
// argument rounds (2 |c| ULP): up to ~180 ULP for c = 42, twice that squared; 1e-4 relative.
TEST_F(VsmTest, EvsmMomentsWarpTheDistanceFromTheLight) {
  Rng rng(402);
  ShaderFunction<glm::vec4(float, glm::vec2, bool, bool)> f("penumbra/vsm.glsl", "evsm_moments");
  std::vector<std::tuple<float, glm::vec2, bool, bool>> cases;
  std::vector<glm::vec4> want;
  for (int i = 0; i < 4000; ++i) {
    const float d = i < 8 ? float(i % 2) : float(rng.next_unit());
    const glm::vec2 c(float(42.0 * rng.next_unit()), float(42.0 * rng.next_unit()));
    const bool reverse_z = i % 2 == 0;
    cases.emplace_back(d, c, reverse_z, false);  // fp32 moments: exponents up to 42
    const double wp = ref::evsm_positive(d, c.x, reverse_z);
    const double wn = ref::evsm_negative(d, c.y, reverse_z);
    want.emplace_back(float(wp), float(wp * wp), float(wn), float(wn * wn));
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, f.run(cases), Tolerance::relative(1e-4),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

TEST_F(VsmTest, LightBleedReductionIsLinstep) {
  Rng rng(403);
  ShaderFunction<float(float, float)> f("penumbra/vsm.glsl", "vsm_reduce_light_bleeding");
  std::vector<std::tuple<float, float>> cases;
  std::vector<float> want;
  for (int i = 0; i < 4000; ++i) {
    const float p = float(rng.next_unit());
    const float a = i % 10 == 0 ? 0.0f : float(0.9 * rng.next_unit());
    cases.emplace_back(p, a);
    want.push_back(float(std::clamp((double(p) - a) / (1.0 - a), 0.0, 1.0)));
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, f.run(cases), Tolerance::absolute(1e-6));
}

// Random moments: mixtures of 1..3 depths (as a filtered map would hold), receivers anywhere.
struct VsmCase {
  glm::vec2 moments;
  float receiver, min_variance, bleed;
  bool reverse_z;
};

TEST_F(VsmTest, VsmMatchesChebyshevReferenceBothConventions) {
  Rng rng(404);
  VsmFn f("penumbra/vsm.glsl", "vsm_shadow");
  std::vector<std::tuple<glm::vec2, float, float, float, bool>> cases;
  std::vector<Interval> iv;
  size_t partial = 0;
  for (int i = 0; i < 6000; ++i) {
    const int k = 1 + int(rng.below(3));
    double m1 = 0, m2 = 0, wsum = 0;
    for (int j = 0; j < k; ++j) {
      const double w = 0.1 + rng.next_unit(), d = rng.next_unit();
      m1 += w * d;
      m2 += w * d * d;
      wsum += w;
    }
    const glm::vec2 m(float(m1 / wsum), float(m2 / wsum));
    const float t = float(rng.next_unit());
    const float mv = i % 4 == 0 ? 0.0f : float(std::pow(10.0, -6.0 + 3.0 * rng.next_unit()));
    const float bleed = i % 3 == 0 ? 0.0f : float(0.5 * rng.next_unit());
    const bool reverse_z = i % 2 == 0;
    cases.emplace_back(m, t, mv, bleed, reverse_z);
    // Reverse-Z: the bound on -depth.
    const double s = reverse_z ? -1.0 : 1.0;
    const double d = s * t - s * m.x;
    // The minimum variance reaches the GPU as sqrt(mv): a few ULP of it either way.
    const Interval p = chebyshev_interval(s * m.x, m.y, s * t, mv * (1 - 16 * kUlp),
                                          mv * (1 + 16 * kUlp), kUlp * std::abs(d));
    iv.push_back(bleed_interval(p, bleed));
    partial += iv.back().lo > 0.01 && iv.back().hi < 0.99;
  }
  const auto got = f.run(cases);
  PENUMBRA_EXPECT_ALL_NEAR(clamp_into(iv, got, 2e-6), got, Tolerance::exact(),
                           [&](size_t i) { return format_tuple(cases[i]); });
  EXPECT_GT(partial, cases.size() / 10);  // plenty of cases between lit and shadowed
}

// Random EVSM moments: mixtures of 1..3 depths warped in double, rounded to float, and a receiver
// anywhere; EVSM2 uses the positive warp's pair, EVSM4 both.
TEST_F(VsmTest, EvsmMatchesChebyshevReferenceBothConventions) {
  Rng rng(405);
  Evsm2Fn evsm2("penumbra/vsm.glsl", "evsm2_shadow");
  Evsm4Fn evsm4("penumbra/vsm.glsl", "evsm4_shadow");
  std::vector<std::tuple<glm::vec2, float, float, float, float, bool, bool>> c2;
  std::vector<std::tuple<glm::vec4, float, glm::vec2, float, float, bool, bool>> c4;
  std::vector<Interval> iv2, iv4;
  size_t partial = 0;
  for (int i = 0; i < 6000; ++i) {
    const bool reverse_z = i % 2 == 0;
    const bool fp16 = i % 3 == 0;
    const double cmax = ref::evsm_max_exponent(fp16);
    const glm::vec2 c(float(cmax * (0.2 + 0.8 * rng.next_unit())),
                      float(cmax * (0.2 + 0.8 * rng.next_unit())));
    const int k = 1 + int(rng.below(3));
    glm::dvec4 m(0.0);
    double wsum = 0;
    for (int j = 0; j < k; ++j) {
      const double w = 0.1 + rng.next_unit(), d = rng.next_unit();
      const double wp = ref::evsm_positive(d, c.x, reverse_z);
      const double wn = ref::evsm_negative(d, c.y, reverse_z);
      m += w * glm::dvec4(wp, wp * wp, wn, wn * wn);
      wsum += w;
    }
    const glm::vec4 mf(m / wsum);
    const float t = float(rng.next_unit());
    const float mv = float(std::pow(10.0, -7.0 + 3.0 * rng.next_unit()));
    const float bleed = i % 3 == 1 ? 0.0f : float(0.4 * rng.next_unit());
    c2.emplace_back(glm::vec2(mf.x, mf.y), t, c.x, mv, bleed, reverse_z, fp16);
    c4.emplace_back(mf, t, c, mv, bleed, reverse_z, fp16);

    // The receiver's warps and their error ranges on the GPU.
    const double wp = ref::evsm_positive(t, c.x, reverse_z);
    const double wn = ref::evsm_negative(t, c.y, reverse_z);
    const double ep = warp_rel_error(c.x) * std::abs(wp), en = warp_rel_error(c.y) * std::abs(wn);
    // Minimum variance in warped space: min_variance (2 c w)^2, its w within the error range.
    auto mv_range = [&](double cc, double w, double e) {
      const double lo = std::max(std::abs(w) - e, 0.0), hi = std::abs(w) + e;
      return std::pair{mv * 4 * cc * cc * lo * lo * (1 - 16 * kUlp),
                       mv * 4 * cc * cc * hi * hi * (1 + 16 * kUlp)};
    };
    const auto [pl, ph] = mv_range(c.x, wp, ep);
    const auto [nl, nh] = mv_range(c.y, wn, en);
    const Interval pos =
        chebyshev_interval(mf.x, mf.y, wp, pl, ph, ep + kUlp * std::abs(wp - mf.x));
    const Interval neg =
        chebyshev_interval(mf.z, mf.w, wn, nl, nh, en + kUlp * std::abs(wn - mf.z));
    iv2.push_back(bleed_interval(pos, bleed));
    iv4.push_back(bleed_interval({std::min(pos.lo, neg.lo), std::min(pos.hi, neg.hi)}, bleed));
    partial += iv4.back().lo > 0.01 && iv4.back().hi < 0.99;
  }
  const auto got2 = evsm2.run(c2);
  const auto got4 = evsm4.run(c4);
  PENUMBRA_EXPECT_ALL_NEAR(clamp_into(iv2, got2, 2e-6), got2, Tolerance::exact(),
                           [&](size_t i) { return format_tuple(c2[i]); });
  PENUMBRA_EXPECT_ALL_NEAR(clamp_into(iv4, got4, 2e-6), got4, Tolerance::exact(),
                           [&](size_t i) { return format_tuple(c4[i]); });
  EXPECT_GT(partial, c4.size() / 20);
  // The intervals are tight where it matters: most are narrower than 1e-3.
  size_t narrow = 0;
  for (const auto& v : iv4) narrow += v.hi - v.lo < 1e-3;
  EXPECT_GT(narrow, iv4.size() * 9 / 10);
}

// Factors lie in [0, 1] and never grow as the receiver moves away from the light (for fixed
// moments); 1e-6 of slack for the non-correctly-rounded division.
TEST_F(VsmTest, FactorsInUnitIntervalAndMonotonicInReceiverDepth) {
  Rng rng(406);
  VsmFn vsm("penumbra/vsm.glsl", "vsm_shadow");
  Evsm2Fn evsm2("penumbra/vsm.glsl", "evsm2_shadow");
  Evsm4Fn evsm4("penumbra/vsm.glsl", "evsm4_shadow");
  ShaderFunction<glm::vec4(float, glm::vec2, bool, bool)> moments("penumbra/vsm.glsl",
                                                                  "evsm_moments");
  constexpr int kSteps = 32;
  for (bool reverse_z : {true, false}) {
    std::vector<std::tuple<glm::vec2, float, float, float, bool>> cv;
    std::vector<std::tuple<glm::vec2, float, float, float, float, bool, bool>> c2;
    std::vector<std::tuple<glm::vec4, float, glm::vec2, float, float, bool, bool>> c4;
    for (int p = 0; p < 200; ++p) {
      // Two depths mixed, moments built by the GPU functions themselves.
      const float d0 = float(rng.next_unit()), d1 = float(rng.next_unit());
      const float w = float(rng.next_unit());
      const glm::vec2 c(float(5.54 * rng.next_unit()), float(5.54 * rng.next_unit()));
      const auto m = moments.run(std::vector<std::tuple<float, glm::vec2, bool, bool>>{
          {d0, c, reverse_z, true}, {d1, c, reverse_z, true}});
      const glm::vec4 m4 = (1.0f - w) * m[0] + w * m[1];
      const glm::vec2 mv2((1.0f - w) * d0 + w * d1, (1.0f - w) * d0 * d0 + w * d1 * d1);
      const float mv = 1e-5f, bleed = p % 2 ? 0.0f : 0.2f;
      for (int k = 0; k < kSteps; ++k) {
        const float f = float(k) / (kSteps - 1);  // distance from the light
        const float depth = reverse_z ? 1.0f - f : f;
        cv.emplace_back(mv2, depth, mv, bleed, reverse_z);
        c2.emplace_back(glm::vec2(m4), depth, c.x, mv, bleed, reverse_z, true);
        c4.emplace_back(m4, depth, c, mv, bleed, reverse_z, true);
      }
    }
    const std::vector<std::vector<float>> results = {vsm.run(cv), evsm2.run(c2), evsm4.run(c4)};
    for (size_t fn = 0; fn < results.size(); ++fn) {
      const auto& got = results[fn];
      size_t bad_range = 0, bad_order = 0;
      for (size_t i = 0; i < got.size(); ++i) {
        if (!(got[i] >= 0.0f && got[i] <= 1.0f)) ++bad_range;
        if (i % kSteps != 0 && got[i] > got[i - 1] + 1e-6f) ++bad_order;
      }
      EXPECT_EQ(bad_range, 0u) << "function " << fn << " reverse_z " << reverse_z;
      EXPECT_EQ(bad_order, 0u) << "function " << fn << " reverse_z " << reverse_z;
    }
  }
}

// A known configuration through a real moment texture: a half-plane occluder (texels x < 32 at
// the blocker depth, the rest at the receiver plane's depth), moments built from the host depths
// by vsm_moments / evsm_moments, stored in an RG32 / RGBA32 float texture and sampled with
// linear filtering. Halfway between texel centres 31 and 32 the filter averages the two moments
// (weight 1/2 is exact at any sub-texel precision): two equally weighted depths a distance D
// apart have variance D^2 / 4 and the receiver lies D / 2 from the mean, so the bound is
// exactly 1/2, for VSM and both EVSM warps. On the lit side (a texel centre) the receiver equals
// the mean: 1. On the shadowed side the variance is the minimum: mv / (mv + D^2).
TEST_F(VsmTest, HalfPlaneMomentTextureGivesKnownFactors) {
  const int width = 64, height = 4, edge = 32;
  for (bool reverse_z : {true, false}) {
    const float receiver = reverse_z ? 0.3f : 0.7f, blocker = reverse_z ? 0.6f : 0.4f;
    std::vector<float> depths(size_t(width * height));
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) depths[size_t(y * width + x)] = x < edge ? blocker : receiver;
    ShaderFunction<glm::vec2(float)> vsm_moments("penumbra/vsm.glsl", "vsm_moments");
    ShaderFunction<glm::vec4(float, glm::vec2, bool, bool)> evsm_moments("penumbra/vsm.glsl",
                                                                         "evsm_moments");
    const glm::vec2 c(5.54f, 5.54f);  // fp16-safe exponents
    std::vector<std::tuple<float>> vin;
    std::vector<std::tuple<float, glm::vec2, bool, bool>> ein;
    for (float d : depths) {
      vin.emplace_back(d);
      ein.emplace_back(d, c, reverse_z, true);
    }
    std::vector<float> rg, rgba;
    for (const auto& m : vsm_moments.run(vin)) rg.insert(rg.end(), {m.x, m.y});
    for (const auto& m : evsm_moments.run(ein)) rgba.insert(rgba.end(), {m.x, m.y, m.z, m.w});
    FloatTextureDesc desc;
    desc.width = width;
    desc.height = height;
    desc.sampler.filter = VK_FILTER_LINEAR;
    desc.channels = 2;
    auto rg_tex = make_float_texture(desc, rg);
    desc.channels = 4;
    auto rgba_tex = make_float_texture(desc, rgba);

    ShaderFunction<float(Sampler2D, glm::vec3, float, float, bool)> vsm("penumbra/vsm.glsl",
                                                                        "vsm_sample_shadow");
    ShaderFunction<float(Sampler2D, glm::vec3, float, float, float, bool, bool)> evsm2(
        "penumbra/vsm.glsl", "evsm2_sample_shadow");
    ShaderFunction<float(Sampler2D, glm::vec3, glm::vec2, float, float, bool, bool)> evsm4(
        "penumbra/vsm.glsl", "evsm4_sample_shadow");
    vsm.bind(0, rg_tex);
    evsm2.bind(0, rg_tex);  // .xy of the EVSM4 moments is the EVSM2 pair: bind that too below
    evsm4.bind(0, rgba_tex);
    const float mv = 1e-6f;
    const float u_edge = float(edge) / width, u_lit = (edge + 8.5f) / width,
                u_dark = (edge - 8.5f) / width;
    const double dist = std::abs(double(receiver) - blocker);
    const std::vector<float> want = {0.5f, 1.0f, float(mv / (mv + dist * dist))};
    std::vector<std::tuple<glm::vec3, float, float, bool>> vc;
    for (float u : {u_edge, u_lit, u_dark})
      vc.emplace_back(glm::vec3(u, 0.5f, receiver), mv, 0.0f, reverse_z);
    PENUMBRA_EXPECT_ALL_NEAR(want, vsm.run(vc), Tolerance::absolute(1e-5))
        << "reverse_z " << reverse_z;

    // EVSM: the edge is 1/2 and the lit side 1; the dark side is tiny (min variance scaled).
    std::vector<std::tuple<glm::vec3, glm::vec2, float, float, bool, bool>> ec;
    for (float u : {u_edge, u_lit, u_dark})
      ec.emplace_back(glm::vec3(u, 0.5f, receiver), c, mv, 0.0f, reverse_z, true);
    // Off the map (u beyond 1): lit, like every filter.
    ec.emplace_back(glm::vec3(1.5f, 0.5f, receiver), c, mv, 0.0f, reverse_z, true);
    const auto got4 = evsm4.run(ec);
    EXPECT_EQ(got4[3], 1.0f);
    EXPECT_NEAR(got4[0], 0.5f, 1e-4) << "reverse_z " << reverse_z;
    EXPECT_NEAR(got4[1], 1.0f, 1e-4);
    EXPECT_LT(got4[2], 0.01f);
    // EVSM2 from the positive pair only.
    std::vector<float> rg2;
    for (size_t i = 0; i < rgba.size(); i += 4) rg2.insert(rg2.end(), {rgba[i], rgba[i + 1]});
    desc.channels = 2;
    evsm2.bind(0, make_float_texture(desc, rg2));
    std::vector<std::tuple<glm::vec3, float, float, float, bool, bool>> e2;
    for (float u : {u_edge, u_lit, u_dark})
      e2.emplace_back(glm::vec3(u, 0.5f, receiver), c.x, mv, 0.0f, reverse_z, true);
    const auto got2 = evsm2.run(e2);
    EXPECT_NEAR(got2[0], 0.5f, 1e-4);
    EXPECT_NEAR(got2[1], 1.0f, 1e-4);
    EXPECT_LT(got2[2], 0.01f);

    // The renderer's form reads a cascade's layer of an array (evsm_moments.comp's output):
    // layer 1 holds the half plane, layers 0 and 2 the blocker everywhere. The array form at
    // layer 1 is the 2D form bit for bit; at layer 0 every receiver is in shadow.
    std::vector<float> layers;
    for (int layer = 0; layer < 3; ++layer)
      for (size_t i = 0; i < rg2.size(); i += 2) {
        const bool half_plane = layer == 1;
        layers.push_back(half_plane ? rg2[i] : rg2[0]);
        layers.push_back(half_plane ? rg2[i + 1] : rg2[1]);
      }
    FloatTextureDesc adesc = desc;
    adesc.layers = 3;
    adesc.array = true;
    ShaderFunction<float(Sampler2DArray, glm::vec3, int32_t, float, float, float, bool, bool)>
        evsm2_array("penumbra/vsm.glsl", "evsm2_sample_shadow_array");
    evsm2_array.bind(0, make_float_texture(adesc, layers));
    std::vector<std::tuple<glm::vec3, int32_t, float, float, float, bool, bool>> ea;
    for (int32_t layer : {1, 0})
      for (float u : {u_edge, u_lit, u_dark})
        ea.emplace_back(glm::vec3(u, 0.5f, receiver), layer, c.x, mv, 0.0f, reverse_z, true);
    const auto gota = evsm2_array.run(ea);
    for (size_t i = 0; i < 3; ++i) {
      EXPECT_EQ(gota[i], got2[i]) << "layer 1, case " << i;
      EXPECT_LT(gota[3 + i], 0.01f) << "layer 0 (all blocker), case " << i;
    }
  }
}

// A size x size x layers depth-map array of random depths in [0.05, 0.95], and its texture
// description.
std::pair<std::vector<float>, FloatTextureDesc> random_depth_array(int size, int layers,
                                                                   uint64_t seed) {
  Rng rng(seed);
  std::vector<float> depth(size_t(size * size * layers));
  for (float& d : depth) d = detail::uniform_scalar(rng, 0.05f, 0.95f);
  FloatTextureDesc desc;
  desc.width = desc.height = size;
  desc.layers = layers;
  desc.array = true;
  return {depth, desc};
}

// The evsm pass's separable blur (evsm2_moments_box_x, then moments_box_y) against a C++ model
// in double on a random 2-layer depth map, every texel, radii 0 to 3: reads clamp at the edges,
// the box is centred (a shift by one texel fails), and each pass averages 2 r + 1 taps.
TEST_F(VsmTest, EvsmMomentBlurIsACentredClampedBoxInBothPasses) {
  const int size = 12, layers = 2;
  const auto [depth, desc] = random_depth_array(size, layers, 0xB10B);
  ShaderFunction<glm::vec2(Sampler2DArray, glm::ivec3, int32_t, int32_t, float, bool, bool)> box_x(
      "penumbra/vsm.glsl", "evsm2_moments_box_x");
  box_x.bind(0, make_float_texture(desc, depth));
  auto at = [&](const std::vector<float>& v, int x, int y, int l, int channels, int c) {
    x = std::clamp(x, 0, size - 1);
    y = std::clamp(y, 0, size - 1);
    return double(v[size_t(((l * size + y) * size + x) * channels + c)]);
  };
  for (int radius = 0; radius <= 3; ++radius) {
    for (bool reverse_z : {true, false}) {
      const float c = 20.0f;
      std::vector<std::tuple<glm::ivec3, int32_t, int32_t, float, bool, bool>> cases;
      for (int l = 0; l < layers; ++l)
        for (int y = 0; y < size; ++y)
          for (int x = 0; x < size; ++x)
            cases.emplace_back(glm::ivec3(x, y, l), radius, size, c, reverse_z, false);
      const auto got = box_x.run(cases);
      std::vector<float> rg;  // the x pass's output, as the y pass reads it
      for (size_t i = 0; i < cases.size(); ++i) {
        const glm::ivec3 t = std::get<0>(cases[i]);
        double m1 = 0.0, m2 = 0.0;
        for (int k = -radius; k <= radius; ++k) {
          const double w = ref::evsm_positive(at(depth, t.x + k, t.y, t.z, 1, 0), c, reverse_z);
          m1 += w;
          m2 += w * w;
        }
        m1 /= 2 * radius + 1;
        m2 /= 2 * radius + 1;
        ASSERT_NEAR(got[i].x, m1, 1e-5 * m1)
            << "texel " << t.x << ", " << t.y << ", " << t.z << " radius " << radius;
        ASSERT_NEAR(got[i].y, m2, 1e-5 * m2);
        rg.insert(rg.end(), {got[i].x, got[i].y});
      }
      FloatTextureDesc mdesc = desc;
      mdesc.channels = 2;
      ShaderFunction<glm::vec2(Sampler2DArray, glm::ivec3, int32_t, int32_t)> box_y(
          "penumbra/vsm.glsl", "moments_box_y");
      box_y.bind(0, make_float_texture(mdesc, rg));
      std::vector<std::tuple<glm::ivec3, int32_t, int32_t>> ycases;
      for (const auto& cs : cases) ycases.emplace_back(std::get<0>(cs), radius, size);
      const auto goty = box_y.run(ycases);
      for (size_t i = 0; i < ycases.size(); ++i) {
        const glm::ivec3 t = std::get<0>(ycases[i]);
        glm::dvec2 m(0.0);
        for (int k = -radius; k <= radius; ++k)
          m += glm::dvec2(at(rg, t.x, t.y + k, t.z, 2, 0), at(rg, t.x, t.y + k, t.z, 2, 1));
        m /= double(2 * radius + 1);
        ASSERT_NEAR(goty[i].x, m.x, 1e-5 * m.x) << "texel " << t.x << ", " << t.y << ", " << t.z;
        ASSERT_NEAR(goty[i].y, m.y, 1e-5 * m.y);
      }
    }
  }
}

// Through a window (the sun's cascades read in place from their toroidal grid): the x pass on a
// map rolled by o, given window o, returns what the plain pass returns on the map, bit for bit,
// edges included (the reads clamp at the map's edges, then move by o), for offsets that wrap in
// x, in y and in both.
TEST_F(VsmTest, EvsmMomentBlurThroughAWindowReadsTheRolledMap) {
  const int size = 12, layers = 2;
  const auto [depth, desc] = random_depth_array(size, layers, 0xB10C);
  ShaderFunction<glm::vec2(Sampler2DArray, glm::ivec3, int32_t, int32_t, float, bool, bool)> plain(
      "penumbra/vsm.glsl", "evsm2_moments_box_x");
  plain.bind(0, make_float_texture(desc, depth));
  for (const glm::ivec2 o : {glm::ivec2(5, 0), glm::ivec2(0, 7), glm::ivec2(11, 3)}) {
    SCOPED_TRACE("window " + std::to_string(o.x) + ", " + std::to_string(o.y));
    std::vector<float> rolled(depth.size());
    for (int l = 0; l < layers; ++l)
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x)
          rolled[size_t((l * size + (y + o.y) % size) * size + (x + o.x) % size)] =
              depth[size_t((l * size + y) * size + x)];
    ShaderFunction<glm::vec2(Sampler2DArray, glm::ivec3, int32_t, int32_t, float, bool, bool,
                             glm::ivec2)>
        windowed("penumbra/vsm.glsl", "evsm2_moments_box_x");
    windowed.bind(0, make_float_texture(desc, rolled));
    std::vector<std::tuple<glm::ivec3, int32_t, int32_t, float, bool, bool>> cases;
    std::vector<std::tuple<glm::ivec3, int32_t, int32_t, float, bool, bool, glm::ivec2>> wcases;
    for (int radius : {0, 2})
      for (int l = 0; l < layers; ++l)
        for (int y = 0; y < size; ++y)
          for (int x = 0; x < size; ++x) {
            cases.emplace_back(glm::ivec3(x, y, l), radius, size, 20.0f, true, false);
            wcases.emplace_back(glm::ivec3(x, y, l), radius, size, 20.0f, true, false, o);
          }
    const auto want = plain.run(cases), got = windowed.run(wcases);
    ASSERT_EQ(want.size(), got.size());
    for (size_t i = 0; i < want.size(); ++i) {
      const glm::ivec3 t = std::get<0>(cases[i]);
      ASSERT_EQ(got[i], want[i]) << "texel " << t.x << ", " << t.y << ", " << t.z << " radius "
                                 << std::get<1>(cases[i]);
    }
  }
}

// A spot light's perspective depths are made linear before the warp: each texel's view depth
// (from the projection's planes, written here from the projection rather than from depth.glsl)
// mapped to [0, 1] between the planes, 1 - that under reverse-Z, then warped and box-averaged.
// Warping the perspective depth itself (the plain evsm2_moments_box_x) misses by far more than
// the tolerance.
TEST_F(VsmTest, SpotMomentsWarpLinearDepthBetweenThePlanes) {
  const int size = 10;
  const double near = 0.2, far = 25.0;
  Rng rng(0x5B07);
  std::vector<float> depth(size_t(size * size));
  for (float& d : depth) d = detail::uniform_scalar(rng, 0.0f, 1.0f);
  FloatTextureDesc desc;
  desc.width = desc.height = size;
  desc.array = true;
  ShaderFunction<glm::vec2(Sampler2DArray, glm::ivec3, int32_t, int32_t, float, float, float, bool,
                           bool)>
      linear("penumbra/vsm.glsl", "evsm2_moments_box_x_linear");
  linear.bind(0, make_float_texture(desc, depth));
  for (const auto& [reverse_z, radius] :
       {std::pair{true, 1}, std::pair{false, 1}, std::pair{true, 2}, std::pair{false, 3}}) {
    const float c = 20.0f;
    std::vector<std::tuple<glm::ivec3, int32_t, int32_t, float, float, float, bool, bool>> cases;
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x)
        cases.emplace_back(glm::ivec3(x, y, 0), radius, size, c, float(near), float(far), reverse_z,
                           false);
    const auto got = linear.run(cases);
    for (size_t i = 0; i < cases.size(); ++i) {
      const glm::ivec3 t = std::get<0>(cases[i]);
      double m1 = 0.0, m2 = 0.0;
      for (int k = -radius; k <= radius; ++k) {
        const double d = depth[size_t(t.y * size + std::clamp(t.x + k, 0, size - 1))];
        // Reverse-Z stores near / z scaled between the planes: d = near (far - z) / (z (far -
        // near)); standard stores 1 - that with the planes swapped.
        const double z = reverse_z ? near * far / (near + d * (far - near))
                                   : near * far / (far - d * (far - near));
        const double l = std::clamp((z - near) / (far - near), 0.0, 1.0);
        const double w = ref::evsm_positive(reverse_z ? 1.0 - l : l, c, reverse_z);
        m1 += w;
        m2 += w * w;
      }
      m1 /= 2 * radius + 1;
      m2 /= 2 * radius + 1;
      ASSERT_NEAR(got[i].x, m1, 1e-4 * m1) << "texel " << t.x << ", " << t.y;
      ASSERT_NEAR(got[i].y, m2, 1e-4 * m2) << "texel " << t.x << ", " << t.y;
    }
  }
}

// ---- EVSM2 reads the renderer makes: a footprint's mip level, a point light's cube ------------

// The EVSM2 pair (E[w+], E[w+^2]) of a depth, warped in double (c+ = c) and rounded to float.
glm::vec2 evsm2_pair(double depth, double c, bool reverse_z) {
  const double w = ref::evsm_positive(depth, c, reverse_z);
  return {float(w), float(w * w)};
}

// An RG32F 2D array of `layers` layers, size x size, with its full mip chain built by the GPU
// (Image::generate_mips: each level the box average of the one above), sampled nearest in and
// between levels. levels[l] receives level l of every layer, read back (layer-major), so the
// expectations use the texels the GPU actually holds.
std::shared_ptr<Texture> mipmapped_moments(int size, int layers, const std::vector<float>& rg,
                                           std::vector<std::vector<float>>& levels) {
  auto& ctx = shared_context();
  gpu::ImageDesc d;
  d.kind = gpu::ImageKind::image_2d_array;
  d.format = VK_FORMAT_R32G32_SFLOAT;
  d.width = d.height = uint32_t(size);
  d.layers = uint32_t(layers);
  d.mip_levels = gpu::full_mip_count(d.width, d.height);
  d.usage = VK_IMAGE_USAGE_SAMPLED_BIT;
  gpu::SamplerDesc sd;
  sd.filter = VK_FILTER_NEAREST;
  sd.mip = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  auto t = std::make_shared<Texture>(Texture{gpu::Image(ctx, d), gpu::Sampler(ctx, sd), false});
  t->image.upload(std::as_bytes(std::span<const float>(rg)));
  gpu::submit_one_shot(ctx, [&](VkCommandBuffer cmd) { t->image.generate_mips(cmd); });
  levels.clear();
  for (uint32_t l = 0; l < d.mip_levels; ++l) {
    const auto bytes = t->image.download(l);
    levels.emplace_back(bytes.size() / sizeof(float));
    std::memcpy(levels.back().data(), bytes.data(), bytes.size());
  }
  return t;
}

using Evsm2ArrayFn =
    ShaderFunction<float(Sampler2DArray, glm::vec3, int32_t, float, float, float, bool, bool)>;
using Evsm2FootprintFn = ShaderFunction<float(Sampler2DArray, glm::vec3, int32_t, glm::vec2,
                                              glm::vec2, float, float, float, bool, bool)>;

// evsm2_sample_shadow_array_footprint reads level log2 of the footprint's shorter side in texels
// (min(|duv_dx|, |duv_dy|) * size), clamped to the chain, and evaluates evsm2_shadow on it. A
// 16x16, 3-layer moment array of random depths has a different average at every level, so the
// level, the texel and the layer each show in the result. Footprints of 2^k texels (k = -2..6)
// put the level exactly on an integer, where nearest mip selection is not in doubt: isotropic,
// rotated, and anisotropic with either side the shorter. Receivers sit at level-0 texel centres,
// never on a texel edge of any level. Expected: evsm2_shadow (tested above) on the read-back
// texel of the expected level, bit for bit (the same function on the same moments; no filtering
// weights in between). With no footprint (zero derivatives) the read is level 0, which is what
// evsm2_sample_shadow_array reads.
TEST_F(VsmTest, Evsm2FootprintReadsTheLevelOfTheFootprintsShorterSide) {
  constexpr int size = 16, layers = 3;
  ASSERT_TRUE(gpu::mips_supported(ctx(), VK_FORMAT_R32G32_SFLOAT))
      << "the test builds its mips with linear blits of RG32F";
  Rng rng(407);
  const float c = 5.54f;
  for (bool reverse_z : {true, false}) {
    SCOPED_TRACE(reverse_z ? "reverse-Z" : "standard depth");
    // Depth of a distance fraction from the light (the warp's f).
    const auto depth_of = [&](double f) { return reverse_z ? 1.0 - f : f; };
    std::vector<float> rg;
    for (int i = 0; i < size * size * layers; ++i) {
      const glm::vec2 m = evsm2_pair(depth_of(0.1 + 0.5 * rng.next_unit()), c, reverse_z);
      rg.insert(rg.end(), {m.x, m.y});
    }
    std::vector<std::vector<float>> levels;
    const auto texture = mipmapped_moments(size, layers, rg, levels);
    ASSERT_EQ(levels.size(), 5u);
    // Level l's moments at uv in layer `layer` (nearest: floor(uv * level size)).
    const auto moments_at = [&](int l, glm::vec2 uv, int layer) {
      const int n = size >> l;
      const int x = int(std::floor(uv.x * float(n))), y = int(std::floor(uv.y * float(n)));
      const size_t i = (size_t(layer * n + y) * size_t(n) + size_t(x)) * 2;
      return glm::vec2(levels[size_t(l)][i], levels[size_t(l)][i + 1]);
    };
    Evsm2FootprintFn footprint("penumbra/vsm.glsl", "evsm2_sample_shadow_array_footprint");
    Evsm2ArrayFn array("penumbra/vsm.glsl", "evsm2_sample_shadow_array");
    Evsm2Fn evsm2("penumbra/vsm.glsl", "evsm2_shadow");
    footprint.bind(0, texture);
    array.bind(0, texture);
    std::vector<
        std::tuple<glm::vec3, int32_t, glm::vec2, glm::vec2, float, float, float, bool, bool>>
        cases;
    std::vector<std::tuple<glm::vec2, float, float, float, float, bool, bool>> direct, level0;
    std::vector<std::tuple<glm::vec3, int32_t, float, float, float, bool, bool>> plain;
    std::vector<int> level_of;
    for (int i = 0; i < 3000; ++i) {
      const int32_t layer = int32_t(rng.below(layers));
      const glm::vec2 uv((float(rng.below(size)) + 0.5f) / size,
                         (float(rng.below(size)) + 0.5f) / size);
      // Mostly behind the stored depths, so the moments decide the factor.
      const float receiver = float(depth_of(0.4 + 0.55 * rng.next_unit()));
      const float mv = 1e-4f, bleed = i % 5 ? 0.0f : 0.05f;
      // The footprint: sides of 2^short and 2^long texels (long >= short), turned by `angle`,
      // the shorter one along x or y.
      const int k_short = int(rng.below(9)) - 2, k_long = k_short + int(rng.below(3));
      const double angle = i % 3 == 0 ? 0.0 : kTwoPi * rng.next_unit();
      const glm::vec2 u(float(std::cos(angle)), float(std::sin(angle))), v(-u.y, u.x);
      glm::vec2 dx = u * float(std::ldexp(1.0, k_short) / size);
      glm::vec2 dy = v * float(std::ldexp(1.0, k_long) / size);
      if (i % 2) std::swap(dx, dy);
      if (i % 10 == 0) dx = dy = glm::vec2(0.0f);  // no footprint: level 0
      const int level = i % 10 == 0 ? 0 : std::clamp(k_short, 0, 4);
      cases.emplace_back(glm::vec3(uv, receiver), layer, dx, dy, c, mv, bleed, reverse_z, false);
      direct.emplace_back(moments_at(level, uv, layer), receiver, c, mv, bleed, reverse_z, false);
      level0.emplace_back(moments_at(0, uv, layer), receiver, c, mv, bleed, reverse_z, false);
      plain.emplace_back(glm::vec3(uv, receiver), layer, c, mv, bleed, reverse_z, false);
      level_of.push_back(level);
    }
    const auto got = footprint.run(cases);
    const auto want = evsm2.run(direct);
    PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact(),
                             [&](size_t i) { return format_tuple(cases[i]); });
    // The level matters: most cases read above level 0 and get another value there.
    const auto at_level0 = evsm2.run(level0);
    size_t differs = 0, above = 0;
    for (size_t i = 0; i < got.size(); ++i) {
      above += level_of[i] > 0;
      differs += level_of[i] > 0 && at_level0[i] != want[i];
    }
    EXPECT_GT(differs, above * 3 / 4);
    EXPECT_GT(above, cases.size() / 2);
    // No footprint: the plain array read (level 0) exactly.
    const auto flat = array.run(plain);
    for (size_t i = 0; i < got.size(); i += 10)
      EXPECT_EQ(got[i], flat[i]) << format_tuple(cases[i]);
    // Outside the map (or not finite): lit, whatever the map holds.
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (const glm::vec3 coord : {glm::vec3(-0.01f, 0.5f, 0.9f), glm::vec3(0.5f, 1.01f, 0.9f),
                                  glm::vec3(nan, 0.5f, 0.9f), glm::vec3(0.5f, 0.5f, nan)})
      EXPECT_EQ(
          footprint(coord, 0, glm::vec2(0.0f), glm::vec2(0.0f), c, 1e-4f, 0.0f, reverse_z, false),
          1.0f)
          << format_value(coord);
  }
}

using Evsm2CubeFn = ShaderFunction<float(SamplerCubeArray, glm::vec3, int32_t, float, float, float,
                                         float, bool, bool)>;

// evsm2_sample_shadow_cube_array reads the moments of the face the direction selects, in cube
// `layer` (clamped to the array, as texture() clamps array layers), and evaluates evsm2_shadow
// at ref. Three cubes of 4 texels per face, each face holding one moment pair of its own (a
// 50/50 mixture of two depths, both depending on cube and face), sampled nearest; receivers
// mostly behind them; directions anywhere inside a face (minor components within 0.8 of the
// major one: no face edge in doubt) at lengths from 1e-3 to 1e3, and layers past either end.
// Expected: evsm2_shadow (tested above) on that face's pair, bit for bit (the same function on
// the same moments; nearest reads of a constant face weigh nothing). Directions too short to
// address a cube (or not numbers) are lit.
TEST_F(VsmTest, Evsm2CubeArrayReadsTheFaceAndCubeOfTheDirection) {
  constexpr int n = 4, cubes = 3;
  Rng rng(408);
  const float c = 5.54f;
  for (bool reverse_z : {true, false}) {
    SCOPED_TRACE(reverse_z ? "reverse-Z" : "standard depth");
    const auto depth_of = [&](double f) { return reverse_z ? 1.0 - f : f; };
    std::vector<glm::vec2> pair(6 * cubes);
    std::vector<float> rg;
    for (int cube = 0; cube < cubes; ++cube)
      for (int face = 0; face < 6; ++face) {
        const glm::vec2 a = evsm2_pair(depth_of(0.1 + 0.05 * face), c, reverse_z);
        const glm::vec2 b = evsm2_pair(depth_of(0.3 + 0.1 * cube + 0.02 * face), c, reverse_z);
        const glm::vec2 m = 0.5f * (a + b);
        pair[size_t(6 * cube + face)] = m;
        for (int t = 0; t < n * n; ++t) rg.insert(rg.end(), {m.x, m.y});
      }
    FloatTextureDesc desc;
    desc.width = desc.height = n;
    desc.layers = cubes;
    desc.channels = 2;
    desc.cube = true;
    desc.array = true;
    Evsm2CubeFn cube_fn("penumbra/vsm.glsl", "evsm2_sample_shadow_cube_array");
    cube_fn.bind(0, make_float_texture(desc, rg));
    Evsm2Fn evsm2("penumbra/vsm.glsl", "evsm2_shadow");
    std::vector<std::tuple<glm::vec3, int32_t, float, float, float, float, bool, bool>> cases;
    std::vector<std::tuple<glm::vec2, float, float, float, float, bool, bool>> direct, other_face;
    for (int i = 0; i < 3000; ++i) {
      const int face = int(rng.below(6));
      const int32_t layer = i < 30 ? std::array{-1, 3, 50}[i % 3] : int32_t(rng.below(cubes));
      const int cube = std::clamp(layer, 0, cubes - 1);
      // A point of the face, (s, t) in [-0.8, 0.8]^2 on the face at major-axis length 1.
      const double a = -0.8 + 1.6 * rng.next_unit(), b = -0.8 + 1.6 * rng.next_unit();
      const glm::dvec3 w = face == 0   ? glm::dvec3(1.0, a, b)
                           : face == 1 ? glm::dvec3(-1.0, a, b)
                           : face == 2 ? glm::dvec3(a, 1.0, b)
                           : face == 3 ? glm::dvec3(a, -1.0, b)
                           : face == 4 ? glm::dvec3(a, b, 1.0)
                                       : glm::dvec3(a, b, -1.0);
      const glm::vec3 dir(w * std::pow(10.0, -3.0 + 6.0 * rng.next_unit()));
      const float ref = float(depth_of(0.4 + 0.55 * rng.next_unit()));
      const float mv = 1e-4f, bleed = i % 5 ? 0.0f : 0.05f;
      const bool fp16 = i % 3 == 0;  // c = 5.54 is below both formats' limits
      cases.emplace_back(dir, layer, ref, c, mv, bleed, reverse_z, fp16);
      direct.emplace_back(pair[size_t(6 * cube + face)], ref, c, mv, bleed, reverse_z, fp16);
      other_face.emplace_back(pair[size_t(6 * cube + (face ^ 1))], ref, c, mv, bleed, reverse_z,
                              fp16);
    }
    const auto got = cube_fn.run(cases);
    const auto want = evsm2.run(direct);
    PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact(),
                             [&](size_t i) { return format_tuple(cases[i]); });
    // The face matters: the opposite face's moments give another value in most cases.
    const auto opposite = evsm2.run(other_face);
    size_t differs = 0;
    for (size_t i = 0; i < want.size(); ++i) differs += want[i] != opposite[i];
    EXPECT_GT(differs, want.size() * 3 / 4);
    // Too short to address a cube (|dir|^2 below the smallest normal float, or 0 after
    // underflow), or NaN: lit. A direction just long enough reads its face like any other.
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float far_ref = float(depth_of(0.95));  // behind every face: shadowed where it reads
    for (const glm::vec3 dir : {glm::vec3(0.0f), glm::vec3(1e-30f, 0.0f, 0.0f),
                                glm::vec3(0.0f, -1e-20f, 0.0f), glm::vec3(nan, 1.0f, 0.0f)})
      EXPECT_EQ(cube_fn(dir, 1, far_ref, c, 1e-4f, 0.0f, reverse_z, false), 1.0f)
          << format_value(dir);
    const float just =
        cube_fn(glm::vec3(1e-18f, 0.0f, 0.0f), 1, far_ref, c, 1e-4f, 0.0f, reverse_z, false);
    EXPECT_EQ(just, evsm2(pair[6], far_ref, c, 1e-4f, 0.0f, reverse_z, false));
    EXPECT_LT(just, 0.5f);
  }
}

// ---- parameter and coordinate limits -------------------------------------------------------

// The bleed amount is clamped to [0, 1] before linstep: a negative amount reduces nothing (p
// comes back unchanged, p / 1 exactly), an amount above 1 keeps only p = 1 (amount 1's step).
// Exact: no rounding is involved in either case.
TEST_F(VsmTest, LightBleedAmountOutsideUnitIntervalIsClamped) {
  ShaderFunction<float(float, float)> f("penumbra/vsm.glsl", "vsm_reduce_light_bleeding");
  std::vector<std::tuple<float, float>> cases;
  std::vector<float> want;
  for (float p : {0.0f, 0.25f, 0.5f, 0.999f, 1.0f}) {
    for (float a : {-1e-6f, -0.5f, -1.0f, -4.0f, -1e30f}) {
      cases.emplace_back(p, a);
      want.push_back(p);  // amount 0
    }
    for (float a : {1.0f + 0x1p-23f, 2.0f, 1e30f}) {
      cases.emplace_back(p, a);
      want.push_back(p >= 1.0f ? 1.0f : 0.0f);  // amount 1
    }
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, f.run(cases), Tolerance::exact(),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

// evsm_warp clamps the depth to [0, 1] before warping: a depth beyond either end warps like the
// end itself, x = 2 f - 1 = +-1 and w = (exp(c+ x), -exp(-c- x)). With c = 5 the argument c x =
// +-5 is exact, so the only error is exp's (3 + 2 |x| = 13 ULP): 1e-5 relative covers it, and an
// unclamped depth (x = 3 for depth 2) would be off by a factor exp(10).
TEST_F(VsmTest, EvsmWarpClampsTheDepthToUnitInterval) {
  ShaderFunction<glm::vec2(float, glm::vec2, bool, bool)> warp("penumbra/vsm.glsl", "evsm_warp");
  const glm::vec2 c(5.0f, 5.0f);
  std::vector<std::tuple<float, glm::vec2, bool, bool>> cases;
  std::vector<glm::vec2> want;
  for (bool reverse_z : {false, true}) {
    for (float depth : {-1e30f, -2.0f, -0.5f, -0x1p-20f, 1.0f + 0x1p-20f, 1.5f, 2.0f, 1e30f}) {
      const double clamped = std::clamp(double(depth), 0.0, 1.0);
      const double x = 2.0 * (reverse_z ? 1.0 - clamped : clamped) - 1.0;
      cases.emplace_back(depth, c, reverse_z, false);
      want.emplace_back(float(std::exp(5.0 * x)), float(-std::exp(-5.0 * x)));
    }
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, warp.run(cases), Tolerance::relative(1e-5),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

// The map is the closed square [0, 1]^2: a coordinate exactly 0 or 1 (either sign of zero) is
// inside; anything beyond, even by the smallest normal float below 0 or one float step above 1,
// or a non-finite component (depth included), is outside. (A negative denormal is not tested:
// Vulkan lets a device flush it to -0, which is inside, and the NVIDIA H100 does, as
// pcf_extremes_tests says of the PCF lookups.)
TEST_F(VsmTest, CoordInMapIsTheClosedUnitSquare) {
  ShaderFunction<bool(glm::vec3)> in_map("penumbra/vsm.glsl", "vsm_coord_in_map");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const float below = -std::numeric_limits<float>::min(), above = 1.0f + 0x1p-23f;
  const std::vector<std::tuple<glm::vec3>> inside = {
      {{0.0f, 0.5f, 0.5f}}, {{0.5f, 0.0f, 0.5f}},  {{0.0f, 0.0f, 0.5f}},  {{-0.0f, -0.0f, 0.5f}},
      {{1.0f, 0.5f, 0.5f}}, {{0.5f, 1.0f, 0.5f}},  {{1.0f, 1.0f, 0.5f}},  {{0.0f, 1.0f, 0.5f}},
      {{1.0f, 0.0f, 0.5f}}, {{0.5f, 0.5f, -7.0f}}, {{0.5f, 0.5f, 1e30f}}, {{0.25f, 0.75f, 0.0f}}};
  const std::vector<std::tuple<glm::vec3>> outside = {
      {{below, 0.5f, 0.5f}}, {{0.5f, below, 0.5f}}, {{above, 0.5f, 0.5f}}, {{0.5f, above, 0.5f}},
      {{nan, 0.5f, 0.5f}},   {{0.5f, nan, 0.5f}},   {{0.5f, 0.5f, nan}},   {{inf, 0.5f, 0.5f}},
      {{0.5f, -inf, 0.5f}},  {{0.5f, 0.5f, inf}},   {{-1.0f, 2.0f, 0.5f}}};
  const auto got_in = in_map.run(inside);
  for (size_t i = 0; i < inside.size(); ++i) EXPECT_TRUE(got_in[i]) << format_tuple(inside[i]);
  const auto got_out = in_map.run(outside);
  for (size_t i = 0; i < outside.size(); ++i) EXPECT_FALSE(got_out[i]) << format_tuple(outside[i]);
}

// Off the map (uv outside [0, 1]^2, or a non-finite coordinate) the EVSM2 reads are lit, exactly
// 1, although every texel of the map holds a blocker that shadows the receiver: the in-map
// control reads the same map and is dark. Both the 2D and the array form.
TEST_F(VsmTest, Evsm2SampleShadowOffTheMapIsLit) {
  const float c = 5.0f, mv = 1e-6f, receiver = 0.7f;
  const glm::vec2 blocker = evsm2_pair(0.4, c, false);  // standard depth: 0.4 is in front
  FloatTextureDesc desc;
  desc.width = desc.height = 4;
  desc.channels = 2;
  desc.sampler.filter = VK_FILTER_LINEAR;
  std::vector<float> rg;
  for (int i = 0; i < 16; ++i) rg.insert(rg.end(), {blocker.x, blocker.y});
  ShaderFunction<float(Sampler2D, glm::vec3, float, float, float, bool, bool)> evsm2(
      "penumbra/vsm.glsl", "evsm2_sample_shadow");
  evsm2.bind(0, make_float_texture(desc, rg));
  std::vector<float> layers = rg;
  layers.insert(layers.end(), rg.begin(), rg.end());
  FloatTextureDesc adesc = desc;
  adesc.layers = 2;
  adesc.array = true;
  Evsm2ArrayFn evsm2_array("penumbra/vsm.glsl", "evsm2_sample_shadow_array");
  evsm2_array.bind(0, make_float_texture(adesc, layers));

  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<glm::vec3> off = {
      {-0.01f, 0.5f, receiver}, {1.01f, 0.5f, receiver}, {0.5f, -0.01f, receiver},
      {0.5f, 1.01f, receiver},  {-3.0f, 4.0f, receiver}, {nan, 0.5f, receiver},
      {0.5f, inf, receiver},    {0.5f, 0.5f, nan},       {0.5f, 0.5f, -inf}};
  for (bool fp16 : {false, true}) {
    EXPECT_LT(evsm2(glm::vec3(0.5f, 0.5f, receiver), c, mv, 0.0f, false, fp16), 0.01f);
    EXPECT_LT(evsm2_array(glm::vec3(0.5f, 0.5f, receiver), 1, c, mv, 0.0f, false, fp16), 0.01f);
    for (const glm::vec3& coord : off) {
      EXPECT_EQ(evsm2(coord, c, mv, 0.0f, false, fp16), 1.0f) << format_value(coord);
      EXPECT_EQ(evsm2_array(coord, 1, c, mv, 0.0f, false, fp16), 1.0f) << format_value(coord);
    }
  }
}

// The last step of every variance filter: clamp to [0, 1], lit for NaN and infinities.
TEST_F(VsmTest, SaturateOrLit) {
  ShaderFunction<float(float)> f("penumbra/vsm.glsl", "vsm_saturate_or_lit");
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<std::tuple<float>> cases{
      {-0.5f}, {1.5f}, {0.3f}, {-0.0f}, {std::numeric_limits<float>::quiet_NaN()}, {inf}, {-inf}};
  EXPECT_EQ(f.run(cases), (std::vector<float>{0.0f, 1.0f, 0.3f, 0.0f, 1.0f, 1.0f, 1.0f}));
}

// The guards of the moment tests: a NaN minimum sigma counts as 0 (a variance of 0 then hides
// the receiver fully), and a receiver beyond the map's depth range reads as one at its end.
TEST_F(VsmTest, MinimumSigmaAndReceiverDepthGuards) {
  ShaderFunction<float(glm::vec2, float, float)> bound("penumbra/vsm.glsl",
                                                       "chebyshev_bound_min_sigma");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(bound(glm::vec2(0.5f, 0.25f), 0.6f, nan), 0.0f);
  EXPECT_EQ(bound(glm::vec2(0.5f, 0.25f), 0.6f, 0.0f), 0.0f);
  VsmFn vsm("penumbra/vsm.glsl", "vsm_shadow");
  const glm::vec2 moments(0.9f, 0.9f * 0.9f + 0.01f);
  for (bool reverse_z : {true, false}) {
    const float end = reverse_z ? 0.0f : 1.0f, beyond = reverse_z ? -0.5f : 1.5f;
    EXPECT_EQ(vsm(moments, beyond, 1e-5f, 0.0f, reverse_z),
              vsm(moments, end, 1e-5f, 0.0f, reverse_z));
  }
}

}  // namespace
}  // namespace penumbra::testing
