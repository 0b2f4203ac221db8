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

namespace penumbra::testing {
namespace fs = std::filesystem;

const char* glsl_name(ResourceKind kind) {
  switch (kind) {
    case ResourceKind::sampler2d_shadow:
      return "sampler2DShadow";
    case ResourceKind::sampler2d_array_shadow:
      return "sampler2DArrayShadow";
    case ResourceKind::sampler_cube_shadow:
      return "samplerCubeShadow";
    case ResourceKind::sampler2d:
      return "sampler2D";
    case ResourceKind::sampler2d_array:
      return "sampler2DArray";
    case ResourceKind::sampler_cube_array_shadow:
      return "samplerCubeArrayShadow";
    case ResourceKind::sampler_cube_array:
      return "samplerCubeArray";
    case ResourceKind::sampler_cube:
      return "samplerCube";
    case ResourceKind::image2d:
      return "image2D";
    case ResourceKind::image2d_array:
      return "image2DArray";
  }
  return "?";
}

static std::string& registered_shader_path() {
  static std::string path;
  return path;
}

bool set_default_shader_path(const char* path) {
  registered_shader_path() = path ? path : "";
  return true;
}

std::vector<fs::path> default_shader_dirs() {
  std::vector<fs::path> dirs;
  const char* env = std::getenv("PENUMBRA_SHADER_PATH");
  if (!env && !registered_shader_path().empty()) env = registered_shader_path().c_str();
  if (env) {
    std::stringstream ss(env);
    std::string item;
    while (std::getline(ss, item, ':'))
      if (!item.empty()) dirs.emplace_back(item);
  }
  dirs.push_back(shader::default_shader_dir());
  return dirs;
}

fs::path resolve_shader_file(const fs::path& file, const std::vector<fs::path>& extra_dirs) {
  std::error_code ec;
  if (file.is_absolute()) {
    if (fs::is_regular_file(file, ec)) return file;
    throw Error("shader file " + file.string() + " does not exist");
  }
  std::vector<fs::path> dirs = extra_dirs;
  for (auto& d : default_shader_dirs()) dirs.push_back(d);
  std::string searched;
  for (const auto& d : dirs) {
    const fs::path candidate = d / file;
    if (fs::is_regular_file(candidate, ec)) return fs::weakly_canonical(candidate, ec);
    searched += (searched.empty() ? "" : ", ") + d.string();
  }
  if (fs::is_regular_file(file, ec)) return fs::absolute(file);
  throw Error("shader file \"" + file.string() + "\" not found (searched: " +
              (searched.empty() ? std::string("no directories") : searched) +
              ", and the working directory)");
}

namespace {

// ---- layout check against reflection -------------------------------------------------------

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
std::string numbered(const std::string& source, const std::vector<int>& only = {}) {
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
constexpr uint32_t kCapabilityStorageImageReadWithoutFormat = 55;
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
constexpr const char* kBoundsOps[] = {"texelFetch", "texelFetchOffset", "imageLoad", "imageStore"};

// std430 layout of PenumbraBounds: 11 scalars, 4 bytes each, in this order.
constexpr const char* kBoundsMembers[] = {"count", "first_case", "op", "type", "level", "levels",
                                          "x",     "y",          "z",  "w",    "h",     "d"};
constexpr uint32_t kBoundsBytes = sizeof(kBoundsMembers) / sizeof(kBoundsMembers[0]) * 4;

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

}  // namespace

struct FunctionEngine::Impl {
  explicit Impl(gpu::Context& c, uint32_t wg) : ctx(c), workgroup(wg) {}
  gpu::Context& ctx;
  std::unique_ptr<gpu::PipelineLayout> layout;
  std::unique_ptr<gpu::ComputePipeline> pipeline;
  std::unique_ptr<gpu::DescriptorPool> pool;
  std::unique_ptr<gpu::CommandRecorder> recorder;
  gpu::Buffer in, out;
  gpu::Buffer bounds;  // PenumbraBounds (check_bounds)
  // GLSL coverage (PENUMBRA_COVERAGE): the counters' meaning, their buffer and binding.
  std::unique_ptr<detail::CoverageMap> coverage;
  gpu::Buffer counters;
  uint32_t coverage_binding = 0;
  bool said_no_printf = false;
  uint32_t workgroup = 64;
  std::mutex mutex;
};

FunctionEngine::~FunctionEngine() = default;

std::shared_ptr<FunctionEngine> FunctionEngine::get(const fs::path& file_arg,
                                                    const std::string& function,
                                                    std::shared_ptr<const TypeDesc> return_type,
                                                    const std::vector<ParamSpec>& params,
                                                    const FunctionOptions& options) {
  const fs::path file = resolve_shader_file(file_arg, options.include_dirs);
  if (options.workgroup_size == 0 || options.workgroup_size > 1024) {
    throw Error("FunctionOptions.workgroup_size = " + std::to_string(options.workgroup_size) +
                ": must be in [1, 1024]");
  }

  // ---- generate the wrapper ----
  std::vector<std::pair<std::string, std::shared_ptr<const TypeDesc>>> in_members, out_members;
  std::ostringstream sig;
  auto type_name = [](const TypeDesc& t) { return t.glsl_base() + t.glsl_array_suffix(); };
  sig << (return_type ? type_name(*return_type) : std::string("void")) << " " << function << "(";
  std::ostringstream call, pre, post, resources;
  std::vector<ResourceKind> resource_kinds;
  std::vector<size_t> resource_params;
  if (return_type) out_members.push_back({"ret", return_type});
  for (size_t i = 0; i < params.size(); ++i) {
    const auto& p = params[i];
    const std::string name = "p" + std::to_string(i);
    if (i) {
      call << ", ";
      sig << ", ";
    }
    switch (p.dir) {
      case ParamSpec::Dir::in:
        in_members.push_back({name, p.type});
        call << "c." << name;
        sig << type_name(*p.type);
        break;
      case ParamSpec::Dir::out:
        out_members.push_back({name, p.type});
        pre << "  " << p.type->declare(name) << ";\n";
        post << "  penumbra_out.results[i]." << name << " = " << name << ";\n";
        call << name;
        sig << "out " << type_name(*p.type);
        break;
      case ParamSpec::Dir::inout:
        in_members.push_back({name, p.type});
        out_members.push_back({name, p.type});
        pre << "  " << p.type->declare(name) << " = c." << name << ";\n";
        post << "  penumbra_out.results[i]." << name << " = " << name << ";\n";
        call << name;
        sig << "inout " << type_name(*p.type);
        break;
      case ParamSpec::Dir::resource: {
        // Storage images are format-less (a parameter cannot carry a format) and have no memory
        // qualifiers (an argument may not have more than its parameter).
        const std::string res = "penumbra_res" + std::to_string(resource_kinds.size());
        resources << "layout(set = 0, binding = " << (2 + resource_kinds.size()) << ") uniform "
                  << glsl_name(p.resource) << " " << res << ";\n";
        call << res;
        sig << glsl_name(p.resource);
        resource_kinds.push_back(p.resource);
        resource_params.push_back(i);
        break;
      }
    }
  }
  sig << ")";
  if (out_members.empty()) {
    throw Error("ShaderFunction " + sig.str() +
                ": nothing to read back (void return and no Out<>/InOut<> parameter)");
  }

  auto layout_of = [](auto& members, std::vector<uint32_t>& offsets,
                      std::vector<std::shared_ptr<const TypeDesc>>& types) {
    std::vector<TypeDesc::Member> m;
    for (auto& [n, t] : members) m.push_back({n, t, 0});
    if (m.empty()) m.push_back({"penumbra_unused", detail::make_scalar(ScalarType::u32), 0});
    auto s = detail::make_struct("S", m);
    for (size_t k = 0; k < members.size(); ++k) {
      offsets.push_back(s->members[k].offset);
      types.push_back(members[k].second);
    }
    return s;
  };

  const bool any_storage = std::any_of(resource_kinds.begin(), resource_kinds.end(), is_storage);
  const uint32_t bounds_binding = uint32_t(2 + resource_kinds.size());
  std::vector<std::string> bounds_types;
  std::ostringstream src;
  src << "#version 460\n";
  src << "#extension GL_GOOGLE_include_directive : require\n";
  // Declaring a format-less storage image that is not writeonly; reading one needs the device's
  // shaderStorageImageReadWithoutFormat (checked after compiling, on the SPIR-V's capabilities).
  if (any_storage) src << "#extension GL_EXT_shader_image_load_formatted : enable\n";
  src << "// Penumbra shader-function wrapper for " << sig.str() << " from " << file.string()
      << "\n";
  if (options.check_bounds) src << bounds_prelude(bounds_binding, any_storage, bounds_types);
  if (!options.prelude.empty()) src << options.prelude << "\n";
  src << "#include \"" << file.string() << "\"\n\n";
  src << "layout(local_size_x = " << options.workgroup_size << ") in;\n";
  auto emit_struct = [&](const char* name, const auto& members) {
    src << "struct " << name << " {\n";
    if (members.empty()) src << "  uint penumbra_unused;\n";
    for (auto& [n, t] : members) src << "  " << t->declare(n) << ";\n";
    src << "};\n";
  };
  emit_struct("PenumbraIn", in_members);
  emit_struct("PenumbraOut", out_members);
  src << "layout(std430, set = 0, binding = 0) readonly buffer PenumbraInputs { PenumbraIn "
         "cases[]; } penumbra_in;\n";
  src << "layout(std430, set = 0, binding = 1) writeonly buffer PenumbraOutputs { PenumbraOut "
         "results[]; } penumbra_out;\n";
  src << resources.str();
  src << "layout(push_constant) uniform PenumbraPush { uint count; uint base; } penumbra_pc;\n\n";
  // One return at the end: coverage (PENUMBRA_COVERAGE) stores its counters there.
  src << "void main() {\n";
  src << "  if (gl_GlobalInvocationID.x < penumbra_pc.count) {\n";
  src << "  uint i = penumbra_pc.base + gl_GlobalInvocationID.x;\n";
  if (options.check_bounds) src << "  penumbra_case = i;\n";
  src << "  PenumbraIn c = penumbra_in.cases[i];\n";
  src << pre.str();
  src << "  " << (return_type ? "penumbra_out.results[i].ret = " : "") << function << "("
      << call.str() << ");\n";
  src << post.str();
  src << "  }\n";
  src << "}\n";

  std::string key = src.str();
  for (const auto& d : options.defines) key += "\n#define " + d.name + " " + d.value;
  for (const auto& s : options.spec_constants)
    key += "\n#spec " + std::to_string(s.id) + "=" + std::to_string(s.bits);
  for (const auto& d : options.include_dirs) key += "\n#dir " + d.string();
  key += std::string("\n#strip-version ") + (options.strip_include_version ? "1" : "0");
  key += std::string("\n#include-once ") + (options.include_once ? "1" : "0");
  // Two C++ descriptions of one GLSL struct give the same wrapper text but different host
  // layouts: each must be checked against reflection on its own.
  for (const auto& [n, t] : in_members) key += "\n#in " + n + " " + layout_signature(*t);
  for (const auto& [n, t] : out_members) key += "\n#out " + n + " " + layout_signature(*t);

  static std::mutex cache_mutex;
  static std::map<std::string, std::shared_ptr<FunctionEngine>> cache;
  static const bool registered = [] {
    // Engines hold pipelines and buffers of the shared device: release them before it goes.
    before_shared_context_destroyed([] {
      std::lock_guard l(cache_mutex);
      cache.clear();
    });
    return true;
  }();
  (void)registered;
  std::lock_guard lock(cache_mutex);
  if (auto it = cache.find(key); it != cache.end()) return it->second;

  std::shared_ptr<FunctionEngine> e(new FunctionEngine());
  e->file_ = file;
  e->signature_ = sig.str();
  e->source_ = src.str();
  e->resource_kinds_ = resource_kinds;
  e->resource_params_ = resource_params;
  e->check_bounds_ = options.check_bounds;
  e->bounds_types_ = bounds_types;
  const auto in_struct = layout_of(in_members, e->input_offsets_, e->input_types_);
  const auto out_struct = layout_of(out_members, e->output_offsets_, e->output_types_);
  e->input_stride_ = in_struct->stride();
  e->output_stride_ = out_struct->stride();

  if (const char* dump = std::getenv("PENUMBRA_DUMP_WRAPPERS")) {
    std::error_code ec;
    fs::create_directories(dump, ec);
    std::ofstream(fs::path(dump) / (function + ".comp")) << e->source_;
  }

  // ---- compile ----
  shader::CompileOptions co;
  co.include_dirs = options.include_dirs;
  for (auto& d : default_shader_dirs()) co.include_dirs.push_back(d);
  co.include_dirs.push_back(file.parent_path());
  co.defines = options.defines;
  co.disk_cache_dir = shader::default_disk_cache_dir();
  co.strip_include_version = options.strip_include_version;
  co.include_once = options.include_once;
  const bool coverage = coverage_directory().has_value();
  shader::Compiler compiler(co);
  const std::string wrapper_name = "penumbra-wrapper(" + function + ").comp";
  shader::CompiledShader compiled;
  try {
    compiled = compiler.compile_source(e->source_, wrapper_name, shader::Stage::compute);
  } catch (const shader::CompileError& err) {
    const auto& diags = err.diagnostics();
    const bool in_wrapper = diags.empty() || diags[0].file.string() == wrapper_name ||
                            diags[0].file.filename().string() == wrapper_name;
    if (!in_wrapper) throw;  // an error in the tested file (or its includes): file:line as is
    // What the files declare under that name and near it, against what the C++ asked for;
    // then glslang's words, and the wrapper's lines around each error (the whole wrapper is
    // mostly bounds-check boilerplate: PENUMBRA_DUMP_WRAPPERS=DIR writes it).
    const std::string why = detail::explain_no_match(detail::glsl_functions(file, co.include_dirs),
                                                     function, e->signature_);
    std::vector<int> lines;
    for (const auto& d : diags)
      if (d.file.filename().string() == wrapper_name) lines.push_back(d.line);
    throw shader::CompileError(
        "ShaderFunction " + e->signature_ + " from " + file.string() +
            ": the generated wrapper does not compile; does the C++ signature match the GLSL "
            "function?\n" +
            (why.empty() ? "  " + file.string() + " declares no function named '" + function +
                               "' or near it\n"
                         : why) +
            err.what() + "\n--- generated wrapper (" + wrapper_name +
            ", the lines around each error; PENUMBRA_DUMP_WRAPPERS=DIR writes it whole) ---\n" +
            numbered(e->source_, lines),
        diags);
  }

  // What the compiler changed in the sources (a dropped #version), once per wrapper.
  for (const std::string& note : compiled.notes)
    std::fprintf(stderr, "[penumbra] ShaderFunction %s: %s\n", e->signature_.c_str(), note.c_str());
  e->notes_ = compiled.notes;

  // ---- check host layouts against reflection ----
  const auto refl = shader::reflect(compiled.spirv);
  check_block(refl, "PenumbraInputs", "PenumbraIn", in_members, e->input_offsets_,
              e->input_stride_);
  check_block(refl, "PenumbraOutputs", "PenumbraOut", out_members, e->output_offsets_,
              e->output_stride_);
  if (options.check_bounds) {
    const auto* b = refl.find_binding("PenumbraBounds");
    if (b == nullptr || !b->block)
      throw Error("wrapper reflection: block PenumbraBounds not found");
    for (uint32_t k = 0; k < kBoundsBytes / 4; ++k) {
      const auto& members = b->block->members;
      auto it = std::find_if(members.begin(), members.end(), [&](const shader::BlockMember& m) {
        return m.name == kBoundsMembers[k];
      });
      if (it == members.end() || it->offset != 4 * k || it->size != 4) {
        throw Error(std::string("wrapper reflection: PenumbraBounds.") + kBoundsMembers[k] +
                    " is not the 4-byte scalar at offset " + std::to_string(4 * k));
      }
    }
  }

  // ---- what the SPIR-V needs of the device ----
  auto& ctx = shared_context();
  e->prints_ = imports_debug_printf(compiled.spirv);
  if (uses_capability(compiled.spirv, kCapabilityStorageImageReadWithoutFormat) &&
      !ctx.info().storage_read_without_format) {
    throw Error("ShaderFunction " + e->signature_ + " from " + file.string() +
                " reads a storage image parameter (imageLoad of a format-less image2D): that needs "
                "shaderStorageImageReadWithoutFormat, which device " +
                ctx.info().name +
                " does not have. A function that only writes its image runs everywhere; to test "
                "reads here, pass the image as a sampler2D and texelFetch it");
  }

  // ---- pipeline ----
  auto impl = std::make_unique<Impl>(ctx, options.workgroup_size);
  std::vector<gpu::BindingDesc> bindings{
      {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
      {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT}};
  for (size_t r = 0; r < resource_kinds.size(); ++r)
    bindings.push_back({static_cast<uint32_t>(2 + r), descriptor_type(resource_kinds[r]), 1,
                        VK_SHADER_STAGE_COMPUTE_BIT});
  if (options.check_bounds) {
    bindings.push_back(
        {bounds_binding, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT});
    impl->bounds = gpu::Buffer(ctx, kBoundsBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  }
  std::vector<uint32_t> spirv = std::move(compiled.spirv);
  if (coverage) {
    // Every check above ran on the wrapper as it is without coverage. The pipeline gets a
    // second compile with lines to map the counters to, and with every function of the tested
    // files, called or not, so that what no test runs counts as not run. An uncalled function
    // may need a capability the tested one does not (a format-less imageLoad elsewhere in the
    // file): then that wrapper is compiled without the uncalled functions, as before.
    shader::CompileOptions cov = co;
    cov.debug_info = true;
    cov.keep_uncalled = true;
    std::vector<uint32_t> lined =
        shader::Compiler(cov)
            .compile_source(e->source_, wrapper_name, shader::Stage::compute)
            .spirv;
    // Capabilities that need a device feature (the others, such as Sampled1D for the bounds
    // checks' kept overloads, every Vulkan device has).
    static const std::set<uint32_t> kFeatureGated = {
        9, 10, 11, 12, 22, 39,  // Float16, Float64, Int64, Int64Atomics, Int16, Int8
        25, 27, 32, 33,         // ImageGatherExtended, StorageImageMultisample, Clip/CullDistance
        34, 41, 42, 45, 49,     // ImageCubeArray, SparseResidency, MinLod, SampledCubeArray,
                                // StorageImageExtendedFormats
        56, 57,                 // StorageImageRead/WriteWithoutFormat
        61, 62, 63, 64, 65, 66, 67, 68};  // GroupNonUniform*
    const std::set<uint32_t> plain = capabilities(spirv);
    bool needs_more = false;
    for (uint32_t c : capabilities(lined))
      needs_more = needs_more || (!plain.count(c) && kFeatureGated.count(c));
    if (needs_more) {
      cov.keep_uncalled = false;
      lined = shader::Compiler(cov)
                  .compile_source(e->source_, wrapper_name, shader::Stage::compute)
                  .spirv;
    }
    spirv = std::move(lined);
    impl->coverage_binding = uint32_t(bounds_binding + (options.check_bounds ? 1 : 0));
    detail::InstrumentedSpirv inst = detail::instrument_for_coverage(
        spirv, 0, impl->coverage_binding, [&](std::string_view name) {
          // The tested files (canonical paths), never the generated wrapper.
          return name != wrapper_name && !name.empty() && name.front() == '/';
        });
    spirv = std::move(inst.spirv);
    impl->coverage = std::make_unique<detail::CoverageMap>(std::move(inst.map));
    bindings.push_back({impl->coverage_binding, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1,
                        VK_SHADER_STAGE_COMPUTE_BIT});
  }
  impl->layout = std::make_unique<gpu::PipelineLayout>(
      impl->ctx, std::vector<std::vector<gpu::BindingDesc>>{bindings}, 8u,
      VkShaderStageFlags{VK_SHADER_STAGE_COMPUTE_BIT});
  gpu::Specialization spec;
  for (const auto& s : options.spec_constants) spec.set<uint32_t>(s.id, s.bits);
  impl->pipeline = std::make_unique<gpu::ComputePipeline>(impl->ctx, spirv, *impl->layout, spec);
  impl->pool = std::make_unique<gpu::DescriptorPool>(impl->ctx, 4);
  impl->recorder = std::make_unique<gpu::CommandRecorder>(impl->ctx);
  e->impl_ = std::move(impl);
  cache.emplace(key, e);
  return e;
}

void FunctionEngine::run(std::span<const std::byte> inputs, size_t count,
                         std::span<std::byte> outputs,
                         const std::vector<ResourceBinding>& resources,
                         std::vector<std::vector<std::string>>* printed) {
  std::lock_guard lock(impl_->mutex);
  auto& ctx = impl_->ctx;
  if (inputs.size() < count * input_stride_ || outputs.size() < count * output_stride_) {
    throw Error("FunctionEngine::run: buffers smaller than count · stride");
  }
  bool any_storage = false;
  for (size_t r = 0; r < resource_kinds_.size(); ++r) {
    if (r >= resources.size() || !resources[r].texture) {
      throw Error("ShaderFunction " + signature_ + ": resource parameter " +
                  std::to_string(resource_params_[r]) + " (" + glsl_name(resource_kinds_[r]) +
                  ") has no " + (is_storage(resource_kinds_[r]) ? "image" : "texture") +
                  " bound; call bind(" + std::to_string(r) + ", " +
                  (is_storage(resource_kinds_[r]) ? "make_storage_image(...))" : "texture)"));
    }
    const auto& b = resources[r];
    if (!kind_matches(resource_kinds_[r], *b.texture, b.sampler)) {
      throw Error("ShaderFunction " + signature_ + ": resource parameter " +
                  std::to_string(resource_params_[r]) + " is a " + glsl_name(resource_kinds_[r]) +
                  " but the bound texture is a " + describe_texture(*b.texture, b.sampler));
    }
    if (b.texture->storage && b.sampler.handle != VK_NULL_HANDLE) {
      throw Error("ShaderFunction " + signature_ + ": resource parameter " +
                  std::to_string(resource_params_[r]) + " is a storage image: it takes no sampler");
    }
    any_storage = any_storage || b.texture->storage;
  }
  const VkDeviceSize in_bytes = std::max<VkDeviceSize>(16, count * input_stride_);
  const VkDeviceSize out_bytes = std::max<VkDeviceSize>(16, count * output_stride_);
  if (impl_->in.size() < in_bytes)
    impl_->in = gpu::Buffer(ctx, in_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  if (impl_->out.size() < out_bytes)
    impl_->out = gpu::Buffer(ctx, out_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  impl_->in.write(inputs.first(count * input_stride_));
  if (check_bounds_) {
    const std::vector<std::byte> zeros(kBoundsBytes, std::byte{0});
    impl_->bounds.write(zeros);
  }
  // Coverage: each invocation stores a row of its counters; a dispatch is at most as many
  // invocations as kCoverageRowBytes holds rows, and the rows are added up after each.
  uint64_t per_dispatch =
      uint64_t{ctx.info().limits.maxComputeWorkGroupCount[0]} * impl_->workgroup;
  const size_t row = impl_->coverage ? impl_->coverage->row_words() : 0;
  if (row > 0) {
    constexpr uint64_t kCoverageRowBytes = 64ull << 20;
    const uint64_t rows = std::max<uint64_t>(1, kCoverageRowBytes / (4 * row) / impl_->workgroup);
    per_dispatch = std::min(per_dispatch, rows * impl_->workgroup);
    const VkDeviceSize bytes = 4 * row * std::min<uint64_t>(per_dispatch, count + impl_->workgroup);
    if (impl_->counters.size() < bytes)
      impl_->counters = gpu::Buffer(ctx, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  } else if (impl_->coverage && impl_->counters.size() == 0) {
    impl_->counters = gpu::Buffer(ctx, 16, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  }

  impl_->pool->reset();
  VkDescriptorSet set = impl_->pool->allocate(impl_->layout->set_layout(0));
  gpu::DescriptorWriter w;
  w.buffer(0, impl_->in.handle()).buffer(1, impl_->out.handle());
  for (size_t r = 0; r < resource_kinds_.size(); ++r) {
    const auto& b = resources[r];
    const uint32_t binding = static_cast<uint32_t>(2 + r);
    if (b.texture->storage) {
      w.storage_image(binding, b.texture->image.view());
    } else {
      w.combined_image(
          binding, b.texture->image.view(),
          b.sampler.handle != VK_NULL_HANDLE ? b.sampler.handle : b.texture->sampler.handle());
    }
  }
  if (check_bounds_)
    w.buffer(static_cast<uint32_t>(2 + resource_kinds_.size()), impl_->bounds.handle());
  if (impl_->coverage) w.buffer(impl_->coverage_binding, impl_->counters.handle());
  w.update(ctx, set);

  VkCommandBuffer cmd = impl_->recorder->begin();
  if (any_storage) {
    // Storage images keep their content between runs: make an earlier run's (or an upload's)
    // writes visible to this one.
    VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    mb.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
    mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT,
                         VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1, &mb, 0, nullptr, 0, nullptr);
  }
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, impl_->pipeline->handle());
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, impl_->layout->handle(), 0, 1, &set,
                          0, nullptr);
  const bool capture = prints_ && ctx.debug_printf_enabled();
  if (capture) (void)ctx.validation_sink().take_printf();  // not this run's
  std::vector<uint64_t> coverage_counts(impl_->coverage ? impl_->coverage->counters() : 0);
  for (uint64_t base = 0; base < count; base += per_dispatch) {
    const uint32_t push[2] = {static_cast<uint32_t>(std::min<uint64_t>(per_dispatch, count - base)),
                              static_cast<uint32_t>(base)};
    vkCmdPushConstants(cmd, impl_->layout->handle(), VK_SHADER_STAGE_COMPUTE_BIT, 0, 8, push);
    const uint32_t groups = (push[0] + impl_->workgroup - 1) / impl_->workgroup;
    vkCmdDispatch(cmd, groups, 1, 1);
    if (row > 0) {
      impl_->recorder->submit_and_wait();
      const auto rows =
          impl_->counters.read_vector<uint32_t>(size_t(groups) * impl_->workgroup * row);
      const auto& live = impl_->coverage->live;
      for (size_t i = 0; i < rows.size(); ++i)
        if (i % row < live.size()) coverage_counts[live[i % row]] += rows[i];
      if (base + per_dispatch < count) {
        cmd = impl_->recorder->begin();
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, impl_->pipeline->handle());
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, impl_->layout->handle(), 0, 1,
                                &set, 0, nullptr);
      }
    }
  }
  if (row == 0) impl_->recorder->submit_and_wait();
  impl_->out.read(outputs.first(count * output_stride_));
  if (printed != nullptr) {
    printed->clear();
    if (prints_) printed->resize(count);
  }
  if (prints_ && !capture && !impl_->said_no_printf) {
    impl_->said_no_printf = true;
    std::fprintf(stderr,
                 "[penumbra] ShaderFunction %s prints (debugPrintfEXT), but the device was made "
                 "without debug printf: run with PENUMBRA_DEBUG_PRINTF=1 and the validation layer "
                 "on to see each case's lines\n",
                 signature_.c_str());
  }
  if (capture) {
    for (const std::string& m : ctx.validation_sink().take_printf()) {
      uint64_t dispatch = 0, invocation = 0;
      std::string text;
      if (parse_printf(m, dispatch, invocation, text) &&
          dispatch * per_dispatch + invocation < count) {
        if (printed != nullptr) (*printed)[dispatch * per_dispatch + invocation].push_back(text);
      } else {
        std::fprintf(stderr, "[penumbra] ShaderFunction %s printed (case unknown): %s\n",
                     signature_.c_str(), printf_text(m).c_str());
      }
    }
  }
  if (impl_->coverage) detail::record_coverage(*impl_->coverage, coverage_counts);
  if (check_bounds_) {
    const auto v = impl_->bounds.read_vector<int32_t>(kBoundsBytes / 4);
    if (v[0] != 0) throw OutOfBoundsError(describe_out_of_bounds(v));
  }
}

std::string FunctionEngine::describe_out_of_bounds(const std::vector<int32_t>& v) const {
  // v: the PenumbraBounds scalars in kBoundsMembers order.
  const uint32_t count = uint32_t(v[0]), first = uint32_t(v[1]), op = uint32_t(v[2]);
  const uint32_t type = uint32_t(v[3]);
  const std::string type_name = type < bounds_types_.size() ? bounds_types_[type] : "?";
  const bool ms = type_name.find("MS") != std::string::npos;
  const bool arrayed = type_name.find("Array") != std::string::npos;
  const int dims =
      type_name.find("1D") != std::string::npos || type_name.find("Buffer") != std::string::npos ? 1
      : type_name.find("3D") != std::string::npos                                                ? 3
                                                  : 2;
  const int comps = dims + (arrayed ? 1 : 0);
  auto vec = [&](int a, int b, int c) {
    const int xs[3] = {a, b, c};
    std::string s = comps == 1 ? "" : "ivec" + std::to_string(comps) + "(";
    for (int k = 0; k < comps; ++k) s += (k ? ", " : "") + std::to_string(xs[k]);
    return s + (comps == 1 ? "" : ")");
  };
  std::ostringstream m;
  m << "ShaderFunction " << signature_ << ": " << count << " access(es) outside an image"
    << " (out-of-bounds texel fetches and image accesses are undefined; FunctionOptions::"
       "check_bounds); the first recorded: case "
    << first << ": " << (op < 4 ? kBoundsOps[op] : "?") << " of a " << type_name << " at "
    << vec(v[6], v[7], v[8]);
  if (op == 1) m << " (coordinate plus offset)";
  std::string size = std::to_string(v[9]);
  if (comps >= 2) size += "x" + std::to_string(v[10]);
  if (comps >= 3) size += "x" + std::to_string(v[11]);
  if (ms) {
    m << ", sample " << v[4] << " of " << v[5];
  } else if (op < 2 && type_name.find("Buffer") == std::string::npos) {
    m << ", level " << v[4] << " of " << v[5];
  }
  m << "; the "
    << (op < 2 && !ms && type_name.find("Buffer") == std::string::npos ? "level's size is "
                                                                       : "size is ")
    << (v[9] == 0 && v[10] == 0 ? std::string("(no such level)") : size)
    << (arrayed ? " (the last is layers)" : "");
  return m.str();
}

namespace {
VkFormat float_format(uint32_t channels, bool half, const char* what) {
  switch (channels) {
    case 1:
      return half ? VK_FORMAT_R16_SFLOAT : VK_FORMAT_R32_SFLOAT;
    case 2:
      return half ? VK_FORMAT_R16G16_SFLOAT : VK_FORMAT_R32G32_SFLOAT;
    case 4:
      return half ? VK_FORMAT_R16G16B16A16_SFLOAT : VK_FORMAT_R32G32B32A32_SFLOAT;
    default:
      throw Error(std::string(what) + ".channels = " + std::to_string(channels) +
                  ": must be 1, 2 or 4");
  }
}
}  // namespace

// ---- textures --------------------------------------------------------------------------------

std::shared_ptr<Texture> make_depth_texture(const DepthTextureDesc& desc,
                                            std::span<const float> depth) {
  auto& ctx = shared_context();
  gpu::ImageDesc d;
  const bool array = desc.array || desc.layers > 1;
  d.kind = desc.cube ? (array ? gpu::ImageKind::cube_array : gpu::ImageKind::cube)
           : array   ? gpu::ImageKind::image_2d_array
                     : gpu::ImageKind::image_2d;
  if (desc.format != VK_FORMAT_D32_SFLOAT && desc.format != VK_FORMAT_D16_UNORM &&
      desc.format != VK_FORMAT_X8_D24_UNORM_PACK32) {
    throw Error("DepthTextureDesc.format = " + std::to_string(int(desc.format)) +
                ": must be D32_SFLOAT, D16_UNORM or X8_D24_UNORM_PACK32");
  }
  d.format = desc.format;
  d.width = desc.width;
  d.height = desc.height;
  d.layers = desc.cube ? 6 * std::max(desc.layers, 1u) : desc.layers;
  if (d.kind == gpu::ImageKind::cube_array && !ctx.info().image_cube_array)
    throw Error("DepthTextureDesc: device " + ctx.info().name +
                " has no cube-map arrays (imageCubeArray)");
  d.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  if (!desc.sampler.compare && desc.sampler.filter == VK_FILTER_LINEAR &&
      !ctx.info().linear_filter_d32) {
    throw Error("DepthTextureDesc.sampler: device " + ctx.info().name +
                " cannot linearly filter D32_SFLOAT without depth compare; use a nearest sampler "
                "or a float texture");
  }
  if (desc.format != VK_FORMAT_D32_SFLOAT) {
    VkFormatProperties fp{};
    vkGetPhysicalDeviceFormatProperties(ctx.physical_device(), d.format, &fp);
    if ((fp.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT) == 0) {
      throw Error("DepthTextureDesc.format: device " + ctx.info().name + " cannot sample " +
                  (desc.format == VK_FORMAT_D16_UNORM ? "D16_UNORM" : "X8_D24_UNORM_PACK32") +
                  " images");
    }
  }
  auto t =
      std::make_shared<Texture>(Texture{gpu::Image(ctx, d), gpu::Sampler(ctx, desc.sampler), true});
  auto unorm = [](float v, double steps) {
    const double c = std::isnan(v) ? 0.0 : std::clamp(double(v), 0.0, 1.0);
    return std::nearbyint(c * steps);
  };
  if (desc.format == VK_FORMAT_D16_UNORM) {
    std::vector<uint16_t> bits(depth.size());
    for (size_t i = 0; i < depth.size(); ++i) bits[i] = uint16_t(unorm(depth[i], 65535.0));
    t->image.upload(std::as_bytes(std::span<const uint16_t>(bits)));
  } else if (desc.format == VK_FORMAT_X8_D24_UNORM_PACK32) {
    std::vector<uint32_t> bits(depth.size());
    for (size_t i = 0; i < depth.size(); ++i) bits[i] = uint32_t(unorm(depth[i], 16777215.0));
    t->image.upload(std::as_bytes(std::span<const uint32_t>(bits)));
  } else {
    t->image.upload_floats(depth);
  }
  return t;
}

std::shared_ptr<Texture> make_float_texture(const FloatTextureDesc& desc,
                                            std::span<const float> texels) {
  auto& ctx = shared_context();
  gpu::ImageDesc d;
  const bool array = desc.array || desc.layers > 1;
  d.kind = desc.cube ? (array ? gpu::ImageKind::cube_array : gpu::ImageKind::cube)
           : array   ? gpu::ImageKind::image_2d_array
                     : gpu::ImageKind::image_2d;
  if (d.kind == gpu::ImageKind::cube_array && !ctx.info().image_cube_array)
    throw Error("FloatTextureDesc: device " + ctx.info().name +
                " has no cube-map arrays (imageCubeArray)");
  d.format = float_format(desc.channels, desc.half, "FloatTextureDesc");
  d.width = desc.width;
  d.height = desc.height;
  d.layers = desc.cube ? 6 * std::max(desc.layers, 1u) : desc.layers;
  if (desc.sampler.filter == VK_FILTER_LINEAR) {
    VkFormatProperties fp{};
    vkGetPhysicalDeviceFormatProperties(ctx.physical_device(), d.format, &fp);
    if ((fp.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT) == 0) {
      throw Error("FloatTextureDesc.sampler: device " + ctx.info().name +
                  " cannot linearly filter a " + std::to_string(desc.channels) + "-channel " +
                  (desc.half ? "16" : "32") + "-bit float texture");
    }
  }
  auto t = std::make_shared<Texture>(
      Texture{gpu::Image(ctx, d), gpu::Sampler(ctx, desc.sampler), false});
  if (desc.half) {
    std::vector<uint16_t> halves(texels.size());
    for (size_t i = 0; i < texels.size(); ++i) halves[i] = glm::packHalf1x16(texels[i]);
    t->image.upload(std::as_bytes(std::span<const uint16_t>(halves)));
  } else {
    t->image.upload(std::as_bytes(texels));
  }
  return t;
}

std::shared_ptr<Texture> make_storage_image(const StorageImageDesc& desc,
                                            std::span<const float> texels) {
  auto& ctx = shared_context();
  gpu::ImageDesc d;
  d.kind =
      (desc.array || desc.layers > 1) ? gpu::ImageKind::image_2d_array : gpu::ImageKind::image_2d;
  d.format = float_format(desc.channels, desc.half, "StorageImageDesc");
  if (desc.width == 0 || desc.height == 0 || desc.layers == 0) {
    throw Error("StorageImageDesc: width, height and layers must be > 0 (got " +
                std::to_string(desc.width) + "x" + std::to_string(desc.height) + "x" +
                std::to_string(desc.layers) + ")");
  }
  d.width = desc.width;
  d.height = desc.height;
  d.layers = desc.layers;
  d.usage = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
            VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  VkFormatProperties fp{};
  vkGetPhysicalDeviceFormatProperties(ctx.physical_device(), d.format, &fp);
  if ((fp.optimalTilingFeatures & VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT) == 0 ||
      (desc.channels == 2 && !ctx.info().storage_image_extended_formats)) {
    throw Error("StorageImageDesc: device " + ctx.info().name + " has no " +
                std::to_string(desc.channels) + "-channel " + (desc.half ? "16" : "32") +
                "-bit float storage images" +
                (desc.channels == 2 ? " (shaderStorageImageExtendedFormats)" : ""));
  }
  const size_t n = size_t(desc.width) * desc.height * desc.layers * desc.channels;
  if (!texels.empty() && texels.size() != n) {
    throw Error("make_storage_image: " + std::to_string(texels.size()) + " floats given for " +
                std::to_string(desc.width) + "x" + std::to_string(desc.height) + "x" +
                std::to_string(desc.layers) + " texels of " + std::to_string(desc.channels) +
                " channel(s) (" + std::to_string(n) + " expected)");
  }
  auto t = std::make_shared<Texture>();
  t->image = gpu::Image(ctx, d);
  t->storage = true;
  std::vector<float> values(texels.begin(), texels.end());
  if (values.empty()) values.assign(n, 0.0f);
  if (desc.half) {
    std::vector<uint16_t> halves(n);
    for (size_t i = 0; i < n; ++i) halves[i] = glm::packHalf1x16(values[i]);
    t->image.upload(std::as_bytes(std::span<const uint16_t>(halves)), VK_IMAGE_LAYOUT_GENERAL);
  } else {
    t->image.upload(std::as_bytes(std::span<const float>(values)), VK_IMAGE_LAYOUT_GENERAL);
  }
  return t;
}

std::vector<float> read_storage_image(Texture& image) {
  if (!image.storage) throw Error("read_storage_image: not a storage image (make_storage_image)");
  const auto bytes = image.image.download(0);
  const VkFormat f = image.image.desc().format;
  const bool half = f == VK_FORMAT_R16_SFLOAT || f == VK_FORMAT_R16G16_SFLOAT ||
                    f == VK_FORMAT_R16G16B16A16_SFLOAT;
  std::vector<float> out(bytes.size() / (half ? 2 : 4));
  if (half) {
    for (size_t i = 0; i < out.size(); ++i) {
      uint16_t h = 0;
      std::memcpy(&h, bytes.data() + 2 * i, 2);
      out[i] = glm::unpackHalf1x16(h);
    }
  } else {
    std::memcpy(out.data(), bytes.data(), out.size() * 4);
  }
  return out;
}

}  // namespace penumbra::testing
