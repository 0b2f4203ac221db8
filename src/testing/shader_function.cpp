#include <algorithm>
#include <cmath>
#include <glm/gtc/packing.hpp>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/shader/reflection.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <sstream>

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
  }
  return "?";
}

std::vector<fs::path> default_shader_dirs() {
  std::vector<fs::path> dirs;
  if (const char* env = std::getenv("PENUMBRA_SHADER_PATH")) {
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

std::string numbered(const std::string& source) {
  std::istringstream in(source);
  std::ostringstream out;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    out << (n < 10 ? "   " : n < 100 ? "  " : " ") << n << "  " << line << "\n";
  }
  return out.str();
}

VkDescriptorType descriptor_type(ResourceKind) {
  return VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
}

bool kind_matches(ResourceKind kind, const Texture& t) {
  const auto vk = t.image.desc().kind;
  const bool compare = t.sampler.desc().compare;
  switch (kind) {
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

std::string describe_texture(const Texture& t) {
  const auto& d = t.image.desc();
  std::string kind = d.kind == gpu::ImageKind::image_2d         ? "2D"
                     : d.kind == gpu::ImageKind::image_2d_array ? "2D array"
                     : d.kind == gpu::ImageKind::cube           ? "cube"
                                                                : "cube array";
  return kind + (t.depth ? " depth" : " float") + " texture with a " +
         (t.sampler.desc().compare ? "compare" : "non-compare") + " sampler";
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

  std::ostringstream src;
  src << "#version 460\n";
  src << "#extension GL_GOOGLE_include_directive : require\n";
  src << "// Penumbra shader-function wrapper for " << sig.str() << " from " << file.string()
      << "\n";
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
  src << "void main() {\n";
  src << "  if (gl_GlobalInvocationID.x >= penumbra_pc.count) return;\n";
  src << "  uint i = penumbra_pc.base + gl_GlobalInvocationID.x;\n";
  src << "  PenumbraIn c = penumbra_in.cases[i];\n";
  src << pre.str();
  src << "  " << (return_type ? "penumbra_out.results[i].ret = " : "") << function << "("
      << call.str() << ");\n";
  src << post.str();
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
    throw shader::CompileError(
        "ShaderFunction " + e->signature_ + " from " + file.string() +
            ": the generated wrapper does not compile; does the C++ signature match the GLSL "
            "function?\n" +
            err.what() + "\n--- generated wrapper ---\n" + numbered(e->source_),
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

  // ---- pipeline ----
  auto impl = std::make_unique<Impl>(shared_context(), options.workgroup_size);
  std::vector<gpu::BindingDesc> bindings{
      {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
      {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT}};
  for (size_t r = 0; r < resource_kinds.size(); ++r)
    bindings.push_back({static_cast<uint32_t>(2 + r), descriptor_type(resource_kinds[r]), 1,
                        VK_SHADER_STAGE_COMPUTE_BIT});
  impl->layout = std::make_unique<gpu::PipelineLayout>(
      impl->ctx, std::vector<std::vector<gpu::BindingDesc>>{bindings}, 8u,
      VkShaderStageFlags{VK_SHADER_STAGE_COMPUTE_BIT});
  gpu::Specialization spec;
  for (const auto& s : options.spec_constants) spec.set<uint32_t>(s.id, s.bits);
  impl->pipeline =
      std::make_unique<gpu::ComputePipeline>(impl->ctx, compiled.spirv, *impl->layout, spec);
  impl->pool = std::make_unique<gpu::DescriptorPool>(impl->ctx, 4);
  impl->recorder = std::make_unique<gpu::CommandRecorder>(impl->ctx);
  e->impl_ = std::move(impl);
  cache.emplace(key, e);
  return e;
}

void FunctionEngine::run(std::span<const std::byte> inputs, size_t count,
                         std::span<std::byte> outputs,
                         const std::vector<std::shared_ptr<Texture>>& resources) {
  std::lock_guard lock(impl_->mutex);
  auto& ctx = impl_->ctx;
  if (inputs.size() < count * input_stride_ || outputs.size() < count * output_stride_) {
    throw Error("FunctionEngine::run: buffers smaller than count · stride");
  }
  for (size_t r = 0; r < resource_kinds_.size(); ++r) {
    if (r >= resources.size() || !resources[r]) {
      throw Error("ShaderFunction " + signature_ + ": resource parameter " +
                  std::to_string(resource_params_[r]) + " (" + glsl_name(resource_kinds_[r]) +
                  ") has no texture bound; call bind(" + std::to_string(r) + ", texture)");
    }
    if (!kind_matches(resource_kinds_[r], *resources[r])) {
      throw Error("ShaderFunction " + signature_ + ": resource parameter " +
                  std::to_string(resource_params_[r]) + " is a " + glsl_name(resource_kinds_[r]) +
                  " but the bound texture is a " + describe_texture(*resources[r]));
    }
  }
  const VkDeviceSize in_bytes = std::max<VkDeviceSize>(16, count * input_stride_);
  const VkDeviceSize out_bytes = std::max<VkDeviceSize>(16, count * output_stride_);
  if (impl_->in.size() < in_bytes)
    impl_->in = gpu::Buffer(ctx, in_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  if (impl_->out.size() < out_bytes)
    impl_->out = gpu::Buffer(ctx, out_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  impl_->in.write(inputs.first(count * input_stride_));

  impl_->pool->reset();
  VkDescriptorSet set = impl_->pool->allocate(impl_->layout->set_layout(0));
  gpu::DescriptorWriter w;
  w.buffer(0, impl_->in.handle()).buffer(1, impl_->out.handle());
  for (size_t r = 0; r < resource_kinds_.size(); ++r)
    w.combined_image(static_cast<uint32_t>(2 + r), resources[r]->image.view(),
                     resources[r]->sampler.handle());
  w.update(ctx, set);

  const uint64_t per_dispatch =
      uint64_t{ctx.info().limits.maxComputeWorkGroupCount[0]} * impl_->workgroup;
  VkCommandBuffer cmd = impl_->recorder->begin();
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, impl_->pipeline->handle());
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, impl_->layout->handle(), 0, 1, &set,
                          0, nullptr);
  for (uint64_t base = 0; base < count; base += per_dispatch) {
    const uint32_t push[2] = {static_cast<uint32_t>(std::min<uint64_t>(per_dispatch, count - base)),
                              static_cast<uint32_t>(base)};
    vkCmdPushConstants(cmd, impl_->layout->handle(), VK_SHADER_STAGE_COMPUTE_BIT, 0, 8, push);
    vkCmdDispatch(cmd, (push[0] + impl_->workgroup - 1) / impl_->workgroup, 1, 1);
  }
  impl_->recorder->submit_and_wait();
  impl_->out.read(outputs.first(count * output_stride_));
}

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
  switch (desc.channels) {
    case 1:
      d.format = desc.half ? VK_FORMAT_R16_SFLOAT : VK_FORMAT_R32_SFLOAT;
      break;
    case 2:
      d.format = desc.half ? VK_FORMAT_R16G16_SFLOAT : VK_FORMAT_R32G32_SFLOAT;
      break;
    case 4:
      d.format = desc.half ? VK_FORMAT_R16G16B16A16_SFLOAT : VK_FORMAT_R32G32B32A32_SFLOAT;
      break;
    default:
      throw Error("FloatTextureDesc.channels = " + std::to_string(desc.channels) +
                  ": must be 1, 2 or 4");
  }
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

}  // namespace penumbra::testing
