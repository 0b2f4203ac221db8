// penumbra-reload-bench: hot-reload latency of penumbra-view, from the file event (when the
// watcher saw the save) to the end of the first frame rendered with the rebuilt pipelines.
//
// On a copy of the shader tree, each file is edited --edits times in four ways:
//   new code    every save puts a constant never compiled before into the code (salted per run),
//               so the driver compiles the changed pipelines from scratch;
//   undo/redo   the saves alternate between two versions, so after the first two the driver's
//               shader cache (Mesa's, on disk) holds both: what tweaking back and forth costs;
// each with
//   frame loop  frames keep running, as in a windowed viewer; the save lands at a random moment
//               of a frame (a second thread) and is reloaded between two frames;
//   on change   the viewer idles until a save, then reloads and renders (penumbra-view --watch).
// Prints medians (the latency and its parts) per file and mode, the median latency in steady
// frames (the median frame before the edits) and its p99, and the device name.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <optional>
#include <penumbra/core/error.hpp>
#include <penumbra/core/stats.hpp>
#include <penumbra/gpu/context.hpp>
#include <penumbra/render/contact_shadows.hpp>
#include <penumbra/scene/scene.hpp>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "session.hpp"

namespace {

namespace fs = std::filesystem;
using penumbra::Error;
using penumbra::runtime::Clock;
using penumbra::runtime::median;

struct Target {
  std::string file;    // relative to the shader directory
  std::string needle;  // replaced by edit(k)
  std::function<std::string(long k)> edit;
  std::string what;
};

std::string read_text(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  if (!in) throw Error(f.string() + ": cannot read");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& f, const std::string& text) {
  std::ofstream out(f, std::ios::binary | std::ios::trunc);
  out << text;
  if (!out) throw Error(f.string() + ": cannot write");
}

std::string replaced(std::string text, const std::string& from, const std::string& to,
                     const std::string& file) {
  const auto at = text.find(from);
  if (at == std::string::npos) throw Error(file + ": '" + from + "' not found (shader changed?)");
  return text.replace(at, from.size(), to);
}

std::string number(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.7f", x);
  return b;
}

std::vector<Target> targets() {
  return {
      {"penumbra/pcf.glsl", "return penumbra_is_finite(v) ? clamp(v, 0.0, 1.0) : 1.0;",
       [](long k) {
         return "return penumbra_is_finite(v) ? clamp(v, 0.0, " + number(1.0 - double(k) * 1e-7) +
                ") : 1.0;";
       },
       "the clamp ending every PCF filter (included by shadow.glsl and forward.frag)"},
      {"penumbra/shadow.glsl", "#include \"penumbra/bias.glsl\"",
       [](long k) { return "// edit " + std::to_string(k) + "\n#include \"penumbra/bias.glsl\""; },
       "a comment (the SPIR-V does not change: the runtime's own cost)"},
      {"penumbra/noise.glsl", "const vec3 kIgnMagic = vec3(0.06711056, 0.00583715, 52.9829189);",
       [](long k) {
         return "const vec3 kIgnMagic = vec3(0.06711056, 0.00583715, " +
                number(52.9829189 + double(k) * 1e-5) + ");";
       },
       "the interleaved-gradient-noise constant (read by shadow-resolve, contact shadows, "
       "forward)"},
      {"contact_shadows.comp", "imageStore(contact_mask, pixel, vec4(mask));",
       [](long k) {
         return "imageStore(contact_mask, pixel, vec4(mask * " + number(1.0 - double(k) * 1e-7) +
                "));";
       },
       "the contact mask store (the pass is recreated)"},
  };
}

struct Options {
  std::string scene = "default";
  uint32_t width = 640, height = 360;
  int edits = 10;
  std::vector<std::string> only;  // file filter
  fs::path shader_dir;            // the tree to copy; empty: the repo's shaders/
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw Error(a + ": missing value");
      return argv[++i];
    };
    if (a == "--scene")
      o.scene = value();
    else if (a == "--size") {
      const std::string v = value();
      if (std::sscanf(v.c_str(), "%ux%u", &o.width, &o.height) != 2 || !o.width || !o.height)
        throw Error("--size " + v + ": expected WxH");
    } else if (a == "--edits") {
      o.edits = std::atoi(value().c_str());
      if (o.edits < 2) throw Error("--edits: expected at least 2");
    } else if (a == "--file")
      o.only.push_back(value());
    else if (a == "--shader-dir")
      o.shader_dir = value();
    else if (a == "--help" || a == "-h") {
      std::printf(
          "usage: penumbra-reload-bench [--scene NAME] [--size WxH] [--edits N] [--file F]...\n"
          "                             [--shader-dir DIR]\n"
          "  defaults: default scene, 640x360, 10 edits per file and mode; --file limits the\n"
          "  files (penumbra/pcf.glsl, penumbra/shadow.glsl, penumbra/noise.glsl,\n"
          "  contact_shadows.comp)\n");
      std::exit(0);
    } else
      throw Error("unknown argument '" + a + "'");
  }
  return o;
}

struct Row {
  std::string file, mode;
  std::vector<double> latency, waited, reload, frame;
  std::string rebuilt;
};

