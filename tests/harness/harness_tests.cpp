// Self-tests of the shader-function harness on the GPU: layouts (vec3 padding, mat3 columns,
// bool, arrays of structs), out/inout parameters, resources, defines and specialization
// constants, error messages, and that a wrong answer really fails with the full report.
#include <gmock/gmock.h>
#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <glm/gtc/packing.hpp>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/interval.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <random>

struct Light {
  glm::vec3 dir;
  float intensity;
};
PENUMBRA_GLSL_STRUCT(Light, "Light", dir, intensity);

struct Pair {
  float a;
  glm::vec3 b;
  bool flag;
};
PENUMBRA_GLSL_STRUCT(Pair, "Pair", a, b, flag);

// More fields than the macro once took (16): twenty, of mixed types and alignments.
struct Wide {
  float f0;
  glm::vec3 v1;
  int32_t i2;
  bool b3;
  glm::vec2 w4;
  float f5;
  glm::vec4 q6;
  uint32_t u7;
  float f8;
  glm::vec3 v9;
  float f10;
  int32_t i11;
  glm::vec2 w12;
  float f13;
  bool b14;
  glm::vec3 v15;
  float f16;
  uint32_t u17;
  glm::vec4 q18;
  float f19;
};
PENUMBRA_GLSL_STRUCT(Wide, "Wide", f0, v1, i2, b3, w4, f5, q6, u7, f8, v9, f10, i11, w12, f13, b14,
                     v15, f16, u17, q18, f19);

// Forty fields, the GLSL struct Wide40 of funcs.glsl.
struct Wide40 {
  float m0;
  glm::vec3 m1;
  int32_t m2;
  glm::vec2 m3;
  float m4;
  glm::vec3 m5;
  int32_t m6;
  glm::vec2 m7;
  float m8;
  glm::vec3 m9;
  int32_t m10;
  glm::vec2 m11;
  float m12;
  glm::vec3 m13;
  int32_t m14;
  glm::vec2 m15;
  float m16;
  glm::vec3 m17;
  int32_t m18;
  glm::vec2 m19;
  float m20;
  glm::vec3 m21;
  int32_t m22;
  glm::vec2 m23;
  float m24;
  glm::vec3 m25;
  int32_t m26;
  glm::vec2 m27;
  float m28;
  glm::vec3 m29;
  int32_t m30;
  glm::vec2 m31;
  float m32;
  glm::vec3 m33;
  int32_t m34;
  glm::vec2 m35;
  float m36;
  glm::vec3 m37;
  int32_t m38;
  glm::vec2 m39;
};
PENUMBRA_GLSL_STRUCT(Wide40, "Wide40", m0, m1, m2, m3, m4, m5, m6, m7, m8, m9, m10, m11, m12, m13,
                     m14, m15, m16, m17, m18, m19, m20, m21, m22, m23, m24, m25, m26, m27, m28, m29,
                     m30, m31, m32, m33, m34, m35, m36, m37, m38, m39);

// The same GLSL struct described with its fields in the wrong order: the layout check must
// refuse it, naming the field and both offsets.
struct LightMisdescribed {
  float intensity;
  glm::vec3 dir;
};
PENUMBRA_GLSL_STRUCT(LightMisdescribed, "Light", intensity, dir);

namespace penumbra::testing {
namespace {

using ::testing::HasSubstr;

const std::filesystem::path kFuncs = PENUMBRA_TEST_DATA_DIR "/harness/funcs.glsl";

class HarnessTest : public GpuTest {};

TEST_F(HarnessTest, ScalarFunctionOverThousandsOfCasesInOneBatch) {
  ShaderFunction<float(float, float, float)> f(kFuncs, "add_mul");
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-100.0f, 100.0f);
  std::vector<std::tuple<float, float, float>> cases(20000);
  std::vector<float> want;
  for (auto& c : cases) {
    c = {u(rng), u(rng), u(rng)};
    // GLSL may fuse a + b*c into an FMA (SPIR-V allows contraction): compute both ways and
    // accept either by comparing with a bound of 1 ULP of the larger term.
    want.push_back(std::get<0>(c) + std::get<1>(c) * std::get<2>(c));
  }
  const auto got = f.run(cases);
  ASSERT_EQ(got.size(), cases.size());
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::ulps(1, 1e-3));
}

// The spec-derived intervals on the device: a * b + c (fused or not), the same `precise` (no
// fusing: only the unfused roundings), a * b and a / b all lie in their intervals; one float
// beyond the product's interval is caught.
TEST_F(HarnessTest, DeviceResultsLieInTheSpecIntervals) {
  ShaderFunction<float(float, float, float)> mul_add(kFuncs, "mul_add");
  ShaderFunction<float(float, float, float)> mul_add_precise(kFuncs, "mul_add_precise");
  ShaderFunction<float(float, float)> mul(kFuncs, "mul2");
  ShaderFunction<float(float, float)> div(kFuncs, "div2");
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-4.0f, 4.0f);
  std::uniform_int_distribution<int> e(-20, 20);
  std::vector<std::tuple<float, float, float>> cases(8192);
  for (auto& c : cases) {
    const float a = std::ldexp(u(rng), e(rng)), b = std::ldexp(u(rng), e(rng));
    // c near -a b, where a fused result differs most from an unfused one.
    const float addend = (rng() & 1u) != 0 ? -a * b * (1.0f + std::ldexp(u(rng), -10)) : u(rng);
    c = {a, b, addend};
  }
  cases[0] = {1.0f + 0x1p-12f, 1.0f + 0x1p-12f, -1.0f};
  std::vector<std::tuple<float, float>> pairs;
  for (const auto& [a, b, c] : cases) pairs.emplace_back(a, b);
  std::vector<Interval> loose, precise, product, quotient;
  for (const auto& [a, b, c] : cases) {
    const auto f = [&] { return Interval(a) * Interval(b) + Interval(c); };
    loose.push_back(spec_interval(f));
    precise.push_back(spec_interval(f, {.precise = true}));
    product.push_back(Interval(a) * Interval(b));
    quotient.push_back(Interval(a) / Interval(b));
  }
  const auto describe = [&](std::size_t i) { return format_tuple(cases[i]); };
  const std::vector<float> fused = mul_add.run(cases);
  const std::vector<float> unfused = mul_add_precise.run(cases);
  PENUMBRA_EXPECT_ALL_WITHIN(loose, fused, describe);
  PENUMBRA_EXPECT_ALL_WITHIN(precise, unfused, describe);
  std::size_t contracted = 0;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const auto [a, b, c] = cases[i];
    contracted += fused[i] == std::fma(a, b, c) && fused[i] != a * b + c;
  }
  std::printf("[spec-interval] mul_add: %zu of %zu results are a fused multiply-add's\n",
              contracted, cases.size());
  std::vector<float> products = mul.run(pairs);
  PENUMBRA_EXPECT_ALL_WITHIN(product, products, describe);
  PENUMBRA_EXPECT_ALL_WITHIN(quotient, div.run(pairs), describe);
  // One float above the product's interval in one case: caught, 1 float outside.
  products[5] = std::nextafter(static_cast<float>(product[5].hi()), INFINITY);
  const WithinResult caught = compare_within(product, products, describe);
  EXPECT_FALSE(caught.passed);
  EXPECT_EQ(caught.failing_cases, 1u);
  EXPECT_EQ(caught.max_outside, 1u) << caught.report;
}

