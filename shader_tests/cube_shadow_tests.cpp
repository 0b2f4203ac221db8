// Function-level tests of the cube-map filters of shaders/penumbra/local_shadow.glsl
// (pcf_cube_array, pcf_cube_vogel_array, pcss_cube_blocker_search, pcss_cube_shadow_array) on
// D32 cube-map arrays, the texel-fetch audit of issue 13 for cubes:
// - the taps: one texel apart on the face, so a PCF over a step edge has a value in closed form;
// - the faces: seamless filtering across face edges (monotone across a seam, exact on uniform
//   cubes at edges and corners);
// - the array layer: out of range, every fetch reads the clamped cube, as texture() does;
// - counts and radii: clamped as documented;
// - bad input (zero, NaN or infinite directions, NaN references, no resolution): lit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <tuple>
#include <vector>

#include "reference/local_ref.hpp"

namespace penumbra::testing {
namespace {

constexpr const char* kLocal = "penumbra/local_shadow.glsl";
constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();
using Params = local_ref::PcssLocalParams;

// depth(cube, face, column, row) for faces +X, -X, +Y, -Y, +Z, -Z (0..5); rows from the top.
using CubeFill = std::function<float(int, int, int, int)>;

std::vector<float> fill_cubes(int cubes, int n, const CubeFill& f) {
  std::vector<float> all;
  for (int c = 0; c < cubes; ++c)
    for (int face = 0; face < 6; ++face)
      for (int row = 0; row < n; ++row)
        for (int col = 0; col < n; ++col) all.push_back(f(c, face, col, row));
  return all;
}

// A cube array with a compare sampler (LESS_OR_EQUAL, linear: bilinear compare taps, as the
// renderer's point shadows use it) or a raw one (nearest).
std::shared_ptr<Texture> cube_texture(int cubes, int n, const CubeFill& f, bool compare) {
  DepthTextureDesc d;
  d.width = d.height = uint32_t(n);
  d.layers = uint32_t(cubes);
  d.array = true;
  d.cube = true;
  d.sampler.compare = compare;
  d.sampler.filter = compare ? VK_FILTER_LINEAR : VK_FILTER_NEAREST;
  return make_depth_texture(d, fill_cubes(cubes, n, f));
}

using PcfCube =
    ShaderFunction<float(SamplerCubeArrayShadow, glm::vec3, int32_t, float, int32_t, float)>;
using VogelCube = ShaderFunction<float(SamplerCubeArrayShadow, glm::vec3, int32_t, float, int32_t,
                                       float, float, float)>;
using SearchCube = ShaderFunction<void(SamplerCubeArray, glm::vec3, int32_t, float, float, int32_t,
                                       float, float, bool, Out<float>, Out<int32_t>)>;
using PcssCube =
    ShaderFunction<float(SamplerCubeArrayShadow, SamplerCubeArray, glm::vec3, int32_t, float, float,
                         float, Params, int32_t, float, bool, glm::vec3)>;
using PlaneSearchCube =
    ShaderFunction<void(SamplerCubeArray, glm::vec3, int32_t, float, float, int32_t, float, float,
                        bool, glm::vec3, float, Out<float>, Out<int32_t>)>;

class CubeShadowTest : public GpuTest {};

// The four cube filters over one cube array, through a compare and a raw sampler.
struct CubeFilters {
  CubeFilters(int cubes, int n, const CubeFill& fill) {
    const auto compare = cube_texture(cubes, n, fill, true);
    const auto raw = cube_texture(cubes, n, fill, false);
    pcf.bind(0, compare);
    vogel.bind(0, compare);
    search.bind(0, raw);
    pcss.bind(0, compare).bind(1, raw);
  }
  PcfCube pcf{kLocal, "pcf_cube_array"};
  VogelCube vogel{kLocal, "pcf_cube_vogel_array"};
  SearchCube search{kLocal, "pcss_cube_blocker_search"};
  PcssCube pcss{kLocal, "pcss_cube_shadow_array"};
};

// A 0.2 m sphere light over a cube of n texels per face, depths 0.1-20 m, search up to 8 texels.
Params sphere_light_params(int n) {
  Params p;
  p.light_radius = 0.2f;
  p.texel_at_unit = 2.0f / float(n);
  p.near = 0.1f;
  p.far = 20.0f;
  p.max_search_texels = 8.0f;
  p.min_filter_texels = 1.0f;
  p.max_filter_texels = 8.0f;
  return p;
}

// On the +Z face of cube 1, the columns left of n/2 - q store 0 (every reference of 0.5 is
// shadowed there) and the rest 1 (lit); cube 0 is lit everywhere. Seen along +Z (the face's
// centre, on a texel corner), tap (i, j) lands on the boundary between columns n/2 + i - 1 and
// n/2 + i, so its bilinear compare is 1, 0.5 or 0, and the PCF of radius r is
// (#{i in [-r, r]: i >= 1 - q} + 0.5 [q <= r]) / (2r + 1). A tap spacing other than one texel,
// or a tap basis turned on the face, gives other values.
TEST_F(CubeShadowTest, PcfTapsAreOneTexelApartOnTheFace) {
  constexpr int n = 32;
  for (int q : {0, 1, 3}) {
    SCOPED_TRACE("q = " + std::to_string(q));
    PcfCube pcf(kLocal, "pcf_cube_array");
    pcf.bind(0, cube_texture(
                    2, n,
                    [&](int c, int face, int col, int) {
                      return c == 1 && face == 4 && col < n / 2 - q ? 0.0f : 1.0f;
                    },
                    true));
    std::vector<std::tuple<glm::vec3, int32_t, float, int32_t, float>> cases;
    for (int r = -2; r <= 7; ++r) {
      cases.emplace_back(glm::vec3(0, 0, 1), 1, 0.5f, r, float(n));
      cases.emplace_back(glm::vec3(0, 0, 2.5f), 1, 0.5f, r, float(n));  // any length
      cases.emplace_back(glm::vec3(0, 0, 1), 0, 0.5f, r, float(n));     // cube 0: lit
    }
    const auto got = pcf.run(cases);
    for (size_t k = 0; k < cases.size(); ++k) {
      const int r = std::clamp(std::get<3>(cases[k]), 0, 5);  // the documented clamp
      double lit = 0.0;
      for (int i = -r; i <= r; ++i) lit += i >= 1 - q ? 1.0 : (i == -q ? 0.5 : 0.0);
      const double want = std::get<1>(cases[k]) == 0 ? 1.0 : lit / (2 * r + 1);
      EXPECT_NEAR(got[k], want, 1e-6)
          << "radius " << std::get<3>(cases[k]) << ", cube " << std::get<1>(cases[k]);
    }
  }
}

// Cube 0 stores 1 (lit at reference 0.5), cube 1 stores 0 (shadowed). Layers past either end
// read the clamped cube in every function, compare taps and raw reads alike, so PCSS and PCF
// agree for any layer argument.
TEST_F(CubeShadowTest, LayersOutOfRangeReadTheClampedCube) {
  constexpr int n = 16;
  const CubeFill fill = [](int c, int, int, int) { return c == 0 ? 1.0f : 0.0f; };
  CubeFilters cube(2, n, fill);
  auto& [pcf, vogel, search, pcss] = cube;
  const Params p = sphere_light_params(n);
  const glm::vec3 dir(0.3f, -0.8f, 0.5f);
  for (int32_t layer : {-7, -1, 0, 1, 2, 100}) {
    const bool lit = layer <= 0;
    SCOPED_TRACE("layer " + std::to_string(layer));
    EXPECT_EQ(pcf(dir, layer, 0.5f, 2, float(n)), lit ? 1.0f : 0.0f);
    EXPECT_EQ(vogel(dir, layer, 0.5f, 16, 3.0f, 0.7f, float(n)), lit ? 1.0f : 0.0f);
    const auto [average, blockers] = search(dir, layer, 0.5f, 4.0f, 16, 0.7f, float(n), false);
    EXPECT_EQ(blockers, lit ? 0 : 16);
    EXPECT_EQ(average, lit ? 0.5f : 0.0f);
    EXPECT_EQ(pcss(dir, layer, 0.5f, 5.0f, float(n), p, 1, 0.7f, false, glm::vec3(0.0f)),
              lit ? 1.0f : 0.0f);
  }
}

// A uniform cube is exactly lit or exactly shadowed in every direction, on face centres, edges
// and corners, for every radius and tap count: no tap reads outside the faces (a border colour or
// another cube would break it).
TEST_F(CubeShadowTest, UniformCubesAreExactlyLitOrShadowedAtEdgesAndCorners) {
  constexpr int n = 8;  // coarse: wide kernels reach across several faces
  PcfCube pcf(kLocal, "pcf_cube_array");
  VogelCube vogel(kLocal, "pcf_cube_vogel_array");
  const CubeFill fill = [](int c, int, int, int) { return c == 0 ? 0.25f : 0.75f; };
  pcf.bind(0, cube_texture(2, n, fill, true));
  vogel.bind(0, cube_texture(2, n, fill, true));
  std::vector<glm::vec3> dirs;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x || y || z)
          dirs.emplace_back(float(x), float(y), float(z));  // centres, edges, corners
  Rng rng(1701);
  for (int i = 0; i < 200; ++i)
    dirs.push_back(unit_vector3()(rng) * float(0.01 + 100.0 * rng.next_unit()));
  std::vector<std::tuple<glm::vec3, int32_t, float, int32_t, float>> pcf_cases;
  std::vector<std::tuple<glm::vec3, int32_t, float, int32_t, float, float, float>> vogel_cases;
  std::vector<float> want;
  for (const auto& d : dirs)
    for (int32_t cube : {0, 1})
      for (float ref : {0.5f}) {
        for (int32_t r = 0; r <= 5; ++r) pcf_cases.emplace_back(d, cube, ref, r, float(n));
        for (float radius : {0.0f, 2.5f, 9.0f})
          vogel_cases.emplace_back(d, cube, ref, 32, radius, 1.3f, float(n));
      }
  // Within float rounding of the bilinear weights (on lavapipe one such tap came out a hair
  // below 1); a tap outside the faces would be off by at least 1 / (4 taps).
  const auto a = pcf.run(pcf_cases);
  for (size_t k = 0; k < a.size(); ++k)
    ASSERT_NEAR(a[k], std::get<1>(pcf_cases[k]) == 0 ? 0.0f : 1.0f, 1e-6f)
        << format_tuple(pcf_cases[k]);
  const auto b = vogel.run(vogel_cases);
  for (size_t k = 0; k < b.size(); ++k)
    ASSERT_NEAR(b[k], std::get<1>(vogel_cases[k]) == 0 ? 0.0f : 1.0f, 1e-6f)
        << format_tuple(vogel_cases[k]);
}

// Across a seam: the +X face stores 0 (shadowed), the others 1. Turning the direction from +X to
// +Y in small steps, every filter's value rises from 0 to 1 without a step back: the taps cross
// the face edge through seamless filtering.
TEST_F(CubeShadowTest, FiltersAreMonotoneAcrossAFaceSeam) {
  constexpr int n = 32;
  const CubeFill fill = [](int, int face, int, int) { return face == 0 ? 0.0f : 1.0f; };
  PcfCube pcf(kLocal, "pcf_cube_array");
  pcf.bind(0, cube_texture(1, n, fill, true));
  VogelCube vogel(kLocal, "pcf_cube_vogel_array");
  vogel.bind(0, cube_texture(1, n, fill, true));
  std::vector<std::tuple<glm::vec3, int32_t, float, int32_t, float>> pc;
  std::vector<std::tuple<glm::vec3, int32_t, float, int32_t, float, float, float>> vc;
  constexpr int steps = 400;
  for (int r : {0, 1, 3}) {
    for (int s = 0; s <= steps; ++s) {
      const double a = glm::radians(25.0 + 40.0 * s / steps);  // the seam is at 45 degrees
      const glm::vec3 d(float(std::cos(a)), float(std::sin(a)), 0.13f);
      pc.emplace_back(d, 0, 0.5f, r, float(n));
      vc.emplace_back(d, 0, 0.5f, 64, float(r) + 0.5f, 0.0f, float(n));
    }
  }
  const auto a = pcf.run(pc);
  const auto b = vogel.run(vc);
  for (const auto* got : {&a, &b}) {
    for (size_t k = 0; k < got->size(); ++k) {
      if (k % (steps + 1) == 0) {
        EXPECT_EQ((*got)[k], 0.0f) << "25 degrees, well inside +X";
        continue;
      }
      ASSERT_GE((*got)[k], (*got)[k - 1] - 1e-6f) << "step " << k % (steps + 1);
      if (k % (steps + 1) == steps) {
        EXPECT_EQ((*got)[k], 1.0f) << "65 degrees, inside +Y";
      }
    }
  }
}

// Counts and radii are clamped as documented: Vogel taps to [1, 64] (0 reads as 1, 100 as 64),
// PCF radius to [0, 5]; NaN rotations count as 0.
TEST_F(CubeShadowTest, TapCountsAndRotationsAreClamped) {
  constexpr int n = 32;
  const CubeFill fill = [](int, int face, int col, int) {
    return face == 4 && col < n / 2 ? 0.0f : 1.0f;
  };
  VogelCube vogel(kLocal, "pcf_cube_vogel_array");
  vogel.bind(0, cube_texture(1, n, fill, true));
  const glm::vec3 d(0.01f, 0.02f, 1.0f);
  const float r = 3.0f;
  EXPECT_EQ(vogel(d, 0, 0.5f, 0, r, 0.4f, float(n)), vogel(d, 0, 0.5f, 1, r, 0.4f, float(n)));
  EXPECT_EQ(vogel(d, 0, 0.5f, -9, r, 0.4f, float(n)), vogel(d, 0, 0.5f, 1, r, 0.4f, float(n)));
  EXPECT_EQ(vogel(d, 0, 0.5f, 100, r, 0.4f, float(n)), vogel(d, 0, 0.5f, 64, r, 0.4f, float(n)));
  EXPECT_EQ(vogel(d, 0, 0.5f, 16, r, kNan, float(n)), vogel(d, 0, 0.5f, 16, r, 0.0f, float(n)));
  const float half = vogel(d, 0, 0.5f, 64, r, 0.4f, float(n));
  EXPECT_GT(half, 0.2f);  // the edge runs through the disk: the counts matter
  EXPECT_LT(half, 0.8f);
  SearchCube search(kLocal, "pcss_cube_blocker_search");
  search.bind(0, cube_texture(1, n, fill, false));
  EXPECT_EQ(search(d, 0, 0.5f, r, 100, 0.4f, float(n), false),
            search(d, 0, 0.5f, r, 64, 0.4f, float(n), false));
  EXPECT_EQ(search(d, 0, 0.5f, r, 0, 0.4f, float(n), false),
            search(d, 0, 0.5f, r, 1, 0.4f, float(n), false));
}

// Directions that address no texel, references that are not numbers and maps without a
// resolution are lit (1), and the blocker search finds nothing; never NaN.
TEST_F(CubeShadowTest, BadInputIsLitAndFindsNoBlocker) {
  constexpr int n = 8;
  const CubeFill fill = [](int, int, int, int) { return 0.0f; };  // everything shadows
  CubeFilters cube(1, n, fill);
  auto& [pcf, vogel, search, pcss] = cube;
  const Params p = sphere_light_params(n);
  const std::vector<std::tuple<glm::vec3, float, float>> bad = {
      {{0, 0, 0}, 0.5f, float(n)},    {{1e-30f, 0, 0}, 0.5f, float(n)},
      {{kNan, 1, 0}, 0.5f, float(n)}, {{kInf, 0, 0}, 0.5f, float(n)},
      {{0, 1, 0}, kNan, float(n)},    {{0, 1, 0}, 0.5f, 0.0f},
      {{0, 1, 0}, 0.5f, -4.0f},       {{0, 1, 0}, 0.5f, kNan}};
  for (const auto& [d, ref, res] : bad) {
    SCOPED_TRACE(format_tuple(std::make_tuple(d, ref, res)));
    EXPECT_EQ(pcf(d, 0, ref, 1, res), 1.0f);
    EXPECT_EQ(vogel(d, 0, ref, 16, 2.0f, 0.0f, res), 1.0f);
    EXPECT_EQ(pcss(d, 0, ref, 5.0f, res, p, 1, 0.0f, false, glm::vec3(0, 1, 0)), 1.0f);
    const auto [average, blockers] = search(d, 0, ref, 2.0f, 16, 0.0f, res, false);
    EXPECT_EQ(blockers, 0);
    EXPECT_FALSE(std::isnan(average));
  }
  // The same map with usable input: shadowed, so the lit results above are the guards'.
  EXPECT_EQ(pcf(glm::vec3(0, 1, 0), 0, 0.5f, 1, float(n)), 0.0f);
}

// The direction of texel (col, row) of cube face `face` (+X, -X, +Y, -Y, +Z, -Z), through its
// centre (Vulkan's cube-map face table).
glm::dvec3 texel_direction(int face, int col, int row, int n) {
  const double a = 2.0 * (col + 0.5) / n - 1.0, b = 2.0 * (row + 0.5) / n - 1.0;
  switch (face) {
    case 0:
      return {1.0, -b, -a};
    case 1:
      return {-1.0, -b, a};
    case 2:
      return {a, 1.0, b};
    case 3:
      return {a, -1.0, -b};
    case 4:
      return {a, -b, 1.0};
    default:
      return {-a, -b, -1.0};
  }
}

// A point light 1 m above a floor (y = -1), its cube (256 texels per face) storing the floor's
// distance (standard depth, near 0.1, far 10) and, in cube 0 only, a box of blockers half-way to
// part of it. A receiver on the floor seen at 64 degrees from its normal: the flat search finds the
// floor itself nearer the light across the disk; the search against the floor's plane finds nothing
// but the real blockers.
TEST_F(CubeShadowTest, BlockerSearchAgainstTheReceiversPlaneIgnoresTheReceiversOwnSurface) {
  constexpr int n = 256;
  constexpr double near = 0.1, far = 10.0;
  const auto stored = [&](glm::dvec3 w) {
    const glm::dvec3 u = glm::normalize(w);
    if (!(u.y < -1e-6)) return 1.0f;
    return float(std::clamp((1.0 / -u.y - near) / (far - near), 0.0, 1.0));
  };
  const glm::vec3 dir(2.0f, -1.0f, 0.5f);  // light to receiver, on the floor
  const glm::dvec3 box_centre = 0.5 * glm::dvec3(dir) + glm::dvec3(0.0, 0.0, 0.1);
  const CubeFill fill = [&](int c, int face, int col, int row) {
    const glm::dvec3 w = texel_direction(face, col, row, n);
    // Cube 0 only: blockers where the ray passes within 0.12 m of box_centre (at 0.5 of the way).
    const glm::dvec3 u = glm::normalize(w);
    const double t = glm::dot(box_centre, u);
    if (c == 0 && t > 0.0 && glm::length(box_centre - t * u) < 0.12)
      return float((t - near) / (far - near));
    return stored(w);
  };
  PlaneSearchCube search(kLocal, "pcss_cube_blocker_search_plane");
  search.bind(0, cube_texture(2, n, fill, false));
  const float dist = glm::length(dir);
  const float inv_range = float(1.0 / (far - near));
  // The receiver moved 5 cm towards the light (its bias): the floor's own texels, read at the
  // nearest texel centre rather than on the tap's exact ray, are within 2 cm of the plane there
  // (half a texel at 256 texels per face, where the floor's distance changes by 4.7 m per
  // radian).
  const float ref = (dist - 0.05f - float(near)) * inv_range;
  const glm::vec3 up(0, 1, 0), none(0.0f);
  for (const float radius : {8.0f, 16.0f}) {
    SCOPED_TRACE("radius " + std::to_string(radius));
    const auto [flat_avg, flat_count] =
        search(dir, 1, ref, radius, 64, 0.3f, float(n), false, none, inv_range);
    EXPECT_GT(flat_count, 16) << "the floor's near half, found by the flat search";
    const auto [plane_avg, plane_count] =
        search(dir, 1, ref, radius, 64, 0.3f, float(n), false, up, inv_range);
    EXPECT_EQ(plane_count, 0) << "the floor against its own plane";
    // Cube 0 has the blockers: found against the plane too, at their own depth.
    const auto [box_avg, box_count] =
        search(dir, 0, ref, radius, 64, 0.3f, float(n), false, up, inv_range);
    EXPECT_GT(box_count, 0);
    EXPECT_NEAR(box_avg, (0.5f * dist - float(near)) * inv_range, 0.05f);
  }
  // A normal that is not a vector, or no range, gives the flat search.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const auto flat = search(dir, 1, ref, 8.0f, 64, 0.3f, float(n), false, none, inv_range);
  EXPECT_EQ(search(dir, 1, ref, 8.0f, 64, 0.3f, float(n), false, glm::vec3(nan, 1, 0), inv_range),
            flat);
  EXPECT_EQ(search(dir, 1, ref, 8.0f, 64, 0.3f, float(n), false, up, 0.0f), flat);
}

}  // namespace
}  // namespace penumbra::testing
