// penumbra-texel-rate: the device's texel-rate floor for the shadow filters, measured.
//
// Runs shaders/bench/texel_rate.comp (one invocation per screen pixel, n x n fetches from a
// depth map on a screen-coherent grid, nothing else) for n = 1..8 and times each dispatch with
// Vulkan timestamp queries (median of --reps dispatches after a warm-up, a barrier between
// them). For each fetch kind (compare taps of a 2D map through the renderer's linear compare
// sampler; texelFetch of the raw depth, as in the PCSS blocker search; compare taps of a
// cube-map array, as the point lights' filters take them) it fits time = base + fetches x cost
// over the points and reports the fetch rate. penumbra-bench divides a filter's fetches by
// that rate to get its floor and reports the resolve's measured time over it (the roofline
// column). A kind whose fitted cost per fetch is not at least 4 standard errors above zero (a
// busy CPU driver's timing noise can swamp it, even make it negative) gets no rate: its
// "gfetch_per_s" is null and "noise" says why. Writes --out (JSON, atomically) and prints a
// table.
//
//   penumbra-texel-rate [--size WxH] [--map N] [--reps N] [--out FILE]
//
// PENUMBRA_DEVICE picks the device; PENUMBRA_VALIDATION=1 turns the validation layer on (any
// message is an error).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <penumbra/core/json.hpp>
#include <penumbra/core/stats.hpp>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/context.hpp>
#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/gpu/resources.hpp>
#include <penumbra/shader/compiler.hpp>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "cli.hpp"

namespace {

using penumbra::Error;
namespace gpu = penumbra::gpu;

struct Options {
  uint32_t width = 1280, height = 720;
  uint32_t map = 2048;
  int reps = 20;
  std::string out;
};

struct Push {
  int32_t size[2];
  int32_t taps_per_axis;
  int32_t mode;
  float texels_per_pixel;
};

Options parse(int argc, char** argv) {
  Options o;
  penumbra::cli::Command app("penumbra-texel-rate",
                             "Measures the device's texel-fetch rates for the shadow filters.");
  app.option(
      "--size",
      [&](const std::string& v) {
        std::tie(o.width, o.height) = penumbra::cli::size("--size", v, 1, 16384);
      },
      "the dispatch size");
  app.option(
      "--map", [&](const std::string& v) { o.map = penumbra::cli::whole("--map", v, 1, 16384); },
      "the shadow map's size in texels");
  app.option(
      "--reps",
      [&](const std::string& v) { o.reps = int(penumbra::cli::whole("--reps", v, 1, 1000)); },
      "repetitions per measurement");
  app.option(
      "--out", [&](const std::string& v) { o.out = v; }, "the JSON result's file");
  app.parse(argc, argv);
  return o;
}

// Least squares y = a + b x.
// A finite double, or null (JSON has no NaN).
std::string json_number(double v) {
  return penumbra::json::number(v, 9);
}

void check_validation(gpu::Context& ctx) {
  if (ctx.validation_enabled()) gpu::throw_if_messages(ctx.validation_sink());
}

int run(const Options& o) {
  gpu::Context ctx;
  penumbra::shader::Compiler compiler;
  const auto shader =
      compiler.compile_file(penumbra::shader::default_shader_dir() / "bench" / "texel_rate.comp");

  gpu::ImageDesc md;
  md.kind = gpu::ImageKind::image_2d_array;
  md.format = VK_FORMAT_D32_SFLOAT;
  md.width = md.height = o.map;
  md.layers = 1;
  gpu::Image map(ctx, md);
  {
    // Depths that vary per texel, so compare taps are neither all lit nor all shadowed.
    std::vector<float> depth(size_t{o.map} * o.map);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (auto& d : depth) d = u(rng);
    map.upload_floats(depth);
  }
  // A cube-map array of one cube, 512^2 faces (the point lights' default), the same depths.
  gpu::ImageDesc cdesc;
  cdesc.kind = gpu::ImageKind::cube_array;
  cdesc.format = VK_FORMAT_D32_SFLOAT;
  cdesc.width = cdesc.height = 512;
  cdesc.layers = 6;
  gpu::Image cube(ctx, cdesc);
  {
    std::vector<float> depth(size_t{6} * 512 * 512);
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (auto& d : depth) d = u(rng);
    cube.upload_floats(depth);
  }
  gpu::ImageDesc rd;
  rd.format = VK_FORMAT_R32_SFLOAT;
  rd.width = o.width;
  rd.height = o.height;
  rd.usage = VK_IMAGE_USAGE_STORAGE_BIT;
  gpu::Image result(ctx, rd);
  gpu::submit_one_shot(
      ctx, [&](VkCommandBuffer cmd) { result.transition(cmd, VK_IMAGE_LAYOUT_GENERAL); });

  gpu::SamplerDesc cd;
  cd.filter = VK_FILTER_LINEAR;
  cd.compare = true;
  cd.compare_op = VK_COMPARE_OP_GREATER_OR_EQUAL;
  gpu::Sampler compare(ctx, cd);
  gpu::Sampler nearest(ctx, gpu::SamplerDesc{});

  const VkShaderStageFlags cs = VK_SHADER_STAGE_COMPUTE_BIT;
  gpu::PipelineLayout layout(ctx,
                             {{{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs},
                               {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs},
                               {2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, cs},
                               {3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs}}},
                             sizeof(Push), cs);
  gpu::ComputePipeline pipeline(ctx, shader.spirv, layout);
  gpu::DescriptorPool pool(ctx, 1);
  VkDescriptorSet set = pool.allocate(layout.set_layout(0));
  gpu::DescriptorWriter()
      .combined_image(0, map.view(), compare.handle())
      .combined_image(1, map.view(), nearest.handle())
      .storage_image(2, result.view())
      .combined_image(3, cube.view(), compare.handle())
      .update(ctx, set);

  const uint32_t reps = uint32_t(o.reps);
  gpu::TimestampPool timestamps(ctx, reps + 1);
  const double pixels = double(o.width) * o.height;
  // One shadow texel per screen pixel: the scale a resolve sees where the map is well matched.
  const float texels_per_pixel = 1.0f;

  struct Point {
    int mode, n;
    double ms;
  };
  std::vector<Point> points;
  const int max_n = 8;
  constexpr int kModes = 3;
  // Cube-map arrays are an optional feature: without it the cube kind is not measured.
  const int modes = ctx.info().image_cube_array ? kModes : 2;
  for (int mode = 0; mode < modes; ++mode) {
    for (int n = 1; n <= max_n; ++n) {
      const Push push{{int32_t(o.width), int32_t(o.height)}, n, mode, texels_per_pixel};
      gpu::submit_one_shot(ctx, [&](VkCommandBuffer cmd) {
        timestamps.reset(cmd);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.handle());
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout.handle(), 0, 1, &set, 0,
                                nullptr);
        vkCmdPushConstants(cmd, layout.handle(), cs, 0, sizeof(Push), &push);
        VkMemoryBarrier2 b{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
        b.srcStageMask = b.dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
        b.srcAccessMask = b.dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
        VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
        dep.memoryBarrierCount = 1;
        dep.pMemoryBarriers = &b;
        // Dispatch 0 warms up (caches, clocks); timestamps 0..reps bracket the timed ones.
        for (uint32_t r = 0; r <= reps; ++r) {
          if (r > 0) timestamps.write(cmd, r - 1);
          vkCmdDispatch(cmd, (o.width + 7) / 8, (o.height + 7) / 8, 1);
          vkCmdPipelineBarrier2(cmd, &dep);
        }
        timestamps.write(cmd, reps);
      });
      const auto ns = timestamps.read_ns(reps + 1);
      std::vector<double> ms;
      for (uint32_t r = 0; r < reps; ++r) ms.push_back((ns[r + 1] - ns[r]) * 1e-6);
      points.push_back({mode, n, penumbra::stats::median(ms)});
      check_validation(ctx);
    }
  }

