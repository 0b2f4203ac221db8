#pragma once

// Host values of tested shader functions, seen as flat lists of named scalar components.
//
// Components<T> visits the scalar components of a value in a fixed order (the order compare,
// print and std430 packing agree on) and names each one:
//   float, int, uint, bool, double      ""
//   glm::vec3                           "x", "y", "z"
//   glm::mat3 (column 2, row 1)         "c2.r1"
//   std::array<vec2, 4> (element 3, y)  "[3].y"
//   a described struct                  "dir.x", "weights[2]"
//   std::tuple<float, vec2>             "#0", "#1.x"
// Described structs are declared once with PENUMBRA_GLSL_STRUCT (see below); the GPU side reads
// the same description (GlslStruct<T>::fields) to generate GLSL and std430 layouts.

#include <array>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <ostream>
#include <string>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <utility>

namespace penumbra::testing {

// One scalar component of a host value. Exactly one of f/d/i/u/b is meaningful, picked by kind.
struct Scalar {
  enum class Kind : std::uint8_t { f32, f64, i32, u32, boolean };
  Kind kind = Kind::f32;
  float f = 0.0f;
  double d = 0.0;
  std::int32_t i = 0;
  std::uint32_t u = 0;
  bool b = false;

  static constexpr Scalar of(float v) {
    Scalar s;
    s.kind = Kind::f32;
    s.f = v;
    return s;
  }
  static constexpr Scalar of(double v) {
    Scalar s;
    s.kind = Kind::f64;
    s.d = v;
    return s;
  }
  static constexpr Scalar of(std::int32_t v) {
    Scalar s;
    s.kind = Kind::i32;
    s.i = v;
    return s;
  }
  static constexpr Scalar of(std::uint32_t v) {
    Scalar s;
    s.kind = Kind::u32;
    s.u = v;
    return s;
  }
  static constexpr Scalar of(bool v) {
    Scalar s;
    s.kind = Kind::boolean;
    s.b = v;
    return s;
  }

  constexpr bool is_floating() const { return kind == Kind::f32 || kind == Kind::f64; }
  // The value as a double (exact for every kind).
  constexpr double as_double() const {
    switch (kind) {
      case Kind::f32:
        return static_cast<double>(f);
      case Kind::f64:
        return d;
      case Kind::i32:
        return static_cast<double>(i);
      case Kind::u32:
        return static_cast<double>(u);
      case Kind::boolean:
        return b ? 1.0 : 0.0;
    }
    return 0.0;
  }
};

// Formats one scalar: floats in decimal with 9 (float) or 17 (double) significant digits, which
// round-trips, and with with_hex also as a hex float: "0.333333343 (0x1.555556p-2)". NaNs show
// their bit pattern: "nan (bits 0x7fc00000)". Integers in decimal, bools as true/false.
std::string format_scalar(const Scalar& s, bool with_hex = true);

// ---------------------------------------------------------------------------------------------
// Described structs

// One member of a described struct: its GLSL name and the C++ member pointer.
template <class C, class M>
struct Field {
  using Owner = C;
  using Type = M;
  std::string_view name;
  M C::*ptr;
};
template <class C, class M>
Field(std::string_view, M C::*) -> Field<C, M>;

// Specialized by PENUMBRA_GLSL_STRUCT with
//   using Type = CppType;
//   static constexpr std::string_view glsl_name;
//   static constexpr auto fields;  // std::tuple<Field<CppType, M>...>, in declaration order
template <class T>
struct GlslStruct {};

template <class T>
concept GlslDescribed = requires {
  { GlslStruct<T>::glsl_name } -> std::convertible_to<std::string_view>;
  GlslStruct<T>::fields;
};

// Calls f(field) for every field of a described struct, in order.
template <GlslDescribed T, class F>
constexpr void for_each_field(F&& f) {
  std::apply([&](const auto&... field) { (f(field), ...); }, GlslStruct<T>::fields);
}

// ---------------------------------------------------------------------------------------------
// Type classification

namespace detail {

template <class T>
inline constexpr bool is_scalar_v =
    std::is_same_v<T, float> || std::is_same_v<T, double> || std::is_same_v<T, std::int32_t> ||
    std::is_same_v<T, std::uint32_t> || std::is_same_v<T, bool>;

template <class T>
struct VecInfo : std::false_type {};
template <glm::length_t L, class S, glm::qualifier Q>
struct VecInfo<glm::vec<L, S, Q>> : std::true_type {
  static constexpr glm::length_t length = L;
  using Scalar = S;
};

template <class T>
struct MatInfo : std::false_type {};
template <glm::length_t C, glm::length_t R, class S, glm::qualifier Q>
struct MatInfo<glm::mat<C, R, S, Q>> : std::true_type {
  static constexpr glm::length_t columns = C;
  static constexpr glm::length_t rows = R;
  using Scalar = S;
};

template <class T>
struct ArrayInfo : std::false_type {};
template <class E, std::size_t N>
struct ArrayInfo<std::array<E, N>> : std::true_type {
  using Element = E;
  static constexpr std::size_t size = N;
};
template <class E, std::size_t N>
struct ArrayInfo<E[N]> : std::true_type {
  using Element = E;
  static constexpr std::size_t size = N;
};

template <class T>
struct TupleInfo : std::false_type {};
template <class... Ts>
struct TupleInfo<std::tuple<Ts...>> : std::true_type {};
template <class A, class B>
struct TupleInfo<std::pair<A, B>> : std::true_type {};

template <class T>
inline constexpr bool dependent_false_v = false;

// Appends a path segment for the lifetime of the object: "x" after "dir" gives "dir.x", "[2]"
// after "weights" gives "weights[2]".
class PathSegment {
 public:
  PathSegment(std::string& path, std::string_view segment) : path_(path), old_size_(path.size()) {
    if (!path.empty() && !segment.empty() && segment.front() != '[') path.push_back('.');
    path.append(segment);
  }
  PathSegment(const PathSegment&) = delete;
  PathSegment& operator=(const PathSegment&) = delete;
  ~PathSegment() { path_.resize(old_size_); }

