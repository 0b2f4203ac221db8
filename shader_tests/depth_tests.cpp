// Function-level tests of shaders/penumbra/depth.glsl against the long double references in
// reference/depth_ref.hpp, for reverse-Z (the default) and standard-Z.
//
// How the tolerances are derived (Vulkan spec, "Precision and Operation of SPIR-V Instructions"):
// +, -, * are correctly rounded in an unspecified direction (relative error < 2^-23 =
// kRoundingRel each; an exact result is returned exactly), OpFDiv is within 2.5 ULP (relative
// < 2.5 * 2^-23); implementations may fuse a * b + c and reassociate (unless `precise`), which
// only removes roundings or reorders sums of terms of one sign, so per-operation sums of
// roundings over non-negative terms bound contracted code too. Each bound below adds a factor
// 1.001 for second-order terms (products of two relative errors, < 1e-12).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/interval.hpp>
#include <penumbra/testing/property.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "reference/depth_ref.hpp"
#include "reference/noise_ref.hpp"
#include "spec_check.hpp"

namespace penumbra::testing {
namespace {

namespace ref = penumbra::reference;
using ref::kRoundingRel;

constexpr const char* kDepth = "penumbra/depth.glsl";
constexpr double kSecondOrder = 1.001;

// linearize_depth and view_distance_to_depth: relative error < 6.5 * 2^-23, counting roundings
// (each < 2^-23 relative) through quotients of non-negative products and sums:
//   linearize = (near * far) / (far * w_far + near * w_near): numerator 1; denominator 1 (1 - d)
//     + 1 (its product) + 1 (the sum of non-negative terms); division 2.5.
//   view_distance_to_depth = (near * (far - z)) / (z * (far - near)): numerator 2, denominator
//     2, division 2.5 (the numerator's errors and the denominator's add, first order).
// Both: 1 + 3 + 2.5 = 2 + 2 + 2.5 = 6.5.
constexpr double kLinearizeRel = 6.5 * kRoundingRel * kSecondOrder;
// linearize_depth_infinite = near / w, w = d or 1 - d: 1 + 2.5.
constexpr double kLinearizeInfiniteRel = 3.5 * kRoundingRel * kSecondOrder;

struct Planes {
  float near, far;
};
// Typical, short, huge-range (near 1e-4, far 1e6), tight (far / near = 2) and wide planes.
const std::vector<Planes> kPlanes = {
    {0.1f, 1000.0f}, {0.01f, 100.0f}, {1e-4f, 1e6f}, {1.0f, 2.0f}, {0.5f, 50000.0f}};
const std::vector<DepthConvention> kConventions = {DepthConvention::reverse_z,
                                                   DepthConvention::standard};

bool is_reverse(DepthConvention c) {
  return c == DepthConvention::reverse_z;
}

// A recorded measurement, e.g. "1.23e-07".
std::string scientific(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", v);
  return text;
}

std::string describe_planes(float near, float far, bool reverse_z) {
  return std::string(reverse_z ? "reverse-Z" : "standard-Z") + " near " + format_value(near) +
         " far " + format_value(far);
}

class DepthTest : public GpuTest {};

// Depths drawn by depth_extremes: half the special depths (0, -0, 1, 1 - ulp, the smallest
// positive floats, 0.5, ...), half ordinary: uniform in [0, 1] or the depth of a log-uniform view
// distance in [near, far] (where reverse-Z's small values and standard-Z's values near 1 live).
std::vector<std::tuple<float, float, float, bool>> depth_cases(uint64_t seed, size_t per_config) {
  Rng rng(seed);
  std::vector<std::tuple<float, float, float, bool>> cases;
  for (const Planes& p : kPlanes) {
    for (const DepthConvention c : kConventions) {
      const auto depth = depth_extremes(c, {.near = p.near, .far = p.far});
      for (size_t i = 0; i < per_config; ++i)
        cases.emplace_back(depth(rng), p.near, p.far, is_reverse(c));
    }
  }
  return cases;
}

// View distances log-uniform in [near / 2, 2 far] (beyond both planes too), plus the planes.
std::vector<std::tuple<float, float, float, bool>> distance_cases(uint64_t seed,
                                                                  size_t per_config) {
  Rng rng(seed);
  std::vector<std::tuple<float, float, float, bool>> cases;
  for (const Planes& p : kPlanes) {
    for (const DepthConvention c : kConventions) {
      cases.emplace_back(p.near, p.near, p.far, is_reverse(c));
      cases.emplace_back(p.far, p.near, p.far, is_reverse(c));
      const double lo = 0.5 * p.near, hi = 2.0 * p.far;
      for (size_t i = 0; i < per_config; ++i) {
        const double z = lo * std::pow(hi / lo, rng.next_unit());
        cases.emplace_back(static_cast<float>(z), p.near, p.far, is_reverse(c));
      }
    }
  }
  return cases;
}

std::string describe_case(const std::tuple<float, float, float, bool>& c) {
  const auto [x, near, far, reverse_z] = c;
  return format_value(x) + " (" + describe_planes(near, far, reverse_z) + ")";
}

// The shader's formulas (depth.glsl), as templates: in double they give the value, on Interval
// what the spec allows a device to return for them.
template <class T>
T saturate_depth_formula(T d, bool reverse_z) {
  using namespace glsl;
  if (d >= T(0.0f)) return min(d, T(1.0f));
  return d < T(0.0f) ? T(0.0f) : (reverse_z ? T(0.0f) : T(1.0f));
}
template <class T>
T linearize_depth_formula(T d, T near, T far, bool reverse_z) {
  const T s = saturate_depth_formula(d, reverse_z);
  const T w_far = reverse_z ? s : T(1.0f) - s;
  const T w_near = reverse_z ? T(1.0f) - s : s;
  return (near * far) / (far * w_far + near * w_near);
}
template <class T>
T view_distance_to_depth_formula(T z, T near, T far, bool reverse_z) {
  using namespace glsl;
  const T range = far - near;
  const T float_max(std::numeric_limits<float>::max());
  if (!(z <= float_max)) return reverse_z ? -near / range : far / range;
  const T num = reverse_z ? near * (far - z) : far * (z - near);
  const T den = z * range;
  if (abs(num) <= float_max && den <= float_max) return num / den;
  return reverse_z ? (near / range) * ((far - z) / z) : (far / range) * ((z - near) / z);
}

// ---------------------------------------------------------------------------------------------
// Linearization and its inverse

// The device result lies in the interval the Vulkan spec allows for the shader's formula (below,
// mirrored as a template), and that interval holds the exact inverse of the projection
// (reference/depth_ref.hpp): the first checks the device, the second the formula. The hand bound
// used before (6.5 * 2^-23 relative) is audited against the interval.
TEST_F(DepthTest, LinearizeDepthMatchesProjectionInverse) {
  ShaderFunction<float(float, float, float, bool)> linearize(kDepth, "linearize_depth");
  const auto cases = depth_cases(0xDE9701, 4096);
  const std::vector<float> got = linearize.run(cases);
  std::vector<Interval> accepted;
  for (const auto& [d, near, far, reverse_z] : cases) {
    accepted.push_back(
        spec_interval([&] { return linearize_depth_formula<Interval>(d, near, far, reverse_z); }));
  }
  EXPECT_TRUE(expect_within_spec(
      {.name = "depth.linearize_depth",
       .exact =
           [&](size_t i) {
             const auto [d, near, far, reverse_z] = cases[i];
             const double clamped = std::clamp(double{d}, 0.0, 1.0);
             return static_cast<double>(
                 ref::view_distance_from_depth(clamped, near, far, reverse_z));
           },
       .old_bound =
           [&](size_t i) {
             const auto [d, near, far, reverse_z] = cases[i];
             return ref::linearize_expectation(d, near, far, reverse_z, kLinearizeRel).bound;
           },
       .describe = [&](size_t i) { return "d = " + describe_case(cases[i]); }},
      accepted, got));
}

TEST_F(DepthTest, LinearizeDepthInfiniteMatchesProjectionInverse) {
  ShaderFunction<float(float, float, bool)> linearize(kDepth, "linearize_depth_infinite");
  Rng rng(0xDE9702);
  std::vector<std::tuple<float, float, bool>> cases;
  for (const float near : {1e-4f, 0.01f, 0.1f, 1.0f}) {
    for (const DepthConvention c : kConventions) {
      const auto depth = depth_extremes(c, {.near = near, .far = 1e7});
      for (int i = 0; i < 4096; ++i) cases.emplace_back(depth(rng), near, is_reverse(c));
    }
  }
  const std::vector<float> got = linearize.run(cases);
  std::vector<double> want, actual, bounds;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [d, near, reverse_z] = cases[i];
    // The far plane's depth (0 reverse, 1 standard) is at +infinity; -0 is depth 0 too, and a
    // denormal depth may be flushed to it (then +infinity is the answer).
    const bool flushed = ref::is_denormal(d) && std::isinf(got[i]);
    const double z = static_cast<double>(
        ref::view_distance_from_depth_infinite(d == 0.0f || flushed ? 0.0f : d, near, reverse_z));
    want.push_back(z);
    actual.push_back(got[i]);
    bounds.push_back(kLinearizeInfiniteRel * z);
  }
  EXPECT_TRUE(ref::all_within_bounds(want, actual, bounds, [&](size_t i) {
    const auto [d, near, reverse_z] = cases[i];
    return "d = " + format_value(d) + " (" + describe_planes(near, INFINITY, reverse_z) + ")";
  }));
}

TEST_F(DepthTest, ViewDistanceToDepthMatchesProjection) {
  ShaderFunction<float(float, float, float, bool)> to_depth(kDepth, "view_distance_to_depth");
  const auto cases = distance_cases(0xDE9703, 4096);
  const std::vector<float> got = to_depth.run(cases);
  std::vector<Interval> accepted;
  for (const auto& [z, near, far, reverse_z] : cases) {
    accepted.push_back(spec_interval(
        [&] { return view_distance_to_depth_formula<Interval>(z, near, far, reverse_z); }));
  }
  const auto exact = [&](size_t i) {
    const auto [z, near, far, reverse_z] = cases[i];
    return static_cast<double>(ref::depth_from_view_distance(z, near, far, reverse_z));
  };
  EXPECT_TRUE(expect_within_spec(
      {.name = "depth.view_distance_to_depth",
       .exact = exact,
       .old_bound = [&](size_t i) { return kLinearizeRel * std::fabs(exact(i)); },
       .describe = [&](size_t i) { return "z = " + describe_case(cases[i]); }},
      accepted, got));
}

TEST_F(DepthTest, ViewDistanceToDepthInfiniteMatchesProjection) {
  ShaderFunction<float(float, float, bool)> to_depth(kDepth, "view_distance_to_depth_infinite");
  Rng rng(0xDE9704);
  std::vector<std::tuple<float, float, bool>> cases;
  for (const float near : {1e-4f, 0.01f, 0.1f, 1.0f}) {
    for (const bool reverse_z : {true, false}) {
      cases.emplace_back(near, near, reverse_z);
      for (int i = 0; i < 4096; ++i) {
        const double z = near * std::pow(1e9, rng.next_unit());
        cases.emplace_back(static_cast<float>(z), near, reverse_z);
      }
    }
  }
  const std::vector<float> got = to_depth.run(cases);
  std::vector<double> want, actual, bounds;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [z, near, reverse_z] = cases[i];
    const double d =
        static_cast<double>(ref::depth_from_view_distance_infinite(z, near, reverse_z));
    const double q = double{near} / z;
    want.push_back(d);
    actual.push_back(got[i]);
    // q = near / z: 2.5 ULP; standard-Z then 1 - q: q's error plus one rounding of the result.
    bounds.push_back(kSecondOrder *
                     (2.5 * kRoundingRel * q + (reverse_z ? 0.0 : kRoundingRel * std::fabs(d))));
  }
  EXPECT_TRUE(ref::all_within_bounds(want, actual, bounds, [&](size_t i) {
    const auto [z, near, reverse_z] = cases[i];
    return "z = " + format_value(z) + " (" + describe_planes(near, INFINITY, reverse_z) + ")";
  }));
}