TEST_F(HarnessTest, Vec3AfterFloatIsPaddedTo16) {
  ShaderFunction<glm::vec3(float, glm::vec3)> f(kFuncs, "scale_vec3");
  EXPECT_EQ(f.engine().input_offsets(), (std::vector<uint32_t>{0, 16}));
  EXPECT_EQ(f.engine().input_stride(), 32u);
  const auto r = f(2.0f, glm::vec3(1, -2, 3.5f));
  EXPECT_EQ(r, glm::vec3(2, -4, 7));
}

TEST_F(HarnessTest, MatricesTravelColumnMajorWithStd430Strides) {
  ShaderFunction<glm::mat3(glm::mat3)> t(kFuncs, "transpose3");
  const glm::mat3 m(1, 2, 3, 4, 5, 6, 7, 8, 9);
  EXPECT_EQ(t(m), glm::transpose(m));
  EXPECT_EQ(t.engine().input_stride(), 48u);  // three vec3 columns at stride 16

  ShaderFunction<glm::mat2(glm::mat2)> inv(kFuncs, "inverse2");
  const glm::mat2 a(4, 2, 7, 6);
  EXPECT_THAT(inv(a), NearTo(glm::inverse(a), Tolerance::ulps(4, 1e-6)));
  EXPECT_EQ(inv.engine().input_stride(), 16u);  // two vec2 columns at stride 8

  ShaderFunction<glm::mat4(glm::mat4, glm::mat4)> mul(kFuncs, "mul4");
  glm::mat4 x(0.0f), y(0.0f);
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) {
      x[c][r] = float(c * 4 + r);
      y[c][r] = float((c + 1) * (r + 2) % 7);
    }
  EXPECT_EQ(mul(x, y), x * y);  // small integers: exact

  ShaderFunction<glm::mat4x3(glm::mat4)> drop(kFuncs, "drop_row");
  EXPECT_EQ(drop(x), glm::mat4x3(x));
}

TEST_F(HarnessTest, BoolsAndBoolVectorsAre32BitInBuffers) {
  ShaderFunction<bool(float)> pos(kFuncs, "is_positive");
  const auto r = pos.run(std::vector<std::tuple<float>>{{1.0f}, {-1.0f}, {0.0f}, {1e-30f}});
  EXPECT_EQ(r, (std::vector<bool>{true, false, false, true}));
  ShaderFunction<glm::bvec3(glm::vec3)> signs(kFuncs, "signs");
  EXPECT_EQ(signs(glm::vec3(1, -1, 2)), glm::bvec3(true, false, true));
}

TEST_F(HarnessTest, IntegerTypes) {
  ShaderFunction<int32_t(float)> fl(kFuncs, "floor_to_int");
  EXPECT_EQ(fl(-2.5f), -3);
  EXPECT_EQ(fl(7.9f), 7);
  ShaderFunction<glm::uvec2(glm::uvec2)> h(kFuncs, "hash2");
  const glm::uvec2 v(0xdeadbeefu, 12345u);
  EXPECT_EQ(h(v), v * 1664525u + 1013904223u);  // unsigned wrap-around matches
  ShaderFunction<glm::ivec4(glm::ivec4)> n(kFuncs, "negate4");
  EXPECT_EQ(n(glm::ivec4(1, -2, 3, INT32_MAX)), glm::ivec4(-1, 2, -3, -INT32_MAX));
}

TEST_F(HarnessTest, OutParametersComeBackAsResults) {
  ShaderFunction<void(glm::vec4, Out<glm::vec2>, Out<glm::vec2>)> f(kFuncs, "split");
  const auto [lo, hi] = f(glm::vec4(1, 2, 3, 4));
  EXPECT_EQ(lo, glm::vec2(1, 2));
  EXPECT_EQ(hi, glm::vec2(3, 4));
}

TEST_F(HarnessTest, InOutParametersGoInAndComeBack) {
  ShaderFunction<float(InOut<float>, float)> f(kFuncs, "accumulate");
  const auto results = f.run(std::vector<std::tuple<float, float>>{{10.0f, 5.0f}, {-1.0f, 1.0f}});
  EXPECT_EQ(std::get<0>(results[0]), 10.0f);  // return value: the old accumulator
  EXPECT_EQ(std::get<1>(results[0]), 15.0f);  // inout: the new one
  EXPECT_EQ(std::get<0>(results[1]), -1.0f);
  EXPECT_EQ(std::get<1>(results[1]), 0.0f);

  ShaderFunction<void(InOut<std::array<float, 3>>)> rev(kFuncs, "reverse3");
  EXPECT_EQ(rev(std::array<float, 3>{1, 2, 3}), (std::array<float, 3>{3, 2, 1}));
}

TEST_F(HarnessTest, UserStructsInAndOut) {
  ShaderFunction<float(Light, glm::vec3)> f(kFuncs, "light_dot");
  const float r = f(Light{glm::vec3(0, 0, 2), 3.0f}, glm::vec3(0, 0, 1));
  EXPECT_EQ(r, 3.0f);
  ShaderFunction<Pair(float, glm::vec3)> mk(kFuncs, "make_pair");
  const Pair p = mk(5.0f, glm::vec3(1, 2, 3));
  EXPECT_EQ(p.a, 5.0f);
  EXPECT_EQ(p.b, glm::vec3(1, 2, 3));
  EXPECT_TRUE(p.flag);
  // Pair: a @0, b @16 (vec3 alignment), flag @28 right after the vec3; size 32.
  EXPECT_EQ(glsl_type<Pair>()->members[1].offset, 16u);
  EXPECT_EQ(glsl_type<Pair>()->members[2].offset, 28u);
  EXPECT_EQ(glsl_type<Pair>()->size, 32u);
}

