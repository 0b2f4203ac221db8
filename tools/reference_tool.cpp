// penumbra-reference: renders a scene's frame, traces the ray-traced reference for each of its
// lights at the GPU's own receivers, and writes reference, visibility and error PNGs and
// metrics.json next to lit.png; one line of metrics per light on stdout.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <optional>
#include <penumbra/core/error.hpp>
#include <penumbra/core/json.hpp>
#include <penumbra/core/stats.hpp>
#include <penumbra/gpu/context.hpp>
#include <penumbra/gpu/gpu_lock.hpp>
#include <penumbra/gpu/validation.hpp>
#include <penumbra/reference/frame.hpp>
#include <penumbra/reference/temporal.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/filters.hpp>
#include <penumbra/scene/scene.hpp>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "cli.hpp"

namespace {
namespace fs = std::filesystem;
using penumbra::Error;

struct Options {
  std::string scene = "default";
  fs::path out;
  uint32_t width = 0, height = 0;
  uint32_t frame = 0;
  penumbra::reference::MeasureOptions measure;
  bool cache = true;
  fs::path cache_dir;
  std::vector<std::pair<std::string, std::string>> sets;  // --set KEY=VALUE, in order
  std::optional<glm::dvec3> move;                         // --move X,Y,Z
  std::vector<penumbra::reference::CameraPath> flicker;   // --flicker
  uint32_t timing_frames = 0;                             // --timing-frames
  bool images = true;                                     // --no-images
  penumbra::reference::FlickerOptions flicker_options;
};

Options parse(int argc, char** argv) {
  Options o;
  o.measure.failure_modes = true;  // the tool tells the failure modes apart by default
  auto& t = o.measure.trace;
  bool flicker_truth = false, no_adaptive = false, no_failure_modes = false, no_images = false,
       no_cache = false;
  penumbra::cli::Command app(
      "penumbra-reference",
      "Traces a scene's shadows with Embree and measures the renderer against them.");
  using penumbra::cli::whole;
  app.option(
      "--scene", [&](const std::string& v) { o.scene = v; },
      "a shipped scene (default, grazing, indoor, space) or a .toml file");
  app.option(
      "--set", [&](const std::string& v) { o.sets.push_back(penumbra::scene::split_set_flag(v)); },
      "override a parameter-table key after loading, e.g. "
      "--set shadows.constant_bias=0.01 (docs/scenes.md lists the keys); repeatable");
  app.option(
      "--move",
      [&](const std::string& v) {
        const auto m = penumbra::cli::triple("--move", v);
        o.move = glm::dvec3(m[0], m[1], m[2]);
      },
      "move the whole scene (objects, lights, camera) by X,Y,Z metres after loading: the same "
      "world far from the origin",
      "X,Y,Z");
  app.option(
      "--out", [&](const std::string& v) { o.out = v; },
      "where the PNGs and metrics.json go (default out/<scene>/reference)");
  app.option(
      "--size",
      [&](const std::string& v) {
        std::tie(o.width, o.height) = penumbra::cli::size("--size", v, 1, 16384);
      },
      "the frame size (default: the scene's [render] size)");
  app.option(
      "--frame", [&](const std::string& v) { o.frame = whole("--frame", v, 0, 1u << 30); },
      "frame index rendered (temporal noise; default 0)");
  app.option(
      "--samples", [&](const std::string& v) { t.samples = whole("--samples", v, 1, 1u << 20); },
      "rays per receiver in penumbrae (default 256)");
  app.option(
      "--initial-samples",
      [&](const std::string& v) { t.initial_samples = whole("--initial-samples", v, 1, 1u << 20); },
      "adaptive: rays after which agreeing receivers stop (default 16)");
  app.flag("--no-adaptive", no_adaptive, "every receiver gets --samples rays");
  app.option(
      "--seed",
      [&](const std::string& v) { t.seed = penumbra::cli::whole64("--seed", v, 0, UINT64_MAX); },
      "the sample sequence's seed (default 1)");
  app.option(
      "--light", [&](const std::string& v) { o.measure.lights.push_back(v); },
      "measure only this light (sun, spot0, point1, ...); repeatable");
  app.option(
      "--threshold",
      [&](const std::string& v) {
        char* end = nullptr;
        const double x = std::strtod(v.c_str(), &end);
        if (v.empty() || *end != '\0' || !(x > 0.0 && x < 1.0))
          throw Error("--threshold " + v + ": expected a number in (0, 1)");
        o.measure.metrics.threshold = x;
      },
      "t of false light (V > R + t) and false shadow (V < R - t) (default 0.1)");
  app.option(
      "--terminator",
      [&](const std::string& v) {
        t.terminator = penumbra::cli::one_of("--terminator", v, {"smooth", "geometric"}) == "smooth"
                           ? penumbra::reference::Terminator::smooth
                           : penumbra::reference::Terminator::geometric;
      },
      "where shadow rays start on smooth-shaded meshes: on the smooth surface the vertex normals "
      "describe (smooth, the default) or on the flat triangles (geometric; docs/accuracy.md, the "
      "shadow terminator)");
  app.option(
      "--threads", [&](const std::string& v) { t.threads = whole("--threads", v, 1, 1024); },
      "tracing threads (default: all)");
  app.option(
      "--cache", [&](const std::string& v) { o.cache_dir = v; },
      "the reference cache (default $PENUMBRA_REFERENCE_CACHE or ~/.cache/penumbra/reference)");
  app.flag("--no-cache", no_cache, "trace every time");
  app.option(
      "--flicker",
      [&](const std::string& v) {
        if (v == "all") {
          o.flicker = penumbra::reference::standard_paths();
          return;
        }
        size_t start = 0;
        while (start <= v.size()) {
          const size_t comma = std::min(v.find(',', start), v.size());
          o.flicker.push_back(penumbra::reference::find_path(v.substr(start, comma - start)));
          start = comma + 1;
        }
      },
      "also measure temporal stability along these camera paths "
      "(translate-1mm, translate-1cm, yaw-0.05deg, sun-0.05deg): the fraction of shadow-edge "
      "pixels whose visibility changes by more than 8/255 between frames, after reprojection; "
      "into metrics.json's \"flicker\"");
  app.option(
      "--flicker-frames",
      [&](const std::string& v) {
        o.flicker_options.frames = whole("--flicker-frames", v, 2, 10000);
      },
      "frames per path (default 16)");
  app.flag("--flicker-truth", flicker_truth,
           "also trace the reference at every frame of the paths and measure its flicker: "
           "what the truth itself shows (detail finer than a pixel, a turning sun), and the "
           "renderer's flicker where the truth held still");
  app.option(
      "--timing-frames",
      [&](const std::string& v) { o.timing_frames = whole("--timing-frames", v, 1, 10000); },
      "after measuring, render N frames with a renderer as penumbra-view builds it (no "
      "visibility output), after a warm-up (0.3-3 s, until the frame time settles), and write "
      "each pass's median GPU ms (Vulkan timestamp queries) into metrics.json's \"timings\"");
  app.flag("--no-failure-modes", no_failure_modes,
           "skip telling acne, leaks and the contact gap apart (their own rays; "
           "metrics.json's acne, leak and contact_gap_* fields, modes.png)");
  app.flag("--no-images", no_images, "write metrics.json alone, no PNGs (penumbra-tune's points)");
  app.parse(argc, argv);
  if (no_adaptive) t.adaptive = false;
  if (no_cache) o.cache = false;
  if (no_failure_modes) o.measure.failure_modes = false;
  if (no_images) o.images = false;
  // The truth along the paths takes the measure's trace options (samples, seed, threads).
  if (flicker_truth) o.flicker_options.truth = t;
  return o;
}

std::string json_string(const std::string& s) {
  return penumbra::json::string(s);
}

int run(int argc, char** argv) {
  // Wall seconds per phase, in metrics.json and on stdout: where a tuning point's time goes.
  const auto started = std::chrono::steady_clock::now();
  auto lap_start = started;
  std::vector<std::pair<std::string, double>> phases;
  const auto lap = [&](const char* phase) {
    const auto now = std::chrono::steady_clock::now();
    phases.emplace_back(phase, std::chrono::duration<double>(now - lap_start).count());
    lap_start = now;
  };
  Options o = parse(argc, argv);
  const fs::path scene_file = penumbra::scene::find_scene(o.scene);
  penumbra::scene::Scene scene = penumbra::scene::load_scene(scene_file);
  if (o.move) penumbra::scene::translate_scene(scene, *o.move);
  penumbra::scene::set_params(scene, o.sets);
  if (o.out.empty()) o.out = fs::path("out") / scene.name / "reference";
  if (o.cache)
    o.measure.cache_dir =
        o.cache_dir.empty() ? penumbra::reference::default_cache_dir() : o.cache_dir;
  o.measure.trace.progress = true;
  if (o.flicker_options.truth) o.flicker_options.truth->progress = true;
  o.flicker_options.cache_dir = o.measure.cache_dir;  // the path's truth is shared the same way

  penumbra::gpu::Context ctx;
  penumbra::render::RendererOptions ro;
  ro.width = o.width;
  ro.height = o.height;
  ro.visibility_output = true;
  penumbra::render::Renderer renderer(ctx, scene, ro);
  renderer.render(o.frame);
  lap("setup");
  const auto m = penumbra::reference::measure_frame(renderer, o.measure);
  lap("still");
  if (m.lights.empty())
    std::printf("note: scene '%s' has no lights to measure\n", scene.name.c_str());
  if (m.triangles == 0)
    std::printf(
        "note: scene '%s' has no shadow casters (no meshes, or every object has "
        "casts_shadows = false): every light is fully visible\n",
        scene.name.c_str());
  if (m.receivers.rejected > 0)
    std::printf(
        "note: %zu pixels have a non-finite position or normal (NaN in a mesh?) and are "
        "not measured\n",
        m.receivers.rejected);

  std::ostringstream header;
  header << "\"scene\": "
         << json_string(scene.name)
         // As given (a shipped scene's name, or the path on the command line), not the
         // resolved absolute path: checked-in results name no machine's folders.
         << ", \"scene_file\": " << json_string(o.scene)
         << ", \"device\": " << json_string(ctx.info().name)
         << ", \"driver\": " << json_string(ctx.info().driver_name + " " + ctx.info().driver_info)
         << ", \"frame\": " << o.frame << ", \"samples\": " << o.measure.trace.samples
         << ", \"initial_samples\": " << o.measure.trace.initial_samples
         << ", \"adaptive\": " << (o.measure.trace.adaptive ? "true" : "false")
         << ", \"seed\": " << o.measure.trace.seed << ", \"terminator\": "
         << (o.measure.trace.terminator == penumbra::reference::Terminator::smooth
                 ? "\"smooth\""
                 : "\"geometric\"")
         << ", \"threshold\": " << o.measure.metrics.threshold << ", \"filters\": {";
  // Each light's filter and its fetches per pixel (penumbra-bench's roofline column).
  bool first_light = true;
  for (const auto& l : m.lights) {
    using penumbra::reference::LightKind;
    std::optional<penumbra::scene::Filter> own;
    if (l.light.kind == LightKind::spot) own = scene.spots.at(l.light.index).filter;
    if (l.light.kind == LightKind::point) own = scene.points.at(l.light.index).filter;
    const auto filter = own.value_or(scene.shadows.filter);
    header << (first_light ? "" : ", ") << json_string(l.light.name())
           << ": {\"filter\": " << json_string(std::string(penumbra::scene::to_string(filter)))
           << ", \"fetches_per_pixel\": "
           << penumbra::scene::filter_fetches_per_pixel(filter, scene.shadows,
                                                        l.light.kind == LightKind::point)
           << "}";
    first_light = false;
  }
  header << "}";
  // Temporal stability along the asked-for paths (after the measured frame: the paths render
  // frames 0..N-1 and put the scene back).
  if (!o.flicker.empty()) {
    header << ", \"flicker\": {";
    for (size_t p = 0; p < o.flicker.size(); ++p) {
      const auto results =
          penumbra::reference::measure_flicker(renderer, o.flicker[p], o.flicker_options);
      header << (p ? ", " : "") << json_string(o.flicker[p].name) << ": {";
      for (size_t i = 0; i < results.size(); ++i) {
        const auto& f = results[i];
        header << (i ? ", " : "") << json_string(f.light) << ": {\"fraction\": " << f.fraction()
               << ", \"fraction_lit\": " << f.fraction_lit()
               << ", \"edge_pixels\": " << f.edge_pixels << ", \"changed\": " << f.changed;
        if (f.has_truth)
          header << ", \"truth_fraction\": " << f.truth_fraction()
                 << ", \"truth_fraction_lit\": " << f.truth_fraction_lit()
                 << ", \"truth_edge_pixels\": " << f.truth_edge_pixels
                 << ", \"truth_changed\": " << f.truth_changed
                 << ", \"excess_fraction\": " << f.excess_fraction()
                 << ", \"excess_fraction_lit\": " << f.excess_fraction_lit()
                 << ", \"excess_changed\": " << f.excess_changed
                 << ", \"path_mean_abs_error\": " << f.path_mean_abs_error
                 << ", \"path_mean_abs_error_lit\": " << f.path_mean_abs_error_lit;
        header << "}";
        std::printf(
            "flicker %-14s %-7s %6.2f%% of %zu shadow-edge pixels (%.2f%% by n.l) over %u "
            "frames\n",
            f.path.c_str(), f.light.c_str(), 100.0 * f.fraction(), f.edge_pixels,
            100.0 * f.fraction_lit(), o.flicker_options.frames);
        if (f.has_truth)
          std::printf(
              "        %-14s %-7s truth %.2f%% of %zu (%.2f%% by n.l); not in the "
              "truth %.2f%% (%.2f%% by n.l) of the truth's edge pixels; mean |dV| "
              "along the path %.4f (%.4f by n.l)\n",
              "", "", 100.0 * f.truth_fraction(), f.truth_edge_pixels,
              100.0 * f.truth_fraction_lit(), 100.0 * f.excess_fraction(),
              100.0 * f.excess_fraction_lit(), f.path_mean_abs_error, f.path_mean_abs_error_lit);
        if (!o.images) continue;
        fs::create_directories(o.out);
        penumbra::render::write_png(
            o.out / ("flicker-" + f.path + "-" + f.light + ".png"), f.width, f.height,
            penumbra::reference::flicker_image(f, m.lit, o.flicker_options.frames - 1));
      }
      header << "}";
    }
    header << "}, \"flicker_frames\": " << o.flicker_options.frames;
    lap("paths");
  }
  // GPU time per pass, as penumbra-view measures it (its renderer has no visibility output, which
  // costs the resolves a write per light): the median over the frames after a warm-up.
  if (o.timing_frames > 0) {
    penumbra::render::RendererOptions plain = ro;
    plain.visibility_output = false;
    penumbra::render::Renderer timed(ctx, scene, plain);
    // Warm-up first: after seconds of tracing on the CPU the GPU has dropped to its idle clock
    // (345 of 1980 MHz on an H200), and frames timed at once ran 5-10x slower than penumbra-view
    // measures them; a fixed 0.3 s warm-up still left one point in 19 at a third of the clock.
    // So: at least 3 frames and 0.3 s, then until a frame's GPU time is within 5% of the one
    // before it (the clock has settled), at most 3 s. A CPU driver (lavapipe) has no such clock
    // and its frame times never settle that closely: one frame.
    // Other processes sharing the GPU (penumbra-tune --jobs) submit nothing while this one
    // warms up and times (PENUMBRA_GPU_LOCK; unset, nothing is locked).
    const penumbra::gpu::ExclusiveGpu alone;
    const auto warm_start = std::chrono::steady_clock::now();
    const auto since = [&] { return std::chrono::steady_clock::now() - warm_start; };
    uint32_t warm = 0;
    double last_total = -1.0;
    for (;;) {
      timed.render(warm++);
      double total = 0.0;
      for (const auto& t : timed.timings()) total += t.gpu_ms;
      const bool settled = last_total > 0.0 && std::abs(total - last_total) <= 0.05 * last_total;
      last_total = total;
      if (ctx.info().is_cpu) break;
      if (warm >= 3 && since() >= std::chrono::milliseconds(300) && settled) break;
      if (since() >= std::chrono::seconds(3) || warm >= 10000) break;
    }
    std::map<std::string, std::vector<double>> samples;
    std::vector<std::string> order;
    for (uint32_t f = 0; f < o.timing_frames; ++f) {
      timed.render(warm + f);
      for (const auto& t : timed.timings()) {
        if (!samples.count(t.name)) order.push_back(t.name);
        samples[t.name].push_back(t.gpu_ms);
      }
    }
    header << ", \"timings\": {\"frames\": " << o.timing_frames << ", \"passes\": {";
    for (size_t i = 0; i < order.size(); ++i)
      header << (i ? ", " : "") << json_string(order[i]) << ": "
             << penumbra::stats::median(samples[order[i]]);
    header << "}}";
    lap("timing");
  }
  phases.emplace_back(
      "total", std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  header << ", \"seconds\": {";
  std::string phase_line;
  for (size_t i = 0; i < phases.size(); ++i) {
    header << (i ? ", " : "") << json_string(phases[i].first) << ": " << phases[i].second;
    char buf[64];
    std::snprintf(buf, sizeof buf, "%s%s %.2f", i ? ", " : "", phases[i].first.c_str(),
                  phases[i].second);
    phase_line += buf;
  }
  header << "}";
  penumbra::reference::write_measurement(m, o.out, header.str(), o.images);
  for (const auto& l : m.lights) {
    std::printf("%s  (%s%llu rays, %.1f s)\n", l.metrics.to_line().c_str(),
                l.reference.from_cache ? "cached: " : "", (unsigned long long)l.reference.rays,
                l.reference.seconds);
    if (l.metrics.receivers == 0)
      std::printf("  note: no pixel of this frame is lit by %s\n", l.light.name().c_str());
    if (l.has_failure_modes) {
      const auto& f = l.failure;
      std::printf("  acne %.3f%% of %llu clear receivers  leaks %.3f%%  contact gap ",
                  100.0 * f.acne, (unsigned long long)f.clear_receivers, 100.0 * f.leak);
      if (std::isfinite(f.contact_gap_texels))
        std::printf(
            "%.2f texels (%.4g m; %.2f texels across the light) over %llu contact "
            "receivers\n",
            f.contact_gap_texels, f.contact_gap_world, f.contact_gap_map_texels,
            (unsigned long long)f.contact_receivers);
      else
        std::printf("not seen (no umbra receiver near a contact)\n");
    }
  }
  std::printf("seconds: %s\n", phase_line.c_str());
  std::printf("wrote %s/%smetrics.json (%s, %ux%u)\n", o.out.string().c_str(),
              o.images ? "{lit,reference,visibility,error,modes}*.png and " : "",
              ctx.info().name.c_str(), m.width, m.height);
  if (ctx.validation_enabled() && ctx.validation_sink().total_seen() != 0) {
    std::fprintf(stderr, "validation: %zu messages\n", ctx.validation_sink().total_seen());
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-reference: %s\n", e.what());
    return 1;
  }
}
