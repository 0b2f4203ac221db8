// penumbra-compile-bench: what a new version of a compute program costs, before its first frame.
//
// For each --program (a compute stage under --shader-dir, compiled with the --define values, or
// a .spv file), makes --versions new versions and times, per version:
//   - glslang: the compile of the source (each version with a define of its own, so the
//     compiler's cache never answers; "-" for a .spv file);
//   - pipeline: vkCreateComputePipelines with the --spec values, no pipeline cache, on SPIR-V
//     whose 32-bit float constants (other than 0, 1, -1 and 0.5) are moved by a few ulps, so
//     that no driver cache has seen it. This is where NVIDIA compiles; llvmpipe translates the
//     SPIR-V here and compiles the code with LLVM at the pipeline's first dispatch, which this
//     does not time.
// Prints the SPIR-V's size and the median, least and greatest of each, and the device.
// --write-spirv DIR writes each compiled program's SPIR-V there (DIR/<name>.spv), for
// spirv-dis or spirv-opt, and to time it again as a .spv file.
//
//   penumbra-compile-bench --program FILE [--program FILE ...] [--define NAME=VALUE ...]
//       [--spec ID=VALUE ...] [--versions N] [--shader-dir DIR] [--write-spirv DIR]
//
// PENUMBRA_DEVICE picks the device; PENUMBRA_VALIDATION=1 turns the validation layer on (any
// message is an error).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <penumbra/core/stats.hpp>
#include <penumbra/gpu/context.hpp>
#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/shader/compiler.hpp>
#include <penumbra/shader/reflection.hpp>
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
};

// Moves every 32-bit float constant but 0, 1, -1 and 0.5 by `ulps`: the same code, new SPIR-V.
// Returns how many it moved.
int move_float_constants(std::vector<uint32_t>& w, uint32_t ulps) {
  std::vector<uint32_t> float_types;
  int moved = 0;
  for (size_t i = 5; i < w.size();) {
    const uint32_t op = w[i] & 0xffffu, words = w[i] >> 16;
    if (words == 0 || i + words > w.size()) throw Error("malformed SPIR-V at word " + std::to_string(i));
    if (op == 22 && words == 3 && w[i + 2] == 32) float_types.push_back(w[i + 1]);  // OpTypeFloat
    if (op == 43 && words == 4 &&  // OpConstant
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
    case K::uniform_buffer: return VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    case K::storage_buffer: return VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    case K::combined_image_sampler: return VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    case K::sampled_image: return VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE;
    case K::storage_image: return VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    case K::sampler: return VK_DESCRIPTOR_TYPE_SAMPLER;
  }
  return VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
}

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
  std::printf("%-36s %9s  %-25s  %-25s\n", "program", "SPIR-V", "glslang ms: median (range)",
              "pipeline ms: median (range)");
  penumbra::shader::CompileOptions co;
  co.include_dirs = {o.shader_dir};
  co.defines = o.defines;
  penumbra::shader::Compiler compiler(co);
  for (const std::string& program : o.programs) {
    const bool spirv_file = fs::path(program).extension() == ".spv";
    const fs::path file = spirv_file ? fs::path(program) : o.shader_dir / program;
    std::vector<double> glslang, pipeline;
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
    for (uint32_t v = 0; v < o.versions; ++v) {
      if (!spirv_file) {
        const auto t = Clock::now();
        spirv = compiler.compile_file(file, {}, {{"PENUMBRA_COMPILE_BENCH_VERSION",
                                                   std::to_string(v)}}).spirv;
        glslang.push_back(ms_since(t));
      }
      const auto refl = penumbra::shader::reflect(spirv);
      std::vector<std::vector<penumbra::gpu::BindingDesc>> sets;
      for (const auto& b : refl.bindings) {
        if (sets.size() <= b.set) sets.resize(b.set + 1);
        sets[b.set].push_back(
            {b.binding, descriptor_type(b.kind), std::max(b.count, 1u), VK_SHADER_STAGE_COMPUTE_BIT});
      }
      penumbra::gpu::Specialization spec;
      for (const auto& [id, value] : o.specs) {
        if (std::none_of(refl.spec_constants.begin(), refl.spec_constants.end(),
                         [&](const auto& c) { return c.id == id; }))
          throw Error("--spec " + std::to_string(id) + "=" + std::to_string(value) + ": " +
                      program + " has no specialization constant " + std::to_string(id));
        spec.set(id, value);
      }
      penumbra::gpu::PipelineLayout layout(
          ctx, sets, refl.push_constants ? refl.push_constants->size : 0, VK_SHADER_STAGE_COMPUTE_BIT);
      std::vector<uint32_t> fresh = spirv;
      move_float_constants(fresh, v + 1);
      const auto t = Clock::now();
      penumbra::gpu::ComputePipeline made(ctx, fresh, layout, spec);
      pipeline.push_back(ms_since(t));
    }
    if (!o.write_spirv.empty() && !spirv_file) {
      const fs::path out = o.write_spirv / (fs::path(program).stem().string() + ".spv");
      penumbra::write_file_atomic(
          out, std::string_view(reinterpret_cast<const char*>(spirv.data()), spirv.size() * 4));
    }
    char size[32];
    std::snprintf(size, sizeof size, "%.1f KB", double(spirv.size()) * 4.0 / 1024.0);
    std::printf("%-36s %9s  %s  %s\n", program.c_str(), size, range(glslang).c_str(),
                range(pipeline).c_str());
    std::fflush(stdout);
  }
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  try {
    penumbra::cli::Command app(
        "penumbra-compile-bench",
        "Times what a new version of a compute program costs: glslang and pipeline creation.");
    app.option("--program", [&](const std::string& v) { o.programs.push_back(v); },
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
          o.specs.push_back(
              {penumbra::cli::whole("--spec", v.substr(0, eq), 0, 0xffff),
               penumbra::cli::whole("--spec", v.substr(eq + 1), 0, 0xffffffffu)});
        },
        "a specialization constant's value, by constant_id, for every program (each must declare "
               "it; repeatable)", "ID=VALUE");
    app.option(
        "--versions",
        [&](const std::string& v) { o.versions = penumbra::cli::whole("--versions", v, 1, 1000); },
        "new versions timed per program (default 10)");
    app.option(
        "--shader-dir", [&](const std::string& v) { o.shader_dir = v; },
        "the shader tree the programs and their includes are read from (default: this build's)");
    app.option(
        "--write-spirv", [&](const std::string& v) { o.write_spirv = v; },
        "write each compiled program's SPIR-V to DIR/<name>.spv", "DIR");
    app.parse(argc, argv);
    if (o.programs.empty()) throw Error("no --program given (try --help)");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-compile-bench: error: %s\n", e.what());
    return 2;
  }
  try {
    run(o);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-compile-bench: error: %s\n", e.what());
    return 1;
  }
}