int run(int argc, char** argv) {
  const Options o = parse(argc, argv);
  char tmpl[] = "/tmp/penumbra-reload-bench-XXXXXX";
  if (!mkdtemp(tmpl)) throw Error("mkdtemp failed");
  const fs::path root = tmpl;
  const fs::path shaders = root / "shaders";
  fs::copy(o.shader_dir.empty() ? penumbra::render::default_shader_dir() : o.shader_dir, shaders,
           fs::copy_options::recursive);
  struct Cleanup {
    fs::path p;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(p, ec);
    }
  } cleanup{root};

  penumbra::gpu::Context ctx;
  auto scene = penumbra::scene::load_scene(penumbra::scene::find_scene(o.scene));
  penumbra::runtime::SessionOptions so;
  so.shader_dir = shaders;
  so.width = o.width;
  so.height = o.height;
  so.log = [](const std::string&) {};
  penumbra::runtime::Session session(ctx, scene, so);

  // Warm up, and the frame time without reloads.
  std::vector<double> frame_ms, gpu_ms;
  for (int i = 0; i < 10; ++i) {
    const auto t0 = Clock::now();
    session.render();
    frame_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    double g = 0;
    for (const auto& t : session.renderer().timings()) g += t.gpu_ms;
    gpu_ms.push_back(g);
  }
  frame_ms.erase(frame_ms.begin(), frame_ms.begin() + 4);
  gpu_ms.erase(gpu_ms.begin(), gpu_ms.begin() + 4);
  const double frame = median(frame_ms);

  std::printf("penumbra-reload-bench on %s\n", ctx.info().name.c_str());
  std::printf(
      "scene %s at %ux%u; frame %.0f ms (GPU %.0f ms), debounce %lld ms; %d edits per "
      "file and mode\n",
      scene.name.c_str(), o.width, o.height, frame, median(gpu_ms),
      static_cast<long long>(session.watcher()->options().debounce.count()), o.edits);
  std::fflush(stdout);

  std::mt19937 rng(std::random_device{}());
  const long salt = long(std::uniform_int_distribution<int>(1, 400000)(rng)) * 20;
  std::vector<Row> rows;
  for (const auto& t : targets()) {
    if (!o.only.empty() && std::find(o.only.begin(), o.only.end(), t.file) == o.only.end())
      continue;
    const fs::path file = fs::weakly_canonical(shaders / t.file);
    const std::string original = read_text(file);
    struct Mode {
      const char* edit;  // "new code" or "undo/redo"
      bool continuous;   // frames keep running (a windowed viewer) or render on change (--watch)
    };
    long unique = salt;
    for (const Mode mode : {Mode{"new code", true}, Mode{"undo/redo", true},
                            Mode{"new code", false}, Mode{"undo/redo", false}}) {
      const bool fresh = std::string(mode.edit) == "new code";
      Row row{t.file, std::string(mode.edit) + (mode.continuous ? ", frame loop" : ", on change"),
              {},     {},
              {},     {},
              {}};
      for (int i = 0; i < o.edits; ++i) {
        const long k = fresh ? ++unique : 1 + (i % 2);
        const std::string text = replaced(original, t.needle, t.edit(k), t.file);
        const penumbra::runtime::ReloadRecord* done = nullptr;
        std::optional<penumbra::runtime::ReloadRecord> idle;
        if (mode.continuous) {
          // The save lands at a random moment of a frame, as when typing next to a live viewer.
          const size_t before = session.reloads().size();
          const auto delay = std::chrono::microseconds(
              std::uniform_int_distribution<long>(0, long(frame * 1000))(rng));
          std::thread editor([&] {
            std::this_thread::sleep_for(delay);
            write_text(file, text);
          });
          const auto deadline = Clock::now() + std::chrono::seconds(30);
          while (!done && Clock::now() < deadline) {
            session.render();
            for (size_t r = before; r < session.reloads().size(); ++r) {
              const auto& rec = session.reloads()[r];
              if (rec.latency_ms &&
                  std::find(rec.changed.begin(), rec.changed.end(), file) != rec.changed.end())
                done = &rec;
            }
          }
          editor.join();
        } else {
          // penumbra-view --watch: idle until a save, then reload and render one frame.
          write_text(file, text);
          idle = session.wait_reload(std::chrono::seconds(30), file);
          if (idle && idle->latency_ms) done = &*idle;
        }
        if (!done) throw Error(t.file + ": the edit was not reloaded within 30 s");
        if (!done->result.ok())
          throw Error(t.file + ": the edit failed to compile: " + session.error_text());
        row.latency.push_back(*done->latency_ms);
        row.waited.push_back(done->waited_ms);
        row.reload.push_back(done->reload_ms);
        row.frame.push_back(*done->latency_ms - done->waited_ms - done->reload_ms);
        if (row.rebuilt.empty()) {
          for (const auto& n : done->result.rebuilt)
            row.rebuilt += (row.rebuilt.empty() ? "" : ", ") + n.substr(0, n.find(' '));
        }
      }
      rows.push_back(row);
      std::printf(
          "  %-22s %-25s latency %4.0f ms (%.2f steady frames; min %4.0f, p99 %4.0f, max %4.0f)"
          "  waited %4.0f  reload %4.0f  frame %4.0f   rebuilt: %s\n",
          row.file.c_str(), row.mode.c_str(), median(row.latency), median(row.latency) / frame,
          *std::min_element(row.latency.begin(), row.latency.end()),
          penumbra::stats::quantile(row.latency, 0.99),
          *std::max_element(row.latency.begin(), row.latency.end()), median(row.waited),
          median(row.reload), median(row.frame), row.rebuilt.c_str());
      std::fflush(stdout);
    }
    write_text(file, original);  // restored; reloaded with the next frames
    for (int i = 0; i < 3; ++i) session.render();
  }
  std::printf(
      "(medians over %d edits; latency = file event -> end of the first frame with the "
      "new pipelines = waited (debounce + the frame in flight) + reload (compile + "
      "pipelines) + frame)\n",
      o.edits);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra-reload-bench: error: %s\n", e.what());
    return 1;
  }
}
