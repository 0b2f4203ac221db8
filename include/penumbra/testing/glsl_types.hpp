#pragma once

// Host ↔ GLSL type mapping for the shader-function harness: a runtime description of each GLSL
// type (name, std430 size/alignment, members) built from the C++ type, and std430 packing of host
// values into and out of storage-buffer bytes.
//
// Supported C++ types: float, int32_t, uint32_t, bool (a 32-bit 0/1 in buffers), glm vec2–4,
// ivec2–4, uvec2–4, bvec2–4, mat2–4 and matCxR, std::array<T, N> (GLSL T[N]), and user structs
// described once with PENUMBRA_GLSL_STRUCT (values.hpp).

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <glm/glm.hpp>
#include <memory>
#include <penumbra/testing/values.hpp>
#include <string>
#include <tuple>
#include <type_traits>
#include <vector>

namespace penumbra::testing {

enum class ScalarType { f32, i32, u32, boolean };

struct TypeDesc {
  enum class Kind { scalar, vector, matrix, array, structure };
  Kind kind = Kind::scalar;
  ScalarType scalar = ScalarType::f32;
  uint32_t components = 1;                  // vector components, or matrix rows
  uint32_t columns = 1;                     // matrix columns
  uint32_t length = 0;                      // array length
  std::shared_ptr<const TypeDesc> element;  // array element
  struct Member {
    std::string name;
    std::shared_ptr<const TypeDesc> type;
    uint32_t offset = 0;  // std430
  };
  std::vector<Member> members;  // structure members in declaration order
  std::string struct_name;

  uint32_t align = 4;       // std430 base alignment
  uint32_t size = 4;        // std430 size (arrays: length · stride)
  uint32_t stride() const;  // array stride of an array of this type under std430

