// penumbra-view: the Penumbra runtime. Headless, it renders a scene's frames offscreen, writes
// PNGs (the lit image and every debug view) and a timings file, and prints what was built and
// the per-pass GPU timings (timestamp queries, medians over the frames). With --watch it then
// keeps running: shader edits are hot-reloaded (runtime/session.hpp) and the PNG rewritten;
// --script / --command drive it headless (runtime/script.hpp).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <penumbra/gpu/context.hpp>
#include <penumbra/gpu/gpu_lock.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <penumbra/shader/compiler.hpp>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include "script.hpp"
#include "view_options.hpp"
#include "session.hpp"
#include "truth.hpp"
#include "window.hpp"
#ifdef PENUMBRA_HAS_IMGUI
#include "ui.hpp"
#endif

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

namespace {

// Frames timed for each --truth snapshot (the median and its spread): 4 keeps a snapshot within
// a second of the new frame on lavapipe at 640x360 (a frame there is about 150 ms).
constexpr std::uint32_t kTruthFrames = 4;

namespace fs = std::filesystem;
using penumbra::Error;
using penumbra::runtime::filters;
using penumbra::runtime::Options;
using penumbra::runtime::view_of;
using penumbra::runtime::views;

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) {
  g_stop = true;
}

int validation_result(penumbra::gpu::Context& ctx) {
  if (!ctx.validation_enabled()) return 0;
  std::printf("validation:  %zu messages\n", ctx.validation_sink().total_seen());
  return ctx.validation_sink().total_seen() != 0 ? 1 : 0;
}

void print_latency_summary(const penumbra::runtime::Session& s) {
  const auto l = s.latencies_ms();
  if (l.empty()) return;
  std::printf(
      "reload latency (file event -> first frame with the new pipelines): median %.0f ms "
      "over %zu reload(s)\n",
      penumbra::runtime::median(l), l.size());
}

penumbra::runtime::SessionOptions session_options(const Options& o, bool watch) {
  penumbra::runtime::SessionOptions so;
  so.shader_dir = o.shader_dir;
  // --shader-dir DIR is an overlay: what DIR lacks comes from the library this viewer was built
  // or installed with.
  if (!o.shader_dir.empty()) so.library_shader_dirs = {penumbra::shader::default_shader_dir()};
  so.width = o.width;
  so.height = o.height;
  so.watch = watch;
  so.visibility_output = o.truth;
  so.debounce = std::chrono::milliseconds(o.debounce_ms);
  return so;
}

// --script / --command: the automation mode.
int run_scripts(penumbra::gpu::Context& ctx, const Options& o) {
  penumbra::runtime::ScriptSetup setup;
  setup.scene = o.scene;
  setup.session = session_options(o, true);
  if (!o.filter.empty()) setup.initial_settings.emplace_back("shadows.filter", o.filter);
  if (!o.view.empty()) setup.initial_settings.emplace_back("render.view", o.view);
  penumbra::runtime::Script script(ctx, setup);
  int command = 0;
  bool go_on = true;
  for (const auto& [kind, arg] : o.scripts) {
    if (!go_on) break;
    if (kind == "command") {
      go_on = script.run_line(arg, "--command " + std::to_string(++command));
    } else if (arg == "-") {
      go_on = script.run(std::cin, "<stdin>");
    } else {
      std::ifstream in(arg);
      if (!in) throw Error("--script " + arg + ": cannot read");
      go_on = script.run(in, arg);
    }
  }
  if (script.has_session()) print_latency_summary(script.session());
  return validation_result(ctx);
}

// Cycles a parameter through `names` (V: views, F: filters).
void cycle(penumbra::runtime::Session& session, const std::string& key,
           const std::vector<std::string>& names) {
  const auto it = std::find(names.begin(), names.end(), session.get(key));
  const size_t next = it == names.end() ? 0 : (size_t(it - names.begin()) + 1) % names.size();
  session.set(key, names[next]);
  std::printf("[window] %s = %s\n", key.c_str(), names[next].c_str());
  std::fflush(stdout);
}

// --truth: the reference measurement's options (failure modes, the reference cache).
penumbra::reference::MeasureOptions truth_options() {
  penumbra::reference::MeasureOptions options;
  options.failure_modes = true;
  options.cache_dir = penumbra::reference::default_cache_dir();
  return options;
}

