// penumbra-compile-bench: what a new version of a compute program costs, before its first frame.
//
// For each --program (a compute stage under --shader-dir, compiled with the --define values, or
// a .spv file), makes --versions new versions and times, per version:
//   - glslang: the compile of the source (each version with a define of its own, so the
//     compiler's cache never answers; "-" for a .spv file);
//   - pipeline: vkCreateComputePipelines with the --spec values, no pipeline cache, on SPIR-V
//     whose 32-bit float constants (other than 0, 1, -1 and 0.5) are moved by some ulps, from a
//     random start per run, so that no driver cache has seen it. This is where NVIDIA compiles;
//     llvmpipe translates the SPIR-V here and compiles the code with LLVM at the first dispatch;
//     The drivers' disk caches are off (MESA_SHADER_CACHE_DISABLE, __GL_SHADER_DISK_CACHE), so
//     a version whose moved constants are all in code the specialization removes is compiled
//     too;
//   - with --dispatch, the first dispatch of one workgroup with the new pipeline (submit and
//     wait), on stand-in resources (zeroed buffers and push constants, 4x4 images): where llvmpipe
//     compiles the code with LLVM. The data the program reads does not change what is compiled.
// Prints the SPIR-V's size and the median, least and greatest of each, and the device.
// --write-spirv DIR (made if missing) writes each compiled program's SPIR-V there (DIR/<name>.spv),
// for spirv-dis or spirv-opt, and to time it again as a .spv file.
//
//   penumbra-compile-bench --program FILE [--program FILE ...] [--define NAME=VALUE ...]
//       [--spec ID=VALUE ...] [--versions N] [--dispatch] [--shader-dir DIR] [--write-spirv DIR]
//
// PENUMBRA_DEVICE picks the device; PENUMBRA_VALIDATION=1 turns the validation layer on (any
// message is an error).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <penumbra/core/stats.hpp>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/context.hpp>
#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/gpu/resources.hpp>
#include <penumbra/shader/compiler.hpp>
#include <penumbra/shader/reflection.hpp>
#include <random>
#include <string>
#include <vector>

#include "cli.hpp"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using penumbra::Error;

double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

struct Options {
  std::vector<std::string> programs;
  std::vector<penumbra::shader::Define> defines;
  std::vector<std::pair<uint32_t, uint32_t>> specs;
  uint32_t versions = 10;
  fs::path shader_dir = penumbra::shader::default_shader_dir();
  fs::path write_spirv;
  bool dispatch = false;
};

// Moves every 32-bit float constant but 0, 1, -1 and 0.5 by `ulps` (under 60000: less than 1%
// of its value): the same code, new SPIR-V.
// Returns how many it moved.
int move_float_constants(std::vector<uint32_t>& w, uint32_t ulps) {
  std::vector<uint32_t> float_types;
  int moved = 0;
  for (size_t i = 5; i < w.size();) {
    const uint32_t op = w[i] & 0xffffu, words = w[i] >> 16;
    if (words == 0 || i + words > w.size())
      throw Error("malformed SPIR-V at word " + std::to_string(i));
    if (op == 22 && words == 3 && w[i + 2] == 32) float_types.push_back(w[i + 1]);  // OpTypeFloat
    if (op == 43 && words == 4 &&                                                   // OpConstant
        std::find(float_types.begin(), float_types.end(), w[i + 1]) != float_types.end()) {
      float v;
      std::memcpy(&v, &w[i + 3], 4);
      if (v != 0.0f && v != 1.0f && v != -1.0f && v != 0.5f) {
        w[i + 3] += ulps;
        ++moved;
      }
    }
    i += words;
  }
  return moved;
}

VkDescriptorType descriptor_type(penumbra::shader::DescriptorKind k) {
  using K = penumbra::shader::DescriptorKind;
  switch (k) {
    case K::uniform_buffer:
      return VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    case K::storage_buffer:
      return VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    case K::combined_image_sampler:
      return VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    case K::sampled_image:
      return VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE;
    case K::storage_image:
      return VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    case K::sampler:
      return VK_DESCRIPTOR_TYPE_SAMPLER;
  }
  return VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
}

