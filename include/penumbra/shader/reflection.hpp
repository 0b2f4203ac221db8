#pragma once

// SPIR-V reflection (SPIRV-Cross): descriptor bindings with the exact layout of their blocks,
// push constants, compute workgroup size and specialization constants. Host-side mirrors of GPU
// structs are checked against this.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::shader {

struct BlockMember {
  std::string name;
  // GLSL type name of one element: "float", "vec3", "mat3", "mat4x3", "int", "uint", "bool",
  // "double", "struct Foo", ...; array dimensions are in array_dims, not in the name.
  std::string type;
  uint32_t offset = 0;  // bytes, relative to the enclosing struct
  uint32_t size = 0;    // declared size of the member (whole array for arrays; 0 for runtime)
  std::vector<uint32_t> array_dims;  // outermost first; 0 for a runtime array
  uint32_t array_stride = 0;         // stride of the outermost dimension (0 if not an array)
  uint32_t matrix_stride = 0;        // 0 if not a matrix
  std::vector<BlockMember> members;  // nested struct members (offsets relative to the struct)
};

struct Block {
  std::string type_name;      // block (struct) type name, e.g. "Params"
  std::string instance_name;  // may be empty for an anonymous block
  uint32_t size = 0;          // declared size; a trailing runtime array counts 0
  std::vector<BlockMember> members;

  // "a.b.c" (array subscripts such as "lights[2].color" are accepted and ignored); nullptr when
  // absent.
  const BlockMember* find(std::string_view dotted_path) const;
};

enum class DescriptorKind {
  uniform_buffer,
  storage_buffer,
  combined_image_sampler,
  sampled_image,
  storage_image,
  sampler
};

std::string_view to_string(DescriptorKind kind);

struct DescriptorBinding {
  uint32_t set = 0;
  uint32_t binding = 0;
  DescriptorKind kind = DescriptorKind::uniform_buffer;
  std::string name;    // instance name, or the block type name for an anonymous block
  uint32_t count = 1;  // array size of the descriptor (product of dims; 0 for a runtime array)
  std::optional<Block> block;  // uniform and storage buffers
  // images:
  int image_dim = 0;  // 1, 2, 3, or 6 for cube (0 for buffers and samplers, 7 for texel buffers)
  bool image_arrayed = false;
  bool image_depth = false;
  int image_format = 0;  // storage images: the SPIR-V ImageFormat (0: Unknown, format-less)
};

// A user-defined stage input or output (built-ins are not listed).
struct StageVariable {
  uint32_t location = 0;
  std::string name;
  std::string type;  // GLSL type of one element, e.g. "vec4", "uint"
  uint32_t array_size = 1;
};

struct SpecConstant {
  uint32_t id = 0;  // constant_id
  std::string name;
  std::string type;
};

struct Reflection {
  std::vector<DescriptorBinding> bindings;  // sorted by (set, binding)
  std::optional<Block> push_constants;
  std::array<uint32_t, 3> workgroup_size{1, 1, 1};  // compute only; spec-constant default values
  std::vector<SpecConstant> spec_constants;         // sorted by id
  std::vector<StageVariable> inputs, outputs;       // sorted by location

  // By instance name, binding name or block type name; nullptr when absent.
  const DescriptorBinding* find_binding(std::string_view name) const;
};

// Throws penumbra::Error when the SPIR-V cannot be parsed.
Reflection reflect(const std::vector<uint32_t>& spirv);

// Why a pipeline made for `made_for` (its descriptor set layouts, push-constant range, vertex
// input, attachments and dispatch size) cannot run `next` (the same stage, recompiled): one line
// per change, empty when it can. `next` may use fewer resources, inputs and outputs, and drop
// block members that no other member's offset depends on; what it keeps must match: every
// binding it uses at the same set and binding with the same kind, count, dimensions and format,
// every block member at the same offset with the same type, the push constants likewise, the
// same workgroup size, spec constants of the same type, inputs and outputs at the same
// locations with the same types.
std::vector<std::string> interface_changes(const Reflection& made_for, const Reflection& next);

// Human-readable multi-line dump.
std::string to_string(const Reflection& reflection);

}  // namespace penumbra::shader