// depth -> view distance -> depth on the GPU. The first step returns z' within z (1 +- e),
// e = 6.5 * 2^-23; the second maps that interval through the (monotonic) projection and adds its
// own 6.5 * 2^-23 relative error. The bound takes the interval's ends exactly rather than to
// first order, so it also holds where a float depth cannot resolve the change (standard-Z next
// to 1). To first order it is 6.5 * 2^-23 * (near far / (z (far - near)) + |d|): a few ULP of 1
// at the near plane, a few ULP of d far away, in either convention.
TEST_F(DepthTest, DepthRoundTripsThroughViewDistance) {
  ShaderFunction<float(float, float, float, bool)> linearize(kDepth, "linearize_depth");
  ShaderFunction<float(float, float, float, bool)> to_depth(kDepth, "view_distance_to_depth");
  auto cases = depth_cases(0xDE9705, 4096);
  const std::vector<float> z = linearize.run(cases);
  std::vector<std::tuple<float, float, float, bool>> back;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [d, near, far, reverse_z] = cases[i];
    back.emplace_back(z[i], near, far, reverse_z);
  }
  const std::vector<float> got = to_depth.run(back);
  std::vector<double> want, actual, bounds;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [d, near, far, reverse_z] = cases[i];
    const double clamped = std::clamp(double{d}, 0.0, 1.0);
    const ref::Real exact_z = ref::view_distance_from_depth(clamped, near, far, reverse_z);
    double bound = 0.0;
    for (const double e : {-kLinearizeRel, kLinearizeRel}) {
      const auto end = static_cast<double>(
          ref::depth_from_view_distance(exact_z * (1.0L + e), near, far, reverse_z));
      bound = std::max(bound, std::fabs(end - clamped) + kLinearizeRel * std::fabs(end));
    }
    want.push_back(clamped);
    actual.push_back(got[i]);
    bounds.push_back(bound);
  }
  EXPECT_TRUE(ref::all_within_bounds(want, actual, bounds,
                                     [&](size_t i) { return "d = " + describe_case(cases[i]); }));
}