  const char* kinds[kModes] = {"compare", "fetch", "cube_compare"};
  std::ostringstream json;
  json << "{\n \"device\": \"" << ctx.info().name << "\",\n \"driver\": \""
       << ctx.info().driver_name << "\",\n \"width\": " << o.width << ",\n \"height\": " << o.height
       << ",\n \"map\": " << o.map << ",\n \"reps\": " << o.reps
       << ",\n \"texels_per_pixel\": " << texels_per_pixel << ",\n \"kinds\": {";
  std::printf("device: %s (%s), %ux%u pixels, %u^2 D32 map, median of %d dispatches\n",
              ctx.info().name.c_str(), ctx.info().driver_name.c_str(), o.width, o.height, o.map,
              o.reps);
  std::printf("%-12s %7s %10s %10s\n", "kind", "fetches", "ms", "Gfetch/s");
  for (int mode = 0; mode < modes; ++mode) {
    std::vector<double> x, y;
    json << (mode ? "," : "") << "\n  \"" << kinds[mode] << "\": {\"points\": [";
    bool first = true;
    for (const auto& p : points) {
      if (p.mode != mode) continue;
      const double fetches = double(p.n) * p.n;
      x.push_back(fetches);
      y.push_back(p.ms);
      const double rate = pixels * fetches / (p.ms * 1e-3) * 1e-9;
      std::printf("%-12s %7.0f %10.4f %10.2f\n", kinds[mode], fetches, p.ms, rate);
      json << (first ? "" : ", ") << "{\"fetches_per_pixel\": " << fetches << ", \"ms\": " << p.ms
           << "}";
      first = false;
    }
    // The marginal cost of one fetch per pixel over the frame, and the fixed cost of a pass. On
    // a busy CPU driver the timings' noise can swamp the fetches' cost, and the fitted slope
    // comes out tiny or negative: a rate from it would be meaningless, so it is reported as
    // noise (JSON null and the reason) and penumbra-bench leaves the roofline columns empty.
    const penumbra::stats::LineFit fit = penumbra::stats::fit_line(x, y);
    json << "], \"base_ms\": " << json_number(fit.intercept)
         << ", \"ms_per_fetch_per_pixel\": " << json_number(fit.slope)
         << ", \"slope_stderr\": " << json_number(fit.slope_stderr);
    if (fit.significantly_positive()) {
      const double rate = pixels / (fit.slope * 1e-3) * 1e-9;
      std::printf("%-12s fit: %.4f ms + %.5f ms (+-%.5f) per fetch per pixel = %.2f Gfetch/s\n",
                  kinds[mode], fit.intercept, fit.slope, fit.slope_stderr, rate);
      json << ", \"gfetch_per_s\": " << rate << "}";
    } else {
      char why[200];
      std::snprintf(why, sizeof why,
                    "the fetches' cost is within the timing noise: slope %.3g ms +- %.3g per "
                    "fetch per pixel (t = %.2f, needs >= 4)",
                    fit.slope, fit.slope_stderr, fit.t());
      std::printf("%-12s fit: no rate, %s\n", kinds[mode], why);
      json << ", \"gfetch_per_s\": null, \"noise\": \"" << why << "\"}";
    }
  }
  json << "\n }\n}\n";
  if (!o.out.empty()) penumbra::write_file_atomic(o.out, json.str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(parse(argc, argv));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-texel-rate: %s\n", e.what());
    return 1;
  }
}
