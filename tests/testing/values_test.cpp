#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <glm/glm.hpp>
#include <limits>
#include <penumbra/testing/values.hpp>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace {

struct Light {
  glm::vec3 dir;
  float intensity;
  std::array<float, 2> weights;
  std::int32_t id;
  bool enabled;
};

struct Scene {
  Light key;
  std::array<Light, 2> fill;
  glm::mat2 basis;
};

}  // namespace

PENUMBRA_GLSL_STRUCT(Light, "Light", dir, intensity, weights, id, enabled);
PENUMBRA_GLSL_STRUCT(Scene, "Scene", key, fill, basis);

namespace {

using penumbra::testing::Components;
using penumbra::testing::format_tuple;
using penumbra::testing::format_value;
using penumbra::testing::glsl_type_name;
using penumbra::testing::GlslStruct;
using penumbra::testing::Scalar;

template <class T>
std::vector<std::string> names_of(const T& value) {
  std::vector<std::string> names;
  Components<T>::visit(value,
                       [&](std::string_view name, const Scalar&) { names.emplace_back(name); });
  return names;
}

template <class T>
std::vector<Scalar> scalars_of(const T& value) {
  std::vector<Scalar> scalars;
  Components<T>::visit(value, [&](std::string_view, const Scalar& s) { scalars.push_back(s); });
  return scalars;
}

TEST(Components, Scalars) {
  static_assert(Components<float>::count == 1);
  static_assert(Components<bool>::count == 1);
  EXPECT_EQ(names_of(1.5f), std::vector<std::string>{""});
  const auto s = scalars_of(std::uint32_t{7});
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].kind, Scalar::Kind::u32);
  EXPECT_EQ(s[0].u, 7u);
  EXPECT_EQ(scalars_of(-3)[0].kind, Scalar::Kind::i32);
  EXPECT_EQ(scalars_of(2.5)[0].kind, Scalar::Kind::f64);
  EXPECT_EQ(scalars_of(true)[0].kind, Scalar::Kind::boolean);
}

TEST(Components, Vectors) {
  static_assert(Components<glm::vec3>::count == 3);
  static_assert(Components<glm::bvec4>::count == 4);
  EXPECT_EQ(names_of(glm::vec3(1, 2, 3)), (std::vector<std::string>{"x", "y", "z"}));
  const auto s = scalars_of(glm::ivec2(4, -5));
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[1].kind, Scalar::Kind::i32);
  EXPECT_EQ(s[1].i, -5);
  EXPECT_EQ(scalars_of(glm::bvec2(false, true))[1].b, true);
  EXPECT_EQ(scalars_of(glm::uvec3(1, 2, 3))[2].kind, Scalar::Kind::u32);
}

TEST(Components, MatricesAreColumnMajor) {
  static_assert(Components<glm::mat3>::count == 9);
  static_assert(Components<glm::mat2x3>::count == 6);  // 2 columns of 3 rows
  glm::mat3 m(0.0f);
  m[2][1] = 42.0f;  // column 2, row 1
  const auto names = names_of(m);
  const auto scalars = scalars_of(m);
  ASSERT_EQ(names.size(), 9u);
  EXPECT_EQ(names[0], "c0.r0");
  EXPECT_EQ(names[1], "c0.r1");
  EXPECT_EQ(names[7], "c2.r1");
  EXPECT_EQ(scalars[7].f, 42.0f);
  EXPECT_EQ(names_of(glm::mat2x3(1.0f)).back(), "c1.r2");
}

TEST(Components, Arrays) {
  using A = std::array<glm::vec2, 4>;
  static_assert(Components<A>::count == 8);
  const auto names = names_of(A{});
  EXPECT_EQ(names.front(), "[0].x");
  EXPECT_EQ(names.back(), "[3].y");
  using Nested = std::array<std::array<float, 2>, 3>;
  static_assert(Components<Nested>::count == 6);
  EXPECT_EQ(names_of(Nested{})[3], "[1][1]");
  using Matrices = std::array<glm::mat2, 2>;
  EXPECT_EQ(names_of(Matrices{})[6], "[1].c1.r0");
}

TEST(Components, DescribedStruct) {
  static_assert(Components<Light>::count == 8);
  const Light light{{0, -1, 0}, 2.0f, {0.25f, 0.75f}, 7, true};
  EXPECT_EQ(names_of(light),
            (std::vector<std::string>{"dir.x", "dir.y", "dir.z", "intensity", "weights[0]",
                                      "weights[1]", "id", "enabled"}));
  const auto s = scalars_of(light);
  EXPECT_EQ(s[1].f, -1.0f);
  EXPECT_EQ(s[5].f, 0.75f);
  EXPECT_EQ(s[6].i, 7);
  EXPECT_TRUE(s[7].b);

  static_assert(Components<Scene>::count == 8 * 3 + 4);
  const auto scene_names = names_of(Scene{});
  EXPECT_EQ(scene_names[0], "key.dir.x");
  EXPECT_EQ(scene_names[8 + 8 + 3], "fill[1].intensity");
  EXPECT_EQ(scene_names.back(), "basis.c1.r1");
}

TEST(Components, Tuples) {
  using T = std::tuple<float, glm::vec2, std::int32_t>;
  static_assert(Components<T>::count == 4);
  EXPECT_EQ(names_of(T{}), (std::vector<std::string>{"#0", "#1.x", "#1.y", "#2"}));
  EXPECT_EQ(names_of(std::pair<float, bool>{}), (std::vector<std::string>{"#0", "#1"}));
}

TEST(Components, UnsupportedTypesHaveNoCount) {
  static_assert(!penumbra::testing::HasComponents<std::string>);
  static_assert(!penumbra::testing::HasComponents<std::int64_t>);
  static_assert(penumbra::testing::HasComponents<std::array<Light, 3>>);
}

