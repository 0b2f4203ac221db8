// Function-level tests of shaders/penumbra/cascade.glsl against the independent double-precision
// references in reference/cascade_ref.hpp:
// - selection by view depth for every cascade count 1..8 (and the vec4 form for 1..4), with
//   depths exactly at, just below and just above every split;
// - blend weight and distance fade against the reference, in [0, 1], monotonic, and the blended
//   visibility continuous across every cascade boundary;
// - world -> shadow-map coordinates for orthographic and perspective lights in both depth
//   conventions, each case checked against an error bound derived from the Vulkan precision
//   rules; the uv Y convention on known points;
// - selection by containment, from per-level coordinates and from clipmap matrices (both overloads
//   of select_cascade_by_position: with the coordinate and without).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <glm/gtc/matrix_transform.hpp>
#include <limits>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/interval.hpp>
#include <penumbra/testing/property.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <reference/cascade_ref.hpp>
#include <spec_check.hpp>
#include <string>
#include <tuple>
#include <vector>

namespace penumbra::testing {
namespace {

using Splits = ref::Splits;
using Mat8 = std::array<glm::mat4, 8>;
using Vec3x8 = std::array<glm::vec3, 8>;

constexpr const char* kCascade = "penumbra/cascade.glsl";
// Unit roundoff of float: a correctly rounded operation errs by at most kU relative.
constexpr double kU = 0x1p-24;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// The blend and fade are 1 - (end - x) / width with width = fraction * range. Relative errors:
// end - x 1 ULP (0 where Sterbenz applies), width 2 roundings, the division 2.5 ULP (Vulkan);
// together <= 8 kU on a quotient <= 1, plus half an ULP for 1 - q: <= 9 kU absolute. 16 kU
// (2^-20 ~ 9.5e-7) leaves a factor ~2 for FMA contraction of the last step.
const Tolerance kRampTolerance = Tolerance::absolute(16 * kU);

float split_of(const Splits& s, int i) {
  return s[static_cast<std::size_t>(i / 4)][i % 4];
}
void set_split(Splits& s, int i, float v) {
  s[static_cast<std::size_t>(i / 4)][i % 4] = v;
}

struct SplitSet {
  Splits splits{};
  float camera_near = 0.1f;
  int32_t count = 1;
};

// Strictly increasing far splits from a random camera near (10% of them equal to the previous
// one when allow_equal: an empty cascade). Entries at and after count hold values the GLSL must
// never read (NaN, -1, 0, 1e30): a reference that reads them would disagree.
SplitSet random_splits(Rng& rng, int32_t count, bool allow_equal) {
  SplitSet s;
  s.count = count;
  s.camera_near = uniform(0.05f, 1.0f)(rng);
  float prev = s.camera_near;
  const auto garbage = one_of({kNaN, -1.0f, 0.0f, 1e30f});
  for (int i = 0; i < ref::kMaxCascades; ++i) {
    if (i >= count) {
      set_split(s.splits, i, garbage(rng));
      continue;
    }
    float far = prev * uniform(1.2f, 4.0f)(rng) + uniform(0.0f, 2.0f)(rng);
    if (allow_equal && i > 0 && rng.bernoulli(0.1)) far = prev;
    set_split(s.splits, i, far);
    prev = far;
  }
  return s;
}

// A depth near the interesting places: exactly at a split, one float either side of one, 0, the
// camera near, or anywhere up to 1.3 x the last split.
float selection_depth(Rng& rng, const SplitSet& s) {
  const double u = rng.next_unit();
  const float sp = split_of(s.splits, static_cast<int>(rng.below(static_cast<uint64_t>(s.count))));
  const float last = split_of(s.splits, s.count - 1);
  if (u < 0.2) return sp;
  if (u < 0.3) return std::nextafter(sp, kInf);
  if (u < 0.4) return std::nextafter(sp, -kInf);
  if (u < 0.45) return u < 0.425 ? 0.0f : s.camera_near;
  return uniform(0.0f, 1.3f * last)(rng);
}

class CascadeTest : public GpuTest {
 protected:
  CascadeTest() : seed_(resolve_seed(0)), rng_(seed_.seed) {}
  std::string seed_note() const {
    return "seed " + std::to_string(seed_.seed) + " (set PENUMBRA_SEED to reproduce)";
  }
  SeedChoice seed_;
  Rng rng_;
};

// ------------------------------------------------------------------------------------------
// Selection by view depth

TEST_F(CascadeTest, SelectionByDepthMatchesReferenceForEveryCount) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<int32_t(float, Splits, int32_t)> select(kCascade, "select_cascade_by_depth");
  std::vector<std::tuple<float, Splits, int32_t>> cases;
  std::vector<int32_t> want;
  for (int32_t count = 1; count <= 8; ++count) {
    for (int k = 0; k < 2000; ++k) {
      const SplitSet s = random_splits(rng_, count, /*allow_equal=*/true);
      const float depth = selection_depth(rng_, s);
      cases.emplace_back(depth, s.splits, count);
      want.push_back(ref::select_cascade_by_depth(depth, s.splits, count));
    }
  }
  const auto got = select.run(cases);
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact(),
                           [&](std::size_t i) { return format_tuple(cases[i]); });
  // Every index is reachable, including "outside" (= count).
  for (int32_t count = 1; count <= 8; ++count) {
    for (int32_t idx = 0; idx <= count; ++idx) {
      const auto first = want.begin() + (count - 1) * 2000;
      EXPECT_NE(std::find(first, first + 2000, idx), first + 2000)
          << "count " << count << ": index " << idx << " never expected";
    }
  }
}

TEST_F(CascadeTest, SelectionByDepthVec4FormMatchesReferenceForOneToFourCascades) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<int32_t(float, glm::vec4, int32_t)> select(kCascade, "select_cascade_by_depth");
  std::vector<std::tuple<float, glm::vec4, int32_t>> cases;
  std::vector<int32_t> want;
  for (int32_t count = 1; count <= 4; ++count) {
    for (int k = 0; k < 2000; ++k) {
      const SplitSet s = random_splits(rng_, count, true);
      const float depth = selection_depth(rng_, s);
      cases.emplace_back(depth, s.splits[0], count);
      want.push_back(ref::select_cascade_by_depth4(depth, s.splits[0], count));
    }
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, select.run(cases), Tolerance::exact(),
                           [&](std::size_t i) { return format_tuple(cases[i]); });
}