// view distance -> depth -> view distance. Now the depth's error d (1 +- e) is magnified by the
// slope of the inverse; the bound maps the interval's ends (clamped to [0, 1], as the shader
// clamps) through it exactly and adds linearize's own error. To first order: 6.5 * 2^-23 * (z |d|
// / s + z), s = near far / (z (far - near)). For reverse-Z |d| / s = (far - z) / far <= 1, so z
// survives to ~13 * 2^-23 relative anywhere; for standard-Z d / s = (z - near) / near, so the
// relative error grows as z / near (until d rounds to 1 and z to far): the reason for reverse-Z.
// The worst relative error of each convention is recorded.
TEST_F(DepthTest, ViewDistanceRoundTripsThroughDepth) {
  ShaderFunction<float(float, float, float, bool)> linearize(kDepth, "linearize_depth");
  ShaderFunction<float(float, float, float, bool)> to_depth(kDepth, "view_distance_to_depth");
  auto all = distance_cases(0xDE9706, 4096);
  std::vector<std::tuple<float, float, float, bool>> cases;
  for (const auto& c : all) {  // inside the frustum: depths in [0, 1] (outside they are clamped)
    if (std::get<0>(c) >= std::get<1>(c) && std::get<0>(c) <= std::get<2>(c)) cases.push_back(c);
  }
  const std::vector<float> d = to_depth.run(cases);
  std::vector<std::tuple<float, float, float, bool>> back;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [z, near, far, reverse_z] = cases[i];
    back.emplace_back(d[i], near, far, reverse_z);
  }
  const std::vector<float> got = linearize.run(back);
  std::vector<double> want, actual, bounds;
  double worst[2] = {0.0, 0.0};
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [z, near, far, reverse_z] = cases[i];
    const ref::Real exact_d = ref::depth_from_view_distance(z, near, far, reverse_z);
    double bound = 0.0;
    for (const double e : {-kLinearizeRel, kLinearizeRel}) {
      const ref::Real end_d = std::clamp(exact_d * (1.0L + e), 0.0L, 1.0L);
      const auto end =
          static_cast<double>(ref::view_distance_from_depth(end_d, near, far, reverse_z));
      bound = std::max(bound, std::fabs(end - z) + kLinearizeRel * end);
    }
    want.push_back(z);
    actual.push_back(got[i]);
    bounds.push_back(bound);
    worst[reverse_z ? 0 : 1] =
        std::max(worst[reverse_z ? 0 : 1], std::fabs(double{got[i]} - z) / z);
  }
  EXPECT_TRUE(ref::all_within_bounds(want, actual, bounds,
                                     [&](size_t i) { return "z = " + describe_case(cases[i]); }));
  RecordProperty("worst_relative_error_reverse_z", scientific(worst[0]));
  RecordProperty("worst_relative_error_standard_z", scientific(worst[1]));
  // Reverse-Z keeps every distance to 13 * 2^-23 (the bound above with |d| / sensitivity <= 1).
  EXPECT_LE(worst[0], 2.0 * kLinearizeRel);
}