// A struct of twenty fields goes in and comes back field by field; its layout is checked
// against the SPIR-V's as every struct's is.
TEST_F(HarnessTest, AStructOfTwentyFieldsRoundTrips) {
  ShaderFunction<Wide(Wide, float)> f(kFuncs, "wide_shift");
  const Wide w{1.0f,
               {2, 3, 4},
               -5,
               true,
               {6, 7},
               8.0f,
               {9, 10, 11, 12},
               13u,
               14.0f,
               {15, 16, 17},
               18.0f,
               -19,
               {20, 21},
               22.0f,
               false,
               {23, 24, 25},
               26.0f,
               27u,
               {28, 29, 30, 31},
               32.0f};
  const Wide r = f(w, 0.5f);
  EXPECT_EQ(r.f0, 1.5f);
  EXPECT_EQ(r.v1, glm::vec3(2.5f, 3.5f, 4.5f));
  EXPECT_EQ(r.i2, -4);
  EXPECT_FALSE(r.b3);
  EXPECT_EQ(r.w4, glm::vec2(6.5f, 7.5f));
  EXPECT_EQ(r.f5, 8.5f);
  EXPECT_EQ(r.q6, glm::vec4(9.5f, 10.5f, 11.5f, 12.5f));
  EXPECT_EQ(r.u7, 14u);
  EXPECT_EQ(r.f8, 14.5f);
  EXPECT_EQ(r.v9, glm::vec3(15.5f, 16.5f, 17.5f));
  EXPECT_EQ(r.f10, 18.5f);
  EXPECT_EQ(r.i11, -18);
  EXPECT_EQ(r.w12, glm::vec2(20.5f, 21.5f));
  EXPECT_EQ(r.f13, 22.5f);
  EXPECT_TRUE(r.b14);
  EXPECT_EQ(r.v15, glm::vec3(23.5f, 24.5f, 25.5f));
  EXPECT_EQ(r.f16, 26.5f);
  EXPECT_EQ(r.u17, 28u);
  EXPECT_EQ(r.q18, glm::vec4(28.5f, 29.5f, 30.5f, 31.5f));
  EXPECT_EQ(r.f19, 32.5f);
  EXPECT_EQ(glsl_type<Wide>()->members.size(), 20u);
}

TEST_F(HarnessTest, AStructOfFortyFieldsRoundTrips) {
  ShaderFunction<Wide40(Wide40, float)> f(kFuncs, "wide40_shift");
  EXPECT_EQ(glsl_type<Wide40>()->members.size(), 40u);
  Wide40 w{};
  int k = 0;
  w.m0 = float(k++);
  w.m1 = glm::vec3(float(k), float(k + 1), float(k + 2));
  k += 3;
  w.m2 = -(k++);
  w.m3 = glm::vec2(float(k), float(k + 1));
  k += 2;
  w.m4 = float(k++);
  w.m5 = glm::vec3(float(k), float(k + 1), float(k + 2));
  k += 3;
  w.m6 = -(k++);
  w.m7 = glm::vec2(float(k), float(k + 1));
  k += 2;
  w.m8 = float(k++);
  w.m9 = glm::vec3(float(k), float(k + 1), float(k + 2));
  k += 3;
  w.m10 = -(k++);
  w.m11 = glm::vec2(float(k), float(k + 1));
  k += 2;
  w.m12 = float(k++);
  w.m13 = glm::vec3(float(k), float(k + 1), float(k + 2));
  k += 3;
  w.m14 = -(k++);
  w.m15 = glm::vec2(float(k), float(k + 1));
  k += 2;
  w.m16 = float(k++);
  w.m17 = glm::vec3(float(k), float(k + 1), float(k + 2));
  k += 3;
  w.m18 = -(k++);
  w.m19 = glm::vec2(float(k), float(k + 1));
  k += 2;
  w.m20 = float(k++);
  w.m21 = glm::vec3(float(k), float(k + 1), float(k + 2));
  k += 3;
  w.m22 = -(k++);
  w.m23 = glm::vec2(float(k), float(k + 1));
  k += 2;
  w.m24 = float(k++);
  w.m25 = glm::vec3(float(k), float(k + 1), float(k + 2));
  k += 3;
  w.m26 = -(k++);
  w.m27 = glm::vec2(float(k), float(k + 1));
  k += 2;
  w.m28 = float(k++);
  w.m29 = glm::vec3(float(k), float(k + 1), float(k + 2));
  k += 3;
  w.m30 = -(k++);
  w.m31 = glm::vec2(float(k), float(k + 1));
  k += 2;
  w.m32 = float(k++);
  w.m33 = glm::vec3(float(k), float(k + 1), float(k + 2));
  k += 3;
  w.m34 = -(k++);
  w.m35 = glm::vec2(float(k), float(k + 1));
  k += 2;
  w.m36 = float(k++);
  w.m37 = glm::vec3(float(k), float(k + 1), float(k + 2));
  k += 3;
  w.m38 = -(k++);
  w.m39 = glm::vec2(float(k), float(k + 1));
  k += 2;
  const Wide40 r = f(w, 0.5f);
  EXPECT_EQ(r.m0, w.m0 + 0.5f);
  EXPECT_EQ(r.m1, w.m1 + 0.5f);
  EXPECT_EQ(r.m2, w.m2 + 1);
  EXPECT_EQ(r.m3, w.m3 + 0.5f);
  EXPECT_EQ(r.m4, w.m4 + 0.5f);
  EXPECT_EQ(r.m5, w.m5 + 0.5f);
  EXPECT_EQ(r.m6, w.m6 + 1);
  EXPECT_EQ(r.m7, w.m7 + 0.5f);
  EXPECT_EQ(r.m8, w.m8 + 0.5f);
  EXPECT_EQ(r.m9, w.m9 + 0.5f);
  EXPECT_EQ(r.m10, w.m10 + 1);
  EXPECT_EQ(r.m11, w.m11 + 0.5f);
  EXPECT_EQ(r.m12, w.m12 + 0.5f);
  EXPECT_EQ(r.m13, w.m13 + 0.5f);
  EXPECT_EQ(r.m14, w.m14 + 1);
  EXPECT_EQ(r.m15, w.m15 + 0.5f);
  EXPECT_EQ(r.m16, w.m16 + 0.5f);
  EXPECT_EQ(r.m17, w.m17 + 0.5f);
  EXPECT_EQ(r.m18, w.m18 + 1);
  EXPECT_EQ(r.m19, w.m19 + 0.5f);
  EXPECT_EQ(r.m20, w.m20 + 0.5f);
  EXPECT_EQ(r.m21, w.m21 + 0.5f);
  EXPECT_EQ(r.m22, w.m22 + 1);
  EXPECT_EQ(r.m23, w.m23 + 0.5f);
  EXPECT_EQ(r.m24, w.m24 + 0.5f);
  EXPECT_EQ(r.m25, w.m25 + 0.5f);
  EXPECT_EQ(r.m26, w.m26 + 1);
  EXPECT_EQ(r.m27, w.m27 + 0.5f);
  EXPECT_EQ(r.m28, w.m28 + 0.5f);
  EXPECT_EQ(r.m29, w.m29 + 0.5f);
  EXPECT_EQ(r.m30, w.m30 + 1);
  EXPECT_EQ(r.m31, w.m31 + 0.5f);
  EXPECT_EQ(r.m32, w.m32 + 0.5f);
  EXPECT_EQ(r.m33, w.m33 + 0.5f);
  EXPECT_EQ(r.m34, w.m34 + 1);
  EXPECT_EQ(r.m35, w.m35 + 0.5f);
  EXPECT_EQ(r.m36, w.m36 + 0.5f);
  EXPECT_EQ(r.m37, w.m37 + 0.5f);
  EXPECT_EQ(r.m38, w.m38 + 1);
  EXPECT_EQ(r.m39, w.m39 + 0.5f);
}