TEST(Components, TypedReferencesAllowDecoding) {
  // What a buffer reader does: assign every scalar of a host value in component order.
  Light light{};
  std::vector<std::string> seen;
  int next = 1;
  penumbra::testing::for_each_scalar(light, [&](std::string_view name, auto& s) {
    using S = std::remove_reference_t<decltype(s)>;
    static_assert(!std::is_const_v<S>);
    seen.emplace_back(name);
    s = static_cast<S>(next++);
  });
  EXPECT_EQ(light.dir, glm::vec3(1, 2, 3));
  EXPECT_EQ(light.intensity, 4.0f);
  EXPECT_EQ(light.weights[1], 6.0f);
  EXPECT_EQ(light.id, 7);
  EXPECT_TRUE(light.enabled);
  EXPECT_EQ(seen, names_of(light));

  const glm::mat2 m(1, 2, 3, 4);
  float sum = 0;
  Components<glm::mat2>::visit_refs(m, [&](std::string_view, const float& v) { sum += v; });
  EXPECT_EQ(sum, 10.0f);
}

TEST(GlslStruct, Description) {
  using D = GlslStruct<Light>;
  static_assert(D::glsl_name == "Light");
  static_assert(std::tuple_size_v<std::remove_cvref_t<decltype(D::fields)>> == 5);
  static_assert(std::get<0>(D::fields).name == "dir");
  static_assert(std::get<4>(D::fields).name == "enabled");
  static_assert(std::is_same_v<std::remove_cvref_t<decltype(std::get<2>(D::fields))>::Type,
                               std::array<float, 2>>);
  Light light{};
  light.*(std::get<1>(D::fields).ptr) = 3.0f;
  EXPECT_EQ(light.intensity, 3.0f);

  std::vector<std::string> types;
  penumbra::testing::for_each_field<Light>([&](const auto& field) {
    types.push_back(glsl_type_name<typename std::remove_cvref_t<decltype(field)>::Type>());
  });
  EXPECT_EQ(types, (std::vector<std::string>{"vec3", "float", "float[2]", "int", "bool"}));
}

TEST(GlslTypeName, Spellings) {
  EXPECT_EQ(glsl_type_name<float>(), "float");
  EXPECT_EQ(glsl_type_name<std::uint32_t>(), "uint");
  EXPECT_EQ(glsl_type_name<glm::ivec2>(), "ivec2");
  EXPECT_EQ(glsl_type_name<glm::bvec4>(), "bvec4");
  EXPECT_EQ(glsl_type_name<glm::mat4>(), "mat4");
  EXPECT_EQ(glsl_type_name<glm::mat2x3>(), "mat2x3");
  EXPECT_EQ(glsl_type_name<glm::dvec3>(), "dvec3");
  EXPECT_EQ((glsl_type_name<std::array<std::array<glm::vec2, 2>, 3>>()), "vec2[3][2]");
  EXPECT_EQ((glsl_type_name<std::array<Light, 4>>()), "Light[4]");
}

TEST(FormatValue, FloatsShowDecimalAndHex) {
  EXPECT_EQ(format_value(1.0f / 3.0f), "0.333333343 (0x1.555556p-2)");
  EXPECT_EQ(format_value(1.0f), "1 (0x1p+0)");
  EXPECT_EQ(format_value(-2.0f), "-2 (-0x1p+1)");
  EXPECT_EQ(format_value(-0.0f), "-0 (-0x0p+0)");
  EXPECT_EQ(format_value(std::numeric_limits<float>::denorm_min()), "1.40129846e-45 (0x1p-149)");
  EXPECT_EQ(format_value(std::numeric_limits<float>::quiet_NaN()), "nan (bits 0x7fc00000)");
  EXPECT_EQ(format_value(-std::numeric_limits<float>::infinity()), "-inf");
  EXPECT_EQ(format_value(0.1), "0.10000000000000001 (0x1.999999999999ap-4)");
  EXPECT_EQ(format_value(-7), "-7");
  EXPECT_EQ(format_value(7u), "7");
  EXPECT_EQ(format_value(true), "true");
}

TEST(FormatValue, Composites) {
  EXPECT_EQ(format_value(glm::vec3(1, 2, 3)), "vec3(1, 2, 3)");
  EXPECT_EQ(format_value(glm::vec2(0.1f, -0.5f)), "vec2(0.100000001, -0.5)");
  EXPECT_EQ(format_value(glm::ivec2(1, -2)), "ivec2(1, -2)");
  EXPECT_EQ(format_value(glm::bvec2(true, false)), "bvec2(true, false)");
  EXPECT_EQ(format_value(glm::mat2(1, 2, 3, 4)), "mat2((1, 2), (3, 4))");
  EXPECT_EQ(format_value(std::array<int, 3>{1, 2, 3}), "[1, 2, 3]");
  const Light light{{0, -1, 0}, 1.0f, {0.5f, 0.5f}, 3, false};
  EXPECT_EQ(format_value(light),
            "Light{dir=vec3(0, -1, 0), intensity=1, weights=[0.5, 0.5], id=3, enabled=false}");
  EXPECT_EQ(format_tuple(std::make_tuple(0.5f, glm::vec2(1, 2), 3)), "(0.5, vec2(1, 2), 3)");
  EXPECT_EQ(format_tuple(std::tuple<>{}), "()");
}

TEST(FormatValue, GtestPrintsGlmValuesReadably) {
  EXPECT_EQ(::testing::PrintToString(glm::vec3(1, 2, 3)), "vec3(1, 2, 3)");
  EXPECT_EQ(::testing::PrintToString(glm::mat2(1.0f)), "mat2((1, 0), (0, 1))");
}

}  // namespace
