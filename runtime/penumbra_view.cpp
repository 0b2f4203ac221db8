// penumbra-view: the Penumbra runtime. Until the renderer lands it prints the device report and
// runs a compute smoke test (compile → pipeline → dispatch → read back → check), with timings.
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/gpu/resources.hpp>
#include <penumbra/shader/compiler.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

constexpr const char* kSmokeShader = R"(#version 460
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer In { vec4 p[]; } in_;
layout(std430, binding = 1) writeonly buffer Out { float d[]; } out_;
layout(push_constant) uniform Push { uint count; } pc;
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= pc.count) return;
  out_.d[i] = length(in_.p[i].xyz) * in_.p[i].w;
}
)";

int run(int argc, char** argv) {
  bool list = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--list-devices") list = true;
    else if (a == "--headless") {
    } else if (a == "--help" || a == "-h") {
      std::printf("usage: penumbra-view [--headless] [--list-devices]\n"
                  "  PENUMBRA_DEVICE=lavapipe|gpu|<index>|<name>  choose the Vulkan device\n"
                  "  PENUMBRA_VALIDATION=1                        Khronos validation layer\n");
      return 0;
    } else {
      std::fprintf(stderr, "penumbra-view: unknown argument '%s' (try --help)\n", a.c_str());
      return 2;
    }
  }
  if (list) {
    std::printf("%s", penumbra::gpu::Context::list_devices().c_str());
    return 0;
  }
  auto t0 = Clock::now();
  penumbra::gpu::Context ctx;
  const double t_instance = ms_since(t0);
  std::printf("%s", ctx.report().c_str());

  t0 = Clock::now();
  penumbra::shader::Compiler compiler;
  const auto shader = compiler.compile_source(kSmokeShader, "smoke.comp",
                                              penumbra::shader::Stage::compute);
  const double t_compile = ms_since(t0);

  t0 = Clock::now();
  penumbra::gpu::PipelineLayout layout(ctx, {{{0}, {1}}}, 4, VK_SHADER_STAGE_COMPUTE_BIT);
  penumbra::gpu::ComputePipeline pipeline(ctx, shader.spirv, layout);
  const double t_pipeline = ms_since(t0);

  const uint32_t n = 1 << 20;
  std::vector<float> p(size_t{n} * 4);
  for (uint32_t i = 0; i < n; ++i) {
    p[i * 4 + 0] = float(i % 1000) * 0.01f;
    p[i * 4 + 1] = float(i % 7);
    p[i * 4 + 2] = -2.0f;
    p[i * 4 + 3] = 0.5f;
  }
  penumbra::gpu::Buffer in(ctx, p.size() * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  penumbra::gpu::Buffer out(ctx, size_t{n} * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  in.write_span<float>(p);
  penumbra::gpu::DescriptorPool pool(ctx);
  VkDescriptorSet set = pool.allocate(layout.set_layout(0));
  penumbra::gpu::DescriptorWriter().buffer(0, in.handle()).buffer(1, out.handle()).update(ctx, set);
  penumbra::gpu::TimestampPool ts(ctx, 2);
  double t_first = 0, gpu_ns = 0;
  for (int rep = 0; rep < 2; ++rep) {
    t0 = Clock::now();
    penumbra::gpu::submit_one_shot(ctx, [&](VkCommandBuffer cmd) {
      ts.reset(cmd);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.handle());
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout.handle(), 0, 1, &set, 0,
                              nullptr);
      vkCmdPushConstants(cmd, layout.handle(), VK_SHADER_STAGE_COMPUTE_BIT, 0, 4, &n);
      ts.write(cmd, 0);
      vkCmdDispatch(cmd, (n + 255) / 256, 1, 1);
      ts.write(cmd, 1);
    });
    if (rep == 0) t_first = ms_since(t0);
    gpu_ns = ts.elapsed_ns(0, 1);
  }
  const auto d = out.read_vector<float>(n);
  uint32_t bad = 0;
  for (uint32_t i = 0; i < n; ++i) {
    const float want =
        std::sqrt(p[i * 4] * p[i * 4] + p[i * 4 + 1] * p[i * 4 + 1] + 4.0f) * 0.5f;
    if (!(std::abs(d[i] - want) <= 1e-5f * std::max(1.0f, want))) ++bad;
  }
  std::printf("smoke test:  %u cases, %u wrong -> %s\n", n, bad, bad == 0 ? "PASS" : "FAIL");
  std::printf("timings:     instance+device %.1f ms, compile %.1f ms, pipeline %.1f ms, "
              "first submit %.1f ms, dispatch %.3f ms (GPU timestamps)\n",
              t_instance, t_compile, t_pipeline, t_first, gpu_ns * 1e-6);
  const size_t validation = ctx.validation_sink().total_seen();
  if (ctx.validation_enabled())
    std::printf("validation:  %zu messages\n", validation);
  return (bad == 0 && validation == 0) ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-view: error: %s\n", e.what());
    return 1;
  }
}