// Macros are tested like functions: the wrapper writes the call as text.
TEST_F(HarnessTest, FunctionLikeMacrosAndMacroTypes) {
  ShaderFunction<float(float)> twice(kFuncs, "TWICE");
  EXPECT_EQ(twice(1.25f), 2.5f);
  ShaderFunction<float(float)> halve(kFuncs, "halve");
  EXPECT_EQ(halve(3.0f), 1.5f);
}

TEST_F(HarnessTest, ArraysOfScalarsVectorsAndStructs) {
  ShaderFunction<float(std::array<float, 4>)> s4(kFuncs, "sum4");
  EXPECT_EQ(s4(std::array<float, 4>{1, 2, 3, 4}), 10.0f);
  ShaderFunction<glm::vec3(std::array<glm::vec3, 3>)> sv(kFuncs, "sum_vec3s");
  EXPECT_EQ(sv(std::array<glm::vec3, 3>{glm::vec3(1), glm::vec3(2), glm::vec3(3, 0, 0)}),
            glm::vec3(6, 3, 3));
  EXPECT_EQ(sv.engine().input_stride(), 48u);  // vec3[3]: stride 16
  ShaderFunction<float(std::array<Light, 3>)> ti(kFuncs, "total_intensity");
  EXPECT_EQ(ti(std::array<Light, 3>{Light{glm::vec3(1), 1.0f}, Light{glm::vec3(2), 2.5f},
                                    Light{glm::vec3(3), 4.0f}}),
            7.5f);
}

TEST_F(HarnessTest, DefinesAndSpecializationConstantsPerTest) {
  ShaderFunction<float(float)> plain(kFuncs, "scaled");
  EXPECT_EQ(plain(3.0f), 3.0f);
  FunctionOptions with_define;
  with_define.defines = {{"HARNESS_SCALE", "2.0"}};
  ShaderFunction<float(float)> doubled(kFuncs, "scaled", with_define);
  EXPECT_EQ(doubled(3.0f), 6.0f);
  FunctionOptions with_spec = with_define;
  with_spec.spec_constants = {spec_constant(7, 10.0f)};
  ShaderFunction<float(float)> spec(kFuncs, "scaled", with_spec);
  EXPECT_EQ(spec(3.0f), 60.0f);
}

TEST_F(HarnessTest, WrapperIsCompiledOncePerProcessAndCanBeDumped) {
  ShaderFunction<float(float, float, float)> a(kFuncs, "add_mul");
  ShaderFunction<float(float, float, float)> b(kFuncs, "add_mul");
  EXPECT_EQ(&a.engine(), &b.engine());
  EXPECT_THAT(a.source(), HasSubstr("add_mul(c.p0, c.p1, c.p2)"));
  EXPECT_THAT(a.source(), HasSubstr("PenumbraIn cases[]"));
  EXPECT_THAT(a.source(), HasSubstr("if (gl_GlobalInvocationID.x < penumbra_pc.count) {"));
}

TEST_F(HarnessTest, FileResolvedThroughSearchPaths) {
  FunctionOptions opts;
  opts.include_dirs = {PENUMBRA_TEST_DATA_DIR};
  ShaderFunction<float(float, float, float)> f("harness/funcs.glsl", "add_mul", opts);
  EXPECT_EQ(f(1.0f, 2.0f, 3.0f), 7.0f);
  try {
    ShaderFunction<float(float)> g("harness/no_such_file.glsl", "x", opts);
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("no_such_file.glsl"));
    EXPECT_THAT(e.what(), HasSubstr(PENUMBRA_TEST_DATA_DIR));
  }
}

TEST_F(HarnessTest, CompileErrorInTestedFileNamesItsFileAndLine) {
  try {
    ShaderFunction<float(float)> f(PENUMBRA_TEST_DATA_DIR "/harness/broken.glsl", "broken");
    FAIL() << "expected a compile error";
  } catch (const shader::CompileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("broken.glsl:5"));
    ASSERT_FALSE(e.diagnostics().empty());
    EXPECT_EQ(e.diagnostics()[0].file.filename(), "broken.glsl");
    EXPECT_EQ(e.diagnostics()[0].line, 5);
  }
}

// GoogleTest cannot say where an exception came from ("unknown file"): a construction error
// names the line that built the ShaderFunction, for every kind of error, and keeps its type.
TEST_F(HarnessTest, ConstructionErrorsNameTheCallersLine) {
  auto expect_at = [](const std::string& what, int line, const std::string& call) {
    EXPECT_THAT(what, ::testing::StartsWith(std::string(__FILE__) + ":" + std::to_string(line) +
                                            ": in ShaderFunction(" + call + "):\n"));
  };
  int line = 0;
  try {
    line = __LINE__ + 1;
    ShaderFunction<float(float)> f("no_such_file.glsl", "f");
    FAIL();
  } catch (const Error& e) {
    expect_at(e.what(), line, "\"no_such_file.glsl\", \"f\"");
    EXPECT_THAT(e.what(), HasSubstr("not found"));
  }
  try {
    line = __LINE__ + 1;
    ShaderFunction<float(float)> f(PENUMBRA_TEST_DATA_DIR "/harness/broken.glsl", "broken");
    FAIL();
  } catch (const shader::CompileError& e) {  // still a CompileError, with its diagnostics
    expect_at(e.what(), line,
              "\"" + std::string(PENUMBRA_TEST_DATA_DIR "/harness/broken.glsl") + "\", \"broken\"");
    ASSERT_FALSE(e.diagnostics().empty());
    EXPECT_EQ(e.diagnostics()[0].line, 5);
  }
}

// A tested file that begins with its own #version (third-party GLSL) compiles: the directive is
// dropped and the engine says so; with strip_include_version off, glslang refuses it.
TEST_F(HarnessTest, AFileWithItsOwnVersionIsTestedWithANote) {
  ShaderFunction<float(float)> f(PENUMBRA_TEST_DATA_DIR "/harness/versioned.glsl",
                                 "versioned_twice");
  EXPECT_EQ(f(1.5f), 3.0f);
  ASSERT_EQ(f.engine().notes().size(), 1u);
  EXPECT_THAT(f.engine().notes()[0], HasSubstr("dropped '#version 330 core'"));
  FunctionOptions keep;
  keep.strip_include_version = false;
  EXPECT_THROW((ShaderFunction<float(float)>(PENUMBRA_TEST_DATA_DIR "/harness/versioned.glsl",
                                             "versioned_twice", keep)),
               shader::CompileError);
}