// ---------------------------------------------------------------------------------------------
// NDC <-> UV

// uv = ndc * 0.5 + 0.5 and ndc = uv * 2 - 1: the scaling by a power of two is exact, the sum one
// rounding (or, fused, the only one): < 1 ULP of the result. The reference is exact in double
// and rounded to nearest float, so the GPU value is within 1 ULP of it.
TEST_F(DepthTest, NdcToUvAndBackAreAffineWithinOneUlp) {
  ShaderFunction<glm::vec2(glm::vec2)> to_uv(kDepth, "ndc_to_uv");
  ShaderFunction<glm::vec2(glm::vec2)> to_ndc(kDepth, "uv_to_ndc");
  const auto coordinate =
      mix(one_of({-1.0f, 0.0f, 1.0f, 0.5f, -0.5f, 1e-8f, -1e-8f}), 0.2, uniform(-4.0f, 4.0f));
  PENUMBRA_EXPECT_PROPERTY(check_property(
      "ndc_to_uv", [&](const auto& cases) { return to_uv.run(cases); },
      [](glm::vec2 ndc) { return glm::vec2(glm::dvec2(ndc) * 0.5 + 0.5); }, Tolerance::ulps(1),
      {.cases = 8192, .seed = 0xDE9707}, vec_of<2>(coordinate)));
  PENUMBRA_EXPECT_PROPERTY(check_property(
      "uv_to_ndc", [&](const auto& cases) { return to_ndc.run(cases); },
      [](glm::vec2 uv) { return glm::vec2(glm::dvec2(uv) * 2.0 - 1.0); }, Tolerance::ulps(1),
      {.cases = 8192, .seed = 0xDE9708}, vec_of<2>(coordinate)));
}

// Vulkan: NDC (-1, -1) is the top-left corner of the framebuffer and uv (0, 0) names it; the
// centre and corners map exactly.
TEST_F(DepthTest, NdcCornersAreUvCornersWithoutYFlip) {
  ShaderFunction<glm::vec2(glm::vec2)> to_uv(kDepth, "ndc_to_uv");
  ShaderFunction<glm::vec2(glm::vec2)> to_ndc(kDepth, "uv_to_ndc");
  const std::vector<std::tuple<glm::vec2>> ndc = {
      {{-1, -1}}, {{1, -1}}, {{-1, 1}}, {{1, 1}}, {{0, 0}}};
  const std::vector<glm::vec2> uv = {{0, 0}, {1, 0}, {0, 1}, {1, 1}, {0.5f, 0.5f}};
  PENUMBRA_EXPECT_ALL_NEAR(uv, to_uv.run(ndc), Tolerance::exact());
  std::vector<std::tuple<glm::vec2>> uv_cases;
  std::vector<glm::vec2> ndc_values;
  for (size_t i = 0; i < uv.size(); ++i) {
    uv_cases.emplace_back(uv[i]);
    ndc_values.push_back(std::get<0>(ndc[i]));
  }
  PENUMBRA_EXPECT_ALL_NEAR(ndc_values, to_ndc.run(uv_cases), Tolerance::exact());
}