void print_lines(const std::vector<std::string>& lines) {
  for (const auto& l : lines) std::printf("%s\n", l.c_str());
  std::fflush(stdout);
}

// --truth's baseline: the view measured against the truth (traced once, then read from the
// reference cache) and printed; nothing when the scene has no shadowed light to measure.
std::optional<penumbra::runtime::TruthSnapshot> truth_baseline(
    penumbra::runtime::Session& session, const penumbra::reference::MeasureOptions& measure,
    const std::optional<penumbra::reference::CameraPath>& path, const std::string& scene) {
  std::printf("[truth] tracing the reference for this view (once; cached in %s)\n",
              measure.cache_dir->string().c_str());
  std::fflush(stdout);
  auto baseline = penumbra::runtime::measure_truth(session, kTruthFrames, measure, path);
  if (baseline.lights.empty()) {
    std::printf("[truth] scene '%s' has no shadowed light to measure: no deltas\n",
                scene.c_str());
    return std::nullopt;
  }
  print_lines(penumbra::runtime::truth_lines(baseline));
  return baseline;
}

// Each light's error heat map of a --truth snapshot, as truth-error.png (one light) or
// truth-error-<light>.png, written atomically into out.
void write_heat_maps(const fs::path& out, const penumbra::runtime::TruthSnapshot& s) {
  for (std::size_t i = 0; i < s.lights.size() && i < s.heat.size(); ++i) {
    const fs::path png =
        out / (s.lights.size() == 1 ? std::string("truth-error.png")
                                    : "truth-error-" + s.lights[i].name + ".png");
    penumbra::render::write_png(png, s.width, s.height, s.heat[i]);
    std::printf("[truth] error heat map: %s\n", png.string().c_str());
  }
  std::fflush(stdout);
}

// "pcf.glsl", "pcf.glsl, noise.glsl": what a batch of reloads changed, for the panel's table.
std::string changed_files(const std::vector<penumbra::runtime::ReloadRecord>& records,
                          std::size_t from) {
  std::string out;
  for (std::size_t i = from; i < records.size(); ++i)
    for (const auto& f : records[i].changed) {
      const std::string name = f.filename().string();
      if (out.find(name) == std::string::npos) out += (out.empty() ? "" : ", ") + name;
    }
  return out.empty() ? "(reload)" : out;
}

