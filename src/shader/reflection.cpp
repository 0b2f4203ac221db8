#include <algorithm>
#include <exception>
#include <penumbra/core/error.hpp>
#include <penumbra/shader/reflection.hpp>
#include <spirv_cross/spirv_cross.hpp>
#include <sstream>

namespace penumbra::shader {

namespace {

using spirv_cross::SPIRType;

uint32_t array_size(const spirv_cross::Compiler& compiler, const SPIRType& type, size_t index) {
  if (type.array_size_literal[index]) return type.array[index];
  // Sized by a specialization constant: its default value.
  return compiler.get_constant(type.array[index]).scalar();
}

// Outermost first (SPIRV-Cross stores the outermost dimension last).
std::vector<uint32_t> array_dims(const spirv_cross::Compiler& compiler, const SPIRType& type) {
  std::vector<uint32_t> dims;
  for (size_t i = type.array.size(); i-- > 0;) dims.push_back(array_size(compiler, type, i));
  return dims;
}

std::string type_name(const spirv_cross::Compiler& compiler, const SPIRType& type) {
  std::string scalar;
  std::string prefix;
  switch (type.basetype) {
    case SPIRType::Struct:
      return "struct " + compiler.get_name(type.self);
    case SPIRType::Boolean:
      scalar = "bool", prefix = "b";
      break;
    case SPIRType::SByte:
      scalar = "int8_t", prefix = "i8";
      break;
    case SPIRType::UByte:
      scalar = "uint8_t", prefix = "u8";
      break;
    case SPIRType::Short:
      scalar = "int16_t", prefix = "i16";
      break;
    case SPIRType::UShort:
      scalar = "uint16_t", prefix = "u16";
      break;
    case SPIRType::Int:
      scalar = "int", prefix = "i";
      break;
    case SPIRType::UInt:
      scalar = "uint", prefix = "u";
      break;
    case SPIRType::Int64:
      scalar = "int64_t", prefix = "i64";
      break;
    case SPIRType::UInt64:
      scalar = "uint64_t", prefix = "u64";
      break;
    case SPIRType::Half:
      scalar = "float16_t", prefix = "f16";
      break;
    case SPIRType::Float:
      scalar = "float", prefix = "";
      break;
    case SPIRType::Double:
      scalar = "double", prefix = "d";
      break;
    case SPIRType::Image:
      return "image";
    case SPIRType::SampledImage:
      return "sampler";
    case SPIRType::Sampler:
      return "sampler";
    case SPIRType::AccelerationStructure:
      return "accelerationStructureEXT";
    default:
      return "unknown";
  }
  if (type.columns > 1) {
    std::string name = prefix + "mat" + std::to_string(type.columns);
    if (type.columns != type.vecsize) name += "x" + std::to_string(type.vecsize);
    return name;
  }
  if (type.vecsize > 1) return prefix + "vec" + std::to_string(type.vecsize);
  return scalar;
}

std::vector<BlockMember> struct_members(const spirv_cross::Compiler& compiler,
                                        const SPIRType& struct_type) {
  std::vector<BlockMember> members;
  for (uint32_t i = 0; i < struct_type.member_types.size(); ++i) {
    const SPIRType& type = compiler.get_type(struct_type.member_types[i]);
    BlockMember member;
    member.name = compiler.get_member_name(struct_type.self, i);
    member.type = type_name(compiler, type);
    member.offset = compiler.type_struct_member_offset(struct_type, i);
    member.size = static_cast<uint32_t>(compiler.get_declared_struct_member_size(struct_type, i));
    member.array_dims = array_dims(compiler, type);
    if (!type.array.empty()) {
      member.array_stride = compiler.type_struct_member_array_stride(struct_type, i);
    }
    if (type.columns > 1) {
      member.matrix_stride = compiler.type_struct_member_matrix_stride(struct_type, i);
    }
    if (type.basetype == SPIRType::Struct) member.members = struct_members(compiler, type);
    members.push_back(std::move(member));
  }
  return members;
}

Block make_block(const spirv_cross::Compiler& compiler, const spirv_cross::Resource& resource) {
  const SPIRType& type = compiler.get_type(resource.base_type_id);
  Block block;
  block.type_name = compiler.get_name(resource.base_type_id);
  block.instance_name = compiler.get_name(resource.id);
  block.size = static_cast<uint32_t>(compiler.get_declared_struct_size(type));
  block.members = struct_members(compiler, type);
  return block;
}

int image_dim(spv::Dim dim) {
  switch (dim) {
    case spv::Dim1D:
      return 1;
    case spv::Dim2D:
    case spv::DimRect:
    case spv::DimSubpassData:
      return 2;
    case spv::Dim3D:
      return 3;
    case spv::DimCube:
      return 6;
    case spv::DimBuffer:
      return 7;
    default:
      return 0;
  }
}

void add_bindings(const spirv_cross::Compiler& compiler,
                  const spirv_cross::SmallVector<spirv_cross::Resource>& resources,
                  DescriptorKind kind, std::vector<DescriptorBinding>& out) {
  for (const spirv_cross::Resource& resource : resources) {
    DescriptorBinding binding;
    binding.kind = kind;
    binding.set = compiler.get_decoration(resource.id, spv::DecorationDescriptorSet);
    binding.binding = compiler.get_decoration(resource.id, spv::DecorationBinding);
    const SPIRType& type = compiler.get_type(resource.type_id);
    binding.count = 1;
    for (uint32_t dim : array_dims(compiler, type)) binding.count *= dim;

    if (kind == DescriptorKind::uniform_buffer || kind == DescriptorKind::storage_buffer) {
      binding.block = make_block(compiler, resource);
      binding.name = binding.block->instance_name.empty() ? binding.block->type_name
                                                          : binding.block->instance_name;
    } else {
      binding.name = compiler.get_name(resource.id);
      if (binding.name.empty()) binding.name = resource.name;
      if (kind != DescriptorKind::sampler) {
        const SPIRType& base = compiler.get_type(resource.base_type_id);
        binding.image_dim = image_dim(base.image.dim);
        binding.image_arrayed = base.image.arrayed;
        binding.image_depth = base.image.depth;
        if (kind == DescriptorKind::storage_image) binding.image_format = int(base.image.format);
      }
    }
    out.push_back(std::move(binding));
  }
}

std::string_view strip_subscript(std::string_view part) {
  const size_t bracket = part.find('[');
  return bracket == std::string_view::npos ? part : part.substr(0, bracket);
}

void dump_members(std::ostringstream& out, const std::vector<BlockMember>& members, int indent) {
  for (const BlockMember& m : members) {
    out << std::string(static_cast<size_t>(indent), ' ') << m.type << ' ' << m.name;
    for (uint32_t dim : m.array_dims) {
      out << '[';
      if (dim != 0) out << dim;
      out << ']';
    }
    out << "  offset=" << m.offset << " size=" << m.size;
    if (m.array_stride != 0) out << " array_stride=" << m.array_stride;
    if (m.matrix_stride != 0) out << " matrix_stride=" << m.matrix_stride;
    out << '\n';
    dump_members(out, m.members, indent + 2);
  }
}

void dump_block(std::ostringstream& out, const Block& block, int indent) {
  out << std::string(static_cast<size_t>(indent), ' ') << "block " << block.type_name;
  if (!block.instance_name.empty()) out << ' ' << block.instance_name;
  out << "  size=" << block.size << '\n';
  dump_members(out, block.members, indent + 2);
}

}  // namespace

const BlockMember* Block::find(std::string_view dotted_path) const {
  const std::vector<BlockMember>* level = &members;
  const BlockMember* found = nullptr;
  while (true) {
    const size_t dot = dotted_path.find('.');
    const std::string_view part = strip_subscript(dotted_path.substr(0, dot));
    const auto it = std::find_if(level->begin(), level->end(),
                                 [&](const BlockMember& m) { return m.name == part; });
    if (it == level->end()) return nullptr;
    found = &*it;
    if (dot == std::string_view::npos) return found;
    dotted_path.remove_prefix(dot + 1);
    level = &found->members;
  }
}

const DescriptorBinding* Reflection::find_binding(std::string_view name) const {
  for (const DescriptorBinding& binding : bindings) {
    if (binding.name == name) return &binding;
    if (binding.block &&
        (binding.block->instance_name == name || binding.block->type_name == name)) {
      return &binding;
    }
  }
  return nullptr;
}

std::string_view to_string(DescriptorKind kind) {
  switch (kind) {
    case DescriptorKind::uniform_buffer:
      return "uniform_buffer";
    case DescriptorKind::storage_buffer:
      return "storage_buffer";
    case DescriptorKind::combined_image_sampler:
      return "combined_image_sampler";
    case DescriptorKind::sampled_image:
      return "sampled_image";
    case DescriptorKind::storage_image:
      return "storage_image";
    case DescriptorKind::sampler:
      return "sampler";
  }
  return "unknown";
}

Reflection reflect(const std::vector<uint32_t>& spirv) {
  try {
    const spirv_cross::Compiler compiler(spirv);
    const spirv_cross::ShaderResources resources = compiler.get_shader_resources();

    Reflection result;
    add_bindings(compiler, resources.uniform_buffers, DescriptorKind::uniform_buffer,
                 result.bindings);
    add_bindings(compiler, resources.storage_buffers, DescriptorKind::storage_buffer,
                 result.bindings);
    add_bindings(compiler, resources.sampled_images, DescriptorKind::combined_image_sampler,
                 result.bindings);
    add_bindings(compiler, resources.separate_images, DescriptorKind::sampled_image,
                 result.bindings);
    add_bindings(compiler, resources.storage_images, DescriptorKind::storage_image,
                 result.bindings);
    add_bindings(compiler, resources.separate_samplers, DescriptorKind::sampler, result.bindings);
    std::stable_sort(result.bindings.begin(), result.bindings.end(),
                     [](const DescriptorBinding& a, const DescriptorBinding& b) {
                       return a.set != b.set ? a.set < b.set : a.binding < b.binding;
                     });

    if (!resources.push_constant_buffers.empty()) {
      result.push_constants = make_block(compiler, resources.push_constant_buffers.front());
    }

    if (compiler.get_execution_model() == spv::ExecutionModelGLCompute) {
      const bool by_id = compiler.get_execution_mode_bitset().get(spv::ExecutionModeLocalSizeId);
      for (uint32_t i = 0; i < 3; ++i) {
        if (by_id) {
          const uint32_t id =
              compiler.get_execution_mode_argument(spv::ExecutionModeLocalSizeId, i);
          result.workgroup_size[i] = compiler.get_constant(id).scalar();
        } else {
          result.workgroup_size[i] =
              compiler.get_execution_mode_argument(spv::ExecutionModeLocalSize, i);
        }
      }
      spirv_cross::SpecializationConstant spec[3];
      compiler.get_work_group_size_specialization_constants(spec[0], spec[1], spec[2]);
      for (uint32_t i = 0; i < 3; ++i) {
        if (spec[i].id != 0) result.workgroup_size[i] = compiler.get_constant(spec[i].id).scalar();
      }
    }

    for (const spirv_cross::SpecializationConstant& sc : compiler.get_specialization_constants()) {
      const spirv_cross::SPIRConstant& constant = compiler.get_constant(sc.id);
      result.spec_constants.push_back(
          SpecConstant{sc.constant_id, compiler.get_name(sc.id),
                       type_name(compiler, compiler.get_type(constant.constant_type))});
    }
    std::sort(result.spec_constants.begin(), result.spec_constants.end(),
              [](const SpecConstant& a, const SpecConstant& b) { return a.id < b.id; });
    const auto stage_variables = [&](const auto& list, std::vector<StageVariable>& out) {
      for (const spirv_cross::Resource& r : list) {
        if (compiler.has_decoration(r.id, spv::DecorationBuiltIn) ||
            !compiler.has_decoration(r.id, spv::DecorationLocation)) {
          continue;
        }
        const SPIRType& type = compiler.get_type(r.type_id);
        StageVariable v;
        v.location = compiler.get_decoration(r.id, spv::DecorationLocation);
        v.name = compiler.get_name(r.id);
        v.type = type_name(compiler, compiler.get_type(r.base_type_id));
        for (uint32_t dim : array_dims(compiler, type)) v.array_size *= dim;
        out.push_back(std::move(v));
      }
      std::sort(out.begin(), out.end(), [](const StageVariable& a, const StageVariable& b) {
        return a.location < b.location;
      });
    };
    stage_variables(resources.stage_inputs, result.inputs);
    stage_variables(resources.stage_outputs, result.outputs);
    return result;
  } catch (const penumbra::Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(std::string("SPIR-V reflection failed: ") + e.what());
  }
}

std::string to_string(const Reflection& reflection) {
  std::ostringstream out;
  out << "workgroup_size " << reflection.workgroup_size[0] << ' ' << reflection.workgroup_size[1]
      << ' ' << reflection.workgroup_size[2] << '\n';
  for (const DescriptorBinding& b : reflection.bindings) {
    out << "set " << b.set << " binding " << b.binding << ": " << to_string(b.kind) << ' '
        << b.name;
    if (b.count != 1) out << " count=" << b.count;
    if (b.image_dim != 0) {
      out << " dim=" << (b.image_dim == 6 ? std::string("cube") : std::to_string(b.image_dim));
      if (b.image_arrayed) out << " arrayed";
      if (b.image_depth) out << " depth";
    }
    out << '\n';
    if (b.block) dump_block(out, *b.block, 2);
  }
  if (reflection.push_constants) {
    out << "push_constants\n";
    dump_block(out, *reflection.push_constants, 2);
  }
  for (const SpecConstant& sc : reflection.spec_constants) {
    out << "spec_constant " << sc.id << ": " << sc.type << ' ' << sc.name << '\n';
  }
  return out.str();
}

namespace {

std::string binding_text(const DescriptorBinding& b) {
  std::string s = std::string(to_string(b.kind)) + " '" + b.name + "'";
  if (b.count != 1) s += "[" + std::to_string(b.count) + "]";
  if (b.image_dim != 0) {
    s += b.image_dim == 6 ? " cube" : " " + std::to_string(b.image_dim) + "D";
    if (b.image_arrayed) s += " array";
    if (b.image_depth) s += " depth";
  }
  if (b.image_format != 0) s += " format " + std::to_string(b.image_format);
  return s;
}

std::string member_type(const BlockMember& m) {
  std::string s = m.type;
  for (uint32_t d : m.array_dims) s += "[" + (d == 0 ? std::string() : std::to_string(d)) + "]";
  return s;
}

void compare_members(const std::vector<BlockMember>& made_for, const std::vector<BlockMember>& next,
                     const std::string& path, std::vector<std::string>& out) {
  for (const BlockMember& n : next) {
    const auto it = std::find_if(made_for.begin(), made_for.end(),
                                 [&](const BlockMember& m) { return m.name == n.name; });
    const std::string where = path + "." + n.name;
    if (it == made_for.end()) {
      out.push_back(where + " (" + member_type(n) + " at offset " + std::to_string(n.offset) +
                    ") is new: the host does not write it");
      continue;
    }
    // A struct is compared member by member (it may lose trailing members); its array stride
    // still moves every element after the first.
    const bool is_struct = !n.members.empty() || !it->members.empty();
    if (it->offset != n.offset || member_type(*it) != member_type(n) ||
        it->array_stride != n.array_stride || it->matrix_stride != n.matrix_stride ||
        (!is_struct && it->size != n.size)) {
      out.push_back(where + " was " + member_type(*it) + " at offset " +
                    std::to_string(it->offset) + " (size " + std::to_string(it->size) +
                    "), is now " + member_type(n) + " at offset " + std::to_string(n.offset) +
                    " (size " + std::to_string(n.size) + ")");
      continue;
    }
    compare_members(it->members, n.members, where, out);
  }
}

void compare_stage_variables(const std::vector<StageVariable>& made_for,
                             const std::vector<StageVariable>& next, const char* what,
                             std::vector<std::string>& out) {
  for (const StageVariable& n : next) {
    const auto it = std::find_if(made_for.begin(), made_for.end(),
                                 [&](const StageVariable& m) { return m.location == n.location; });
    const std::string text =
        n.type + (n.array_size != 1 ? "[" + std::to_string(n.array_size) + "]" : std::string()) +
        " '" + n.name + "'";
    if (it == made_for.end()) {
      out.push_back(std::string(what) + " at location " + std::to_string(n.location) + " (" + text +
                    ") is new: the pipeline has nothing there");
    } else if (it->type != n.type || it->array_size != n.array_size) {
      out.push_back(std::string(what) + " at location " + std::to_string(n.location) + " was " +
                    it->type + " '" + it->name + "', is now " + text);
    }
  }
}

}  // namespace

std::vector<std::string> interface_changes(const Reflection& made_for, const Reflection& next) {
  std::vector<std::string> out;
  for (const DescriptorBinding& n : next.bindings) {
    const auto it = std::find_if(
        made_for.bindings.begin(), made_for.bindings.end(),
        [&](const DescriptorBinding& m) { return m.set == n.set && m.binding == n.binding; });
    const std::string where =
        "set " + std::to_string(n.set) + ", binding " + std::to_string(n.binding);
    if (it == made_for.bindings.end()) {
      out.push_back(where + " (" + binding_text(n) +
                    ") is new: the pipeline layout has no such binding");
      continue;
    }
    if (it->kind != n.kind || it->count != n.count || it->image_dim != n.image_dim ||
        it->image_arrayed != n.image_arrayed || it->image_depth != n.image_depth ||
        it->image_format != n.image_format) {
      out.push_back(where + " was " + binding_text(*it) + ", is now " + binding_text(n));
      continue;
    }
    if (it->block && n.block) {
      compare_members(it->block->members, n.block->members, n.block->type_name, out);
    }
  }
  if (next.push_constants) {
    if (!made_for.push_constants) {
      out.push_back("push constants (" + next.push_constants->type_name +
                    ") are new: the pipeline layout has no push-constant range");
    } else {
      compare_members(made_for.push_constants->members, next.push_constants->members,
                      next.push_constants->type_name, out);
    }
  }
  if (made_for.workgroup_size != next.workgroup_size) {
    const auto text = [](const std::array<uint32_t, 3>& w) {
      return std::to_string(w[0]) + "x" + std::to_string(w[1]) + "x" + std::to_string(w[2]);
    };
    // Named by the first layout qualifier that differs, which locates the declaration.
    const char* axis[3] = {"local_size_x", "local_size_y", "local_size_z"};
    int changed = 0;
    while (changed < 2 && made_for.workgroup_size[changed] == next.workgroup_size[changed])
      ++changed;
    out.push_back("workgroup size ('" + std::string(axis[changed]) + "') was " +
                  text(made_for.workgroup_size) + ", is now " + text(next.workgroup_size) +
                  ": the pass sizes its dispatch for " + text(made_for.workgroup_size) +
                  " when the pipeline is built, so a new size takes a restart");
  }
  for (const SpecConstant& n : next.spec_constants) {
    const auto it = std::find_if(made_for.spec_constants.begin(), made_for.spec_constants.end(),
                                 [&](const SpecConstant& m) { return m.id == n.id; });
    if (it != made_for.spec_constants.end() && it->type != n.type) {
      out.push_back("specialization constant " + std::to_string(n.id) + " was " + it->type +
                    ", is now " + n.type + " '" + n.name + "'");
    }
  }
  compare_stage_variables(made_for.inputs, next.inputs, "input", out);
  compare_stage_variables(made_for.outputs, next.outputs, "output", out);
  return out;
}

}  // namespace penumbra::shader