// ---------------------------------------------------------------------------------------------
// Position reconstruction

struct Camera {
  double tan_half_fov_y, aspect, near, far;  // far = +inf: infinite far plane
  bool reverse_z;
};
const std::vector<Camera> kCameras = {
    {0.41421356, 16.0 / 9.0, 0.1, 1000.0, true},  // 45 degrees vertical
    {0.41421356, 16.0 / 9.0, 0.1, 1000.0, false},
    {1.0, 1.0, 1e-4, 1e6, true},  // 90 degrees, extreme planes
    {1.0, 1.0, 1e-4, 1e6, false},
    {0.57735027, 2.35, 0.05, std::numeric_limits<double>::infinity(), true},  // infinite far
    {0.57735027, 2.35, 0.05, std::numeric_limits<double>::infinity(), false},
};

std::string describe_camera(const Camera& c) {
  return "tan " + std::to_string(c.tan_half_fov_y) + " aspect " + std::to_string(c.aspect) +
         " near " + std::to_string(c.near) + " far " + std::to_string(c.far) +
         (c.reverse_z ? " reverse-Z" : " standard-Z");
}

// The inverse projection in float, as an application would hand it over (the double inverse,
// rounded).
glm::mat4 inverse_projection(const Camera& c) {
  return glm::mat4(
      glm::inverse(ref::perspective(c.tan_half_fov_y, c.aspect, c.near, c.far, c.reverse_z)));
}

// A point in the frustum at a log-uniform view distance in [near, min(far, 1e5 near)].
glm::dvec3 frustum_point(Rng& rng, const Camera& c) {
  const double hi = std::min(c.far, c.near * 1e5);
  const double z = c.near * std::pow(hi / c.near, rng.next_unit());
  const glm::dvec2 uv(rng.next_unit(), rng.next_unit());
  return ref::view_position(uv, z, c.tan_half_fov_y, c.aspect);
}

// view_position_from_depth against its expression in double from the same float inputs, with the
// bound derived in ref::inverse_projection_reconstruction (depth_ref.hpp).
TEST_F(DepthTest, ViewPositionFromDepthMatchesInverseMatrixInDouble) {
  ShaderFunction<glm::vec3(glm::vec2, float, glm::mat4)> reconstruct(kDepth,
                                                                     "view_position_from_depth");
  Rng rng(0xDE9709);
  std::vector<std::tuple<glm::vec2, float, glm::mat4>> cases;
  std::vector<size_t> camera_of;
  for (size_t k = 0; k < kCameras.size(); ++k) {
    const Camera& c = kCameras[k];
    const glm::dmat4 proj =
        ref::perspective(c.tan_half_fov_y, c.aspect, c.near, c.far, c.reverse_z);
    for (int i = 0; i < 4096; ++i) {
      const ref::Projected p = ref::project(proj, frustum_point(rng, c));
      cases.emplace_back(glm::vec2(p.uv), static_cast<float>(p.depth), inverse_projection(c));
      camera_of.push_back(k);
    }
  }
  const std::vector<glm::vec3> got = reconstruct.run(cases);
  std::vector<double> want, actual, bounds;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [uv, d, m] = cases[i];
    const ref::BoundedPosition want_i = ref::inverse_projection_reconstruction(uv, d, m);
    for (int r = 0; r < 3; ++r) {
      want.push_back(want_i.value[r]);
      actual.push_back(got[i][r]);
      bounds.push_back(want_i.bound[r]);
    }
  }
  EXPECT_TRUE(ref::all_within_bounds(want, actual, bounds, [&](size_t k) {
    return format_tuple(std::make_tuple(std::get<0>(cases[k / 3]), std::get<1>(cases[k / 3]))) +
           " " + describe_camera(kCameras[camera_of[k / 3]]) + " ." + "xyz"[k % 3];
  }));
}

// view_position_from_view_distance against the frustum geometry in double: x = ndc.x * (aspect *
// t) * z: the ndc rounding and three products, 4 * 2^-23 relative; y = -ndc.y * t * z: 3; z
// exact.
TEST_F(DepthTest, ViewPositionFromViewDistanceMatchesFrustumGeometry) {
  ShaderFunction<glm::vec3(glm::vec2, float, float, float)> reconstruct(
      kDepth, "view_position_from_view_distance");
  PENUMBRA_EXPECT_PROPERTY(check_property(
      "view_position_from_view_distance",
      [&](const auto& cases) {
        const std::vector<glm::vec3> got = reconstruct.run(cases);
        return std::vector<glm::dvec3>(got.begin(), got.end());
      },
      [](glm::vec2 uv, float z, float t, float aspect) {
        return ref::view_position(glm::dvec2(uv), z, t, aspect);
      },
      Tolerance::relative(4.0 * kRoundingRel * kSecondOrder), {.cases = 16384, .seed = 0xDE970A},
      mix(one_of({glm::vec2(0.0f), glm::vec2(1.0f), glm::vec2(0.5f), glm::vec2(0.0f, 1.0f)}), 0.1,
          uniform<glm::vec2>(0.0f, 1.0f)),
      map(uniform(0.0f, 1.0f),
          [](float u) { return static_cast<float>(1e-4 * std::pow(1e10, u)); }),
      uniform(0.05f, 3.0f), uniform(0.3f, 4.0f)));
}