// Window mode: render and present every frame; the reload loop runs between frames and its
// error shows in the title.
int run_window(penumbra::gpu::Context& ctx, penumbra::runtime::Window& window, const Options& o,
               const penumbra::scene::Scene& scene, uint32_t frames) {
  using Clock = std::chrono::steady_clock;
  penumbra::runtime::Session session(ctx, scene, session_options(o, true));
  if (!o.view.empty()) session.set("render.view", o.view);
  std::printf("\nbuilt for this scene:\n%s", session.renderer().built().to_string().c_str());
  std::string over;
  for (const auto& lib : session.library_dirs()) over += " over " + lib.string();
  std::printf(
      "\n[window] %ux%u, watching %s%s; left drag orbits, right drag looks, WASD/QE fly, scroll "
      "zooms, V/F cycle view/filter, R resets the camera, T the truth's heat maps, Esc closes\n",
      window.width(), window.height(), session.shader_dir().string().c_str(), over.c_str());
  std::fflush(stdout);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

#ifdef PENUMBRA_HAS_IMGUI
  std::unique_ptr<penumbra::runtime::Ui> ui;
  if (o.ui) ui = std::make_unique<penumbra::runtime::Ui>(ctx, window, o.ui_rows);
  std::printf("[window] panel: %s\n",
              ui ? penumbra::runtime::ui_version().c_str() : "off (--no-ui)");
  const auto ui_mouse = [&] { return ui && ui->wants_mouse(); };
  const auto ui_keyboard = [&] { return ui && ui->wants_keyboard(); };
#else
  std::printf("[window] panel: not built (libimgui-dev missing)\n");
  const auto ui_mouse = [] { return false; };
  const auto ui_keyboard = [] { return false; };
#endif
  // --truth: the baseline now; after every reload that rebuilt something, what it did (the
  // panel's table of saves and the log), and each light's error heat map to show (T).
  const penumbra::reference::MeasureOptions measure = truth_options();
  std::optional<penumbra::reference::CameraPath> flicker_path;
  if (!o.truth_flicker.empty()) flicker_path = penumbra::reference::find_path(o.truth_flicker);
  std::optional<penumbra::runtime::TruthSnapshot> truth, truth_start;
  if (o.truth) truth = truth_baseline(session, measure, flicker_path, scene.name);
  if (truth) {
    truth_start = truth;
#ifdef PENUMBRA_HAS_IMGUI
    if (ui) ui->truth_baseline(*truth);
#endif
  }
  std::size_t reloads_seen = session.reloads().size();
  std::unique_ptr<penumbra::gpu::Image> heat_image;
  int heat_uploaded = -1;  // the light whose heat map heat_image holds

  const penumbra::scene::Camera home = session.renderer().scene().camera;
  penumbra::runtime::CameraControls controls;
  auto last = Clock::now();
  auto last_title = last - std::chrono::seconds(1);
  double fps = 0.0;
  uint32_t frame = 0, frames_since_title = 0;
  std::string title, shown_error;
  while (!window.should_close() && !g_stop) {
    window.poll();
    const auto now = Clock::now();
    const double dt = std::chrono::duration<double>(now - last).count();
    last = now;
#ifdef PENUMBRA_HAS_IMGUI
    if (ui) {
      ui->new_frame();
      ui->panel(session);
    }
#endif
    const std::vector<int> keys = window.take_keys();
    const double scroll = window.take_scroll();
    for (const int key : ui_keyboard() ? std::vector<int>{} : keys) {
      if (key == GLFW_KEY_ESCAPE) window.close();
      if (key == GLFW_KEY_V) cycle(session, "render.view", views());
      if (key == GLFW_KEY_F) cycle(session, "shadows.filter", filters());
      if (key == GLFW_KEY_R) session.renderer().scene().camera = home;
#ifdef PENUMBRA_HAS_IMGUI
      if (key == GLFW_KEY_T && ui) ui->cycle_heat_light();
#endif
    }
    // After the panel: a parameter it set may have rebuilt the renderer (and its scene).
    if (ui_mouse())
      controls.cancel();
    else
      controls.update(window.handle(), session.renderer().scene().camera, dt, scroll);

    session.set_frame_index(frame++);
    session.render(1);
    if (session.reloads().size() > reloads_seen) {
      const auto& records = session.reloads();
      const bool rebuilt = std::any_of(records.begin() + std::ptrdiff_t(reloads_seen),
                                       records.end(),
                                       [](const auto& r) { return !r.result.rebuilt.empty(); });
      if (truth && rebuilt) {
        auto after = penumbra::runtime::measure_truth(session, kTruthFrames, measure, flicker_path);
        print_lines(penumbra::runtime::truth_lines(*truth, after));
        print_lines(penumbra::runtime::truth_since(*truth_start, after));
#ifdef PENUMBRA_HAS_IMGUI
        if (ui) ui->add_save(changed_files(records, reloads_seen), *truth, after, *truth_start);
#endif
        truth = std::move(after);
        heat_uploaded = -1;
      }
      reloads_seen = records.size();
    }
    // The error heat map of the last snapshot in place of the frame, when the panel asks.
    const penumbra::gpu::Image* shown = &session.renderer().output_image();
#ifdef PENUMBRA_HAS_IMGUI
    const int heat = ui && truth ? ui->heat_light() : -1;
    if (heat >= 0 && std::size_t(heat) < truth->heat.size()) {
      if (heat != heat_uploaded || !heat_image || heat_image->desc().width != truth->width ||
          heat_image->desc().height != truth->height) {
        penumbra::gpu::ImageDesc d;
        d.width = truth->width;
        d.height = truth->height;
        d.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
        heat_image = std::make_unique<penumbra::gpu::Image>(ctx, d);
        const auto& texels = truth->heat[std::size_t(heat)];
        heat_image->upload(std::as_bytes(std::span(texels)),
                           VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
        heat_uploaded = heat;
      }
      shown = heat_image.get();
    }
    if (ui)
      window.present(*shown, [&](VkCommandBuffer cmd) { ui->record(cmd); });
    else
#endif
      window.present(*shown);

    ++frames_since_title;
    if (now - last_title > std::chrono::milliseconds(250)) {
      if (frame > frames_since_title)  // the first update has no full interval
        fps = frames_since_title / std::chrono::duration<double>(now - last_title).count();
      frames_since_title = 0;
      char head[256];
      std::snprintf(head, sizeof head, "penumbra-view - %s - %s, %s - %.1f fps", scene.name.c_str(),
                    session.get("render.view").c_str(), session.get("shadows.filter").c_str(), fps);
      std::string t = head;
      std::string error = session.error_text();
      if (!error.empty()) {
        error = error.substr(0, error.find('\n'));
        if (error.size() > 160) error = error.substr(0, 157) + "...";
        t += " - RELOAD ERROR: " + error;
      }
      if (error != shown_error) {
        std::printf("[window] title %s: %s\n", error.empty() ? "clear" : "shows the reload error",
                    t.c_str());
        std::fflush(stdout);
        shown_error = error;
      }
      if (t != title) window.set_title(t);
      title = t;
      last_title = now;
    }
    if (o.exit_after_frames && window.presented() >= frames) break;
  }
  const auto name = [&](VkFormat f) {
    return f == VK_FORMAT_B8G8R8A8_UNORM   ? std::string("B8G8R8A8_UNORM")
           : f == VK_FORMAT_R8G8B8A8_UNORM ? std::string("R8G8B8A8_UNORM")
                                           : "VkFormat " + std::to_string(f);
  };
  std::printf(
      "\n[window] presented %llu frames (%u rendered) to a %ux%u %s swapchain, recreated %u "
      "times\n",
      static_cast<unsigned long long>(window.presented()), frame, window.width(), window.height(),
      name(window.format()).c_str(), window.recreated());
  std::printf("[window] last title: %s\n", title.c_str());
  std::printf("[window] camera.position %s, camera.target %s\n",
              session.get("camera.position").c_str(), session.get("camera.target").c_str());
  std::printf("GPU time per pass of the last frame:\n%s", session.timings_text().c_str());
  print_latency_summary(session);
  return validation_result(ctx);
}

int run(int argc, char** argv) {
  const Options o = penumbra::runtime::parse_options(argc, argv);
  if (o.list_devices) {
    std::printf("%s", penumbra::gpu::Context::list_devices().c_str());
    return 0;
  }
  if (o.list_params) {  // the table and the scene's values, without a device
    penumbra::scene::Scene scene =
        penumbra::scene::load_scene(penumbra::scene::find_scene(o.scene));
    if (o.move) penumbra::scene::translate_scene(scene, *o.move);
    if (!o.filter.empty()) penumbra::scene::set_param(scene, "shadows.filter", o.filter);
    penumbra::scene::set_params(scene, o.sets);
    std::printf("%s", penumbra::scene::params_json(&scene).c_str());
    return 0;
  }
  const bool display =
      std::getenv("DISPLAY") != nullptr || std::getenv("WAYLAND_DISPLAY") != nullptr;
  std::string why;
  std::unique_ptr<penumbra::runtime::WindowSystem> glfw;
  if (!o.headless) {
    if (!o.scripts.empty())
      why = "--script / --command run headless";
    else if (!display)
      why = "no display (DISPLAY and WAYLAND_DISPLAY are unset)";
    else
      glfw = penumbra::runtime::WindowSystem::init(why);
  }
  // With a window system: the instance extensions it needs and VK_KHR_swapchain.
  std::unique_ptr<penumbra::gpu::Context> context;
  if (glfw) {
    penumbra::gpu::ContextOptions co;
    co.instance_extensions = glfw->instance_extensions();
    co.device_extensions = {VK_KHR_SWAPCHAIN_EXTENSION_NAME};
    try {
      context = std::make_unique<penumbra::gpu::Context>(co);
    } catch (const std::exception& e) {
      why = std::string("no Vulkan context that can present: ") + e.what();
      glfw.reset();
    }
  }
  if (!context) context = std::make_unique<penumbra::gpu::Context>();
  penumbra::gpu::Context& ctx = *context;

  if (!o.scripts.empty()) {
    if (!o.headless && display) std::printf("penumbra-view: %s\n", why.c_str());
    std::printf("%s", ctx.report().c_str());
    return run_scripts(ctx, o);
  }

  const fs::path scene_file = penumbra::scene::find_scene(o.scene);
  penumbra::scene::Scene scene = penumbra::scene::load_scene(scene_file);
  if (o.move) penumbra::scene::translate_scene(scene, *o.move);
  if (!o.filter.empty()) penumbra::scene::set_param(scene, "shadows.filter", o.filter);
  penumbra::scene::set_params(scene, o.sets);
  const uint32_t frames = o.frames ? o.frames : std::max(1u, scene.render.frames);

  std::unique_ptr<penumbra::runtime::Window> window;
  if (glfw) {
    try {
      window = std::make_unique<penumbra::runtime::Window>(
          ctx, o.width ? o.width : scene.render.width, o.height ? o.height : scene.render.height,
          "penumbra-view - " + scene.name);
    } catch (const std::exception& e) {
      why = std::string("no window: ") + e.what();
    }
  }
  std::printf("%s", ctx.report().c_str());
  std::printf("scene:       %s (%s)\n", scene.name.c_str(), scene_file.string().c_str());
  if (window) return run_window(ctx, *window, o, scene, frames);
  if (!o.headless) std::printf("penumbra-view: rendering headless: %s\n", why.c_str());
  if (o.truth && !o.watch)
    throw Error("--truth reports what each reload did: rendering headless (" + why +
                "), it needs --watch");

  const auto t0 = std::chrono::steady_clock::now();
  penumbra::runtime::Session session(ctx, scene, session_options(o, o.watch));
  penumbra::render::Renderer& renderer = session.renderer();
  const double build_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("\nbuilt for this scene (%.0f ms):\n%s", build_ms,
              renderer.built().to_string().c_str());

  // out/<scene name> unless --out says; an existing directory is reused (its PNGs and
  // timings.csv are replaced, other files stay), which the output says.
  const fs::path out = o.out.empty() ? fs::path("out") / scene.name : o.out;
  std::error_code out_ec;
  const bool out_existed = fs::exists(out, out_ec);
  if (out_existed && !fs::is_directory(out, out_ec))
    throw Error((o.out.empty() ? "out/" + scene.name : "--out " + out.string()) +
                ": exists and is not a directory");
  fs::create_directories(out, out_ec);
  if (out_ec)
    throw Error("cannot create the output directory " + out.string() + ": " + out_ec.message());

  // Frames for timing, in the scene's own view: alone on the GPU when other processes share it
  // (PENUMBRA_GPU_LOCK, as penumbra-tune --jobs and a cluster worker's slots set it).
  std::map<std::string, std::vector<double>> samples;
  std::vector<std::string> order;
  // What each frame drew into the shadow maps (shadows.cache), for shadow_maps.csv.
  std::ostringstream maps_csv;
  maps_csv << "frame,layers,drawn,scrolled,moving_drawn,texels_drawn,triangles_drawn\n";
  std::vector<double> texels_per_frame, triangles_per_frame;
  {
    const penumbra::gpu::ExclusiveGpu alone;
    for (uint32_t f = 0; f < frames; ++f) {
      renderer.render(f);
      for (const auto& t : renderer.timings()) {
        if (!samples.count(t.name)) order.push_back(t.name);
        samples[t.name].push_back(t.gpu_ms);
      }
      const auto& c = renderer.shadow_cache_stats();
      maps_csv << f << ',' << c.layers << ',' << c.drawn << ',' << c.scrolled << ','
               << c.moving_drawn << ',' << c.texels_drawn << ',' << c.triangles_drawn << "\n";
      texels_per_frame.push_back(double(c.texels_drawn));
      triangles_per_frame.push_back(double(c.triangles_drawn));
    }
  }
  std::vector<std::string> written;
  const std::string first_view = o.view.empty() ? "lit" : o.view;
  {
    renderer.set_debug_view(view_of(first_view));
    renderer.render(frames);
    const fs::path png = out / (first_view + ".png");
    penumbra::render::write_png(png, renderer.width(), renderer.height(), renderer.read_rgba8());
    written.push_back(png.string());
  }
  if (o.view.empty()) {
    for (const auto& name : views()) {
      if (name == "lit") continue;
      renderer.set_debug_view(view_of(name));
      // `redrawn` shows what a frame drew after the one before it, not after the views before.
      if (name == "redrawn") renderer.render(frames - 1);
      renderer.render(frames);
      const fs::path png = out / (name + ".png");
      penumbra::render::write_png(png, renderer.width(), renderer.height(), renderer.read_rgba8());
      written.push_back(png.string());
    }
  }

  std::printf("\nGPU time per pass on %s, %ux%u, median of %u frame(s):\n", ctx.info().name.c_str(),
              renderer.width(), renderer.height(), frames);
  std::ostringstream csv;
  csv << "device,scene,width,height,pass,median_ms,frames\n";
  double total = 0;
  for (const auto& name : order) {
    const double m = penumbra::runtime::median(samples[name]);
    total += m;
    std::printf("  %-22s %9.3f ms\n", name.c_str(), m);
    csv << '"' << ctx.info().name << "\"," << scene.name << ',' << renderer.width() << ','
        << renderer.height() << ',' << name << ',' << m << ',' << frames << "\n";
  }
  std::printf("  %-22s %9.3f ms\n", "total", total);
  if (renderer.shadow_cache_stats().layers > 0)
    std::printf(
        "shadow maps: %.2f Mtexels and %.3f Mtriangles drawn per frame (median; frame 0: %.2f "
        "and %.3f), %s\n",
        penumbra::runtime::median(texels_per_frame) * 1e-6,
        penumbra::runtime::median(triangles_per_frame) * 1e-6, texels_per_frame.front() * 1e-6,
        triangles_per_frame.front() * 1e-6,
        scene.shadows.cache ? "cached (shadows.cache)" : "every layer every frame");
  penumbra::write_file_atomic(out / "timings.csv", csv.str());
  penumbra::write_file_atomic(out / "shadow_maps.csv", maps_csv.str());
  std::printf(
      "\nwrote%s:\n",
      out_existed ? " (into an existing directory: files of these names were replaced)" : "");
  for (const auto& w : written) std::printf("  %s\n", w.c_str());
  std::printf("  %s\n", (out / "timings.csv").string().c_str());
  std::printf("  %s\n", (out / "shadow_maps.csv").string().c_str());
  std::fflush(stdout);

  if (o.watch) {
    // Live: the first view's PNG is rewritten after every reload that rebuilt something.
    renderer.set_debug_view(view_of(first_view));
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    std::string over;
    for (const auto& lib : session.library_dirs()) over += " over " + lib.string();
    std::printf("\n[watch] watching %s%s (%zu directories); edit a shader, Ctrl-C stops\n",
                session.shader_dir().string().c_str(), over.c_str(),
                session.watcher()->directories().size());
    std::fflush(stdout);
    const fs::path png = out / (first_view + ".png");
    // --truth: the baseline now (the truth traced once, then read from the reference cache),
    // and after every reload that rebuilt something, what it did to GPU time and error.
    const penumbra::reference::MeasureOptions measure = truth_options();
    std::optional<penumbra::runtime::TruthSnapshot> before, start;
    std::optional<penumbra::reference::CameraPath> flicker_path;
    if (o.truth) {
      if (!o.truth_flicker.empty()) flicker_path = penumbra::reference::find_path(o.truth_flicker);
      before = truth_baseline(session, measure, flicker_path, scene.name);
      if (before) {
        write_heat_maps(out, *before);
        start = before;
      }
    }
    while (!g_stop) {
      const auto rec = session.wait_reload(std::chrono::milliseconds(200));
      if (!rec || rec->result.rebuilt.empty()) continue;
      penumbra::render::write_png(png, renderer.width(), renderer.height(), session.pixels());
      std::printf("[watch] wrote %s\n", png.string().c_str());
      std::fflush(stdout);
      if (before) {
        const auto t = std::chrono::steady_clock::now();
        auto after =
            penumbra::runtime::measure_truth(session, kTruthFrames, measure, flicker_path);
        print_lines(penumbra::runtime::truth_lines(*before, after));
        print_lines(penumbra::runtime::truth_since(*start, after));
        std::printf("[truth] measured in %.0f ms after the new frame\n",
                    std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                              t)
                        .count());
        std::fflush(stdout);
        write_heat_maps(out, after);
        before = std::move(after);
      }
    }
    print_latency_summary(session);
  }
  return validation_result(ctx);
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
