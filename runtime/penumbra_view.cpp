// penumbra-view: the Penumbra runtime. Headless, it renders a scene's frames offscreen, writes
// PNGs (the lit image and every debug view) and a timings file, and prints what was built and
// the per-pass GPU timings (timestamp queries, medians over the frames).
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/context.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/scene/scene.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using penumbra::Error;

struct Options {
  std::string scene = "default";
  bool headless = false;
  uint32_t frames = 0;  // 0: the scene's [render] frames
  fs::path out;
  std::string view;  // empty: lit plus every debug view
  std::string filter;
  uint32_t width = 0, height = 0;
  bool list_devices = false;
};

const std::map<std::string, penumbra::scene::DebugView>& views() {
  using penumbra::scene::DebugView;
  static const std::map<std::string, DebugView> v = {
      {"lit", DebugView::lit},
      {"shadow_factor", DebugView::shadow_factor},
      {"cascades", DebugView::cascades},
      {"contact_mask", DebugView::contact_mask},
      {"texel_density", DebugView::texel_density},
      {"penumbra", DebugView::penumbra}};
  return v;
}

const std::map<std::string, penumbra::scene::Filter>& filters() {
  using penumbra::scene::Filter;
  static const std::map<std::string, Filter> f = {
      {"hard", Filter::hard}, {"pcf", Filter::pcf}, {"pcss", Filter::pcss}, {"poisson", Filter::poisson}};
  return f;
}

template <class M>
std::string keys(const M& m) {
  std::string s;
  for (const auto& [k, v] : m) s += (s.empty() ? "" : ", ") + k;
  return s;
}

uint32_t parse_uint(const std::string& flag, const std::string& v) {
  try {
    size_t used = 0;
    const unsigned long x = std::stoul(v, &used);
    if (used != v.size() || x > 100000) throw std::out_of_range(v);
    return static_cast<uint32_t>(x);
  } catch (const std::exception&) {
    throw Error(flag + " " + v + ": expected a whole number");
  }
}

void usage() {
  std::printf(
      "usage: penumbra-view [--scene NAME|FILE] [--headless] [--frames N] [--out DIR]\n"
      "                     [--view VIEW] [--filter FILTER] [--size WxH] [--list-devices]\n"
      "  --scene     a shipped scene (default, grazing, space, indoor) or a .toml file\n"
      "  --headless  render offscreen and write PNGs (the default when there is no display)\n"
      "  --out       where PNGs and timings go (default out/<scene>)\n"
      "  --view      %s (default: lit, then every debug view)\n"
      "  --filter    %s (default: the scene's)\n"
      "  PENUMBRA_DEVICE=lavapipe|gpu|<index>|<name>, PENUMBRA_VALIDATION=1\n",
      keys(views()).c_str(), keys(filters()).c_str());
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw Error(a + ": missing value");
      return argv[++i];
    };
    if (a == "--scene") o.scene = value();
    else if (a == "--headless") o.headless = true;
    else if (a == "--frames") o.frames = parse_uint(a, value());
    else if (a == "--out") o.out = value();
    else if (a == "--view") {
      o.view = value();
      if (!views().count(o.view)) throw Error("--view " + o.view + ": expected one of " + keys(views()));
    } else if (a == "--filter") {
      o.filter = value();
      if (!filters().count(o.filter))
        throw Error("--filter " + o.filter + ": expected one of " + keys(filters()));
    } else if (a == "--size") {
      const std::string v = value();
      const auto x = v.find('x');
      if (x == std::string::npos) throw Error("--size " + v + ": expected WxH, e.g. 1280x720");
      o.width = parse_uint(a, v.substr(0, x));
      o.height = parse_uint(a, v.substr(x + 1));
      if (o.width == 0 || o.height == 0) throw Error("--size " + v + ": both sides must be > 0");
    } else if (a == "--list-devices") o.list_devices = true;
    else if (a == "--help" || a == "-h") {
      usage();
      std::exit(0);
    } else throw Error("unknown argument '" + a + "' (try --help)");
  }
  return o;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

