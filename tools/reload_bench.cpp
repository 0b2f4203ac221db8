// penumbra-reload-bench: hot-reload latency of penumbra-view, from the file event (when the
// watcher saw the save) to the end of the first frame rendered with the rebuilt pipelines.
//
// On a copy of the shader tree, each file is edited --edits times in four ways:
//   new code    every save puts a constant never compiled before into the code (new to the run),
//               so the driver compiles the changed pipelines from scratch;
//   undo/redo   the saves alternate between two versions, so after the first two the driver's
//               shader cache (Mesa's, on disk) holds both: what tweaking back and forth costs;
// each with
//   frame loop  frames keep running, as in a windowed viewer; the save lands at a random moment
//               of a frame (a second thread) and is reloaded between two frames;
//   on change   the viewer idles until a save, then reloads and renders (penumbra-view --watch).
// Prints medians (the latency and its parts) per file and mode, the median latency in steady
// frames (the median frame before the edits) and its p99, and the device name.
//
// By default four files with hand-picked edits (below). --all edits every file of the shader
// tree's penumbra/ and render/: each in the first scene (of the shipped ones, and the default
// scene with the PCSS and EVSM filters) whose pipelines read it, by moving one float literal of
// its code (the first inside a function body, else a global constant's) by a few ulps per save;
// a file with no literal gets a comment. The row says when the SPIR-V did not change (the edit
// reaches no code the scene compiles). The driver's shader caches (Mesa's, NVIDIA's) are pointed
// at a fresh directory for the run, so "never compiled before" holds without salting the edits.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <optional>
#include <penumbra/core/error.hpp>
#include <penumbra/core/stats.hpp>
#include <penumbra/gpu/context.hpp>
#include <penumbra/gpu/validation.hpp>
#include <penumbra/render/contact_shadows.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "cli.hpp"
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

