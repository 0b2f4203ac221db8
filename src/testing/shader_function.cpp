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

namespace penumbra::testing {
namespace fs = std::filesystem;

using namespace detail;

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

}  // namespace penumbra::testing