TEST_F(CascadeTest, DepthExactlyAtASplitBelongsToTheNearerCascade) {
  ShaderFunction<int32_t(float, Splits, int32_t)> select(kCascade, "select_cascade_by_depth");
  const Splits splits{glm::vec4(2, 5, 12, 30), glm::vec4(60, 100, 150, 200)};
  std::vector<std::tuple<float, Splits, int32_t>> cases;
  std::vector<int32_t> want;
  for (int i = 0; i < 8; ++i) {
    const float sp = split_of(splits, i);
    cases.emplace_back(sp, splits, 8);
    want.push_back(i);
    cases.emplace_back(std::nextafter(sp, kInf), splits, 8);
    want.push_back(i + 1);
    cases.emplace_back(std::nextafter(sp, 0.0f), splits, 8);
    want.push_back(i);
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, select.run(cases), Tolerance::exact(),
                           [&](std::size_t i) { return format_tuple(cases[i]); });
}

// ------------------------------------------------------------------------------------------
// Blend weight

// A blend fraction: 10% 0 (hard switch), 10% 1 (the whole range), 5% above 1 (clamped to 1),
// otherwise in [0.01, 0.6].
float random_fraction(Rng& rng) {
  const double u = rng.next_unit();
  if (u < 0.1) return 0.0f;
  if (u < 0.2) return 1.0f;
  if (u < 0.25) return uniform(1.0f, 3.0f)(rng);
  return uniform(0.01f, 0.6f)(rng);
}

// A depth mostly inside or near the band [far - width, far] (width > 0), sometimes exactly at
// its ends, sometimes anywhere in [0, 1.5 far].
float band_depth(Rng& rng, float near, float far, float fraction) {
  const double range = static_cast<double>(far) - near;
  double width = std::min(std::max(static_cast<double>(fraction), 0.0), 1.0) * range;
  if (width <= 0.0) width = 0.1 * range;
  const double u = rng.next_unit();
  if (u < 0.1) return far;
  if (u < 0.2) return static_cast<float>(far - width);
  if (u < 0.3) return uniform(0.0f, 1.5f * far)(rng);
  return static_cast<float>(far - width * 1.3 + width * 1.4 * rng.next_unit());
}

// cascade_end_ramp and its two users as cascade.glsl writes them: in double the value, on
// Interval what the spec allows a device to return.
template <class T>
T end_ramp_formula(T x, T end, T width) {
  using namespace glsl;
  if (!(width >= T(std::numeric_limits<float>::min())) || !is_finite(width) || !is_finite(end))
    return x > end ? T(1.0f) : T(0.0f);
  if (x >= end) return T(1.0f);
  if (!(x > end - T(2.0f) * width)) return T(0.0f);
  if (width > T(1.2676506e30f)) {
    x = x * T(0x1p-64f);
    end = end * T(0x1p-64f);
    width = width * T(0x1p-64f);
  }
  return clamp(T(1.0f) - (end - x) / width, T(0.0f), T(1.0f));
}
template <class T>
T blend_weight_formula(T depth, T near, T far, T band_fraction) {
  using namespace glsl;
  if (is_nan(depth)) return T(0.0f);
  const T fraction = band_fraction > T(0.0f) ? min(band_fraction, T(1.0f)) : T(0.0f);
  return end_ramp_formula(depth, far, fraction * (far - near));
}
template <class T>
T distance_fade_formula(T depth, T max_distance, T fade_fraction) {
  using namespace glsl;
  if (is_nan(depth)) return T(1.0f);
  const T fraction = fade_fraction > T(0.0f) ? min(fade_fraction, T(1.0f)) : T(0.0f);
  return end_ramp_formula(depth, max_distance, fraction * max_distance);
}

// The device lies in the spec's interval for the shader's formula, the interval holds the
// reference's exact ramp, and the hand bound (16 kU absolute) is audited.
TEST_F(CascadeTest, BlendWeightMatchesReference) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<float(float, float, float, float)> blend(kCascade, "cascade_blend_weight");
  std::vector<std::tuple<float, float, float, float>> cases;
  std::vector<Interval> accepted;
  for (int k = 0; k < 8000; ++k) {
    const float near = uniform(0.0f, 200.0f)(rng_);
    const float far = near + uniform(0.05f, 800.0f)(rng_);
    const float fraction = random_fraction(rng_);
    const float depth = band_depth(rng_, near, far, fraction);
    cases.emplace_back(depth, near, far, fraction);
    accepted.push_back(
        spec_interval([&] { return blend_weight_formula<Interval>(depth, near, far, fraction); }));
  }
  EXPECT_TRUE(expect_within_spec(
      {.name = "cascade.cascade_blend_weight",
       .exact = [&](std::size_t i) { return std::apply(ref::cascade_blend_weight, cases[i]); },
       .old_bound = [](std::size_t) { return 16 * kU; },
       .describe = [&](std::size_t i) { return format_tuple(cases[i]); }},
      accepted, blend.run(cases)));
}

// Counts the places where a sorted sweep decreases or leaves [0, 1]; names the first.
std::string check_monotone_unit(const std::vector<float>& x, const std::vector<float>& w,
                                std::size_t first, std::size_t n) {
  std::string problems;
  for (std::size_t i = first; i < first + n; ++i) {
    const bool out = !(w[i] >= 0.0f && w[i] <= 1.0f);
    const bool down = i > first && w[i] < w[i - 1];
    if ((out || down) && problems.empty()) {
      problems = (out ? "outside [0, 1]" : "decreasing") + std::string(" at x = ") +
                 format_value(x[i]) + ": w = " + format_value(w[i]) +
                 (i > first ? ", previous " + format_value(w[i - 1]) : std::string());
    }
  }
  return problems;
}

