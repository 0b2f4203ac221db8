// penumbra-startup-bench: per-stage fixed costs of the GPU and shader layers, as medians over
// repeated runs. Stages: instance+device creation, first glslang compile in the process, later
// compiles, pipeline creation, first dispatch of a never-seen shader (cold: Mesa compiles it) and
// of a shader seen before (warm: Mesa's disk cache answers), and a steady-state dispatch.
//
// Run it twice: once as is (warm cache numbers) and once with MESA_SHADER_CACHE_DISABLE=true
// (the "warm" column then shows what a cold cache costs every time).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <penumbra/core/error.hpp>
#include <penumbra/core/stats.hpp>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/gpu/resources.hpp>
#include <penumbra/shader/compiler.hpp>
#include <random>
#include <string>
#include <vector>

#include "cli.hpp"

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}
using penumbra::stats::median;

// A shader whose text (and so SPIR-V and Mesa cache key) is unique per `salt`.
std::string shader_source(uint64_t salt) {
  return "#version 460\nlayout(local_size_x = 64) in;\n"
         "layout(std430, binding = 0) buffer B { float v[]; } b;\n"
         "void main() {\n  uint i = gl_GlobalInvocationID.x;\n"
         "  float x = b.v[i];\n  for (int k = 0; k < 8; ++k) x = x * 0.5 + sin(x);\n"
         "  b.v[i] = uintBitsToFloat(floatBitsToUint(x) ^ " +
         std::to_string(static_cast<uint32_t>(salt)) + "u);\n}\n";
}

double dispatch_ms(penumbra::gpu::Context& ctx, const penumbra::gpu::ComputePipeline& p,
                   const penumbra::gpu::PipelineLayout& layout, VkDescriptorSet set) {
  const auto t = Clock::now();
  penumbra::gpu::submit_one_shot(ctx, [&](VkCommandBuffer cmd) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.handle());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout.handle(), 0, 1, &set, 0,
                            nullptr);
    vkCmdDispatch(cmd, 4, 1, 1);
  });
  return ms_since(t);
}

int run(int reps) {
  std::vector<double> t_instance;
  for (int i = 0; i < reps; ++i) {
    const auto t = Clock::now();
    penumbra::gpu::Context c;
    t_instance.push_back(ms_since(t));
  }
  penumbra::gpu::Context ctx;
  std::printf("device: %s (%s), Mesa cache: %s\n", ctx.info().name.c_str(),
              ctx.info().driver_name.c_str(),
              std::getenv("MESA_SHADER_CACHE_DISABLE") ? "disabled" : "enabled");

  penumbra::shader::Compiler compiler;
  // A random base so "cold" really is cold even when the disk cache survives from earlier runs.
  const uint64_t base = (uint64_t{std::random_device{}()} << 8) & 0xffffff00u;
  auto t = Clock::now();
  compiler.compile_source(shader_source(base), "bench.comp", penumbra::shader::Stage::compute);
  const double t_first_compile = ms_since(t);

  std::vector<double> t_compile, t_pipeline, t_cold, t_warm, t_steady;
  penumbra::gpu::PipelineLayout layout(ctx, {{{0}}});
  penumbra::gpu::Buffer buf(ctx, 256 * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  penumbra::gpu::DescriptorPool pool(ctx);
  VkDescriptorSet set = pool.allocate(layout.set_layout(0));
  penumbra::gpu::DescriptorWriter().buffer(0, buf.handle()).update(ctx, set);
  for (int i = 0; i < reps; ++i) {
    t = Clock::now();
    const auto shader = compiler.compile_source(shader_source(base + 1 + uint64_t(i)), "bench.comp",
                                                penumbra::shader::Stage::compute);
    t_compile.push_back(ms_since(t));
    {
      t = Clock::now();
      penumbra::gpu::ComputePipeline p(ctx, shader.spirv, layout);
      t_pipeline.push_back(ms_since(t));
      t_cold.push_back(dispatch_ms(ctx, p, layout, set));
      t_steady.push_back(dispatch_ms(ctx, p, layout, set));
    }
    // Same SPIR-V, new pipeline object: Mesa's disk cache (if enabled) has the machine code.
    penumbra::gpu::ComputePipeline again(ctx, shader.spirv, layout);
    t_warm.push_back(dispatch_ms(ctx, again, layout, set));
  }
  std::printf("stage                                   median ms  (of %d)\n", reps);
  std::printf("instance + device creation              %9.2f\n", median(t_instance));
  std::printf("first compile in process (glslang init) %9.2f\n", t_first_compile);
  std::printf("later compiles                          %9.2f\n", median(t_compile));
  std::printf("compute pipeline creation               %9.2f\n", median(t_pipeline));
  std::printf("first dispatch, new shader (cold)       %9.2f\n", median(t_cold));
  std::printf("first dispatch, seen shader (warm)      %9.2f\n", median(t_warm));
  std::printf("steady-state dispatch (submit + wait)   %9.2f\n", median(t_steady));
  std::printf("cold / warm first dispatch ratio        %9.1fx\n", median(t_cold) / median(t_warm));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int reps = 9;
  try {
    penumbra::cli::Command app(
        "penumbra-startup-bench",
        "Times Vulkan start-up, a first dispatch cold and warm, and a steady one.");
    app.option(
        "--reps",
        [&](const std::string& v) { reps = int(penumbra::cli::whole("--reps", v, 1, 1000)); },
        "repetitions (default 9)");
    app.parse(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-startup-bench: error: %s\n", e.what());
    return 2;
  }
  try {
    return run(reps);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-startup-bench: error: %s\n", e.what());
    return 1;
  }
}