 private:
  std::string& path_;
  std::size_t old_size_;
};

std::string index_segment(std::size_t index);     // "[3]"
std::string tuple_segment(std::size_t index);     // "#3"
std::string matrix_segment(int column, int row);  // "c2.r1"
inline constexpr std::string_view kVectorNames[] = {"x", "y", "z", "w"};

}  // namespace detail

// ---------------------------------------------------------------------------------------------
// Components

// Primary template: unsupported types have no `count`.
template <class T>
struct Components {};

template <class T>
concept HasComponents = requires {
  { Components<T>::count } -> std::convertible_to<std::size_t>;
};

// Shared by every specialization. Each specialization implements
//   template <class V, class F> static void walk(V& value, std::string& path, F& f);
// with V = T or const T: it appends its segments to `path` and calls
// f(std::string_view name, S& scalar) for every scalar S (float, double, int32_t, uint32_t,
// bool; const when V is).
template <class T, class Derived>
struct ComponentsBase {
  // f(std::string_view name, const Scalar& value) for every component, in order.
  template <class F>
  static void visit(const T& value, F&& f) {
    std::string path;
    auto to_scalar = [&f](std::string_view name, const auto& s) { f(name, Scalar::of(s)); };
    Derived::walk(value, path, to_scalar);
  }
  // f(std::string_view name, S& scalar) with a reference to each scalar member, typed; S is
  // const when value is. For decoding buffers into host values and for typed printing.
  template <class V, class F>
  requires std::is_same_v<std::remove_const_t<V>, T>
  static void visit_refs(V& value, F&& f) {
    std::string path;
    Derived::walk(value, path, f);
  }
};

template <class T>
requires detail::is_scalar_v<T>
struct Components<T> : ComponentsBase<T, Components<T>> {
  static constexpr std::size_t count = 1;
  template <class V, class F>
  static void walk(V& value, std::string& path, F& f) {
    f(std::string_view(path), value);
  }
};

template <glm::length_t L, class S, glm::qualifier Q>
requires detail::is_scalar_v<S>
struct Components<glm::vec<L, S, Q>>
    : ComponentsBase<glm::vec<L, S, Q>, Components<glm::vec<L, S, Q>>> {
  static constexpr std::size_t count = static_cast<std::size_t>(L);
  template <class V, class F>
  static void walk(V& value, std::string& path, F& f) {
    for (glm::length_t c = 0; c < L; ++c) {
      detail::PathSegment segment(path, detail::kVectorNames[c]);
      f(std::string_view(path), value[c]);
    }
  }
};

template <glm::length_t C, glm::length_t R, class S, glm::qualifier Q>
requires(std::is_same_v<S, float> ||
         std::is_same_v<S, double>) struct Components<glm::mat<C, R, S, Q>>
    : ComponentsBase<glm::mat<C, R, S, Q>, Components<glm::mat<C, R, S, Q>>> {
  static constexpr std::size_t count = static_cast<std::size_t>(C) * static_cast<std::size_t>(R);
  template <class V, class F>
  static void walk(V& value, std::string& path, F& f) {
    for (glm::length_t c = 0; c < C; ++c) {
      for (glm::length_t r = 0; r < R; ++r) {
        detail::PathSegment segment(path, detail::matrix_segment(c, r));
        f(std::string_view(path), value[c][r]);
      }
    }
  }
};

template <class E, std::size_t N>
requires HasComponents<E>
struct Components<std::array<E, N>>
    : ComponentsBase<std::array<E, N>, Components<std::array<E, N>>> {
  static constexpr std::size_t count = N * Components<E>::count;
  template <class V, class F>
  static void walk(V& value, std::string& path, F& f) {
    for (std::size_t k = 0; k < N; ++k) {
      detail::PathSegment segment(path, detail::index_segment(k));
      Components<E>::walk(value[k], path, f);
    }
  }
};

template <class E, std::size_t N>
requires HasComponents<E>
struct Components<E[N]> : ComponentsBase<E[N], Components<E[N]>> {
  static constexpr std::size_t count = N * Components<E>::count;
  template <class V, class F>
  static void walk(V& value, std::string& path, F& f) {
    for (std::size_t k = 0; k < N; ++k) {
      detail::PathSegment segment(path, detail::index_segment(k));
      Components<E>::walk(value[k], path, f);
    }
  }
};

template <class... Ts>
requires(HasComponents<Ts>&&...) struct Components<std::tuple<Ts...>>
    : ComponentsBase<std::tuple<Ts...>, Components<std::tuple<Ts...>>> {
  static constexpr std::size_t count = (std::size_t{0} + ... + Components<Ts>::count);
  template <class V, class F>
  static void walk(V& value, std::string& path, F& f) {
    walk_elements(value, path, f, std::index_sequence_for<Ts...>{});
  }

 private:
  template <class V, class F, std::size_t... I>
  static void walk_elements(V& value, std::string& path, F& f, std::index_sequence<I...>) {
    (walk_element<I>(std::get<I>(value), path, f), ...);
  }
  template <std::size_t I, class E, class F>
  static void walk_element(E& element, std::string& path, F& f) {
    detail::PathSegment segment(path, detail::tuple_segment(I));
    Components<std::remove_const_t<E>>::walk(element, path, f);
  }
};

template <class A, class B>
requires(HasComponents<A>&& HasComponents<B>) struct Components<std::pair<A, B>>
    : ComponentsBase<std::pair<A, B>, Components<std::pair<A, B>>> {
  static constexpr std::size_t count = Components<A>::count + Components<B>::count;
  template <class V, class F>
  static void walk(V& value, std::string& path, F& f) {
    {
      detail::PathSegment segment(path, detail::tuple_segment(0));
      Components<A>::walk(value.first, path, f);
    }
    detail::PathSegment segment(path, detail::tuple_segment(1));
    Components<B>::walk(value.second, path, f);
  }
};

template <GlslDescribed T>
struct Components<T> : ComponentsBase<T, Components<T>> {
  static constexpr std::size_t count = std::apply(
      [](const auto&... field) {
        return (std::size_t{0} + ... +
                Components<typename std::remove_cvref_t<decltype(field)>::Type>::count);
      },
      GlslStruct<T>::fields);
  template <class V, class F>
  static void walk(V& value, std::string& path, F& f) {
    std::apply(
        [&](const auto&... field) { (walk_field(value.*(field.ptr), field.name, path, f), ...); },
        GlslStruct<T>::fields);
  }