// Both reconstructions of the same depth-buffer sample agree: the inverse matrix, and
// linearize_depth(_infinite) followed by view_position_from_view_distance. Each is compared with
// the exact reconstruction from the same float (uv, d): the precise route's relative error is at
// most 6.5 (linearize; 3.5 for an infinite far plane) + 4 units of 2^-23 per component, whatever
// the convention; the matrix route's bound is the one derived above. The worst relative errors
// are recorded: under standard-Z the matrix route loses ~z / near ULPs, the precise route does
// not.
TEST_F(DepthTest, PreciseReconstructionAvoidsTheInverseMatrixError) {
  ShaderFunction<glm::vec3(glm::vec2, float, glm::mat4)> via_matrix(kDepth,
                                                                    "view_position_from_depth");
  ShaderFunction<float(float, float, float, bool)> linearize(kDepth, "linearize_depth");
  ShaderFunction<float(float, float, bool)> linearize_infinite(kDepth, "linearize_depth_infinite");
  ShaderFunction<glm::vec3(glm::vec2, float, float, float)> via_distance(
      kDepth, "view_position_from_view_distance");
  Rng rng(0xDE970B);
  for (const Camera& c : kCameras) {
    const glm::dmat4 proj =
        ref::perspective(c.tan_half_fov_y, c.aspect, c.near, c.far, c.reverse_z);
    const bool infinite = std::isinf(c.far);
    const auto near = static_cast<float>(c.near), far = static_cast<float>(c.far);
    const auto t = static_cast<float>(c.tan_half_fov_y), aspect = static_cast<float>(c.aspect);
    std::vector<std::tuple<glm::vec2, float, glm::mat4>> matrix_cases;
    std::vector<std::tuple<float, float, float, bool>> linearize_cases;
    std::vector<std::tuple<float, float, bool>> linearize_cases_infinite;
    for (int i = 0; i < 4096; ++i) {
      const ref::Projected p = ref::project(proj, frustum_point(rng, c));
      const auto d = static_cast<float>(p.depth);
      if (d <= 0.0f || d >= 1.0f) continue;  // the planes themselves: see the extremes tests
      matrix_cases.emplace_back(glm::vec2(p.uv), d, inverse_projection(c));
      linearize_cases.emplace_back(d, near, far, c.reverse_z);
      linearize_cases_infinite.emplace_back(d, near, c.reverse_z);
    }
    const std::vector<glm::vec3> matrix_got = via_matrix.run(matrix_cases);
    const std::vector<float> z = infinite ? linearize_infinite.run(linearize_cases_infinite)
                                          : linearize.run(linearize_cases);
    std::vector<std::tuple<glm::vec2, float, float, float>> position_cases;
    for (size_t i = 0; i < z.size(); ++i) {
      position_cases.emplace_back(std::get<0>(matrix_cases[i]), z[i], t, aspect);
    }
    const std::vector<glm::vec3> precise_got = via_distance.run(position_cases);

    const double precise_rel = ((infinite ? 3.5 : 6.5) + 4.0) * kRoundingRel * kSecondOrder;
    std::vector<double> want, actual, bounds;
    double worst_matrix = 0.0, worst_precise = 0.0;
    for (size_t i = 0; i < z.size(); ++i) {
      const auto [uv, d, m] = matrix_cases[i];
      const double exact_z =
          infinite
              ? static_cast<double>(ref::view_distance_from_depth_infinite(d, near, c.reverse_z))
              : static_cast<double>(ref::view_distance_from_depth(d, near, far, c.reverse_z));
      const glm::dvec3 exact = ref::view_position(glm::dvec2(uv), exact_z, t, aspect);
      for (int r = 0; r < 3; ++r) {
        want.push_back(exact[r]);
        actual.push_back(precise_got[i][r]);
        bounds.push_back(precise_rel * std::fabs(exact[r]));
        worst_precise = std::max(worst_precise, std::fabs(precise_got[i][r] - exact[r]) / exact_z);
        worst_matrix = std::max(worst_matrix, std::fabs(matrix_got[i][r] - exact[r]) / exact_z);
      }
    }
    EXPECT_TRUE(ref::all_within_bounds(want, actual, bounds, [&](size_t k) {
      return format_tuple(std::make_tuple(std::get<0>(matrix_cases[k / 3]),
                                          std::get<1>(matrix_cases[k / 3]))) +
             " " + describe_camera(c) + " ." + "xyz"[k % 3];
    }));
    RecordProperty("worst_relative_error_matrix " + describe_camera(c), scientific(worst_matrix));
    RecordProperty("worst_relative_error_precise " + describe_camera(c), scientific(worst_precise));
  }
}

