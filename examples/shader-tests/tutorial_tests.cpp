// The complete example of docs/testing-shaders.md, as a project outside Penumbra writes it. It is
// built and run with every test run (in Penumbra's tree, and in CI against an installed package),
// so the tutorial cannot drift from the harness.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/interval.hpp>
#include <penumbra/testing/property.hpp>
#include <penumbra/testing/shader_function.hpp>

// 1. Describe a GLSL struct once: C++ type, GLSL name, fields in GLSL declaration order.
struct SpotLight {
  glm::vec3 position;
  float cos_outer;
  glm::vec3 direction;
  float cos_inner;
};
PENUMBRA_GLSL_STRUCT(SpotLight, "SpotLight", position, cos_outer, direction, cos_inner);

namespace {

using namespace penumbra::testing;

// 2. Where the GLSL lives: penumbra_add_shader_tests(... SHADER_DIRS glsl) in CMakeLists.txt puts
//    glsl/ on the search path of every test it registers (PENUMBRA_SHADER_PATH), before
//    Penumbra's own library. FunctionOptions::include_dirs adds directories in code.

// 3. Derive from GpuTest: any Vulkan validation message fails the test.
class TutorialTest : public GpuTest {};

// 4. A property test: 10 000 seeded random cases in one dispatch against a C++ reference.
TEST_F(TutorialTest, WrappedLambertMatchesReference) {
  ShaderFunction<float(glm::vec3, glm::vec3, float)> lambert("my_shading.glsl", "wrapped_lambert");
  auto reference = [](glm::vec3 n, glm::vec3 l, float wrap) {
    const double d = double(n.x) * l.x + double(n.y) * l.y + double(n.z) * l.z;
    return float(std::max((d + wrap) / (1.0 + wrap), 0.0));
  };
  // dot() may be fused and reassociated; the division is within 2.5 ULP (Vulkan spec,
  // Appendix A): 4 ULP plus an absolute floor near 0, where the max() clamps, is the bound.
  PENUMBRA_EXPECT_PROPERTY(check_property(
      "wrapped_lambert", [&](const auto& cases) { return lambert.run(cases); }, reference,
      Tolerance::ulps(4, 1e-6), {.cases = 10000}, unit_vector3(), unit_vector3(),
      uniform(0.0f, 1.0f)));
}

// 4b. The same function against the Vulkan spec's own precision rules, with no tolerance to
//     pick: the reference is written once as a template; in double it is the value, on
//     Interval it is every result the spec allows a device to return for this formula (dot's
//     sums in any order, fused multiply-adds, the division's 2.5 ULP, flushed denormals).
template <class T, class V>
T wrapped_lambert_formula(const V& n, const V& l, const T& wrap) {
  using namespace penumbra::testing::glsl;
  return max((dot(n, l) + wrap) / (T(1.0f) + wrap), T(0.0f));
}

TEST_F(TutorialTest, WrappedLambertLiesInTheSpecInterval) {
  ShaderFunction<float(glm::vec3, glm::vec3, float)> lambert("my_shading.glsl", "wrapped_lambert");
  Rng rng(kDefaultSeed);
  const auto cases =
      generate_cases(rng, 10000, unit_vector3(), unit_vector3(), uniform(0.0f, 1.0f));
  std::vector<Interval> accepted;
  for (const auto& [n, l, wrap] : cases) {
    accepted.push_back(spec_interval(
        [&] { return wrapped_lambert_formula(to_interval(n), to_interval(l), Interval(wrap)); }));
  }
  PENUMBRA_EXPECT_ALL_WITHIN(accepted, lambert.run(cases),
                             [&](std::size_t i) { return format_tuple(cases[i]); });
}

// 5. Structs in, out-parameters back.
TEST_F(TutorialTest, SpotConeReturnsAttenuationAndVector) {
  ShaderFunction<float(SpotLight, glm::vec3, Out<glm::vec3>)> cone("my_shading.glsl", "spot_cone");
  const SpotLight light{glm::vec3(0, 10, 0), std::cos(0.5f), glm::vec3(0, -1, 0), std::cos(0.3f)};
  const auto [on_axis, to_light] = cone(light, glm::vec3(0, 0, 0));
  EXPECT_EQ(on_axis, 1.0f);
  EXPECT_EQ(to_light, glm::vec3(0, 10, 0));
  const auto [outside, unused] = cone(light, glm::vec3(100, 0, 0));
  EXPECT_EQ(outside, 0.0f);
}

// 6. Resources: a depth map from a host array, sampled through a compare sampler.
TEST_F(TutorialTest, ShadowTapAgainstCompareThenFilter) {
  const std::vector<float> depth = {0.2f, 0.8f,   // row 0
                                    0.2f, 0.8f};  // row 1
  DepthTextureDesc desc;
  desc.width = 2;
  desc.height = 2;
  desc.sampler.filter = VK_FILTER_LINEAR;
  desc.sampler.compare_op = VK_COMPARE_OP_LESS_OR_EQUAL;  // lit when receiver <= stored
  ShaderFunction<float(Sampler2DShadow, glm::vec2, float)> tap("my_shading.glsl", "shadow_tap");
  tap.bind(0, make_depth_texture(desc, depth));
  // At u = 0.5 the bilinear footprint is half on each column: receiver 0.5 is lit only by the
  // right column (0.8), so the filtered result is 0.5 — up to the weight quantisation the
  // Vulkan spec allows (subTexelPrecisionBits).
  const double bits = ctx().info().limits.subTexelPrecisionBits;
  EXPECT_NEAR(tap(glm::vec2(0.5f, 0.5f), 0.5f), 0.5, 2.0 * std::ldexp(1.0, -int(bits)));
  EXPECT_EQ(tap(glm::vec2(0.5f, 0.5f), 0.1f), 1.0f);  // in front of everything: lit
  EXPECT_EQ(tap(glm::vec2(0.5f, 0.5f), 0.9f), 0.0f);  // behind everything: shadowed
}

}  // namespace