TEST_F(CascadeTest, BlendWeightIsInUnitRangeAndMonotoneAcrossTheBand) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<float(float, float, float, float)> blend(kCascade, "cascade_blend_weight");
  constexpr std::size_t kConfigs = 16, kSweep = 1024;
  std::vector<std::tuple<float, float, float, float>> cases;
  std::vector<float> depths;
  for (std::size_t c = 0; c < kConfigs; ++c) {
    const float near = uniform(0.0f, 100.0f)(rng_);
    const float far = near + uniform(0.1f, 500.0f)(rng_);
    const float fraction = c == 0 ? 0.0f : uniform(0.01f, 1.0f)(rng_);
    const double width = (fraction > 0.0f ? fraction : 0.1) * (static_cast<double>(far) - near);
    std::vector<float> sweep;
    for (std::size_t k = 0; k < kSweep; ++k) {
      sweep.push_back(static_cast<float>(far - 1.2 * width + 1.4 * width * rng_.next_unit()));
    }
    sweep.push_back(far);
    sweep.push_back(static_cast<float>(far - width));
    std::sort(sweep.begin(), sweep.end());
    sweep.resize(kSweep);
    for (float d : sweep) {
      cases.emplace_back(d, near, far, fraction);
      depths.push_back(d);
    }
  }
  const auto got = blend.run(cases);
  for (std::size_t c = 0; c < kConfigs; ++c) {
    EXPECT_EQ(check_monotone_unit(depths, got, c * kSweep, kSweep), "")
        << "config " << format_tuple(cases[c * kSweep]);
  }
}

// Blended visibility at depth d: v = mix(s[i], s[i + 1], w) with i the selected cascade, w the
// weight of the next one and s[count] = 1 (lit). Across a split it must not jump: just above
// split i cascade i + 1 is selected with weight 0, so v = s[i + 1]; at the split (which belongs
// to cascade i) w is exactly 1 and v = s[i + 1]; one float below the split, w is within
// ulp(split) / width (+ rounding) of 1. At the band's start w is ~0 on both sides.
TEST_F(CascadeTest, BlendedVisibilityIsContinuousAcrossCascadeBoundaries) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<int32_t(float, Splits, int32_t)> select(kCascade, "select_cascade_by_depth");
  ShaderFunction<float(float, Splits, int32_t, int32_t, float, float)> to_next(
      kCascade, "cascade_blend_to_next");
  struct Probe {
    SplitSet s;
    float fraction;
    std::array<float, 9> vis;  // per-cascade visibility, vis[count] = 1
    float depth;
    int boundary;  // the split (or band start) this probe sits at
    int side;      // -1 below, 0 at, +1 above
    bool band_start;
  };
  std::vector<Probe> probes;
  for (int32_t count = 2; count <= 8; ++count) {
    for (int rep = 0; rep < 40; ++rep) {
      Probe p{};
      p.s = random_splits(rng_, count, false);
      p.fraction = uniform(0.05f, 0.5f)(rng_);
      for (int i = 0; i < 9; ++i)
        p.vis[static_cast<std::size_t>(i)] = i < count ? uniform(0.0f, 1.0f)(rng_) : 1.0f;
      for (int b = 0; b + 1 < count; ++b) {
        const float sp = split_of(p.s.splits, b);
        const double near = b == 0 ? p.s.camera_near : split_of(p.s.splits, b - 1);
        const auto start = static_cast<float>(sp - p.fraction * (sp - near));
        for (int side = -1; side <= 1; ++side) {
          p.boundary = b;
          p.side = side;
          p.band_start = false;
          const float toward = side < 0 ? -kInf : kInf;
          p.depth = side == 0 ? sp : std::nextafter(sp, toward);
          probes.push_back(p);
          p.band_start = true;
          p.depth = side == 0 ? start : std::nextafter(start, toward);
          probes.push_back(p);
        }
      }
    }
  }
  std::vector<std::tuple<float, Splits, int32_t>> select_cases;
  for (const Probe& p : probes) select_cases.emplace_back(p.depth, p.s.splits, p.s.count);
  const auto selected = select.run(select_cases);
  std::vector<std::tuple<float, Splits, int32_t, int32_t, float, float>> blend_cases;
  for (std::size_t k = 0; k < probes.size(); ++k) {
    const Probe& p = probes[k];
    blend_cases.emplace_back(p.depth, p.s.splits, selected[k], p.s.count, p.s.camera_near,
                             p.fraction);
  }
  const auto weights = to_next.run(blend_cases);

  // Group the three probes (below, at, above) of each boundary and compare.
  std::vector<double> below, above, at, at_expected, start_below, start_above;
  std::vector<double> bounds;
  for (std::size_t k = 0; k + 2 < probes.size(); k += 6) {
    for (int which = 0; which < 2; ++which) {
      double v[3];
      for (int side = 0; side < 3; ++side) {
        const std::size_t idx = k + static_cast<std::size_t>(2 * side + which);
        const Probe& p = probes[idx];
        const auto i = static_cast<std::size_t>(selected[idx]);
        const double w = weights[idx];
        const double next = i + 1 < 9 ? p.vis[i + 1] : 1.0;
        v[side] = (1.0 - w) * p.vis[i] + w * next;
      }
      const Probe& p = probes[k + static_cast<std::size_t>(which)];
      if (which == 0) {
        below.push_back(v[0]);
        at.push_back(v[1]);
        above.push_back(v[2]);
        at_expected.push_back(p.vis[static_cast<std::size_t>(p.boundary + 1)]);
        const float sp = split_of(p.s.splits, p.boundary);
        const double near =
            p.boundary == 0 ? p.s.camera_near : split_of(p.s.splits, p.boundary - 1);
        // One float step in band widths, plus the ramp's rounding.
        bounds.push_back((sp - static_cast<double>(std::nextafter(sp, 0.0f))) /
                             (p.fraction * (sp - near)) +
                         16 * kU);
      } else {
        start_below.push_back(v[0]);
        start_above.push_back(v[2]);
      }
    }
  }
  const double worst_bound = *std::max_element(bounds.begin(), bounds.end());
  ASSERT_LT(worst_bound, 1e-3) << "the generated splits are too close for this test";
  // At the split: exactly the next cascade's visibility (w == 1 exactly).
  PENUMBRA_EXPECT_ALL_NEAR(at_expected, at, Tolerance::ulps(0));
  // Just above: the next cascade alone.
  PENUMBRA_EXPECT_ALL_NEAR(at_expected, above, Tolerance::ulps(0));
  // Just below: within one float step of the ramp.
  PENUMBRA_EXPECT_ALL_NEAR(above, below, Tolerance::absolute(worst_bound));
  // Band start: the weight starts from 0, so both sides show (almost) the cascade itself.
  PENUMBRA_EXPECT_ALL_NEAR(start_above, start_below, Tolerance::absolute(worst_bound));
}

