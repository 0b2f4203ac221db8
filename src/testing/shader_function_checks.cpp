// The shader-function harness's checks (shader_function_detail.hpp): the wrapper's block layouts
// against SPIR-V reflection, resources against their GLSL parameters, the debug-printf
// messages, and the bounds-checked fetch overloads generated into the wrapper.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <glm/gtc/packing.hpp>
#include <map>
#include <mutex>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/shader/reflection.hpp>
#include <penumbra/testing/coverage.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <set>
#include <sstream>

#include "coverage_spirv.hpp"
#include "glsl_scan.hpp"

#include "shader_function_detail.hpp"

namespace penumbra::testing::detail {
namespace fs = std::filesystem;

// ---- layout check against reflection -------------------------------------------------------

namespace {

void check_member(const TypeDesc& host, const shader::BlockMember& dev, const std::string& path,
                  uint32_t host_offset) {
  if (dev.offset != host_offset) {
    throw Error("host layout mismatch at " + path + " (" + host.glsl_base() +
                "): host std430 offset " + std::to_string(host_offset) + ", SPIR-V offset " +
                std::to_string(dev.offset));
  }
  if (host.kind == TypeDesc::Kind::array) {
    if (dev.array_dims.empty() || dev.array_dims[0] != host.length ||
        dev.array_stride != host.element->stride()) {
      throw Error("host layout mismatch at " + path + ": host array [" +
                  std::to_string(host.length) + "] stride " +
                  std::to_string(host.element->stride()) + ", SPIR-V array " +
                  (dev.array_dims.empty() ? std::string("(none)")
                                          : "[" + std::to_string(dev.array_dims[0]) + "]") +
                  " stride " + std::to_string(dev.array_stride));
    }
    // Nested arrays and arrays of structs: compare the element through a synthetic member.
    const TypeDesc& e = *host.element;
    if (e.kind == TypeDesc::Kind::structure) {
      for (size_t i = 0; i < e.members.size(); ++i) {
        const auto& hm = e.members[i];
        auto it = std::find_if(dev.members.begin(), dev.members.end(),
                               [&](const shader::BlockMember& m) { return m.name == hm.name; });
        if (it == dev.members.end()) {
          throw Error("host layout mismatch at " + path + "[]: member '" + hm.name +
                      "' is not in the GLSL struct " + e.struct_name);
        }
        check_member(*hm.type, *it, path + "[]." + hm.name, hm.offset);
      }
    }
    return;
  }
  if (host.kind == TypeDesc::Kind::matrix && dev.matrix_stride != host.align) {
    throw Error("host layout mismatch at " + path + ": host column stride " +
                std::to_string(host.align) + ", SPIR-V matrix stride " +
                std::to_string(dev.matrix_stride));
  }
  if (host.kind == TypeDesc::Kind::structure) {
    if (dev.members.size() != host.members.size()) {
      throw Error("host layout mismatch at " + path + ": the C++ description of struct " +
                  host.struct_name + " has " + std::to_string(host.members.size()) +
                  " fields, the GLSL struct has " + std::to_string(dev.members.size()));
    }
    for (const auto& hm : host.members) {
      auto it = std::find_if(dev.members.begin(), dev.members.end(),
                             [&](const shader::BlockMember& m) { return m.name == hm.name; });
      if (it == dev.members.end()) {
        throw Error("host layout mismatch at " + path + ": field '" + hm.name +
                    "' of the C++ description is not a member of GLSL struct " + host.struct_name);
      }
      check_member(*hm.type, *it, path + "." + hm.name, hm.offset);
    }
    return;
  }
  if (dev.size != 0 && dev.size != host.size) {
    throw Error("host layout mismatch at " + path + ": host size " + std::to_string(host.size) +
                ", SPIR-V size " + std::to_string(dev.size) + " (GLSL type " + dev.type + ")");
  }
}

}  // namespace

void check_block(
    const shader::Reflection& refl, const char* block, const char* struct_name,
    const std::vector<std::pair<std::string, std::shared_ptr<const TypeDesc>>>& members,
    const std::vector<uint32_t>& offsets, uint32_t stride) {
  const auto* binding = refl.find_binding(block);
  if (binding == nullptr || !binding->block || binding->block->members.empty()) {
    throw Error(std::string("wrapper reflection: block ") + block + " not found");
  }
  const auto& cases = binding->block->members[0];
  for (size_t i = 0; i < members.size(); ++i) {
    auto it =
        std::find_if(cases.members.begin(), cases.members.end(),
                     [&](const shader::BlockMember& m) { return m.name == members[i].first; });
    if (it == cases.members.end()) {
      throw Error(std::string("wrapper reflection: member ") + struct_name + "." +
                  members[i].first + " not found");
    }
    check_member(*members[i].second, *it, std::string(struct_name) + "." + members[i].first,
                 offsets[i]);
  }
  // After the members, so a misplaced member is named rather than only the total.
  if (cases.array_stride != stride) {
    throw Error(std::string("host layout mismatch: ") + struct_name + " stride: host std430 " +
                std::to_string(stride) + ", SPIR-V " + std::to_string(cases.array_stride));
  }
}

std::string layout_signature(const TypeDesc& t) {
  std::string s = t.glsl_base() + t.glsl_array_suffix() + "/" + std::to_string(t.size);
  if (t.kind == TypeDesc::Kind::array) s += "<" + layout_signature(*t.element) + ">";
  if (t.kind == TypeDesc::Kind::structure) {
    s += "{";
    for (const auto& m : t.members)
      s += m.name + "@" + std::to_string(m.offset) + ":" + layout_signature(*m.type) + ";";
    s += "}";
  }
  return s;
}

// The source with line numbers; with `only` given, just the lines within 3 of those (and "..."
// where lines are left out).
std::string numbered(const std::string& source, const std::vector<int>& only) {
  std::istringstream in(source);
  std::ostringstream out;
  std::string line;
  int n = 0;
  bool skipped = false;
  while (std::getline(in, line)) {
    ++n;
    if (!only.empty() &&
        std::none_of(only.begin(), only.end(), [&](int at) { return std::abs(at - n) <= 3; })) {
      if (!skipped) out << "  ...\n";
      skipped = true;
      continue;
    }
    skipped = false;
    out << (n < 10 ? "   " : n < 100 ? "  " : " ") << n << "  " << line << "\n";
  }
  return out.str();
}

bool is_storage(ResourceKind kind) {
  return kind == ResourceKind::image2d || kind == ResourceKind::image2d_array;
}

VkDescriptorType descriptor_type(ResourceKind kind) {
  return is_storage(kind) ? VK_DESCRIPTOR_TYPE_STORAGE_IMAGE
                          : VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
}

bool kind_matches(ResourceKind kind, const Texture& t, const ExternalSampler& external) {
  const auto vk = t.image.desc().kind;
  if (is_storage(kind)) {
    return t.storage && (kind == ResourceKind::image2d ? vk == gpu::ImageKind::image_2d
                                                       : vk == gpu::ImageKind::image_2d_array);
  }
  if (t.storage) return false;
  const bool compare =
      external.handle != VK_NULL_HANDLE ? external.compare : t.sampler.desc().compare;
  switch (kind) {
    case ResourceKind::image2d:
    case ResourceKind::image2d_array:
      return false;
    case ResourceKind::sampler2d_shadow:
      return t.depth && compare && vk == gpu::ImageKind::image_2d;
    case ResourceKind::sampler2d_array_shadow:
      return t.depth && compare && vk == gpu::ImageKind::image_2d_array;
    case ResourceKind::sampler_cube_shadow:
      return t.depth && compare && vk == gpu::ImageKind::cube;
    case ResourceKind::sampler2d:
      return !compare && vk == gpu::ImageKind::image_2d;
    case ResourceKind::sampler2d_array:
      return !compare && vk == gpu::ImageKind::image_2d_array;
    case ResourceKind::sampler_cube_array_shadow:
      return t.depth && compare && vk == gpu::ImageKind::cube_array;
    case ResourceKind::sampler_cube_array:
      return !compare && vk == gpu::ImageKind::cube_array;
    case ResourceKind::sampler_cube:
      return !compare && vk == gpu::ImageKind::cube;
  }
  return false;
}

std::string describe_texture(const Texture& t, const ExternalSampler& external) {
  const auto& d = t.image.desc();
  std::string kind = d.kind == gpu::ImageKind::image_2d         ? "2D"
                     : d.kind == gpu::ImageKind::image_2d_array ? "2D array"
                     : d.kind == gpu::ImageKind::cube           ? "cube"
                                                                : "cube array";
  if (t.storage) return kind + " storage image";
  const bool own = external.handle == VK_NULL_HANDLE;
  const bool compare = own ? t.sampler.desc().compare : external.compare;
  return kind + (t.depth ? " depth" : " float") + " texture with " +
         (own ? "a " : "the caller's ") + (compare ? "compare" : "non-compare") + " sampler";
}

// SPIR-V: does the module declare this capability (OpCapability, opcode 17)?
bool uses_capability(const std::vector<uint32_t>& spirv, uint32_t capability) {
  for (size_t i = 5; i < spirv.size();) {
    const uint32_t words = spirv[i] >> 16, opcode = spirv[i] & 0xffffu;
    if (words == 0) break;
    if (opcode == 17 && i + 1 < spirv.size() && spirv[i + 1] == capability) return true;
    i += words;
  }
  return false;
}

// Does the module import NonSemantic.DebugPrintf (OpExtInstImport, opcode 11)?
std::set<uint32_t> capabilities(const std::vector<uint32_t>& spirv) {
  std::set<uint32_t> caps;
  for (size_t i = 5; i < spirv.size();) {
    const uint32_t words = spirv[i] >> 16, opcode = spirv[i] & 0xffffu;
    if (words == 0 || i + words > spirv.size()) break;
    if (opcode == 17 && i + 1 < spirv.size()) caps.insert(spirv[i + 1]);  // OpCapability
    i += words;
  }
  return caps;
}

bool imports_debug_printf(const std::vector<uint32_t>& spirv) {
  for (size_t i = 5; i < spirv.size();) {
    const uint32_t words = spirv[i] >> 16, opcode = spirv[i] & 0xffffu;
    if (words == 0 || i + words > spirv.size()) break;
    if (opcode == 11 && words > 2) {
      const char* name = reinterpret_cast<const char*>(&spirv[i + 2]);
      const size_t max = (words - 2) * 4;
      if (std::string(name, strnlen(name, max)).rfind("NonSemantic.DebugPrintf", 0) == 0)
        return true;
    }
    i += words;
  }
  return false;
}

// A verbose debug printf message: which dispatch and invocation printed, and what. Returns false
// for a message without the invocation (the layer not in verbose mode).
bool parse_printf(const std::string& message, uint64_t& dispatch, uint64_t& invocation,
                  std::string& text) {
  const std::string dispatch_key = "Compute Dispatch Index ";
  const std::string id_key = "Global invocation ID (x, y, z) = (";
  const size_t d = message.find(dispatch_key);
  const size_t g = message.find(id_key);
  if (d == std::string::npos || g == std::string::npos) return false;
  dispatch = std::strtoull(message.c_str() + d + dispatch_key.size(), nullptr, 10);
  invocation = std::strtoull(message.c_str() + g + id_key.size(), nullptr, 10);
  const size_t close = message.find(')', g + id_key.size());
  if (close == std::string::npos) return false;
  text = message.substr(std::min(message.size(), close + 2));
  // What the layer appends: where it could not find a line, or, for SPIR-V with line
  // information (coverage), the file and line of the printf.
  for (const char* tail : {" Unable to find SPIR-V OpLine", "\nUnable to find SPIR-V OpLine",
                           " Debug shader printf message generated in file",
                           "\nDebug shader printf message generated in file"}) {
    const size_t t = text.rfind(tail);
    if (t != std::string::npos) text.resize(t);
  }
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  return true;
}

// The text of a non-verbose message: what follows the layer's header.
std::string printf_text(const std::string& message) {
  const size_t id = message.find("MessageID = ");
  const size_t bar = id == std::string::npos ? std::string::npos : message.find("| ", id);
  return bar == std::string::npos ? message : message.substr(bar + 2);
}

// ---- bounds checks -----------------------------------------------------------------------------

// The overloads the checked texel fetches cover: every GLSL type texelFetch takes, so that a
// tested file's other code (globals of other types included) still compiles under the macros.
struct FetchOverload {
  const char* type;   // without the i/u prefix
  const char* coord;  // coordinate type
  int dims;           // components of the coordinate (the last is the layer for arrays)
  bool lod;           // texelFetch takes a level (else: none, or a sample index for MS)
  bool ms;            // multisampled: the third argument is the sample
};
constexpr FetchOverload kFetchOverloads[] = {
    {"sampler1D", "int", 1, true, false},        {"sampler2D", "ivec2", 2, true, false},
    {"sampler3D", "ivec3", 3, true, false},      {"sampler1DArray", "ivec2", 2, true, false},
    {"sampler2DArray", "ivec3", 3, true, false}, {"samplerBuffer", "int", 1, false, false},
    {"sampler2DMS", "ivec2", 2, false, true},    {"sampler2DMSArray", "ivec3", 3, false, true},
};
std::string ivec3_of(const char* coord, const std::string& v) {
  return std::string(coord) == "int"     ? "ivec3(" + v + ", 0, 0)"
         : std::string(coord) == "ivec2" ? "ivec3(" + v + ", 0)"
                                         : v;
}

// GLSL placed before the tested file: the report buffer, the case index, the checked versions,
// and the macros that route the tested code's calls through them. Type names (the `type` the
// report records) are collected in `types`.
std::string bounds_prelude(uint32_t binding, bool images, std::vector<std::string>& types) {
  std::ostringstream g;
  g << "// ---- Penumbra bounds checks (FunctionOptions::check_bounds) ----\n";
  g << "layout(std430, set = 0, binding = " << binding
    << ") buffer PenumbraBounds {\n  uint count;\n"
    << "  uint first_case;\n  uint op;\n  uint type;\n  int level;\n  int levels;\n"
    << "  int x;\n  int y;\n  int z;\n  int w;\n  int h;\n  int d;\n} penumbra_bounds;\n";
  g << "uint penumbra_case = 0u;\n";
  g << "void penumbra_out_of_bounds(uint op, uint type, ivec3 p, int level, ivec3 size, int "
       "levels) {\n"
       "  if (atomicAdd(penumbra_bounds.count, 1u) != 0u) return;\n"
       "  penumbra_bounds.first_case = penumbra_case;\n"
       "  penumbra_bounds.op = op;\n  penumbra_bounds.type = type;\n"
       "  penumbra_bounds.level = level;\n  penumbra_bounds.levels = levels;\n"
       "  penumbra_bounds.x = p.x;\n  penumbra_bounds.y = p.y;\n  penumbra_bounds.z = p.z;\n"
       "  penumbra_bounds.w = size.x;\n  penumbra_bounds.h = size.y;\n"
       "  penumbra_bounds.d = size.z;\n}\n";
  g << "bool penumbra_inside(ivec3 p, ivec3 size) {\n"
       "  return all(greaterThanEqual(p, ivec3(0))) && all(lessThan(p, size));\n}\n";
  for (const char* prefix : {"", "i", "u"}) {
    const std::string vec4 = std::string(prefix) + "vec4";
    for (const auto& o : kFetchOverloads) {
      const std::string type = std::string(prefix) + o.type;
      const uint32_t id = uint32_t(types.size());
      types.push_back(type);
      const std::string p3 = ivec3_of(o.coord, "p");
      const std::string size3 = ivec3_of(o.coord, o.lod ? "textureSize(s, lod)" : "textureSize(s)");
      for (int op = 0; op < 2; ++op) {
        if (op == 1 && (!o.lod || std::string(o.type) == "samplerBuffer")) continue;
        g << vec4 << " penumbra_checked_" << kBoundsOps[op] << "(" << type << " s, " << o.coord
          << " p";
        if (o.lod) g << ", int lod";
        if (o.ms) g << ", int lod";  // the sample index, named lod to share the code below
        // The offset has no layer component: int for 1D and 1D arrays, ivec2 for 2D and 2D
        // arrays, ivec3 for 3D.
        const char* offset_type = std::string(o.type) == "sampler1DArray"   ? "int"
                                  : std::string(o.type) == "sampler2DArray" ? "ivec2"
                                                                            : o.coord;
        if (op == 1) g << ", " << offset_type << " offset";
        g << ") {\n";
        if (op == 1) {
          g << "  p += "
            << (std::string(offset_type) == o.coord ? "offset"
                : std::string(offset_type) == "int" ? "ivec2(offset, 0)"
                                                    : "ivec3(offset, 0)")
            << ";\n";
        }
        if (o.lod) {
          g << "  int levels = textureQueryLevels(s);\n"
               "  bool level_ok = lod >= 0 && lod < levels;\n"
            << "  ivec3 size = level_ok ? " << size3 << " : ivec3(0);\n";
        } else if (o.ms) {
          g << "  int levels = textureSamples(s);\n  bool level_ok = lod >= 0 && lod < levels;\n"
            << "  ivec3 size = " << size3 << ";\n";
        } else {
          g << "  int levels = 1;\n  bool level_ok = true;\n  int lod = 0;\n"
            << "  ivec3 size = " << size3 << ";\n";
        }
        if (std::string(o.coord) == "int") g << "  size.yz = ivec2(1);\n";
        if (std::string(o.coord) == "ivec2") g << "  size.z = 1;\n";
        g << "  if (!level_ok || !penumbra_inside(" << p3 << ", size)) {\n"
          << "    penumbra_out_of_bounds(" << op << "u, " << id << "u, " << p3
          << ", lod, size, levels);\n    return " << vec4 << "(0);\n  }\n";
        g << "  return texelFetch(s, p" << (o.lod || o.ms ? ", lod" : "") << ");\n}\n";
      }
    }
  }
  if (images) {
    // Format-less, like the harness's own storage images (a parameter cannot carry a format).
    // The memory qualifiers accept any argument that may be read (or written).
    for (const auto& [type, coord] :
         {std::pair<const char*, const char*>{"image2D", "ivec2"}, {"image2DArray", "ivec3"}}) {
      const uint32_t id = uint32_t(types.size());
      types.push_back(type);
      const std::string p3 = ivec3_of(coord, "p");
      const std::string size3 = ivec3_of(coord, "imageSize(img)");
      const std::string check = std::string("  ivec3 size = ") + size3 + ";\n" +
                                (std::string(coord) == "ivec2" ? "  size.z = 1;\n" : "") +
                                "  bool inside = penumbra_inside(" + p3 + ", size);\n";
      g << "vec4 penumbra_checked_imageLoad(coherent volatile readonly " << type << " img, "
        << coord << " p) {\n"
        << check << "  if (!inside) {\n    penumbra_out_of_bounds(2u, " << id << "u, " << p3
        << ", 0, size, 1);\n    return vec4(0);\n  }\n  return imageLoad(img, p);\n}\n";
      g << "void penumbra_checked_imageStore(coherent volatile writeonly " << type << " img, "
        << coord << " p, vec4 v) {\n"
        << check << "  if (!inside) {\n    penumbra_out_of_bounds(3u, " << id << "u, " << p3
        << ", 0, size, 1);\n    return;\n  }\n  imageStore(img, p, v);\n}\n";
    }
    g << "#define imageLoad penumbra_checked_imageLoad\n";
    g << "#define imageStore penumbra_checked_imageStore\n";
  }
  g << "#define texelFetch penumbra_checked_texelFetch\n";
  g << "#define texelFetchOffset penumbra_checked_texelFetchOffset\n";
  g << "// ---- end of the bounds checks ----\n";
  return g.str();
}


}  // namespace penumbra::testing::detail
