// Function-level tests of shaders/penumbra/finite.glsl: the bit-level NaN and infinity tests
// every file of the library uses, checked against std::isfinite / std::isnan.
//
// These functions look at the bits (floatBitsToUint), never at float comparisons, so they are
// exact on every driver, also on those that optimise as if no value were NaN or infinite.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <tuple>
#include <vector>

namespace penumbra::testing {
namespace {

constexpr const char* kFinite = "penumbra/finite.glsl";
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kMax = std::numeric_limits<float>::max();
constexpr float kDenorm = std::numeric_limits<float>::denorm_min();

class FiniteTest : public GpuTest {};

// The vec3 overload is true exactly when all three components are finite: every combination of a
// finite value, NaN, +inf and -inf in each component (4^3 = 64 cases), so each component alone
// non-finite, every pair, and all three, with the others finite. Expected: std::isfinite on each.
TEST_F(FiniteTest, Vec3IsFiniteExactlyWhenEveryComponentIs) {
  ShaderFunction<bool(glm::vec3)> is_finite(kFinite, "penumbra_is_finite");
  const std::vector<float> values = {1.5f, kNaN, kInf, -kInf};
  std::vector<std::tuple<glm::vec3>> cases;
  for (float x : values) {
    for (float y : values) {
      for (float z : values) cases.emplace_back(glm::vec3(x, y, z));
    }
  }
  // Finite extremes in every component: the largest float, the smallest denormal, signed zero.
  cases.emplace_back(glm::vec3(kMax, -kMax, kDenorm));
  cases.emplace_back(glm::vec3(-0.0f, 0.0f, -kDenorm));
  const std::vector<bool> got = is_finite.run(cases);
  for (size_t i = 0; i < cases.size(); ++i) {
    const glm::vec3 v = std::get<0>(cases[i]);
    const bool expected = std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
    EXPECT_EQ(got[i], expected) << "(" << v.x << ", " << v.y << ", " << v.z << ")";
  }
}

// The float overloads, on the boundaries of the exponent field: the largest finite float and
// the infinities, the smallest NaN payload, denormals and zeros of both signs.
TEST_F(FiniteTest, ScalarIsFiniteAndIsNanMatchStd) {
  ShaderFunction<bool(float)> is_finite(kFinite, "penumbra_is_finite");
  ShaderFunction<bool(float)> is_nan(kFinite, "penumbra_is_nan");
  const std::vector<std::tuple<float>> cases = {
      {0.0f},
      {-0.0f},
      {1.0f},
      {-1.0f},
      {kMax},
      {-kMax},
      {kInf},
      {-kInf},
      {kNaN},
      {-kNaN},
      {kDenorm},
      {-kDenorm},
      {std::bit_cast<float>(0x7f800001u)},  // the smallest NaN payload
      {std::bit_cast<float>(0xff800001u)}};
  const std::vector<bool> finite = is_finite.run(cases);
  const std::vector<bool> nan = is_nan.run(cases);
  for (size_t i = 0; i < cases.size(); ++i) {
    const float x = std::get<0>(cases[i]);
    EXPECT_EQ(finite[i], static_cast<bool>(std::isfinite(x))) << std::bit_cast<uint32_t>(x);
    EXPECT_EQ(nan[i], static_cast<bool>(std::isnan(x))) << std::bit_cast<uint32_t>(x);
  }
}

}  // namespace
}  // namespace penumbra::testing