TEST_F(CascadeTest, BlendToNextMatchesReference) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<float(float, Splits, int32_t, int32_t, float, float)> to_next(
      kCascade, "cascade_blend_to_next");
  std::vector<std::tuple<float, Splits, int32_t, int32_t, float, float>> cases;
  std::vector<float> want;
  for (int k = 0; k < 8000; ++k) {
    const auto count = static_cast<int32_t>(1 + rng_.below(8));
    const SplitSet s = random_splits(rng_, count, true);
    const float depth = selection_depth(rng_, s);
    const float fraction = random_fraction(rng_);
    // Mostly the selected cascade (how the resolve calls it), sometimes any index in [-1, count].
    const int32_t cascade = rng_.bernoulli(0.8)
                                ? ref::select_cascade_by_depth(depth, s.splits, count)
                                : uniform(-1, count)(rng_);
    cases.emplace_back(depth, s.splits, cascade, count, s.camera_near, fraction);
    want.push_back(static_cast<float>(
        ref::cascade_blend_to_next(depth, s.splits, cascade, count, s.camera_near, fraction)));
  }
  PENUMBRA_EXPECT_ALL_NEAR(want, to_next.run(cases), kRampTolerance,
                           [&](std::size_t i) { return format_tuple(cases[i]); });
}

// The two-vec4 forms (what the sun resolve calls with its block's members): the same
// selection, blend and split as the reference, for every count, cascade and fraction, and the
// same results as the array forms, bit for bit.
TEST_F(CascadeTest, TwoVec4FormsMatchTheReferenceAndTheArrayForms) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<int32_t(float, glm::vec4, glm::vec4, int32_t)> select(kCascade,
                                                                      "select_cascade_by_depth");
  ShaderFunction<float(float, glm::vec4, glm::vec4, int32_t, int32_t, float, float)> to_next(
      kCascade, "cascade_blend_to_next");
  ShaderFunction<float(glm::vec4, glm::vec4, int32_t)> split(kCascade, "cascade_split");
  ShaderFunction<float(float, Splits, int32_t, int32_t, float, float)> to_next_array(
      kCascade, "cascade_blend_to_next");
  std::vector<std::tuple<float, glm::vec4, glm::vec4, int32_t>> selections;
  std::vector<std::tuple<float, glm::vec4, glm::vec4, int32_t, int32_t, float, float>> blends;
  std::vector<std::tuple<float, Splits, int32_t, int32_t, float, float>> array_blends;
  std::vector<std::tuple<glm::vec4, glm::vec4, int32_t>> splits;
  std::vector<int32_t> want_selection;
  std::vector<float> want_blend, want_split;
  for (int k = 0; k < 4000; ++k) {
    const auto count = static_cast<int32_t>(1 + rng_.below(8));
    const SplitSet s = random_splits(rng_, count, true);
    const float depth = selection_depth(rng_, s);
    const float fraction = random_fraction(rng_);
    const int32_t selected = ref::select_cascade_by_depth(depth, s.splits, count);
    const int32_t cascade = rng_.bernoulli(0.8) ? selected : uniform(-1, count)(rng_);
    const auto i = static_cast<int32_t>(rng_.below(8));
    selections.emplace_back(depth, s.splits[0], s.splits[1], count);
    blends.emplace_back(depth, s.splits[0], s.splits[1], cascade, count, s.camera_near, fraction);
    array_blends.emplace_back(depth, s.splits, cascade, count, s.camera_near, fraction);
    splits.emplace_back(s.splits[0], s.splits[1], i);
    want_selection.push_back(selected);
    want_blend.push_back(static_cast<float>(
        ref::cascade_blend_to_next(depth, s.splits, cascade, count, s.camera_near, fraction)));
    want_split.push_back(s.splits[static_cast<std::size_t>(i / 4)][i % 4]);
  }
  PENUMBRA_EXPECT_ALL_NEAR(want_selection, select.run(selections), Tolerance::exact(),
                           [&](std::size_t i) { return format_tuple(selections[i]); });
  const auto got_blend = to_next.run(blends);
  PENUMBRA_EXPECT_ALL_NEAR(want_blend, got_blend, kRampTolerance,
                           [&](std::size_t i) { return format_tuple(blends[i]); });
  PENUMBRA_EXPECT_ALL_NEAR(to_next_array.run(array_blends), got_blend, Tolerance::exact(),
                           [&](std::size_t i) { return format_tuple(blends[i]); });
  PENUMBRA_EXPECT_ALL_NEAR(want_split, split.run(splits), Tolerance::exact(),
                           [&](std::size_t i) { return format_tuple(splits[i]); });
}

// ------------------------------------------------------------------------------------------
// Distance fade

TEST_F(CascadeTest, DistanceFadeMatchesReference) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<float(float, float, float)> fade(kCascade, "shadow_distance_fade");
  std::vector<std::tuple<float, float, float>> cases;
  std::vector<Interval> accepted;
  for (int k = 0; k < 8000; ++k) {
    const float max_distance = uniform(1.0f, 2000.0f)(rng_);
    const float fraction = random_fraction(rng_);
    const float depth = band_depth(rng_, 0.0f, max_distance, fraction);
    cases.emplace_back(depth, max_distance, fraction);
    accepted.push_back(spec_interval(
        [&] { return distance_fade_formula<Interval>(depth, max_distance, fraction); }));
  }
  EXPECT_TRUE(expect_within_spec(
      {.name = "cascade.shadow_distance_fade",
       .exact = [&](std::size_t i) { return std::apply(ref::shadow_distance_fade, cases[i]); },
       .old_bound = [](std::size_t) { return 16 * kU; },
       .describe = [&](std::size_t i) { return format_tuple(cases[i]); }},
      accepted, fade.run(cases)));
}