// View +Y is the top of the image: with the Vulkan projection (proj[1][1] < 0), a point above
// the view axis has uv.y < 0.5, and both reconstructions put uv.y < 0.5 above the axis.
TEST_F(DepthTest, ViewUpIsTheTopOfTheImage) {
  ShaderFunction<glm::vec3(glm::vec2, float, glm::mat4)> via_matrix(kDepth,
                                                                    "view_position_from_depth");
  ShaderFunction<glm::vec3(glm::vec2, float, float, float)> via_distance(
      kDepth, "view_position_from_view_distance");
  for (const Camera& c : kCameras) {
    const glm::dmat4 proj =
        ref::perspective(c.tan_half_fov_y, c.aspect, c.near, c.far, c.reverse_z);
    const ref::Projected above = ref::project(proj, glm::dvec3(0.0, 1.0, -10.0));
    EXPECT_LT(above.uv.y, 0.5) << describe_camera(c);
    const glm::vec3 m =
        via_matrix(glm::vec2(0.5f, 0.25f), static_cast<float>(above.depth), inverse_projection(c));
    EXPECT_GT(m.y, 0.0f) << describe_camera(c);
    EXPECT_LT(m.z, 0.0f) << describe_camera(c);
    const glm::vec3 p =
        via_distance(glm::vec2(0.75f, 0.25f), 10.0f, static_cast<float>(c.tan_half_fov_y),
                     static_cast<float>(c.aspect));
    EXPECT_GT(p.x, 0.0f) << describe_camera(c);  // right of the axis: uv.x > 0.5
    EXPECT_GT(p.y, 0.0f) << describe_camera(c);
    EXPECT_EQ(p.z, -10.0f) << describe_camera(c);
  }
}

// world = R * view + t (the inverse view matrix, affine): per component three products and three
// sums of four terms in any association: within 4 * 2^-23 * sum_j |M_ij p_j|.
TEST_F(DepthTest, WorldPositionFromViewMatchesAffineTransform) {
  ShaderFunction<glm::vec3(glm::vec3, glm::mat4)> to_world(kDepth, "world_position_from_view");
  Rng rng(0xDE970C);
  std::vector<std::tuple<glm::vec3, glm::mat4>> cases;
  for (int i = 0; i < 16384; ++i) {
    // A camera anywhere within 1e4 of the origin looking along a random direction.
    const glm::dvec3 eye = glm::dvec3(uniform<glm::vec3>(-1e4f, 1e4f)(rng));
    const glm::dvec3 forward = glm::dvec3(unit_vector3()(rng));
    const glm::dvec3 up = std::fabs(forward.y) < 0.99 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0);
    const glm::dvec3 right = glm::normalize(glm::cross(forward, up));
    const glm::dvec3 true_up = glm::cross(right, forward);
    glm::dmat4 inv_view(1.0);  // camera to world: columns right, up, -forward, eye
    inv_view[0] = glm::dvec4(right, 0.0);
    inv_view[1] = glm::dvec4(true_up, 0.0);
    inv_view[2] = glm::dvec4(-forward, 0.0);
    inv_view[3] = glm::dvec4(eye, 1.0);
    cases.emplace_back(uniform<glm::vec3>(-1e3f, 1e3f)(rng), glm::mat4(inv_view));
  }
  const std::vector<glm::vec3> got = to_world.run(cases);
  std::vector<double> want, actual, bounds;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [p, m] = cases[i];
    for (int r = 0; r < 3; ++r) {
      double sum = double{m[3][r]}, magnitude = std::fabs(double{m[3][r]});
      for (int j = 0; j < 3; ++j) {
        sum += double{m[j][r]} * p[j];
        magnitude += std::fabs(double{m[j][r]} * p[j]);
      }
      want.push_back(sum);
      actual.push_back(got[i][r]);
      bounds.push_back(4.0 * kRoundingRel * magnitude * kSecondOrder);
    }
  }
  EXPECT_TRUE(ref::all_within_bounds(want, actual, bounds, [&](size_t k) {
    return format_value(std::get<0>(cases[k / 3])) + " ." + "xyz"[k % 3];
  }));
}

