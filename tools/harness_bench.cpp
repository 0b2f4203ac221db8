// penumbra-harness-bench: what the shader-function harness costs.
//   fixed cost per tested function: wrapper generation + glslang + reflection check + pipeline +
//     the first dispatch (where lavapipe compiles with LLVM), cold and warm Mesa cache;
//   throughput of a small function at 1, 1e3 and 1e6 cases per batch (median of repeats),
//     split into host packing, GPU time (timestamps are not used: the whole run() is timed, as a
//     user sees it) and cases/s.
// Cold numbers come from functions never compiled before (a random define makes each wrapper
// unique); warm numbers from a second process-level engine for the same wrapper text after the
// first was dropped... which the harness never does, so "warm" is measured with a fresh process
// run: start the bench twice, the second run's "first use" hits Mesa's disk cache.
#include <stdlib.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <penumbra/core/stats.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
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

const char* kLibrary = R"(// A small library for the bench.
float bench_small(float a, vec2 b) { return a * b.x + b.y * BENCH_SALT; }
)";

int run(int reps, bool fixed_salt) {
  penumbra::gpu::Context& ctx = penumbra::testing::shared_context();
  // The bench's GLSL goes into a fresh directory of its own, removed at exit.
  char tmpl[] = "/tmp/penumbra-harness-bench.XXXXXX";
  const char* made = ::mkdtemp(tmpl);
  if (made == nullptr) {
    std::fprintf(stderr, "penumbra-harness-bench: cannot create a temporary directory\n");
    return 1;
  }
  const std::string dir = made;
  struct Cleanup {
    std::string dir;
    ~Cleanup() {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  } cleanup{dir};
  std::ofstream(dir + "/bench.glsl") << kLibrary;
  std::printf("device: %s (%s), validation %s, Mesa cache %s\n", ctx.info().name.c_str(),
              ctx.info().driver_name.c_str(), ctx.validation_enabled() ? "on" : "off",
              std::getenv("MESA_SHADER_CACHE_DISABLE") ? "disabled" : "enabled");

  // Fixed cost: construct + first run of one case, for `reps` distinct functions.
  std::mt19937 rng(fixed_salt ? 1u : std::random_device{}());
  std::vector<double> construct, first_run, fixed;
  for (int i = 0; i < reps; ++i) {
    penumbra::testing::FunctionOptions o;
    o.defines = {{"BENCH_SALT", std::to_string(rng() % 1000000) + ".0"}};
    auto t = Clock::now();
    penumbra::testing::ShaderFunction<float(float, glm::vec2)> f(dir + "/bench.glsl", "bench_small",
                                                                 o);
    construct.push_back(ms_since(t));
    auto t2 = Clock::now();
    (void)f(1.0f, glm::vec2(2.0f, 3.0f));
    first_run.push_back(ms_since(t2));
    fixed.push_back(ms_since(t));
  }
  std::printf("\nfixed cost per tested function (median of %d distinct functions)\n", reps);
  std::printf("  generate + compile + reflect + pipeline  %8.2f ms\n", median(construct));
  std::printf("  first run (LLVM compile on lavapipe)     %8.2f ms\n", median(first_run));
  std::printf("  total                                    %8.2f ms\n", median(fixed));

  penumbra::testing::FunctionOptions o;
  o.defines = {{"BENCH_SALT", "1.0"}};
  penumbra::testing::ShaderFunction<float(float, glm::vec2)> f(dir + "/bench.glsl", "bench_small",
                                                               o);
  std::printf("\nthroughput of float(float, vec2) (median of %d runs)\n", reps);
  std::printf("  %10s %12s %14s\n", "cases", "ms/run", "cases/s");
  for (size_t n : {size_t{1}, size_t{1000}, size_t{1000000}}) {
    std::vector<std::tuple<float, glm::vec2>> cases(n);
    for (size_t i = 0; i < n; ++i) cases[i] = {float(i), glm::vec2(0.5f, float(i % 7))};
    (void)f.run(cases);  // warm-up: buffers sized, pipeline compiled
    std::vector<double> times;
    for (int r = 0; r < reps; ++r) {
      auto t = Clock::now();
      const auto out = f.run(cases);
      times.push_back(ms_since(t));
      if (out[n - 1] != float(n - 1) * 0.5f + float((n - 1) % 7)) {
        std::fprintf(stderr, "wrong result\n");
        return 1;
      }
    }
    const double ms = median(times);
    std::printf("  %10zu %12.3f %14.3g\n", n, ms, double(n) / (ms * 1e-3));
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int reps = 9;
  bool fixed_salt = false;
  try {
    penumbra::cli::Command app("penumbra-harness-bench",
                               "Times the shader-function harness: compile, dispatch, compare.");
    app.option(
        "--reps",
        [&](const std::string& v) { reps = int(penumbra::cli::whole("--reps", v, 1, 1000)); },
        "repetitions per size (default 9)");
    app.flag("--same-functions", fixed_salt, "the same salts every run: a second run is warm");
    app.parse(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-harness-bench: error: %s\n", e.what());
    return 2;
  }
  try {
    const int rc = run(reps, fixed_salt);
    penumbra::testing::GpuEnvironment().TearDown();
    return rc;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-harness-bench: error: %s\n", e.what());
    return 1;
  }
}