// A storage image's format as SPIR-V names it (ImageFormat), for the stand-in image.
VkFormat storage_format(int spirv_format) {
  switch (spirv_format) {
    case 1:
      return VK_FORMAT_R32G32B32A32_SFLOAT;
    case 2:
      return VK_FORMAT_R16G16B16A16_SFLOAT;
    case 3:
      return VK_FORMAT_R32_SFLOAT;
    case 4:
      return VK_FORMAT_R8G8B8A8_UNORM;
    case 6:
      return VK_FORMAT_R32G32_SFLOAT;
    case 7:
      return VK_FORMAT_R16G16_SFLOAT;
    case 9:
      return VK_FORMAT_R16_SFLOAT;
    case 15:
      return VK_FORMAT_R8_UNORM;
    case 33:
      return VK_FORMAT_R32_UINT;
    default:
      return VK_FORMAT_UNDEFINED;
  }
}

// Zeroed stand-ins for every binding of a program, written into one descriptor set per set
// index: what a dispatch needs to be valid, whatever it reads.
struct StandIns {
  StandIns(penumbra::gpu::Context& ctx, const std::string& program,
           const penumbra::shader::Reflection& refl, const penumbra::gpu::PipelineLayout& layout)
      : pool(ctx, 16) {
    using K = penumbra::shader::DescriptorKind;
    for (uint32_t i = 0; i < layout.set_count(); ++i)
      sets.push_back(pool.allocate(layout.set_layout(i)));
    std::vector<penumbra::gpu::DescriptorWriter> writers(sets.size());
    for (const auto& b : refl.bindings) {
      const std::string name =
          program + ": binding " + std::to_string(b.binding) + " ('" + b.name + "')";
      auto& w = writers.at(b.set);
      const uint32_t count = std::max(b.count, 1u);
      if (b.kind == K::uniform_buffer || b.kind == K::storage_buffer) {
        const VkDeviceSize size = std::max<VkDeviceSize>(b.block ? b.block->size : 0, 256);
        auto& buf =
            buffers.emplace_back(ctx, size,
                                 b.kind == K::uniform_buffer ? VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT
                                                             : VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
        std::vector<std::byte> zeros(size);
        buf.write(zeros);
        w.buffer(b.binding, buf.handle(), descriptor_type(b.kind));
      } else if (b.kind == K::combined_image_sampler && (b.image_dim == 2 || b.image_dim == 6)) {
        penumbra::gpu::ImageDesc d;
        d.kind = b.image_dim == 6 ? (b.image_arrayed ? penumbra::gpu::ImageKind::cube_array
                                                     : penumbra::gpu::ImageKind::cube)
                                  : (b.image_arrayed ? penumbra::gpu::ImageKind::image_2d_array
                                                     : penumbra::gpu::ImageKind::image_2d);
        d.format = b.image_depth ? VK_FORMAT_D16_UNORM : VK_FORMAT_R8G8B8A8_UNORM;
        d.width = d.height = 4;
        d.layers = b.image_dim == 6 ? 6 : 1;
        auto& img = images.emplace_back(ctx, d);
        img.upload(std::vector<std::byte>(size_t{16} * d.layers *
                                          penumbra::gpu::format_texel_size(d.format)));
        penumbra::gpu::SamplerDesc sd;
        sd.compare = b.image_depth;
        auto& smp = samplers.emplace_back(ctx, sd);
        for (uint32_t e = 0; e < count; ++e)
          w.combined_image(b.binding, img.view(), smp.handle(),
                           VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, e);
      } else if (b.kind == K::storage_image && b.image_dim == 2 &&
                 storage_format(b.image_format) != VK_FORMAT_UNDEFINED) {
        penumbra::gpu::ImageDesc d;
        d.kind = b.image_arrayed ? penumbra::gpu::ImageKind::image_2d_array
                                 : penumbra::gpu::ImageKind::image_2d;
        d.format = storage_format(b.image_format);
        d.width = d.height = 4;
        d.usage = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
        auto& img = images.emplace_back(ctx, d);
        penumbra::gpu::submit_one_shot(
            ctx, [&](VkCommandBuffer cmd) { img.transition(cmd, VK_IMAGE_LAYOUT_GENERAL); });
        w.storage_image(b.binding, img.view());
      } else {
        throw Error(name + ": --dispatch has no stand-in for a " +
                    std::string(penumbra::shader::to_string(b.kind)) + " of this kind (Dim " +
                    std::to_string(b.image_dim) + (b.image_arrayed ? ", arrayed" : "") +
                    ", SPIR-V image format " + std::to_string(b.image_format) + ")");
      }
    }
    for (size_t i = 0; i < sets.size(); ++i) writers[i].update(ctx, sets[i]);
  }
  penumbra::gpu::DescriptorPool pool;
  std::vector<VkDescriptorSet> sets;
  std::deque<penumbra::gpu::Buffer> buffers;
  std::deque<penumbra::gpu::Image> images;
  std::deque<penumbra::gpu::Sampler> samplers;
};

std::string range(std::vector<double> v) {
  if (v.empty()) return "        -                ";
  std::sort(v.begin(), v.end());
  char s[64];
  std::snprintf(s, sizeof s, "%8.1f (%6.1f-%6.1f)", penumbra::stats::median(v), v.front(),
                v.back());
  return s;
}

void run(const Options& o) {
  penumbra::gpu::Context ctx;
  std::printf("device: %s (%s); %u new versions per program\n", ctx.info().name.c_str(),
              ctx.info().driver_name.c_str(), o.versions);
  std::printf("%-36s %9s  %-25s  %-25s%s\n", "program", "SPIR-V", "glslang ms: median (range)",
              "pipeline ms: median (range)",
              o.dispatch ? "  first dispatch ms: median (range)" : "");
  penumbra::shader::CompileOptions co;
  co.include_dirs = {o.shader_dir};
  co.defines = o.defines;
  penumbra::shader::Compiler compiler(co);
  for (const std::string& program : o.programs) {
    const bool spirv_file = fs::path(program).extension() == ".spv";
    const fs::path file = spirv_file ? fs::path(program) : o.shader_dir / program;
    std::vector<double> glslang, pipeline, dispatch;
    std::vector<uint32_t> spirv;
    if (spirv_file) {
      if (const std::string problem = penumbra::file_problem(file); !problem.empty())
        throw Error(file.string() + ": " + problem);
      std::ifstream in(file, std::ios::binary);
      const std::string bytes((std::istreambuf_iterator<char>(in)), {});
      if (!in && !in.eof()) throw Error(file.string() + ": cannot be read");
      if (bytes.size() < 20 || bytes.size() % 4 != 0)
        throw Error(file.string() + ": not SPIR-V (" + std::to_string(bytes.size()) + " bytes)");
      spirv.resize(bytes.size() / 4);
      std::memcpy(spirv.data(), bytes.data(), bytes.size());
    } else if (penumbra::shader::stage_from_path(file) != penumbra::shader::Stage::compute) {
      throw Error(program + ": penumbra-compile-bench times compute programs (.comp or .spv)");
    }
    std::unique_ptr<penumbra::gpu::PipelineLayout> layout;
    std::unique_ptr<StandIns> stand_ins;
    // A random start, so that no disk cache holds a version from an earlier run: Mesa's is keyed
    // by the code after specialization, which two programs that differ only in code the
    // constants remove share.
    const uint32_t salt = 1 + std::random_device{}() % 60000;
    for (uint32_t v = 0; v < o.versions; ++v) {
      if (!spirv_file) {
        const auto t = Clock::now();
        spirv =
            compiler.compile_file(file, {}, {{"PENUMBRA_COMPILE_BENCH_VERSION", std::to_string(v)}})
                .spirv;
        glslang.push_back(ms_since(t));
      }
      const auto refl = penumbra::shader::reflect(spirv);
      std::vector<std::vector<penumbra::gpu::BindingDesc>> sets;
      for (const auto& b : refl.bindings) {
        if (sets.size() <= b.set) sets.resize(b.set + 1);
        sets[b.set].push_back({b.binding, descriptor_type(b.kind), std::max(b.count, 1u),
                               VK_SHADER_STAGE_COMPUTE_BIT});
      }
      penumbra::gpu::Specialization spec;
      for (const auto& [id, value] : o.specs) {
        if (std::none_of(refl.spec_constants.begin(), refl.spec_constants.end(),
                         [&](const auto& c) { return c.id == id; }))
          throw Error("--spec " + std::to_string(id) + "=" + std::to_string(value) + ": " +
                      program + " has no specialization constant " + std::to_string(id));
        spec.set(id, value);
      }
      if (!layout) {  // every version has the first one's interface
        layout = std::make_unique<penumbra::gpu::PipelineLayout>(
            ctx, sets, refl.push_constants ? refl.push_constants->size : 0,
            VK_SHADER_STAGE_COMPUTE_BIT);
        if (o.dispatch) stand_ins = std::make_unique<StandIns>(ctx, program, refl, *layout);
      }
      std::vector<uint32_t> fresh = spirv;
      move_float_constants(fresh, salt + v);
      auto t = Clock::now();
      penumbra::gpu::ComputePipeline made(ctx, fresh, *layout, spec);
      pipeline.push_back(ms_since(t));
      if (stand_ins) {
        t = Clock::now();
        penumbra::gpu::submit_one_shot(ctx, [&](VkCommandBuffer cmd) {
          vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, made.handle());
          vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout->handle(), 0,
                                  uint32_t(stand_ins->sets.size()), stand_ins->sets.data(), 0,
                                  nullptr);
          if (refl.push_constants) {  // zeroed, like the other stand-ins
            const std::vector<std::byte> zeros(refl.push_constants->size);
            vkCmdPushConstants(cmd, layout->handle(), VK_SHADER_STAGE_COMPUTE_BIT, 0,
                               uint32_t(zeros.size()), zeros.data());
          }
          vkCmdDispatch(cmd, 1, 1, 1);
        });
        dispatch.push_back(ms_since(t));
      }
    }
    if (!o.write_spirv.empty() && !spirv_file) {
      const fs::path out = o.write_spirv / (fs::path(program).stem().string() + ".spv");
      penumbra::write_file_atomic(
          out, std::string_view(reinterpret_cast<const char*>(spirv.data()), spirv.size() * 4));
    }
    char size[32];
    std::snprintf(size, sizeof size, "%.1f KB", double(spirv.size()) * 4.0 / 1024.0);
    std::printf("%-36s %9s  %s  %s%s\n", program.c_str(), size, range(glslang).c_str(),
                range(pipeline).c_str(), o.dispatch ? ("  " + range(dispatch)).c_str() : "");
    std::fflush(stdout);
    // PENUMBRA_VALIDATION=1: any message fails the run.
    if (ctx.validation_enabled()) penumbra::gpu::throw_if_messages(ctx.validation_sink());
  }
  if (ctx.validation_enabled()) std::printf("validation: 0 messages\n");
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  try {
    penumbra::cli::Command app(
        "penumbra-compile-bench",
        "Times what a new version of a compute program costs: glslang and pipeline creation.");
    app.option(
        "--program", [&](const std::string& v) { o.programs.push_back(v); },
        "a compute stage under --shader-dir (render/tonemap.comp), or a .spv file "
        "(repeatable)",
        "FILE");
    app.option(
        "--define",
        [&](const std::string& v) {
          const auto eq = v.find('=');
          if (eq == 0) throw Error("--define " + v + ": expected NAME=VALUE or NAME");
          o.defines.push_back({v.substr(0, eq), eq == std::string::npos ? "" : v.substr(eq + 1)});
        },
        "a define for every program (repeatable)", "NAME=VALUE");
    app.option(
        "--spec",
        [&](const std::string& v) {
          const auto eq = v.find('=');
          if (eq == std::string::npos) throw Error("--spec " + v + ": expected ID=VALUE");
          o.specs.push_back({penumbra::cli::whole("--spec", v.substr(0, eq), 0, 0xffff),
                             penumbra::cli::whole("--spec", v.substr(eq + 1), 0, 0xffffffffu)});
        },
        "a specialization constant's value, by constant_id, for every program (each must declare "
        "it; repeatable)",
        "ID=VALUE");
    app.option(
        "--versions",
        [&](const std::string& v) { o.versions = penumbra::cli::whole("--versions", v, 1, 1000); },
        "new versions timed per program (default 10)");
    app.option(
        "--shader-dir", [&](const std::string& v) { o.shader_dir = v; },
        "the shader tree the programs and their includes are read from (default: this build's)");
    app.flag("--dispatch", o.dispatch,
             "also time each new version's first dispatch (llvmpipe compiles there)");
    app.option(
        "--write-spirv", [&](const std::string& v) { o.write_spirv = v; },
        "write each compiled program's SPIR-V to DIR/<name>.spv", "DIR");
    app.parse(argc, argv);
    if (o.programs.empty()) throw Error("no --program given (try --help)");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-compile-bench: error: %s\n", e.what());
    return 2;
  }
  // The drivers' disk caches stay out of it (unless the caller set them): a version whose moved
  // constants all lie in code the specialization removes is the same code after it, and Mesa's
  // cache answered such a version in 2 ms where its compile takes 70 (a filter half with PCF,
  // whose moved constants are the Poisson disk's).
  setenv("MESA_SHADER_CACHE_DISABLE", "true", 0);
  setenv("__GL_SHADER_DISK_CACHE", "0", 0);
  try {
    if (!o.write_spirv.empty()) {
      std::error_code ec;
      fs::create_directories(o.write_spirv, ec);
      if (ec)
        throw Error("--write-spirv " + o.write_spirv.string() +
                    ": cannot create it: " + ec.message());
    }
    run(o);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-compile-bench: error: %s\n", e.what());
    return 1;
  }
}