TEST_F(CascadeTest, DistanceFadeIsInUnitRangeAndMonotone) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<float(float, float, float)> fade(kCascade, "shadow_distance_fade");
  constexpr std::size_t kConfigs = 8, kSweep = 1024;
  std::vector<std::tuple<float, float, float>> cases;
  std::vector<float> depths;
  for (std::size_t c = 0; c < kConfigs; ++c) {
    const float max_distance = uniform(10.0f, 1000.0f)(rng_);
    const float fraction = c == 0 ? 0.0f : uniform(0.01f, 1.0f)(rng_);
    std::vector<float> sweep;
    for (std::size_t k = 0; k < kSweep; ++k) {
      sweep.push_back(uniform(0.0f, 1.2f * max_distance)(rng_));
    }
    std::sort(sweep.begin(), sweep.end());
    for (float d : sweep) {
      cases.emplace_back(d, max_distance, fraction);
      depths.push_back(d);
    }
  }
  const auto got = fade.run(cases);
  for (std::size_t c = 0; c < kConfigs; ++c) {
    EXPECT_EQ(check_monotone_unit(depths, got, c * kSweep, kSweep), "")
        << "config " << format_tuple(cases[c * kSweep]);
  }
}

TEST_F(CascadeTest, DistanceFadeKnownValues) {
  ShaderFunction<float(float, float, float)> fade(kCascade, "shadow_distance_fade");
  // max 100, fraction 0.25: band [75, 100]. Exactly representable points of the ramp.
  const std::vector<std::tuple<float, float, float>> cases = {
      {0.0f, 100.0f, 0.25f},   {75.0f, 100.0f, 0.25f},
      {87.5f, 100.0f, 0.25f},  {93.75f, 100.0f, 0.25f},
      {100.0f, 100.0f, 0.25f}, {250.0f, 100.0f, 0.25f},
      {100.0f, 100.0f, 0.0f},  {std::nextafter(100.0f, 200.0f), 100.0f, 0.0f}};
  const std::vector<float> want = {0.0f, 0.0f, 0.5f, 0.75f, 1.0f, 1.0f, 0.0f, 1.0f};
  PENUMBRA_EXPECT_ALL_NEAR(want, fade.run(cases), kRampTolerance,
                           [&](std::size_t i) { return format_tuple(cases[i]); });
}

// ------------------------------------------------------------------------------------------
// World -> shadow-map coordinates

// Per-component bound on |GPU - exact| for world_to_shadow_coord under the Vulkan precision
// rules: each clip component is a 4-term dot product (any order, FMA contraction allowed), off
// by at most gamma_4 = 4u / (1 - 4u) times sum_j |m_rj p_j|; the divide by w adds 2.5 ULP
// (<= 5u relative) and propagates the errors of both operands; uv = ndc * 0.5 + 0.5 adds half
// an ULP of the result. Doubled for the first-order approximation.
glm::dvec3 coord_error_bound(const glm::mat4& m, const glm::vec3& p, const ref::ShadowCoord& r) {
  const double gamma4 = 4 * kU / (1 - 4 * kU);
  glm::dvec4 sum_abs(0.0);
  for (int row = 0; row < 4; ++row) {
    for (int col = 0; col < 4; ++col) {
      const double pj = col < 3 ? static_cast<double>(p[col]) : 1.0;
      sum_abs[row] += std::abs(static_cast<double>(m[col][row]) * pj);
    }
  }
  const double w = r.clip.w;
  glm::dvec3 bound;
  for (int k = 0; k < 3; ++k) {
    const double ndc = r.clip[k] / w;
    const double d_ndc = (gamma4 * sum_abs[k] + std::abs(ndc) * gamma4 * sum_abs[3]) / std::abs(w) +
                         5 * kU * std::abs(ndc);
    bound[k] = k < 2 ? 0.5 * d_ndc + kU * std::abs(r.coord[k]) : d_ndc;
  }
  return 2.0 * bound + glm::dvec3(1e-30);
}

// Compares GPU coordinates with the reference case by case, each component against its own
// bound: the batch compared is the error in units of the bound (must be <= 1), and the report
// shows the inputs, the expected and actual coordinates and the bound.
::testing::AssertionResult coords_within_bounds(const std::vector<glm::mat4>& matrices,
                                                const std::vector<glm::vec3>& points,
                                                const std::vector<glm::vec3>& got) {
  std::vector<glm::dvec3> zero, scaled;
  std::vector<std::string> notes;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const ref::ShadowCoord r = ref::world_to_shadow_coord(matrices[i], points[i]);
    const glm::dvec3 expected = r.outside ? glm::dvec3(-1.0) : r.coord;
    // Outside cases must be exactly kShadowCoordOutside: a bound of 1e-30 admits no error.
    const glm::dvec3 bound =
        r.outside ? glm::dvec3(1e-30) : coord_error_bound(matrices[i], points[i], r);
    zero.emplace_back(0.0);
    scaled.push_back((glm::dvec3(got[i]) - expected) / bound);
    notes.push_back("point " + format_value(points[i]) + ", matrix " + format_value(matrices[i]) +
                    ", expected " + format_value(expected) + ", got " + format_value(got[i]) +
                    ", bound " + format_value(bound) + " (error / bound shown)");
  }
  return all_near(zero, scaled, Tolerance::absolute(1.0), [&](std::size_t i) { return notes[i]; });
}

struct LightSetup {
  glm::mat4 view_proj;
  glm::vec3 center;  // the point the light looks at
  glm::vec3 eye;
  float half_width;  // orthographic half extent, or the distance scale of a perspective light
};

