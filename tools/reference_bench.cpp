// penumbra-reference-bench: how long the ray-traced reference takes. For each scene: render one
// frame (the G-buffer gives the receivers), build the BVH, then trace every light --repeat times
// without the cache, adaptive (the default) and with every receiver at the full sample count.
// Prints medians, rays per second, the share of receivers that needed the full count, the CPU
// and the thread count.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <penumbra/core/stats.hpp>
#include <penumbra/gpu/context.hpp>
#include <penumbra/reference/reference.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/scene/scene.hpp>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "cli.hpp"

namespace {
using penumbra::Error;
namespace ref = penumbra::reference;

using penumbra::stats::median;

std::string cpu_name() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown CPU";
}

int run(int argc, char** argv) {
  std::vector<std::string> scenes;
  uint32_t repeat = 3, samples = 256, threads = 0, width = 0, height = 0;
  bool full = true;
  penumbra::cli::Command app("penumbra-reference-bench",
                             "Times the ray-traced reference: BVH build, rays per second.");
  using penumbra::cli::whole;
  app.option(
      "--scene", [&](const std::string& v) { scenes.push_back(v); },
      "a shipped scene or a .toml file; repeatable (default: the shipped scenes)");
  app.option(
      "--repeat", [&](const std::string& v) { repeat = whole("--repeat", v, 1, 1u << 24); },
      "runs per measurement, the median is reported (default 3)");
  app.option(
      "--samples", [&](const std::string& v) { samples = whole("--samples", v, 1, 1u << 24); },
      "rays per receiver in penumbrae (default 256)");
  app.option(
      "--threads", [&](const std::string& v) { threads = whole("--threads", v, 1, 1u << 24); },
      "tracing threads (default: all)");
  app.option(
      "--size",
      [&](const std::string& v) {
        std::tie(width, height) = penumbra::cli::size("--size", v, 1, 16384);
      },
      "the frame size (default: the scene's)");
  bool adaptive_only = false;
  app.flag("--adaptive-only", adaptive_only, "time the adaptive trace alone");
  app.parse(argc, argv);
  if (adaptive_only) full = false;
  if (scenes.empty()) scenes = penumbra::scene::shipped_scenes();
  const uint32_t used_threads =
      threads ? threads : std::max(1u, std::thread::hardware_concurrency());
  std::printf("reference bench: %s, %u thread(s), %u samples per penumbra receiver, median of %u\n",
              cpu_name().c_str(), used_threads, samples, repeat);
  std::printf("%-10s %-7s %-9s %9s %8s %9s %10s %8s %9s\n", "scene", "light", "mode", "receivers",
              "full %", "rays", "median s", "Mrays/s", "BVH s");
  penumbra::gpu::Context ctx;
  for (const auto& name : scenes) {
    const auto scene = penumbra::scene::load_scene(penumbra::scene::find_scene(name));
    penumbra::render::RendererOptions ro;
    ro.width = width;
    ro.height = height;
    penumbra::render::Renderer renderer(ctx, scene, ro);
    renderer.render(0);
    const auto g = renderer.read_gbuffer();
    const auto receivers = ref::receivers_from_gbuffer(
        g.width, g.height, g.depth, g.normal_view, g.camera.view, g.camera.proj, g.camera.origin);
    size_t valid = 0;
    for (auto v : receivers.valid) valid += v;
    const auto t0 = std::chrono::steady_clock::now();
    const ref::Tracer tracer(scene, g.camera.origin);
    const double bvh = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    for (const auto& light : ref::scene_lights(scene)) {
      const auto area = ref::area_light(scene, light);
      for (bool adaptive : {true, false}) {
        if (!adaptive && (!full || area.hard())) continue;
        ref::TraceOptions o;
        o.samples = samples;
        o.adaptive = adaptive;
        o.threads = threads;
        std::vector<double> seconds;
        ref::Visibility v;
        for (uint32_t r = 0; r < repeat; ++r) {
          v = tracer.trace(receivers, area, o);
          seconds.push_back(v.seconds);
        }
        size_t full_count = 0;
        for (auto s : v.samples) full_count += s == (area.hard() ? 1u : samples);
        const double med = median(seconds);
        std::printf("%-10s %-7s %-9s %9zu %7.2f%% %9llu %10.3f %8.1f %9.3f\n", name.c_str(),
                    light.name().c_str(),
                    area.hard() ? "hard"
                    : adaptive  ? "adaptive"
                                : "full",
                    valid, valid ? 100.0 * double(full_count) / double(valid) : 0.0,
                    static_cast<unsigned long long>(v.rays), med,
                    med > 0 ? double(v.rays) / med * 1e-6 : 0.0, bvh);
        if (adaptive && !area.hard()) {
          // The noise actually left, against 16x the samples (not adaptive): over the receivers
          // the adaptive trace found partly visible, and over every 50th receiver it stopped
          // early (how often 16 agreeing rays missed a penumbra).
          ref::TraceOptions fine = o;
          fine.samples = 16 * samples;
          fine.adaptive = false;
          ref::Receivers subset = receivers;
          for (size_t i = 0; i < subset.size(); ++i) {
            const bool partial = v.value[i] > 0.0f && v.value[i] < 1.0f;
            const bool stopped = v.samples[i] > 0 && v.samples[i] < samples;
            if (!(partial || (stopped && i % 50 == 0))) subset.valid[i] = 0;
          }
          const auto f = tracer.trace(subset, area, fine);
          double sum_partial = 0.0, sum_stopped = 0.0, worst = 0.0;
          size_t partial = 0, stopped = 0, missed = 0;
          for (size_t i = 0; i < subset.size(); ++i) {
            if (!subset.valid[i] || !(f.samples[i] > 0)) continue;
            const double d = std::abs(double(v.value[i]) - double(f.value[i]));
            if (v.value[i] > 0.0f && v.value[i] < 1.0f) {
              sum_partial += d;
              ++partial;
              worst = std::max(worst, d);
            } else {
              sum_stopped += d;
              ++stopped;
              missed += d > 0.0;
            }
          }
          std::printf(
              "%-10s %-7s vs %u samples: penumbra mean |dR| %.5f (max %.3f, %zu receivers);"
              " early stops: %zu of %zu sampled differ, mean |dR| %.5f\n",
              name.c_str(), light.name().c_str(), fine.samples,
              partial ? sum_partial / double(partial) : 0.0, worst, partial, missed, stopped,
              stopped ? sum_stopped / double(stopped) : 0.0);
        }
      }
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-reference-bench: %s\n", e.what());
    return 1;
  }
}