// Where a file is edited: a scene, and parameter sets that make its pipelines read the file.
struct Setting {
  std::string scene;
  std::vector<std::pair<std::string, std::string>> sets;
  std::string label() const {
    std::string l = scene;
    for (const auto& [k, v] : sets) l += " " + k + "=" + v;
    return l;
  }
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

// The float literals (digits '.' digits) of code in a GLSL text, as (offset, length): those inside
// a function body (brace depth > 0) first, then those at file scope; comments and preprocessor
// lines are skipped.
std::vector<std::pair<size_t, size_t>> float_literals(const std::string& text) {
  std::vector<std::pair<size_t, size_t>> body, global;
  int depth = 0;
  bool line_start = true;
  for (size_t i = 0; i < text.size();) {
    const char c = text[i];
    if (c == '/' && i + 1 < text.size() && text[i + 1] == '/') {
      i = text.find('\n', i);
      if (i == std::string::npos) break;
      continue;
    }
    if (c == '/' && i + 1 < text.size() && text[i + 1] == '*') {
      i = text.find("*/", i + 2);
      if (i == std::string::npos) break;
      i += 2;
      continue;
    }
    if (line_start && c == '#') {  // a preprocessor line (#define values are not code)
      i = text.find('\n', i);
      if (i == std::string::npos) break;
      continue;
    }
    if (c == '\n')
      line_start = true;
    else if (c != ' ' && c != '\t')
      line_start = false;
    if (c == '{') ++depth;
    if (c == '}') --depth;
    const bool word_before = i > 0 && (std::isalnum(static_cast<unsigned char>(text[i - 1])) ||
                                       text[i - 1] == '_' || text[i - 1] == '.');
    if (std::isdigit(static_cast<unsigned char>(c)) && !word_before) {
      size_t j = i;
      while (j < text.size() && std::isdigit(static_cast<unsigned char>(text[j]))) ++j;
      if (j + 1 < text.size() && text[j] == '.' &&
          std::isdigit(static_cast<unsigned char>(text[j + 1]))) {
        size_t end = j + 1;
        while (end < text.size() && std::isdigit(static_cast<unsigned char>(text[end]))) ++end;
        (depth > 0 ? body : global).push_back({i, end - i});
      }
      i = j;
      continue;
    }
    ++i;
  }
  body.insert(body.end(), global.begin(), global.end());
  return body;
}

// A new-code edit of any file: its n-th float literal (float_literals' order) moved by a
// relative 2^-22 per step (a distinct float for every save, far below what a shadow shows), or
// a comment when it has none.
Target auto_target(const std::string& rel, const std::string& text, size_t n = 0) {
  const auto literals = float_literals(text);
  if (literals.empty()) {
    const std::string first_line = text.substr(0, text.find('\n'));
    return {rel, first_line,
            [first_line](long k) { return first_line + " // edit " + std::to_string(k); },
            "a comment (no float literal in its code)"};
  }
  const auto [at, len] = literals[std::min(n, literals.size() - 1)];
  // The literal with a little context, so the needle is unique in the file.
  size_t from = at, to = at + len;
  while (text.find(text.substr(from, to - from)) != from && (from > 0 || to < text.size())) {
    if (from > 0) --from;
    if (to < text.size()) ++to;
  }
  const std::string needle = text.substr(from, to - from);
  const std::string before = text.substr(from, at - from),
                    after = text.substr(at + len, to - at - len);
  const double value = std::stod(text.substr(at, len));
  char what[96];
  std::snprintf(what, sizeof what, "the literal %s (line %zu)", text.substr(at, len).c_str(),
                size_t(std::count(text.begin(), text.begin() + long(at), '\n')) + 1);
  return {rel, needle,
          [before, after, value](long k) {
            char b[48];
            const double moved =
                value == 0.0 ? double(k) * 1e-20 : value * (1.0 + double(k) * std::ldexp(1.0, -22));
            std::snprintf(b, sizeof b, "%.9g", moved);
            std::string lit = b;
            if (lit.find_first_of(".e") == std::string::npos) lit += ".0";
            return before + lit + after;
          },
          what};
}

struct Options {
  std::string scene;  // empty: default (--all: the first setting that reads each file)
  uint32_t width = 640, height = 360;
  int edits = 10;
  std::vector<std::string> only;  // file filter
  fs::path shader_dir;            // the tree to copy; empty: the repo's shaders/
  bool all = false;               // every file of penumbra/ and render/
  std::vector<std::string> modes{"new-loop", "undo-loop", "new-change", "undo-change"};
  bool late_compile = false;  // compile a burst only once the debounce has handed it out
};

Options parse(int argc, char** argv) {
  Options o;
  penumbra::cli::Command app(
      "penumbra-reload-bench",
      "Hot-reload latency: file event -> end of the first frame with the new pipelines.");
  app.footer(
      "Defaults: the default scene at 640x360, 10 edits per file and mode, four files with "
      "hand-picked edits (penumbra/pcf.glsl, penumbra/shadow.glsl, penumbra/noise.glsl, "
      "contact_shadows.comp); --all: every file (docs/hot-reload.md).");
  app.option(
      "--scene", [&](const std::string& v) { o.scene = v; },
      "the scene (with --all: only this one, instead of the first that reads each file)");
  app.option(
      "--size",
      [&](const std::string& v) {
        std::tie(o.width, o.height) = penumbra::cli::size("--size", v, 16, 16384);
      },
      "the render size (default 640x360)");
  app.flag("--late-compile", o.late_compile,
           "compile a save only once the debounce is over (the runtime compiles it while the "
           "debounce runs: this measures what that saves)");
  app.option(
      "--edits",
      [&](const std::string& v) { o.edits = int(penumbra::cli::whole("--edits", v, 2, 100000)); },
      "saves per file and mode (default 10)");
  app.option(
      "--file", [&](const std::string& v) { o.only.push_back(v); },
      "only this file (repeatable); with --all any file under penumbra/ or render/");
  app.option(
      "--shader-dir", [&](const std::string& v) { o.shader_dir = v; },
      "the shader tree to copy and edit (default: the repo's shaders/)");
  app.flag("--all", o.all,
           "every file of the tree's penumbra/ and render/, each in the first setting that "
           "reads it (default, indoor, space, grazing, then the default scene with the pcss "
           "and evsm2 filters, then an analytic-sphere test scene)");
  app.option(
      "--modes",
      [&](const std::string& v) {
        o.modes.clear();
        std::stringstream in(v);
        for (std::string m; std::getline(in, m, ',');)
          o.modes.push_back(penumbra::cli::one_of(
              "--modes", m, {"new-loop", "undo-loop", "new-change", "undo-change"}));
        if (o.modes.empty()) throw Error("--modes: expected at least one mode");
      },
      "of new-loop, undo-loop, new-change, undo-change (default: all four)");
  app.parse(argc, argv);
  return o;
}

struct Row {
  std::string file, mode;
  std::vector<double> latency, waited, reload, frame;
  std::string rebuilt;
  int same_spirv = 0;  // edits after which every rebuilt program kept its SPIR-V
  int during_frame = 0;  // edits compiled while a frame ran (the frame loop)
  int early = 0;         // edits compiled while their burst settled (before the debounce ended)
};

penumbra::scene::Scene scene_for(const Setting& setting) {
  auto scene = penumbra::scene::load_scene(penumbra::scene::find_scene(setting.scene));
  penumbra::scene::set_params(scene, setting.sets);
  return scene;
}

// A setting's pipelines, built once to see which files they read and whether an edit of a
// file changes their SPIR-V.
struct Probe {
  Setting setting;
  std::unique_ptr<penumbra::runtime::Session> session;
  std::set<std::string> read;  // relative to the tree