  // GLSL spelling of the type without array suffixes ("vec3", "mat4x3", "Light"), and the
  // array suffix ("[4]", "[2][3]") that follows a declared name.
  std::string glsl_base() const;
  std::string glsl_array_suffix() const;
  // "vec3 name", "float name[4]"
  std::string declare(const std::string& name) const;
};

namespace detail {

inline uint32_t round_up(uint32_t v, uint32_t a) {
  return (v + a - 1) / a * a;
}

std::shared_ptr<const TypeDesc> make_scalar(ScalarType s);
std::shared_ptr<const TypeDesc> make_vector(ScalarType s, uint32_t n);
std::shared_ptr<const TypeDesc> make_matrix(uint32_t columns, uint32_t rows);
std::shared_ptr<const TypeDesc> make_array(std::shared_ptr<const TypeDesc> element, uint32_t n);
std::shared_ptr<const TypeDesc> make_struct(std::string name,
                                            std::vector<TypeDesc::Member> members);

template <class T>
struct TypeOf;

template <>
struct TypeOf<float> {
  static std::shared_ptr<const TypeDesc> get() { return make_scalar(ScalarType::f32); }
};
template <>
struct TypeOf<int32_t> {
  static std::shared_ptr<const TypeDesc> get() { return make_scalar(ScalarType::i32); }
};
template <>
struct TypeOf<uint32_t> {
  static std::shared_ptr<const TypeDesc> get() { return make_scalar(ScalarType::u32); }
};
template <>
struct TypeOf<bool> {
  static std::shared_ptr<const TypeDesc> get() { return make_scalar(ScalarType::boolean); }
};

template <class S>
constexpr ScalarType scalar_of() {
  if constexpr (std::is_same_v<S, float>)
    return ScalarType::f32;
  else if constexpr (std::is_same_v<S, int32_t>)
    return ScalarType::i32;
  else if constexpr (std::is_same_v<S, uint32_t>)
    return ScalarType::u32;
  else {
    static_assert(std::is_same_v<S, bool>, "GLSL vectors hold float, int, uint or bool");
    return ScalarType::boolean;
  }
}

template <glm::length_t N, class S, glm::qualifier Q>
struct TypeOf<glm::vec<N, S, Q>> {
  static_assert(N >= 2 && N <= 4, "GLSL vectors have 2 to 4 components");
  static std::shared_ptr<const TypeDesc> get() { return make_vector(scalar_of<S>(), N); }
};

template <glm::length_t C, glm::length_t R, glm::qualifier Q>
struct TypeOf<glm::mat<C, R, float, Q>> {
  static std::shared_ptr<const TypeDesc> get() { return make_matrix(C, R); }
};

template <class T, size_t N>
struct TypeOf<std::array<T, N>> {
  static std::shared_ptr<const TypeDesc> get() {
    return make_array(TypeOf<T>::get(), static_cast<uint32_t>(N));
  }
};

template <class T>
concept DescribedStruct = requires {
  GlslStruct<T>::glsl_name;
  GlslStruct<T>::fields;
};

template <DescribedStruct T>
struct TypeOf<T> {
  static std::shared_ptr<const TypeDesc> get() {
    std::vector<TypeDesc::Member> members;
    std::apply(
        [&](const auto&... field) {
          (members.push_back(
               {std::string(field.name),
                TypeOf<std::remove_cvref_t<decltype(std::declval<T&>().*(field.ptr))>>::get(), 0}),
           ...);
        },
        GlslStruct<T>::fields);
    return make_struct(std::string(GlslStruct<T>::glsl_name), std::move(members));
  }
};

// std430 packing: write `value` of type T at `dst` (which is the start of its std430 slot).
template <class T>
void pack(const T& value, std::byte* dst, const TypeDesc& type);
template <class T>
void unpack(T& value, const std::byte* src, const TypeDesc& type);

template <class T>
void pack(const T& value, std::byte* dst, const TypeDesc& type) {
  if constexpr (std::is_same_v<T, bool>) {
    const uint32_t v = value ? 1u : 0u;
    std::memcpy(dst, &v, 4);
  } else if constexpr (std::is_arithmetic_v<T>) {
    static_assert(sizeof(T) == 4);
    std::memcpy(dst, &value, 4);
  } else if constexpr (DescribedStruct<T>) {
    size_t i = 0;
    std::apply(
        [&](const auto&... field) {
          ((pack(value.*(field.ptr), dst + type.members[i].offset, *type.members[i].type), ++i),
           ...);
        },
        GlslStruct<T>::fields);
  } else if constexpr (requires {
                         typename T::value_type;
                         std::tuple_size<T>::value;
                       }) {
    const uint32_t stride = type.element->stride();
    for (size_t i = 0; i < value.size(); ++i) pack(value[i], dst + i * stride, *type.element);
  } else if constexpr (requires {
                         T::length();
                         typename T::col_type;
                       }) {  // glm matrix
    const uint32_t col_stride = type.components == 2 ? 8u : 16u;
    for (glm::length_t c = 0; c < T::length(); ++c)
      for (glm::length_t r = 0; r < T::col_type::length(); ++r)
        std::memcpy(dst + c * col_stride + r * 4, &value[c][r], 4);
  } else {  // glm vector
    for (glm::length_t i = 0; i < T::length(); ++i) pack(value[i], dst + i * 4, type);
  }
}

template <class T>
void unpack(T& value, const std::byte* src, const TypeDesc& type) {
  if constexpr (std::is_same_v<T, bool>) {
    uint32_t v = 0;
    std::memcpy(&v, src, 4);
    value = v != 0;
  } else if constexpr (std::is_arithmetic_v<T>) {
    std::memcpy(&value, src, 4);
  } else if constexpr (DescribedStruct<T>) {
    size_t i = 0;
    std::apply(
        [&](const auto&... field) {
          ((unpack(value.*(field.ptr), src + type.members[i].offset, *type.members[i].type), ++i),
           ...);
        },
        GlslStruct<T>::fields);
  } else if constexpr (requires {
                         typename T::value_type;
                         std::tuple_size<T>::value;
                       }) {
    const uint32_t stride = type.element->stride();
    for (size_t i = 0; i < value.size(); ++i) unpack(value[i], src + i * stride, *type.element);
  } else if constexpr (requires {
                         T::length();
                         typename T::col_type;
                       }) {
    const uint32_t col_stride = type.components == 2 ? 8u : 16u;
    for (glm::length_t c = 0; c < T::length(); ++c)
      for (glm::length_t r = 0; r < T::col_type::length(); ++r)
        std::memcpy(&value[c][r], src + c * col_stride + r * 4, 4);
  } else {
    for (glm::length_t i = 0; i < T::length(); ++i) unpack(value[i], src + i * 4, type);
  }
}

}  // namespace detail

// The GLSL type of a C++ type, with its std430 layout.
template <class T>
std::shared_ptr<const TypeDesc> glsl_type() {
  return detail::TypeOf<std::remove_cvref_t<T>>::get();
}

}  // namespace penumbra::testing