// A C++ signature that matches no GLSL overload lists what the file declares under that name
// (file:line: the GLSL signature) against what was asked for; a misspelled name lists the near
// names; the wrapper is shown only around the error, not its few hundred lines of boilerplate.
TEST_F(HarnessTest, SignatureMismatchExplainsAndShowsTheWrapper) {
  const std::string declared = kFuncs.string() + ":46: bool is_positive(float x)";
  const auto message = [](auto make) -> std::string {
    try {
      make();
    } catch (const shader::CompileError& e) {
      return e.what();
    }
    return "no error";
  };
  // A wrong parameter type.
  std::string m = message([] { ShaderFunction<float(glm::vec2)> f(kFuncs, "is_positive"); });
  EXPECT_THAT(m, HasSubstr("does the C++ signature match"));
  EXPECT_THAT(m, HasSubstr("the C++ signature asks for: float is_positive(vec2)"));
  EXPECT_THAT(m, HasSubstr("the GLSL declares 'is_positive' as:\n    " + declared)) << m;
  EXPECT_THAT(m, HasSubstr("generated wrapper"));
  EXPECT_LT(std::count(m.begin(), m.end(), '\n'), 40) << "the whole wrapper was printed:\n" << m;
  // A wrong return type.
  m = message([] { ShaderFunction<glm::vec3(float)> f(kFuncs, "is_positive"); });
  EXPECT_THAT(m, HasSubstr("asks for: vec3 is_positive(float)"));
  EXPECT_THAT(m, HasSubstr(declared)) << m;
  // A misspelled name: no such function, and the near names.
  m = message([] { ShaderFunction<bool(float)> f(kFuncs, "is_postive"); });
  EXPECT_THAT(m, HasSubstr("no GLSL function is named 'is_postive'"));
  EXPECT_THAT(m, HasSubstr("near names (did you mean one of these?):\n    " + declared)) << m;
  // Nothing near: said so.
  m = message([] { ShaderFunction<bool(float)> f(kFuncs, "completely_unknown_name"); });
  EXPECT_THAT(m, HasSubstr("declares no function named 'completely_unknown_name' or near it"));
}

TEST_F(HarnessTest, HostLayoutMismatchNamesTheMemberAndBothOffsets) {
  try {
    ShaderFunction<float(LightMisdescribed, glm::vec3)> f(kFuncs, "light_dot");
    FAIL();
  } catch (const Error& e) {
    // The C++ description puts intensity first (offset 0) and dir at 16; GLSL has dir at 0.
    EXPECT_THAT(e.what(), HasSubstr("PenumbraIn.p0.intensity"));
    EXPECT_THAT(e.what(), HasSubstr("host std430 offset 0, SPIR-V offset 12"));
  }
}

TEST_F(HarnessTest, WrongAnswerFailsWithFullReport) {
  ShaderFunction<float(float, float, float)> f(kFuncs, "add_mul");
  std::vector<std::tuple<float, float, float>> cases;
  std::vector<float> wrong;
  for (int i = 0; i < 50; ++i) {
    cases.push_back({float(i), 2.0f, 0.5f});
    // A reference with a bug in every 5th case (off by 1 ULP from 3.5 on, then more).
    wrong.push_back(float(i) + 1.0f + (i % 5 == 3 ? 0.25f : 0.0f));
  }
  const auto got = f.run(cases);
  auto describe = [&](size_t i) { return format_tuple(cases[i]); };
  const auto result = compare_batch(wrong, got, Tolerance::ulps(2), describe);
  EXPECT_FALSE(result.passed);
  EXPECT_EQ(result.failing_cases, 10u);
  EXPECT_THAT(result.report, HasSubstr("case 3"));
  EXPECT_THAT(result.report, HasSubstr("(3, 2, 0.5)"));
  EXPECT_THAT(result.report, HasSubstr("0x1.1p+2"));  // expected 4.25 in hex-float
  EXPECT_THAT(result.report, HasSubstr("0x1p+2"));    // actual 4
  EXPECT_THAT(result.report, HasSubstr("ULP"));
  EXPECT_NONFATAL_FAILURE(PENUMBRA_EXPECT_ALL_NEAR(wrong, got, Tolerance::ulps(2)), "case 48");
}

// CPU compare-then-filter reference for one bilinear compare tap (LESS_OR_EQUAL, clamp).
double reference_tap(const std::vector<float>& depth, int w, int h, glm::vec2 uv, float ref) {
  auto lit = [&](int x, int y) {
    x = std::clamp(x, 0, w - 1);
    y = std::clamp(y, 0, h - 1);
    return ref <= depth[size_t(y) * w + x] ? 1.0 : 0.0;
  };
  const double fx = double(uv.x) * w - 0.5, fy = double(uv.y) * h - 0.5;
  const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
  const double a = fx - x0, b = fy - y0;
  return (1 - a) * (1 - b) * lit(x0, y0) + a * (1 - b) * lit(x0 + 1, y0) +
         (1 - a) * b * lit(x0, y0 + 1) + a * b * lit(x0 + 1, y0 + 1);
}

TEST_F(HarnessTest, CompareSamplerPcfMatchesCpuCompareThenFilter) {
  const int w = 32, h = 24;
  std::mt19937 rng(99);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> depth(size_t(w) * h);
  for (auto& d : depth) d = u(rng);
  DepthTextureDesc desc;
  desc.width = w;
  desc.height = h;
  desc.sampler.filter = VK_FILTER_LINEAR;
  auto map = make_depth_texture(desc, depth);

  ShaderFunction<float(Sampler2DShadow, glm::vec2, float, glm::vec2)> pcf(kFuncs, "pcf3x3");
  pcf.bind(0, map);
  std::vector<std::tuple<glm::vec2, float, glm::vec2>> cases;
  std::vector<float> want;
  const glm::vec2 texel(1.0f / w, 1.0f / h);
  for (int i = 0; i < 5000; ++i) {
    const glm::vec2 uv(u(rng), u(rng));
    const float ref = u(rng);
    cases.push_back({uv, ref, texel});
    double sum = 0;
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x)
        sum += reference_tap(depth, w, h, uv + glm::vec2(x, y) * texel, ref);
    want.push_back(float(sum / 9.0));
  }
  const auto got = pcf.run(cases);
  // Each tap's bilinear weights may be quantised to subTexelPrecisionBits (Vulkan spec,
  // "Texel Filtering"): a tap moves by at most 2·2^-bits, and so does their mean.
  const double bound =
      2.0 * std::ldexp(1.0, -int(ctx().info().limits.subTexelPrecisionBits)) + 1e-6;
  PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::absolute(bound),
                           [&](size_t i) { return format_tuple(cases[i]); });
}

TEST_F(HarnessTest, ArrayCompareAndRawDepthResources) {
  const int w = 4, h = 4, layers = 3;
  std::vector<float> depth(size_t(w) * h * layers);
  for (int l = 0; l < layers; ++l)
    for (int i = 0; i < w * h; ++i) depth[size_t(l) * w * h + i] = 0.2f + 0.3f * float(l);
  DepthTextureDesc desc;
  desc.width = w;
  desc.height = h;
  desc.layers = layers;
  auto arr = make_depth_texture(desc, depth);
  ShaderFunction<float(Sampler2DArrayShadow, glm::vec4)> tap(kFuncs, "compare_tap_array");
  tap.bind(0, arr);
  for (int l = 0; l < layers; ++l) {
    EXPECT_EQ(tap(glm::vec4(0.5f, 0.5f, float(l), 0.45f)), l >= 1 ? 1.0f : 0.0f) << l;
  }
  DepthTextureDesc raw_desc;
  raw_desc.width = w;
  raw_desc.height = h;
  raw_desc.sampler.compare = false;
  auto raw = make_depth_texture(raw_desc, std::span(depth).first(w * h));
  ShaderFunction<float(Sampler2D, glm::vec2)> read(kFuncs, "raw_depth");
  read.bind(0, raw);
  EXPECT_EQ(read(glm::vec2(0.3f, 0.9f)), 0.2f);
}