 private:
  template <class M, class F>
  static void walk_field(M& member, std::string_view name, std::string& path, F& f) {
    static_assert(HasComponents<std::remove_const_t<M>>,
                  "a field of a described struct has an unsupported type");
    detail::PathSegment segment(path, name);
    Components<std::remove_const_t<M>>::walk(member, path, f);
  }
};

// Free-function forms: for_each_scalar(value, [](std::string_view name, auto& s) { ... }).
template <class V, class F>
requires HasComponents<std::remove_const_t<V>>
void for_each_scalar(V& value, F&& f) {
  Components<std::remove_const_t<V>>::visit_refs(value, f);
}

// ---------------------------------------------------------------------------------------------
// GLSL type names and printing

// The GLSL spelling of a host type: "float", "uint", "vec3", "ivec2", "bvec4", "mat3",
// "mat2x3" (2 columns, 3 rows), "float[4]", "vec2[3][2]" (std::array<std::array<vec2,2>,3>),
// the glsl_name of a described struct. double maps to "double"/"dvec3"/"dmat4".
template <class T>
std::string glsl_type_name() {
  if constexpr (std::is_same_v<T, float>) {
    return "float";
  } else if constexpr (std::is_same_v<T, double>) {
    return "double";
  } else if constexpr (std::is_same_v<T, std::int32_t>) {
    return "int";
  } else if constexpr (std::is_same_v<T, std::uint32_t>) {
    return "uint";
  } else if constexpr (std::is_same_v<T, bool>) {
    return "bool";
  } else if constexpr (detail::VecInfo<T>::value) {
    using S = typename detail::VecInfo<T>::Scalar;
    std::string prefix = std::is_same_v<S, float>           ? ""
                         : std::is_same_v<S, double>        ? "d"
                         : std::is_same_v<S, std::int32_t>  ? "i"
                         : std::is_same_v<S, std::uint32_t> ? "u"
                                                            : "b";
    return prefix + "vec" + std::to_string(detail::VecInfo<T>::length);
  } else if constexpr (detail::MatInfo<T>::value) {
    using S = typename detail::MatInfo<T>::Scalar;
    constexpr auto c = detail::MatInfo<T>::columns;
    constexpr auto r = detail::MatInfo<T>::rows;
    std::string name = std::is_same_v<S, double> ? "dmat" : "mat";
    name += std::to_string(c);
    if constexpr (c != r) name += "x" + std::to_string(r);
    return name;
  } else if constexpr (detail::ArrayInfo<T>::value) {
    std::string element = glsl_type_name<typename detail::ArrayInfo<T>::Element>();
    // The outer dimension comes first: float[3][2] is an array of 3 arrays of 2 floats.
    const std::size_t bracket = element.find('[');
    const std::string dims = "[" + std::to_string(detail::ArrayInfo<T>::size) + "]";
    if (bracket == std::string::npos) return element + dims;
    return element.insert(bracket, dims);
  } else if constexpr (GlslDescribed<T>) {
    return std::string(GlslStruct<T>::glsl_name);
  } else {
    static_assert(detail::dependent_false_v<T>, "glsl_type_name: type has no GLSL equivalent");
  }
}

namespace detail {

// Appends a value in the compact form used inside composites (no hex floats).
template <class T>
void append_value(std::string& out, const T& value) {
  if constexpr (is_scalar_v<T>) {
    out += format_scalar(Scalar::of(value), false);
  } else if constexpr (VecInfo<T>::value) {
    out += glsl_type_name<T>();
    out += '(';
    for (glm::length_t c = 0; c < VecInfo<T>::length; ++c) {
      if (c != 0) out += ", ";
      append_value(out, value[c]);
    }
    out += ')';
  } else if constexpr (MatInfo<T>::value) {
    // Column by column, as GLSL constructors take them: mat2((1, 0), (0, 1)).
    out += glsl_type_name<T>();
    out += '(';
    for (glm::length_t c = 0; c < MatInfo<T>::columns; ++c) {
      if (c != 0) out += ", ";
      out += '(';
      for (glm::length_t r = 0; r < MatInfo<T>::rows; ++r) {
        if (r != 0) out += ", ";
        append_value(out, value[c][r]);
      }
      out += ')';
    }
    out += ')';
  } else if constexpr (ArrayInfo<T>::value) {
    out += '[';
    for (std::size_t k = 0; k < ArrayInfo<T>::size; ++k) {
      if (k != 0) out += ", ";
      append_value(out, value[k]);
    }
    out += ']';
  } else if constexpr (TupleInfo<T>::value) {
    out += '(';
    std::apply(
        [&](const auto&... element) {
          bool first = true;
          ((out += first ? "" : ", ", first = false, append_value(out, element)), ...);
        },
        value);
    out += ')';
  } else if constexpr (GlslDescribed<T>) {
    out += GlslStruct<T>::glsl_name;
    out += '{';
    bool first = true;
    for_each_field<T>([&](const auto& field) {
      if (!first) out += ", ";
      first = false;
      out += field.name;
      out += '=';
      append_value(out, value.*(field.ptr));
    });
    out += '}';
  } else {
    static_assert(dependent_false_v<T>, "format_value: unsupported type");
  }
}

}  // namespace detail

// Human-readable text of a value. A lone float also shows its hex form:
//   format_value(1.0f / 3)          "0.333333343 (0x1.555556p-2)"
//   format_value(glm::vec3(1,2,3))  "vec3(1, 2, 3)"
//   format_value(light)             "Light{dir=vec3(0, -1, 0), intensity=1}"
//   format_value(std::array{1, 2})  "[1, 2]"
// Decimal floats have 9 (float) or 17 (double) significant digits, enough to round-trip.
template <class T>
std::string format_value(const T& value) {
  if constexpr (detail::is_scalar_v<T>) {
    return format_scalar(Scalar::of(value), true);
  } else {
    std::string out;
    detail::append_value(out, value);
    return out;
  }
}

// "(a, b, c)" for the arguments of one case.
template <class... Ts>
std::string format_tuple(const std::tuple<Ts...>& values) {
  std::string out;
  detail::append_value(out, values);
  return out;
}

}  // namespace penumbra::testing