  Probe(penumbra::gpu::Context& ctx, const fs::path& shaders, Setting s, uint32_t width,
        uint32_t height)
      : setting(std::move(s)) {
    penumbra::runtime::SessionOptions so;
    so.shader_dir = shaders;
    so.width = width;
    so.height = height;
    so.watch = false;
    so.log = [](const std::string&) {};
    session = std::make_unique<penumbra::runtime::Session>(ctx, scene_for(setting), so);
    const fs::path root = fs::weakly_canonical(shaders);
    for (const auto& f : session->renderer().shader_files())
      read.insert(fs::relative(f, root).generic_string());
  }
  // Whether the edit changes the SPIR-V of a pipeline that reads the file (the file is put back).
  bool changes_code(const fs::path& file, const std::string& original, const std::string& edited) {
    write_text(file, edited);
    const auto rec = session->reload({file});
    write_text(file, original);
    session->reload({file});
    return rec.result.ok() && rec.result.same_spirv.size() < rec.result.rebuilt.size();
  }
};

// Every edit of one file in each mode, on a running session.
void measure(penumbra::runtime::Session& session, const fs::path& shaders, const Target& t,
             const Options& o, double frame, std::mt19937& rng) {
  const fs::path file = fs::weakly_canonical(shaders / t.file);
  const std::string original = read_text(file);
  long unique = 0;  // the run's own driver caches: new values only need to be new in the run
  for (const std::string& mode : o.modes) {
    const bool fresh = mode.rfind("new", 0) == 0;
    const bool continuous = mode.find("loop") != std::string::npos;
    Row row;
    row.file = t.file;
    row.mode = std::string(fresh ? "new code" : "undo/redo") +
               (continuous ? ", frame loop" : ", on change");
    for (int i = 0; i < o.edits; ++i) {
      const long k = fresh ? ++unique : 1 + (i % 2);
      const std::string text = replaced(original, t.needle, t.edit(k), t.file);
      const penumbra::runtime::ReloadRecord* done = nullptr;
      std::optional<penumbra::runtime::ReloadRecord> idle;
      if (continuous) {
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
      if (done->result.same_spirv.size() == done->result.rebuilt.size()) ++row.same_spirv;
      if (done->during_frame) ++row.during_frame;
      if (done->compiled_early) ++row.early;
      if (row.rebuilt.empty()) {
        for (const auto& n : done->result.rebuilt)
          row.rebuilt += (row.rebuilt.empty() ? "" : ", ") + n.substr(0, n.find(' '));
      }
    }
    std::string note;
    if (row.same_spirv == o.edits)
      note = "  (SPIR-V unchanged)";
    else if (row.same_spirv > 0)
      note = "  (SPIR-V unchanged in " + std::to_string(row.same_spirv) + ")";
    std::printf(
        "  %-34s %-25s latency %4.0f ms (%.2f steady frames; min %4.0f, p99 %4.0f, max %4.0f)"
        "  waited %4.0f  reload %4.0f  frame %4.0f  in a frame %2d/%-2d  early %2d/%-2d"
        "  rebuilt: %s%s\n",
        row.file.c_str(), row.mode.c_str(), median(row.latency), median(row.latency) / frame,
        *std::min_element(row.latency.begin(), row.latency.end()),
        penumbra::stats::quantile(row.latency, 0.99),
        *std::max_element(row.latency.begin(), row.latency.end()), median(row.waited),
        median(row.reload), median(row.frame), row.during_frame, o.edits, row.early, o.edits,
        row.rebuilt.c_str(), note.c_str());
    std::fflush(stdout);
  }
  write_text(file, original);  // restored, and reloaded before the next file's first edit
  session.wait_reload(std::chrono::seconds(30), file);
  for (int i = 0; i < 3; ++i) session.render();
}

std::vector<std::string> tree_files(const fs::path& shaders) {
  std::vector<std::string> out;
  for (const char* dir : {"penumbra", "render"})
    for (const auto& e : fs::directory_iterator(shaders / dir))
      if (e.is_regular_file()) out.push_back(std::string(dir) + "/" + e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

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
  // The drivers' shader caches in this run's directory (read when the driver loads): a new-code
  // save is new to them, an undo is cached after its first compile.
  fs::create_directories(root / "driver-cache");
  const std::string cache = (root / "driver-cache").string();
  setenv("MESA_SHADER_CACHE_DIR", cache.c_str(), 1);
  setenv("__GL_SHADER_DISK_CACHE_PATH", cache.c_str(), 1);

  penumbra::gpu::Context ctx;
  std::printf("penumbra-reload-bench on %s\n", ctx.info().name.c_str());

  // What to edit, and where.
  std::vector<std::pair<Setting, std::vector<Target>>> plan;
  if (!o.all) {
    std::vector<Target> chosen;
    for (const auto& t : targets())
      if (o.only.empty() || std::find(o.only.begin(), o.only.end(), t.file) != o.only.end())
        chosen.push_back(t);
    plan.push_back({Setting{o.scene.empty() ? "default" : o.scene, {}}, chosen});
  } else {
    std::vector<Setting> settings;
    if (!o.scene.empty()) {
      settings = {{o.scene, {}}};
    } else {
      settings = {{"default", {}},
                  {"indoor", {}},
                  {"space", {}},
                  {"grazing", {}},
                  {"default", {{"shadows.filter", "pcss"}}},
                  {"default", {{"shadows.filter", "evsm2"}}}};
#ifdef PENUMBRA_TEST_SCENES
      // Analytic sphere shadows: a test scene of the source tree (no shipped scene has them).
      const fs::path orrery = fs::path(PENUMBRA_TEST_SCENES) / "orrery.toml";
      if (fs::exists(orrery)) settings.push_back({orrery.string(), {}});
#endif
    }
    std::vector<std::string> files = tree_files(shaders);
    if (!o.only.empty()) {
      for (const auto& f : o.only)
        if (std::find(files.begin(), files.end(), f) == files.end())
          throw Error("--file " + f + ": not a file of the tree's penumbra/ or render/");
      files = o.only;
    }
    // Each setting's pipelines, built when a file first needs them (in order: --file F often
    // needs the default scene's alone).
    std::vector<std::unique_ptr<Probe>> built(settings.size());
    auto probe = [&](size_t i) -> Probe& {
      if (!built[i])
        built[i] = std::make_unique<Probe>(ctx, shaders, settings[i], o.width, o.height);
      return *built[i];
    };
    // Each file in the first setting where its edit changes code, else the first that reads it.
    std::vector<std::vector<Target>> chosen(settings.size());
    std::vector<std::string> unread;
    for (const auto& f : files) {
      const fs::path file = fs::weakly_canonical(shaders / f);
      const std::string original = read_text(file);
      // Up to 4 of its literals in each setting that reads it.
      const size_t tries =
          std::min<size_t>(4, std::max<size_t>(1, float_literals(original).size()));
      std::optional<Target> first;
      int pick = -1;
      for (size_t i = 0; i < settings.size() && pick < 0; ++i) {
        if (!probe(i).read.count(f)) continue;
        for (size_t n = 0; n < tries && pick < 0; ++n) {
          const Target t = auto_target(f, original, n);
          if (!first) first = t, pick = -2 - int(i);  // the fallback: the first that reads it
          if (t.what.rfind("a comment", 0) == 0) break;
          // k = -1: a value the measured edits (k >= 1) never use.
          if (probe(i).changes_code(file, original, replaced(original, t.needle, t.edit(-1), f))) {
            chosen[i].push_back(t);
            pick = int(i);
          }
        }
      }
      if (!first)
        unread.push_back(f);
      else if (pick < 0)
        chosen[size_t(-2 - pick)].push_back(*first);
    }
    for (size_t i = 0; i < settings.size(); ++i)
      if (!chosen[i].empty()) plan.push_back({settings[i], chosen[i]});
    built.clear();
    for (const auto& f : unread)
      std::printf("  %-34s read by no pipeline of the settings tried: not measured\n", f.c_str());
  }

  std::mt19937 rng(std::random_device{}());
  for (const auto& [setting, chosen] : plan) {
    penumbra::runtime::SessionOptions so;
    so.shader_dir = shaders;
    so.width = o.width;
    so.height = o.height;
    so.compile_early = !o.late_compile;
    so.log = [](const std::string&) {};
    penumbra::runtime::Session session(ctx, scene_for(setting), so);
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
    std::printf(
        "scene %s at %ux%u; frame %.0f ms (GPU %.0f ms), debounce %lld ms; %d edits per "
        "file and mode\n",
        setting.label().c_str(), o.width, o.height, frame, median(gpu_ms),
        static_cast<long long>(session.watcher()->options().debounce.count()), o.edits);
    for (const Target& t : chosen)
      std::printf("  %-34s edit: %s\n", t.file.c_str(), t.what.c_str());
    std::fflush(stdout);
    for (const Target& t : chosen) measure(session, shaders, t, o, frame, rng);
  }
  std::printf(
      "(medians over %d edits; latency = file event -> end of the first frame with the "
      "new pipelines = waited (until the compile began: the debounce, or with early compiles "
      "the first look at the burst; in the frame loop, for a save seen between frames, the rest "
      "of the frame in flight too) + reload (compile + pipelines, until swapped in: after the "
      "debounce, and for a compile in a frame after that frame) + frame; in a frame: saves "
      "compiled while a frame ran; early: saves compiled while the debounce ran)\n",
      o.edits);
  if (ctx.validation_enabled()) {  // PENUMBRA_VALIDATION=1: any message fails the run
    const auto messages = ctx.validation_sink().take();
    std::printf("validation: %zu messages\n", messages.size());
    for (const auto& m : messages)
      std::fprintf(stderr, "  %s\n", penumbra::gpu::to_string(m).c_str());
    if (!messages.empty()) return 1;
  }
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