// The texture formats a product's shaders read: RG/RGBA in fp16 come back as the nearest
// halves (0.1 is not one), D16 and D24 depths as the nearest of their unorm steps, and a float
// cube gives each face's value along that face's axis.
TEST_F(HarnessTest, HalfFloatUnormDepthAndFloatCubeTextures) {
  ShaderFunction<glm::vec4(Sampler2D, glm::ivec2)> fetch(kFuncs, "fetch_texel");
  const std::vector<float> rgba{0.1f, -2.5f, 65504.0f, 1.0f / 3.0f, 7.0f, 0.0f, -0.0f, 1e-3f};
  for (uint32_t channels : {2u, 4u}) {
    FloatTextureDesc half;
    half.width = uint32_t(rgba.size()) / channels;
    half.channels = channels;
    half.half = true;
    fetch.bind(0, make_float_texture(half, rgba));
    for (uint32_t x = 0; x < half.width; ++x) {
      const glm::vec4 got = fetch(glm::ivec2(int(x), 0));
      for (uint32_t c = 0; c < channels; ++c) {
        const float want = glm::unpackHalf1x16(glm::packHalf1x16(rgba[x * channels + c]));
        EXPECT_EQ(got[int(c)], want) << channels << " channels, texel " << x << "." << c;
      }
    }
  }
  EXPECT_NE(glm::unpackHalf1x16(glm::packHalf1x16(0.1f)), 0.1f);  // the test sees the rounding

  ShaderFunction<float(Sampler2D, glm::vec2)> read(kFuncs, "raw_depth");
  const std::vector<float> depth{0.1f, 0.5f, 0.999999f, 0.3333333f};
  for (auto [format, steps] : {std::pair{VK_FORMAT_D16_UNORM, 65535.0},
                               std::pair{VK_FORMAT_X8_D24_UNORM_PACK32, 16777215.0}}) {
    DepthTextureDesc d;
    d.width = 4;
    d.format = format;
    d.sampler.compare = false;
    read.bind(0, make_depth_texture(d, depth));
    for (int x = 0; x < 4; ++x) {
      const double want = std::nearbyint(double(depth[size_t(x)]) * steps) / steps;
      // The unorm-to-float conversion is exact to 1 ULP of the float (Vulkan's unorm rule).
      EXPECT_NEAR(read(glm::vec2((float(x) + 0.5f) / 4.0f, 0.5f)), want, want * 1.2e-7 + 1e-12)
          << "format " << int(format) << ", texel " << x;
    }
  }
  DepthTextureDesc bad;
  bad.format = VK_FORMAT_R8_UNORM;
  EXPECT_THROW(make_depth_texture(bad, std::span(depth).first(1)), Error);

  FloatTextureDesc cube;
  cube.cube = true;
  const std::vector<float> faces{10.0f, 11.0f, 12.0f, 13.0f, 14.0f, 15.0f};  // +X -X +Y -Y +Z -Z
  ShaderFunction<float(SamplerCube, glm::vec3)> at(kFuncs, "cube_value");
  at.bind(0, make_float_texture(cube, faces));
  const glm::vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int f = 0; f < 6; ++f) EXPECT_EQ(at(axes[f] * 3.0f), faces[size_t(f)]) << "face " << f;
}

// Storage images: every case writes its own texel of an rgba32f image in one dispatch; the image
// comes back with those values where written and its initial content elsewhere. A layered
// image takes the layer from z; an r16f image keeps the nearest halves.
TEST_F(HarnessTest, StorageImagesAreWrittenInPlaceAndReadBack) {
  StorageImageDesc desc;
  desc.width = 64;
  desc.height = 32;
  const std::vector<float> initial(64 * 32 * 4, -1.0f);
  auto img = make_storage_image(desc, initial);
  ShaderFunction<uint32_t(Image2D, glm::ivec2, glm::vec4)> store(kFuncs, "store_texel");
  store.bind(0, img);
  std::vector<std::tuple<glm::ivec2, glm::vec4>> cases;
  for (int y = 0; y < 32; y += 2)
    for (int x = 0; x < 64; ++x)
      cases.emplace_back(glm::ivec2(x, y), glm::vec4(float(x), float(y), float(x * y), 0.5f));
  const auto ids = store.run(cases);
  for (size_t c = 0; c < cases.size(); ++c) {
    const auto p = std::get<0>(cases[c]);
    ASSERT_EQ(ids[c], uint32_t(p.x + 1000 * p.y));
  }
  const auto got = read_storage_image(*img);
  ASSERT_EQ(got.size(), initial.size());
  for (int y = 0; y < 32; ++y) {
    for (int x = 0; x < 64; ++x) {
      const size_t t = (size_t(y) * 64 + size_t(x)) * 4;
      const glm::vec4 want =
          y % 2 == 0 ? glm::vec4(float(x), float(y), float(x * y), 0.5f) : glm::vec4(-1.0f);
      for (int k = 0; k < 4; ++k) ASSERT_EQ(got[t + size_t(k)], want[k]) << x << "," << y;
    }
  }

  StorageImageDesc layered;
  layered.width = 4;
  layered.height = 2;
  layered.layers = 3;
  layered.channels = 1;
  layered.half = true;
  auto arr = make_storage_image(layered);
  ShaderFunction<uint32_t(Image2DArray, glm::ivec3, glm::vec4)> store_layer(kFuncs,
                                                                            "store_layer_texel");
  store_layer.bind(0, arr);
  std::vector<std::tuple<glm::ivec3, glm::vec4>> lcases;
  for (int l = 0; l < 3; ++l)
    lcases.emplace_back(glm::ivec3(l, 1, l), glm::vec4(0.1f * float(l + 1)));
  const auto layers = store_layer.run(lcases);
  EXPECT_EQ(layers, (std::vector<uint32_t>{0, 1, 2}));
  const auto texels = read_storage_image(*arr);
  ASSERT_EQ(texels.size(), 4u * 2u * 3u);
  for (int l = 0; l < 3; ++l) {
    for (int i = 0; i < 8; ++i) {
      const bool written = i == 4 + l;  // row 1, column l
      const float stored = texels[size_t(l) * 8 + size_t(i)];
      if (!written) {
        EXPECT_EQ(stored, 0.0f) << "layer " << l << ", texel " << i;
        continue;
      }
      // Vulkan lets a store to a 16-bit float image round to nearest or toward zero (lavapipe
      // truncates 0.3 to 0.2998): either neighbouring half, nothing else.
      const float x = 0.1f * float(l + 1);
      const uint16_t nearest = glm::packHalf1x16(x);
      const float rte = glm::unpackHalf1x16(nearest);
      const float rtz = rte > x ? glm::unpackHalf1x16(uint16_t(nearest - 1)) : rte;
      EXPECT_TRUE(stored == rte || stored == rtz)
          << "layer " << l << ": " << stored << ", want " << rte << " or " << rtz;
    }
  }
  // A storage image is not a texture, and the other way round.
  ShaderFunction<glm::vec4(Sampler2D, glm::ivec2)> fetch(kFuncs, "fetch_texel");
  fetch.bind(0, img);
  EXPECT_THROW(fetch(glm::ivec2(0)), Error);
  store.bind(0, arr);
  EXPECT_THROW(store(glm::ivec2(0), glm::vec4(0)), Error);
}