// gtest prints GLM values through these (found by argument-dependent lookup) instead of bytes.
namespace glm {
template <length_t L, class T, qualifier Q>
void PrintTo(const vec<L, T, Q>& value, std::ostream* os) {
  *os << penumbra::testing::format_value(value);
}
template <length_t C, length_t R, class T, qualifier Q>
void PrintTo(const mat<C, R, T, Q>& value, std::ostream* os) {
  *os << penumbra::testing::format_value(value);
}
}  // namespace glm

// Describes a C++ struct to the harness, once, at global namespace scope (it specializes
// penumbra::testing::GlslStruct<CppType>). Up to 256 fields, in declaration order; each field's
// C++ name is also its GLSL name:
//   struct Light { glm::vec3 dir; float intensity; };
//   PENUMBRA_GLSL_STRUCT(Light, "Light", dir, intensity);
#define PENUMBRA_GLSL_STRUCT(CppType, glsl_name_literal, ...)                          \
  template <>                                                                          \
  struct penumbra::testing::GlslStruct<CppType> {                                      \
    using Type = CppType;                                                              \
    static constexpr std::string_view glsl_name = glsl_name_literal;                   \
    static constexpr auto fields =                                                     \
        std::make_tuple(PENUMBRA_DETAIL_FOR_EACH(PENUMBRA_DETAIL_FIELD, __VA_ARGS__)); \
  }