// ray_plane_point, the screen footprint on a receiver's tangent plane (shadow_resolve.comp's
// evsm2 mips), against the ray-plane intersection in double from the same float inputs, over
// eyes up to 1e4 m from the origin and receivers 0.1 to 100 m away: where the ray meets the plane
// within the cap, the hit to 2e-4 of the move plus 64 float roundings of the positions; where it
// grazes past the cap, runs parallel or meets the plane behind the eye, a move of exactly the cap
// along the ray. Cases within 10% of the cap are left out (float and double may decide apart).
TEST_F(DepthTest, RayPlanePointFollowsTheRayToTheReceiverPlaneWithinItsCap) {
  ShaderFunction<glm::vec3(glm::vec3, glm::vec3, glm::vec3, glm::vec3, float)> footprint(
      kDepth, "ray_plane_point");
  Rng rng(0xF007);
  auto unit = [&] {
    const double z = 2.0 * rng.next_unit() - 1.0, a = 6.283185307179586 * rng.next_unit();
    const double r = std::sqrt(1.0 - z * z);
    return glm::dvec3(r * std::cos(a), r * std::sin(a), z);
  };
  enum Kind { hit, grazing, parallel, behind };
  std::vector<std::tuple<glm::vec3, glm::vec3, glm::vec3, glm::vec3, float>> cases;
  std::vector<Kind> kinds;
  for (int kind = hit; kind <= behind; ++kind) {
    for (int i = 0; i < 2048;) {
      const glm::dvec3 eye =
          unit() * std::pow(1e4, rng.next_unit()) * (rng.bernoulli(0.3) ? 0.0 : 1.0);
      const glm::dvec3 view = unit();
      const glm::dvec3 p = eye + view * (0.1 * std::pow(1e3, rng.next_unit()));
      // A neighbouring pixel's point: a small step across the view ray.
      glm::dvec3 side = glm::normalize(glm::cross(view, unit()));
      const glm::dvec3 through = p + side * (glm::length(p - eye) * 1e-3);
      const float stretch = float(1.0 + 63.0 * rng.next_unit());
      glm::dvec3 n = unit();
      const glm::dvec3 dir = through - eye;
      if (kind == parallel) n = glm::normalize(glm::cross(dir, unit()));
      if (kind == behind && glm::dot(dir, n) * glm::dot(p - eye, n) > 0.0) n = -n;
      const glm::vec3 fe(eye), fp(p), ft(through), fn(n);
      // The decision in double on the float inputs.
      const glm::dvec3 de(fe), dp(fp), dt(ft), dn(fn), dd = dt - de;
      const double cap = double(stretch) * glm::length(dt - dp);
      const double denom = glm::dot(dd, dn), t = glm::dot(dp - de, dn) / denom;
      const double moved = glm::length(de + dd * t - dp);
      if (kind == hit && !(t > 0.0 && moved < 0.9 * cap)) continue;
      if (kind == grazing && !(t > 0.0 && moved > 1.1 * cap)) continue;
      if (kind == parallel && denom != 0.0 && std::abs(denom) > 1e-6 * glm::length(dd)) {
        // float rounding of n: only a near-parallel ray, which must land beyond the cap
        if (!(t <= 0.0 || moved > 1.1 * cap)) continue;
      }
      if (kind == behind && !(t < 0.0)) continue;
      cases.emplace_back(fe, ft, fp, fn, stretch);
      kinds.push_back(Kind(kind));
      ++i;
    }
  }
  const std::vector<glm::vec3> got = footprint.run(cases);
  size_t bad = 0;
  double worst = 0.0;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [fe, ft, fp, fn, stretch] = cases[i];
    const glm::dvec3 de(fe), dp(fp), dt(ft), dn(fn), dd = dt - de;
    const double cap = double(stretch) * glm::length(dt - dp);
    glm::dvec3 want;
    double tolerance;
    const double positions = 64.0 * kRoundingRel * (glm::length(de) + glm::length(dp));
    if (kinds[i] == hit) {
      want = de + dd * (glm::dot(dp - de, dn) / glm::dot(dd, dn));
      tolerance = 2e-4 * glm::length(want - dp) + positions;
    } else {
      want = dp + dd * (cap / glm::length(dd));
      tolerance = 1e-5 * cap + positions;
    }
    const double err = glm::length(glm::dvec3(got[i]) - want);
    worst = std::max(worst, err / tolerance);
    if (!(err <= tolerance) && ++bad <= 5) {
      ADD_FAILURE() << "case " << i << " (kind " << kinds[i] << "): got (" << got[i].x << ", "
                    << got[i].y << ", " << got[i].z << "), want (" << want.x << ", " << want.y
                    << ", " << want.z << "), |error| " << err << " > " << tolerance;
    }
  }
  EXPECT_EQ(bad, 0u) << "of " << cases.size();
  std::printf("ray_plane_point: %zu cases, worst error %.3g of its bound\n", cases.size(), worst);
}

// Planes at 1e18 and 1e19 (the documented range of far), z = 1e20: far * (z - near) overflows,
// so view_distance_to_depth takes its product of ratios; standard-Z's (z - near) / z is 0.99 here,
// not 1 (for nearer planes it rounds to 1 and hides a sign error).
TEST_F(DepthTest, ViewDistanceToDepthRatioFormWithFarPlanesNear1e19) {
  ShaderFunction<float(float, float, float, bool)> to_depth(kDepth, "view_distance_to_depth");
  const float near = 1e18f, far = 1e19f;
  for (const float z : {1e20f, 3e20f, 1e21f}) {
    for (const bool reverse_z : {true, false}) {
      const double want = double(ref::depth_from_view_distance(z, near, far, reverse_z));
      EXPECT_NEAR(to_depth(z, near, far, reverse_z), want, 8 * 0x1p-23 * std::fabs(want))
          << "z " << z << (reverse_z ? " reverse-Z" : " standard-Z");
    }
  }
}

}  // namespace
}  // namespace penumbra::testing