// Reading a format-less image (the only kind a GLSL parameter can be) needs
// shaderStorageImageReadWithoutFormat: where the device has it, a read-modify-write sees the
// image's content and leaves the sum; elsewhere building the function fails naming the feature.
TEST_F(HarnessTest, StorageImageReadsWhereTheDeviceCanElseANamedError) {
  using Fn = ShaderFunction<glm::vec4(Image2D, glm::ivec2, glm::vec4)>;
  if (!shared_context().info().storage_read_without_format) {
    try {
      Fn add(kFuncs, "add_to_texel");
      FAIL() << "built a function that reads a format-less image without the device feature";
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr("shaderStorageImageReadWithoutFormat"));
      EXPECT_THAT(e.what(), HasSubstr(shared_context().info().name));
    }
    return;
  }
  Fn add(kFuncs, "add_to_texel");
  StorageImageDesc desc;
  desc.width = 8;
  std::vector<float> initial(8 * 4);
  for (size_t i = 0; i < initial.size(); ++i) initial[i] = float(i);
  auto img = make_storage_image(desc, initial);
  add.bind(0, img);
  std::vector<std::tuple<glm::ivec2, glm::vec4>> cases;
  for (int x = 0; x < 8; ++x) cases.emplace_back(glm::ivec2(x, 0), glm::vec4(100.0f));
  const auto old = add.run(cases);
  const auto now = read_storage_image(*img);
  for (int x = 0; x < 8; ++x) {
    for (int k = 0; k < 4; ++k) {
      EXPECT_EQ(old[size_t(x)][k], initial[size_t(x) * 4 + size_t(k)]);
      EXPECT_EQ(now[size_t(x) * 4 + size_t(k)], initial[size_t(x) * 4 + size_t(k)] + 100.0f);
    }
  }
}

// A product's own VkSampler is bound in place of the texture's: the same texture read past its
// edge wraps through its own repeat sampler and gives the border through the caller's.
TEST_F(HarnessTest, TheCallersOwnSamplerIsBoundInPlaceOfTheTexturesOwn) {
  auto& ctx = shared_context();
  FloatTextureDesc desc;
  desc.width = 4;
  desc.sampler.address = VK_SAMPLER_ADDRESS_MODE_REPEAT;
  const std::vector<float> texels{1.0f, 2.0f, 3.0f, 4.0f};
  auto tex = make_float_texture(desc, texels);

  VkSamplerCreateInfo info{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  info.magFilter = info.minFilter = VK_FILTER_NEAREST;
  info.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  info.addressModeU = info.addressModeV = info.addressModeW =
      VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_BORDER;
  info.borderColor = VK_BORDER_COLOR_FLOAT_TRANSPARENT_BLACK;
  info.maxLod = VK_LOD_CLAMP_NONE;
  VkSampler product = VK_NULL_HANDLE;
  ASSERT_EQ(vkCreateSampler(ctx.device(), &info, nullptr, &product), VK_SUCCESS);

  ShaderFunction<float(Sampler2D, glm::vec2)> read(kFuncs, "raw_depth");
  const glm::vec2 past_edge(1.125f, 0.5f);  // texel 4.5: wraps to texel 0
  read.bind(0, tex);
  EXPECT_EQ(read(past_edge), 1.0f);
  EXPECT_EQ(read(glm::vec2(0.625f, 0.5f)), 3.0f);
  read.bind(0, tex, ExternalSampler{product, false});
  EXPECT_EQ(read(past_edge), 0.0f);
  EXPECT_EQ(read(glm::vec2(0.625f, 0.5f)), 3.0f);
  // Said to compare: refused for a plain sampler2D, naming whose sampler it is.
  read.bind(0, tex, ExternalSampler{product, true});
  try {
    read(past_edge);
    ADD_FAILURE() << "a compare sampler was bound to a sampler2D";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("the caller's compare sampler"));
  }
  vkDestroySampler(ctx.device(), product, nullptr);
}

// The bounds checks: a texel fetch, a fetch with an offset, a fetch of a level that does not
// exist and an image store outside the image each fail the run with OutOfBoundsError naming
// the case, the coordinate and the size; in-bounds runs pass; check_bounds = false lets the
// undefined fetch through (the device's answer comes back).
TEST_F(HarnessTest, OutOfBoundsAccessesFailTheRunNamingCaseCoordinateAndSize) {
  FloatTextureDesc desc;
  desc.width = 4;
  desc.height = 2;
  desc.channels = 4;
  std::vector<float> texels(4 * 2 * 4, 7.0f);
  auto tex = make_float_texture(desc, texels);
  ShaderFunction<glm::vec4(Sampler2D, glm::ivec2)> fetch(kFuncs, "fetch_texel");
  fetch.bind(0, tex);
  std::vector<std::tuple<glm::ivec2>> inside;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) inside.emplace_back(glm::ivec2(x, y));
  EXPECT_NO_THROW(fetch.run(inside));
  auto expect_oob = [](auto&& run, std::vector<std::string> parts) {
    try {
      run();
      ADD_FAILURE() << "no OutOfBoundsError";
    } catch (const OutOfBoundsError& e) {
      for (const auto& p : parts) EXPECT_THAT(e.what(), HasSubstr(p));
    }
  };
  std::vector<std::tuple<glm::ivec2>> one_out = inside;
  one_out[5] = {glm::ivec2(4, 1)};
  expect_oob([&] { fetch.run(one_out); },
             {"1 access(es) outside an image", "case 5: texelFetch of a sampler2D at ivec2(4, 1)",
              "level 0 of 1", "size is 4x2"});
  std::vector<std::tuple<glm::ivec2>> negative{{glm::ivec2(0, -1)}, {glm::ivec2(0, -1)}};
  expect_oob([&] { fetch.run(negative); }, {"2 access(es)", "at ivec2(0, -1)"});

  ShaderFunction<glm::vec4(Sampler2D, glm::ivec2, int)> level(kFuncs, "fetch_level");
  level.bind(0, tex);
  EXPECT_NO_THROW(level(glm::ivec2(3, 1), 0));
  expect_oob([&] { level(glm::ivec2(0, 0), 1); }, {"level 1 of 1", "(no such level)"});

  FloatTextureDesc arr_desc;
  arr_desc.width = 4;
  arr_desc.height = 2;
  arr_desc.layers = 2;
  auto arr = make_float_texture(arr_desc, std::vector<float>(16, 1.0f));
  ShaderFunction<glm::vec4(Sampler2DArray, glm::ivec3)> offset(kFuncs, "fetch_layer_offset");
  offset.bind(0, arr);
  EXPECT_NO_THROW(offset(glm::ivec3(2, 1, 1)));
  expect_oob([&] { offset(glm::ivec3(3, 0, 0)); },
             {"texelFetchOffset of a sampler2DArray at ivec3(4, 0, 0) (coordinate plus offset)",
              "size is 4x2x2 (the last is layers)"});
  expect_oob([&] { offset(glm::ivec3(0, 0, 2)); }, {"at ivec3(1, 0, 2)"});

  StorageImageDesc sdesc;
  sdesc.width = 3;
  sdesc.height = 3;
  auto img = make_storage_image(sdesc);
  ShaderFunction<uint32_t(Image2D, glm::ivec2, glm::vec4)> store(kFuncs, "store_texel");
  store.bind(0, img);
  EXPECT_NO_THROW(store(glm::ivec2(2, 2), glm::vec4(1)));
  expect_oob([&] { store(glm::ivec2(2, 3), glm::vec4(1)); },
             {"imageStore of a image2D at ivec2(2, 3)", "size is 3x3"});

  FunctionOptions unchecked;
  unchecked.check_bounds = false;
  ShaderFunction<glm::vec4(Sampler2D, glm::ivec2)> raw(kFuncs, "fetch_texel", unchecked);
  raw.bind(0, tex);
  EXPECT_NO_THROW(raw.run(one_out));
  EXPECT_EQ(raw.source().find("penumbra_checked"), std::string::npos);
  EXPECT_NE(fetch.source().find("#define texelFetch penumbra_checked_texelFetch"),
            std::string::npos);
}