glm::vec3 any_perpendicular_up(const glm::vec3& dir) {
  return std::abs(dir.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
}

// A directional light's cascade: an orthographic box of half width hw around a random centre,
// depth range [near, far] along a random direction; reverse-Z swaps near and far (near -> 1).
LightSetup random_ortho_light(Rng& rng, bool reverse_z) {
  LightSetup l;
  const glm::vec3 dir = unit_vector3()(rng);
  l.center = uniform(glm::vec3(-50.0f), glm::vec3(50.0f))(rng);
  l.half_width = uniform(2.0f, 200.0f)(rng);
  const float distance = 2.0f * l.half_width;
  l.eye = l.center - dir * distance;
  const glm::mat4 view = glm::lookAtRH(l.eye, l.center, any_perpendicular_up(dir));
  const float near = 0.5f * l.half_width, far = 3.5f * l.half_width;
  const float hh = l.half_width * uniform(0.5f, 1.0f)(rng);
  const glm::mat4 proj = reverse_z
                             ? glm::orthoRH_ZO(-l.half_width, l.half_width, -hh, hh, far, near)
                             : glm::orthoRH_ZO(-l.half_width, l.half_width, -hh, hh, near, far);
  l.view_proj = proj * view;
  return l;
}

// A spot light: a perspective frustum from a random eye towards a random centre.
LightSetup random_perspective_light(Rng& rng, bool reverse_z) {
  LightSetup l;
  const glm::vec3 dir = unit_vector3()(rng);
  l.center = uniform(glm::vec3(-20.0f), glm::vec3(20.0f))(rng);
  l.half_width = uniform(5.0f, 50.0f)(rng);
  l.eye = l.center - dir * l.half_width;
  const glm::mat4 view = glm::lookAtRH(l.eye, l.center, any_perpendicular_up(dir));
  const float fov = uniform(0.3f, 2.5f)(rng);
  const float near = uniform(0.05f, 1.0f)(rng), far = 4.0f * l.half_width;
  const glm::mat4 proj = reverse_z ? glm::perspectiveRH_ZO(fov, 1.0f, far, near)
                                   : glm::perspectiveRH_ZO(fov, 1.0f, near, far);
  l.view_proj = proj * view;
  return l;
}

TEST_F(CascadeTest, WorldToShadowCoordOrthographicBothConventions) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<glm::vec3(glm::mat4, glm::vec3)> to_coord(kCascade, "world_to_shadow_coord");
  for (bool reverse_z : {true, false}) {
    SCOPED_TRACE(reverse_z ? "reverse-Z" : "standard depth");
    std::vector<std::tuple<glm::mat4, glm::vec3>> cases;
    std::vector<glm::mat4> matrices;
    std::vector<glm::vec3> points;
    for (int k = 0; k < 4000; ++k) {
      const LightSetup l = random_ortho_light(rng_, reverse_z);
      const glm::vec3 p =
          l.center + uniform(glm::vec3(-1.3f), glm::vec3(1.3f))(rng_) * l.half_width;
      cases.emplace_back(l.view_proj, p);
      matrices.push_back(l.view_proj);
      points.push_back(p);
    }
    const auto got = to_coord.run(cases);
    EXPECT_TRUE(coords_within_bounds(matrices, points, got));
  }
}

TEST_F(CascadeTest, WorldToShadowCoordPerspectiveBothConventions) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<glm::vec3(glm::mat4, glm::vec3)> to_coord(kCascade, "world_to_shadow_coord");
  for (bool reverse_z : {true, false}) {
    SCOPED_TRACE(reverse_z ? "reverse-Z" : "standard depth");
    std::vector<std::tuple<glm::mat4, glm::vec3>> cases;
    std::vector<glm::mat4> matrices;
    std::vector<glm::vec3> points;
    int behind = 0;
    while (cases.size() < 4000) {
      const LightSetup l = random_perspective_light(rng_, reverse_z);
      // Around the eye and the centre: in front, beside and behind the light.
      const glm::vec3 p = l.eye + uniform(glm::vec3(-2.0f), glm::vec3(2.0f))(rng_) * l.half_width;
      const ref::ShadowCoord r = ref::world_to_shadow_coord(l.view_proj, p);
      // Keep w away from 0, where the sign itself is within rounding (the extremes test that).
      const glm::dvec3 bound_w = coord_error_bound(l.view_proj, p, r);
      if (std::abs(r.clip.w) < 1e-3 || (!r.outside && bound_w.x > 1e-3)) continue;
      behind += r.clip.w < 0.0 ? 1 : 0;
      cases.emplace_back(l.view_proj, p);
      matrices.push_back(l.view_proj);
      points.push_back(p);
    }
    EXPECT_GT(behind, 500) << "the generator should put many points behind the light";
    const auto got = to_coord.run(cases);
    EXPECT_TRUE(coords_within_bounds(matrices, points, got));
  }
}

TEST_F(CascadeTest, ShadowCoordUvIsNdcTimesHalfPlusHalfWithoutYFlip) {
  // With the identity matrix the position is the NDC: NDC y = -1 (framebuffer row 0 in Vulkan,
  // the top row) must give v = 0 (texture row 0); depth passes through unchanged.
  ShaderFunction<glm::vec3(glm::mat4, glm::vec3)> to_coord(kCascade, "world_to_shadow_coord");
  const glm::mat4 id(1.0f);
  const std::vector<std::tuple<glm::mat4, glm::vec3>> cases = {
      {id, glm::vec3(-1, -1, 0.25f)},
      {id, glm::vec3(1, 1, 0.75f)},
      {id, glm::vec3(0.5f, -0.5f, 0)},
      {id, glm::vec3(-0.5f, 0.5f, 1)},
      {2.0f * id, glm::vec3(0.5f, -0.5f, 0.5f)}};  // w = 2: a perspective divide
  const std::vector<glm::vec3> want = {glm::vec3(0, 0, 0.25f), glm::vec3(1, 1, 0.75f),
                                       glm::vec3(0.75f, 0.25f, 0), glm::vec3(0.25f, 0.75f, 1),
                                       glm::vec3(0.75f, 0.25f, 0.5f)};
  PENUMBRA_EXPECT_ALL_NEAR(want, to_coord.run(cases), Tolerance::exact(),
                           [&](std::size_t i) { return format_tuple(cases[i]); });
}

