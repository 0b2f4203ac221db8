#include <algorithm>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/glsl_types.hpp>

namespace penumbra::testing {

uint32_t TypeDesc::stride() const {
  return detail::round_up(size, align);
}

std::string TypeDesc::glsl_base() const {
  auto prefix = [](ScalarType s) -> std::string {
    switch (s) {
      case ScalarType::f32:
        return "";
      case ScalarType::i32:
        return "i";
      case ScalarType::u32:
        return "u";
      case ScalarType::boolean:
        return "b";
    }
    return "";
  };
  switch (kind) {
    case Kind::scalar:
      switch (scalar) {
        case ScalarType::f32:
          return "float";
        case ScalarType::i32:
          return "int";
        case ScalarType::u32:
          return "uint";
        case ScalarType::boolean:
          return "bool";
      }
      return "float";
    case Kind::vector:
      return prefix(scalar) + "vec" + std::to_string(components);
    case Kind::matrix:
      return columns == components
                 ? "mat" + std::to_string(columns)
                 : "mat" + std::to_string(columns) + "x" + std::to_string(components);
    case Kind::array:
      return element->glsl_base();
    case Kind::structure:
      return struct_name;
  }
  return "";
}

std::string TypeDesc::glsl_array_suffix() const {
  if (kind != Kind::array) return "";
  return "[" + std::to_string(length) + "]" + element->glsl_array_suffix();
}

std::string TypeDesc::declare(const std::string& name) const {
  return glsl_base() + " " + name + glsl_array_suffix();
}

namespace detail {

std::shared_ptr<const TypeDesc> make_scalar(ScalarType s) {
  auto t = std::make_shared<TypeDesc>();
  t->kind = TypeDesc::Kind::scalar;
  t->scalar = s;
  t->align = t->size = 4;
  return t;
}

std::shared_ptr<const TypeDesc> make_vector(ScalarType s, uint32_t n) {
  auto t = std::make_shared<TypeDesc>();
  t->kind = TypeDesc::Kind::vector;
  t->scalar = s;
  t->components = n;
  t->size = 4 * n;
  t->align = n == 2 ? 8 : 16;
  return t;
}

std::shared_ptr<const TypeDesc> make_matrix(uint32_t columns, uint32_t rows) {
  auto t = std::make_shared<TypeDesc>();
  t->kind = TypeDesc::Kind::matrix;
  t->scalar = ScalarType::f32;
  t->components = rows;
  t->columns = columns;
  t->align = rows == 2 ? 8 : 16;  // std430: a column vector's alignment, no rounding to vec4
  t->size = columns * t->align;
  return t;
}

std::shared_ptr<const TypeDesc> make_array(std::shared_ptr<const TypeDesc> element, uint32_t n) {
  if (n == 0) throw Error("GLSL arrays in the harness need a fixed size > 0");
  auto t = std::make_shared<TypeDesc>();
  t->kind = TypeDesc::Kind::array;
  t->length = n;
  t->align = element->align;
  t->size = n * element->stride();
  t->element = std::move(element);
  return t;
}

std::shared_ptr<const TypeDesc> make_struct(std::string name,
                                            std::vector<TypeDesc::Member> members) {
  auto t = std::make_shared<TypeDesc>();
  t->kind = TypeDesc::Kind::structure;
  t->struct_name = std::move(name);
  uint32_t offset = 0, align = 4;
  for (auto& m : members) {
    offset = round_up(offset, m.type->align);
    m.offset = offset;
    offset += m.type->size;
    align = std::max(align, m.type->align);
  }
  t->align = align;
  t->size = round_up(offset, align);
  t->members = std::move(members);
  return t;
}

}  // namespace detail
}  // namespace penumbra::testing