TEST_F(HarnessTest, ResourceErrorsNameTheParameter) {
  ShaderFunction<float(Sampler2DShadow, glm::vec3)> tap(kFuncs, "compare_tap");
  try {
    tap(glm::vec3(0.5f));
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("resource parameter 0 (sampler2DShadow) has no texture bound"));
  }
  DepthTextureDesc raw_desc;
  raw_desc.sampler.compare = false;
  const float one = 1.0f;
  tap.bind(0, make_depth_texture(raw_desc, std::span(&one, 1)));
  try {
    tap(glm::vec3(0.5f));
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("non-compare sampler"));
  }
  EXPECT_THROW(tap.bind(3, nullptr), Error);
}

// Debug printf: each case's debugPrintfEXT lines come back per case and in order, and a failing
// comparison lists the reported cases' lines. The shared test device has debug printf on
// whenever validation is (PENUMBRA_DEBUG_PRINTF=0 turns it off).
TEST_F(HarnessTest, DebugPrintfLinesComeBackPerCaseAndInTheFailureReport) {
  ASSERT_TRUE(shared_context().debug_printf_enabled());
  ASSERT_TRUE(shared_context().debug_printf_verbose());
  ShaderFunction<float(float)> f(kFuncs, "print_and_square");
  EXPECT_TRUE(f.engine().prints());
  std::vector<std::tuple<float>> cases;
  for (int i = 0; i < 300; ++i) cases.emplace_back(i % 7 == 3 ? -float(i) : float(i));
  const auto got = f.run(cases);
  ASSERT_EQ(f.printed().size(), cases.size());
  std::vector<float> want;
  char line[64];
  for (size_t c = 0; c < cases.size(); ++c) {
    const float x = std::get<0>(cases[c]);
    want.push_back(x * x);
    std::vector<std::string> lines;
    std::snprintf(line, sizeof line, "x = %f", double(x));
    lines.emplace_back(line);
    if (x < 0) {
      std::snprintf(line, sizeof line, "negative: %f", double(x));
      lines.emplace_back(line);
    }
    ASSERT_EQ(f.printed()[c], lines) << "case " << c;
  }
  want[10] += 1.0f;  // case 10: x = -10, which printed two lines
  EXPECT_NONFATAL_FAILURE(PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact()),
                          "case 10\n  value: expected 101");
  EXPECT_NONFATAL_FAILURE(PENUMBRA_EXPECT_ALL_NEAR(want, got, Tolerance::exact()),
                          "  printf: x = -10.000000\n  printf: negative: -10.000000\n");
  // A function that does not print leaves nothing for the next report.
  ShaderFunction<float(float, float, float)> quiet(kFuncs, "add_mul");
  (void)quiet(1.0f, 2.0f, 3.0f);
  EXPECT_TRUE(quiet.printed().empty());
  EXPECT_TRUE(last_run_printf().empty());
}

// The robust-access mode (PENUMBRA_ROBUST_ACCESS=1: VK_EXT_robustness2 on the shared device).
// CTest runs this suite twice: as part of the binary (the mode off, as asked) and again with the
// variable set, where an unchecked out-of-bounds fetch must read zeros on every device.
class RobustAccess : public GpuTest {};

TEST_F(RobustAccess, UncheckedOutOfBoundsFetchesReadZerosWhenOn) {
  const char* env = std::getenv("PENUMBRA_ROBUST_ACCESS");
  const bool asked = env != nullptr && std::string(env) == "1";
  const auto& info = shared_context().info();
  ASSERT_EQ(info.robust_access, asked);
  EXPECT_THAT(shared_context().report(), HasSubstr(asked ? "robustness:  on" : "robustness:  off"));
  FloatTextureDesc desc;
  desc.width = 4;
  desc.height = 2;
  desc.channels = 4;
  auto tex = make_float_texture(desc, std::vector<float>(4 * 2 * 4, 7.0f));
  FunctionOptions unchecked;
  unchecked.check_bounds = false;
  ShaderFunction<glm::vec4(Sampler2D, glm::ivec2)> fetch(kFuncs, "fetch_texel", unchecked);
  fetch.bind(0, tex);
  const std::vector<std::tuple<glm::ivec2>> cases{
      {glm::ivec2(1, 1)}, {glm::ivec2(4, 1)}, {glm::ivec2(-1, 0)}, {glm::ivec2(0, 100000)}};
  const auto got = fetch.run(cases);
  EXPECT_EQ(got[0], glm::vec4(7.0f));
  if (!asked) {
    std::printf("[robust-access] off\n");
    return;
  }
  for (size_t c = 1; c < cases.size(); ++c) {
    // robustImageAccess2: zero colour; alpha 0, or 1 for a format without alpha.
    EXPECT_EQ(glm::vec3(got[c]), glm::vec3(0.0f)) << "case " << c;
    EXPECT_TRUE(got[c].w == 0.0f || got[c].w == 1.0f) << "case " << c;
  }
  std::printf("[robust-access] on: checked\n");
}

}  // namespace
}  // namespace penumbra::testing