TEST_F(CascadeTest, NearAndFarPlanesMapToTheConventionsDepths) {
  // A spot light at the origin looking down -Z, near 0.5, far 40: a point on the near plane has
  // depth 1 under reverse-Z and 0 under standard depth; on the far plane the opposite.
  ShaderFunction<glm::vec3(glm::mat4, glm::vec3)> to_coord(kCascade, "world_to_shadow_coord");
  const glm::mat4 reverse = glm::perspectiveRH_ZO(1.0f, 1.0f, 40.0f, 0.5f);
  const glm::mat4 standard = glm::perspectiveRH_ZO(1.0f, 1.0f, 0.5f, 40.0f);
  const std::vector<std::tuple<glm::mat4, glm::vec3>> cases = {{reverse, glm::vec3(0, 0, -0.5f)},
                                                               {reverse, glm::vec3(0, 0, -40.0f)},
                                                               {standard, glm::vec3(0, 0, -0.5f)},
                                                               {standard, glm::vec3(0, 0, -40.0f)}};
  const std::vector<glm::vec3> want = {glm::vec3(0.5f, 0.5f, 1), glm::vec3(0.5f, 0.5f, 0),
                                       glm::vec3(0.5f, 0.5f, 0), glm::vec3(0.5f, 0.5f, 1)};
  // A few ULP of 1 from the projection's rounding (the bound test covers the general case).
  PENUMBRA_EXPECT_ALL_NEAR(want, to_coord.run(cases), Tolerance::absolute(1e-6),
                           [&](std::size_t i) { return format_tuple(cases[i]); });
}

// ------------------------------------------------------------------------------------------
// Selection by containment

// True when x * res or (1 - x) * res is within `margin` texels of border, where float rounding
// could decide either way.
bool near_uv_edge(double x, double res, double border, double margin) {
  return std::abs(x * res - border) < margin || std::abs((1.0 - x) * res - border) < margin;
}

TEST_F(CascadeTest, SelectionByContainmentOfCoordinatesMatchesReference) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<int32_t(Vec3x8, int32_t, float, float)> select(kCascade,
                                                                "select_cascade_by_containment");
  std::vector<std::tuple<Vec3x8, int32_t, float, float>> cases;
  std::vector<int32_t> want;
  const auto resolution = one_of({256.0f, 1024.0f, 2048.0f, 4096.0f});
  const auto border = one_of({0.0f, 0.5f, 1.0f, 2.0f, 4.0f});
  for (int32_t count = 1; count <= 8; ++count) {
    for (int k = 0; k < 1000; ++k) {
      const float res = resolution(rng_), b = border(rng_);
      Vec3x8 coords{};
      for (auto& c : coords) {
        do {
          c = uniform(glm::vec3(-0.2f, -0.2f, -0.1f), glm::vec3(1.2f, 1.2f, 1.1f))(rng_);
        } while (near_uv_edge(c.x, res, b, 1e-3) || near_uv_edge(c.y, res, b, 1e-3));
      }
      cases.emplace_back(coords, count, b, res);
      want.push_back(ref::select_cascade_by_containment(coords, count, b, res));
    }
  }
  // Both "inside some level" and "outside all" occur.
  EXPECT_GT(std::count_if(want.begin(), want.end(), [](int32_t v) { return v == 0; }), 1000);
  PENUMBRA_EXPECT_ALL_NEAR(want, select.run(cases), Tolerance::exact(),
                           [&](std::size_t i) { return format_tuple(cases[i]); });
}

// Clipmap levels: concentric orthographic boxes around a random centre, level i twice as wide as
// level i - 1, each with a small random offset (texel snapping moves them independently).
Mat8 random_clipmap(Rng& rng, bool reverse_z, glm::vec3& center, float& base) {
  Mat8 m{};
  const glm::vec3 dir = unit_vector3()(rng);
  center = uniform(glm::vec3(-100.0f), glm::vec3(100.0f))(rng);
  base = uniform(4.0f, 32.0f)(rng);
  const glm::vec3 up = any_perpendicular_up(dir);
  for (int i = 0; i < 8; ++i) {
    const float hw = base * static_cast<float>(1 << i);
    const glm::vec3 c = center + uniform(glm::vec3(-0.05f), glm::vec3(0.05f))(rng) * hw;
    const glm::vec3 eye = c - dir * (2.0f * hw);
    const glm::mat4 view = glm::lookAtRH(eye, c, up);
    const float near = 0.5f * hw, far = 3.5f * hw;
    const glm::mat4 proj = reverse_z ? glm::orthoRH_ZO(-hw, hw, -hw, hw, far, near)
                                     : glm::orthoRH_ZO(-hw, hw, -hw, hw, near, far);
    m[static_cast<std::size_t>(i)] = proj * view;
  }
  return m;
}

using PositionCase = std::tuple<glm::vec3, Mat8, int32_t, float, float>;

// Points around random clipmaps, 500 for each count 1..8: a log-uniform distance from the centre,
// so every level gets points, redrawn while the point lies within float rounding of a level's
// edge (in uv or depth). want receives the reference's level, per_level how many chose each.
std::vector<PositionCase> clipmap_position_cases(Rng& rng, bool reverse_z,
                                                 std::vector<int32_t>& want,
                                                 std::vector<int>& per_level) {
  std::vector<PositionCase> cases;
  per_level.assign(9, 0);
  for (int32_t count = 1; count <= 8; ++count) {
    for (int k = 0; k < 500; ++k) {
      glm::vec3 center;
      float base = 0.0f;
      const Mat8 levels = random_clipmap(rng, reverse_z, center, base);
      const float res = 1024.0f, border = rng.bernoulli(0.5) ? 0.0f : 2.0f;
      glm::vec3 p;
      bool ambiguous = true;
      while (ambiguous) {
        const float radius = base * std::exp2(uniform(-1.0f, 9.0f)(rng));
        p = center + unit_vector3()(rng) * radius;
        ambiguous = false;
        for (int i = 0; i < count && !ambiguous; ++i) {
          const ref::ShadowCoord r =
              ref::world_to_shadow_coord(levels[static_cast<std::size_t>(i)], p);
          ambiguous = near_uv_edge(r.coord.x, res, border, 1e-2) ||
                      near_uv_edge(r.coord.y, res, border, 1e-2) || std::abs(r.coord.z) < 1e-5 ||
                      std::abs(r.coord.z - 1.0) < 1e-5;
        }
      }
      cases.emplace_back(p, levels, count, border, res);
      const int32_t level = ref::select_cascade_by_position(p, levels, count, border, res);
      want.push_back(level);
      ++per_level[static_cast<std::size_t>(level)];
    }
  }
  return cases;
}