#define PENUMBRA_DETAIL_FIELD(member) \
  ::penumbra::testing::Field {        \
#member, &Type::member            \
  }

// m(a), m(b), ... for up to 256 arguments: C++20's __VA_OPT__ ends the recursion, and each
// PENUMBRA_DETAIL_EXPAND level rescans the text (4 nested 4 times: 256 rescans) so the deferred
// PENUMBRA_DETAIL_FE_AGAIN expands once per argument.
#define PENUMBRA_DETAIL_PARENS ()
#define PENUMBRA_DETAIL_EXPAND(...) \
  PENUMBRA_DETAIL_EXPAND4(          \
      PENUMBRA_DETAIL_EXPAND4(PENUMBRA_DETAIL_EXPAND4(PENUMBRA_DETAIL_EXPAND4(__VA_ARGS__))))
#define PENUMBRA_DETAIL_EXPAND4(...) \
  PENUMBRA_DETAIL_EXPAND3(           \
      PENUMBRA_DETAIL_EXPAND3(PENUMBRA_DETAIL_EXPAND3(PENUMBRA_DETAIL_EXPAND3(__VA_ARGS__))))
#define PENUMBRA_DETAIL_EXPAND3(...) \
  PENUMBRA_DETAIL_EXPAND2(           \
      PENUMBRA_DETAIL_EXPAND2(PENUMBRA_DETAIL_EXPAND2(PENUMBRA_DETAIL_EXPAND2(__VA_ARGS__))))
#define PENUMBRA_DETAIL_EXPAND2(...) \
  PENUMBRA_DETAIL_EXPAND1(           \
      PENUMBRA_DETAIL_EXPAND1(PENUMBRA_DETAIL_EXPAND1(PENUMBRA_DETAIL_EXPAND1(__VA_ARGS__))))
#define PENUMBRA_DETAIL_EXPAND1(...) __VA_ARGS__
#define PENUMBRA_DETAIL_FOR_EACH(m, ...) \
  __VA_OPT__(PENUMBRA_DETAIL_EXPAND(PENUMBRA_DETAIL_FE_STEP(m, __VA_ARGS__)))
#define PENUMBRA_DETAIL_FE_STEP(m, a, ...) \
  m(a) __VA_OPT__(, PENUMBRA_DETAIL_FE_AGAIN PENUMBRA_DETAIL_PARENS(m, __VA_ARGS__))
#define PENUMBRA_DETAIL_FE_AGAIN() PENUMBRA_DETAIL_FE_STEP