int run(int argc, char** argv) {
  const Options o = parse(argc, argv);
  if (o.list_devices) {
    std::printf("%s", penumbra::gpu::Context::list_devices().c_str());
    return 0;
  }
  const bool display = std::getenv("DISPLAY") != nullptr || std::getenv("WAYLAND_DISPLAY") != nullptr;
  if (!o.headless && display) {
    std::printf("penumbra-view: the interactive window is not built yet; rendering headless\n");
  }

  const fs::path scene_file = penumbra::scene::find_scene(o.scene);
  penumbra::scene::Scene scene = penumbra::scene::load_scene(scene_file);
  if (!o.filter.empty()) scene.shadows.filter = filters().at(o.filter);
  const uint32_t frames = o.frames ? o.frames : std::max(1u, scene.render.frames);

  penumbra::gpu::Context ctx;
  std::printf("%s", ctx.report().c_str());
  std::printf("scene:       %s (%s)\n", scene.name.c_str(), scene_file.string().c_str());

  const auto t0 = std::chrono::steady_clock::now();
  penumbra::render::RendererOptions ro;
  ro.width = o.width;
  ro.height = o.height;
  penumbra::render::Renderer renderer(ctx, scene, ro);
  const double build_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("\nbuilt for this scene (%.0f ms):\n%s", build_ms, renderer.built().to_string().c_str());

  const fs::path out = o.out.empty() ? fs::path("out") / scene.name : o.out;
  fs::create_directories(out);

  // Frames for timing, in the scene's own view.
  std::map<std::string, std::vector<double>> samples;
  std::vector<std::string> order;
  for (uint32_t f = 0; f < frames; ++f) {
    renderer.render(f);
    for (const auto& t : renderer.timings()) {
      if (!samples.count(t.name)) order.push_back(t.name);
      samples[t.name].push_back(t.gpu_ms);
    }
  }
  std::vector<std::string> written;
  const std::string first_view = o.view.empty() ? "lit" : o.view;
  {
    renderer.set_debug_view(views().at(first_view));
    renderer.render(frames);
    const fs::path png = out / (first_view + ".png");
    penumbra::render::write_png(png, renderer.width(), renderer.height(), renderer.read_rgba8());
    written.push_back(png.string());
  }
  if (o.view.empty()) {
    for (const auto& [name, view] : views()) {
      if (name == "lit") continue;
      renderer.set_debug_view(view);
      renderer.render(frames);
      const fs::path png = out / (name + ".png");
      penumbra::render::write_png(png, renderer.width(), renderer.height(), renderer.read_rgba8());
      written.push_back(png.string());
    }
  }

  std::printf("\nGPU time per pass on %s, %ux%u, median of %u frame(s):\n", ctx.info().name.c_str(),
              renderer.width(), renderer.height(), frames);
  std::ofstream csv(out / "timings.csv");
  csv << "device,scene,width,height,pass,median_ms,frames\n";
  double total = 0;
  for (const auto& name : order) {
    const double m = median(samples[name]);
    total += m;
    std::printf("  %-18s %9.3f ms\n", name.c_str(), m);
    csv << '"' << ctx.info().name << "\"," << scene.name << ',' << renderer.width() << ','
        << renderer.height() << ',' << name << ',' << m << ',' << frames << "\n";
  }
  std::printf("  %-18s %9.3f ms\n", "total", total);
  std::printf("\nwrote:\n");
  for (const auto& w : written) std::printf("  %s\n", w.c_str());
  std::printf("  %s\n", (out / "timings.csv").string().c_str());
  if (ctx.validation_enabled()) {
    std::printf("validation:  %zu messages\n", ctx.validation_sink().total_seen());
    if (ctx.validation_sink().total_seen() != 0) return 1;
  }
  return 0;
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