TEST_F(CascadeTest, SelectionByPositionInClipmapLevelsMatchesReference) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<int32_t(glm::vec3, Mat8, int32_t, float, float, Out<glm::vec3>)> select(
      kCascade, "select_cascade_by_position");
  for (bool reverse_z : {true, false}) {
    SCOPED_TRACE(reverse_z ? "reverse-Z" : "standard depth");
    std::vector<int32_t> want;
    std::vector<int> per_level;
    const std::vector<PositionCase> cases =
        clipmap_position_cases(rng_, reverse_z, want, per_level);
    for (int i = 0; i <= 8; ++i)
      EXPECT_GT(per_level[static_cast<std::size_t>(i)], 20) << "level " << i;
    const auto got = select.run(cases);
    std::vector<int32_t> got_levels;
    std::vector<glm::mat4> matrices;
    std::vector<glm::vec3> points, coords;
    for (std::size_t i = 0; i < got.size(); ++i) {
      got_levels.push_back(std::get<0>(got[i]));
      const int32_t level = want[i];
      const Mat8& levels = std::get<1>(cases[i]);
      matrices.push_back(level < std::get<2>(cases[i]) ? levels[static_cast<std::size_t>(level)]
                                                       : glm::mat4(0.0f));
      points.push_back(std::get<0>(cases[i]));
      coords.push_back(std::get<1>(got[i]));
    }
    PENUMBRA_EXPECT_ALL_NEAR(want, got_levels, Tolerance::exact(),
                             [&](std::size_t i) { return format_tuple(cases[i]); });
    // The returned coordinate is the selected level's (kShadowCoordOutside when none; the zero
    // matrix gives w = 0, which the reference maps to outside too).
    EXPECT_TRUE(coords_within_bounds(matrices, points, coords));
  }
}

// The overload without the coordinate forwards to the full one: the same level, case for case,
// over the clipmap points above (counts 1..8, both conventions), and the reference's level.
// Counts outside [0, 8] are clamped alike: 0 and below select nothing (0); 9 and above are 8
// (taken from the count-8 points, whose every level was kept off the edges).
TEST_F(CascadeTest, SelectionByPositionWithoutTheCoordinateMatchesTheFullOverload) {
  SCOPED_TRACE(seed_note());
  ShaderFunction<int32_t(glm::vec3, Mat8, int32_t, float, float)> level_only(
      kCascade, "select_cascade_by_position");
  ShaderFunction<int32_t(glm::vec3, Mat8, int32_t, float, float, Out<glm::vec3>)> full(
      kCascade, "select_cascade_by_position");
  for (bool reverse_z : {true, false}) {
    SCOPED_TRACE(reverse_z ? "reverse-Z" : "standard depth");
    std::vector<int32_t> want;
    std::vector<int> per_level;
    std::vector<PositionCase> cases = clipmap_position_cases(rng_, reverse_z, want, per_level);
    const size_t generated = cases.size();
    for (size_t i = 0; i < generated; ++i) {
      if (std::get<2>(cases[i]) != 8) continue;
      for (int32_t count : {-3, 0, 9, 100}) {
        PositionCase c = cases[i];
        std::get<2>(c) = count;
        want.push_back(count <= 0 ? 0 : want[i]);
        cases.push_back(c);
      }
    }
    const auto got = level_only.run(cases);
    const auto with_coord = full.run(cases);
    std::vector<int32_t> full_levels;
    for (const auto& r : with_coord) full_levels.push_back(std::get<0>(r));
    PENUMBRA_EXPECT_ALL_NEAR(full_levels, got, Tolerance::exact(),
                             [&](std::size_t i) { return format_tuple(cases[i]); });
    PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact(),
                             [&](std::size_t i) { return format_tuple(cases[i]); });
    for (int i = 0; i <= 8; ++i)
      EXPECT_GT(per_level[static_cast<std::size_t>(i)], 20) << "level " << i;
  }
}

// A coordinate with one non-finite component is outside, whichever component it is (y here:
// x and z finite); a ramp a few hundred FLT_MIN wide keeps its slope (no 2^-64 scaling below
// kCascadeLargeDivisor, which would take it into the denormals).
TEST_F(CascadeTest, OneNonFiniteComponentAndTinyRamps) {
  ShaderFunction<glm::vec3(glm::mat4, glm::vec3)> to_coord(kCascade, "world_to_shadow_coord");
  glm::mat4 m(1.0f);
  m[1][1] = 10.0f;  // clip.y = 10 y: overflows for y = 1e38
  EXPECT_EQ(to_coord(m, glm::vec3(0.5f, 1e38f, 0.5f)), glm::vec3(-1.0f));
  EXPECT_EQ(to_coord(m, glm::vec3(0.5f, 0.01f, 0.5f)), glm::vec3(0.75f, 0.55f, 0.5f));
  ShaderFunction<float(float, float, float)> ramp(kCascade, "cascade_end_ramp");
  const float w = 1e-36f, end = 4e-36f;
  EXPECT_NEAR(ramp(end - 0.5f * w, end, w), 0.5f, 1e-3f);
  EXPECT_NEAR(ramp(end - 0.25f * w, end, w), 0.75f, 1e-3f);
}

}  // namespace
}  // namespace penumbra::testing
