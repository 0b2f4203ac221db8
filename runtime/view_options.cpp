// penumbra-view's command line (view_options.hpp).
#include "view_options.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <penumbra/reference/temporal.hpp>
#include <penumbra/scene/params.hpp>
#include <stdexcept>
#include <tuple>

#include "cli.hpp"

namespace penumbra::runtime {
namespace {
namespace fs = std::filesystem;

// The parameter table's choices of a key, in their order.
const std::vector<std::string>& choices(std::string_view key) {
  static std::map<std::string, std::vector<std::string>> cache;
  auto& out = cache[std::string(key)];
  if (out.empty())
    for (std::string_view c : penumbra::scene::param(key).choices) out.emplace_back(c);
  return out;
}

std::string keys(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& k : names) s += (s.empty() ? "" : ", ") + k;
  return s;
}

}  // namespace

const std::vector<std::string>& views() {
  return choices("render.view");
}
const std::vector<std::string>& filters() {
  return choices("shadows.filter");
}

scene::DebugView view_of(const std::string& name) {
  const auto& v = views();
  return static_cast<scene::DebugView>(std::find(v.begin(), v.end(), name) - v.begin());
}

namespace {

// A directory for --shader-dir, or an error saying what the path is instead.
void check_shader_dir(const fs::path& dir) {
  std::error_code ec;
  if (fs::is_directory(dir, ec)) return;
  const std::string problem = penumbra::file_problem(dir);
  throw Error("--shader-dir " + penumbra::printable(dir.string()) + ": " +
              (problem == "not found" ? problem
               : problem.empty()      ? std::string("is a file, not a directory")
                                 : problem.substr(0, problem.find(',')) + ", not a directory"));
}

// A script file for --script: a regular file or a pipe (--script <(...)), or "-" (stdin); a
// directory or a device (/dev/zero would be read for ever) is refused, saying which.
void check_script(const std::string& file) {
  if (const std::string problem = penumbra::file_problem(file);
      file != "-" && !problem.empty() && problem.find("FIFO") == std::string::npos) {
    throw Error("--script " + penumbra::printable(file) + ": " +
                (problem == "not found"
                     ? std::string("no such file")
                     : problem.substr(0, problem.find(',')) + ", not a script file"));
  }
}

}  // namespace

Options parse_options(int argc, char** argv) {
  Options o;
  penumbra::cli::Command app("penumbra-view",
                             "Renders a scene's shadows; live, it hot-reloads its shaders.");
  app.footer(
      "Window mode (a display and no --headless): the live view with hot reload; left drag\n"
      "orbits, right drag looks, WASD/QE fly (Shift: faster), scroll zooms, V / F cycle the\n"
      "view / filter, R resets the camera, T the truth's heat maps, Esc closes.\n"
      "Environment: PENUMBRA_DEVICE=lavapipe|gpu|<index>|<name>, PENUMBRA_VALIDATION=1");
  app.option(
      "--scene", [&](const std::string& v) { o.scene = v; },
      "a shipped scene (default, grazing, space, indoor) or a .toml file");
  app.flag("--headless", o.headless,
           "render offscreen and write PNGs (the default when there is no display)");
  app.option(
      "--frames", [&](const std::string& v) { o.frames = cli::whole("--frames", v, 1, 10000); },
      "frames to render, 1 to 10000 (render.frames' range)");
  app.option(
      "--out", [&](const std::string& v) { o.out = v; },
      "where PNGs and timings go (default out/<scene name>; an existing directory is "
      "reused and its files of the same names replaced)");
  app.option(
      "--view", [&](const std::string& v) { o.view = cli::one_of("--view", v, views()); },
      keys(views()) + " (default: lit, then every debug view)");
  app.option(
      "--filter", [&](const std::string& v) { o.filter = cli::one_of("--filter", v, filters()); },
      keys(filters()) + " (default: the scene's)");
  // The scene file's range for render.width and render.height; the device's own limits are
  // checked once it is known (check_size).
  app.option(
      "--size",
      [&](const std::string& v) {
        std::tie(o.width, o.height) = cli::size("--size", v, 16, 16384);
      },
      "the render size, each side 16 to 16384 (default: the scene's)");
  app.flag("--list-devices", o.list_devices, "list the Vulkan devices and exit");
  app.flag("--list-params", o.list_params,
           "print the parameter table as JSON (key, type, range, choices, doc, default) with "
           "the scene's values after --set, and exit");
  app.option(
      "--shader-dir",
      [&](const std::string& v) {
        o.shader_dir = v;
        check_shader_dir(o.shader_dir);
      },
      "a shader tree to compile and watch over the library (the repo's or the installed "
      "shaders/): files in DIR win, the rest are read from the library");
  app.flag("--watch", o.watch,
           "after the frames, keep running: shader edits are hot-reloaded and the view's PNG "
           "rewritten after each (Ctrl-C stops)");
  app.flag("--truth", o.truth,
           "after every reload, the GPU ms and the error against the ray-traced truth (per "
           "light: mean |dV|, false light and shadow, acne, contact gap) before -> after, "
           "and each light's error heat map; the truth is traced once. Window: a table of "
           "the last saves in the panel, T shows the heat maps; headless: needs --watch, "
           "prints them and writes truth-error*.png");
  app.option(
      "--truth-flicker",
      [&](const std::string& v) {
        o.truth_flicker = v;
        penumbra::reference::find_path(o.truth_flicker);  // an unknown path names the known ones
        o.truth = true;
      },
      "--truth, and the flicker and error along a camera path (translate-1mm, translate-1cm, "
      "yaw-0.05deg, sun-0.05deg)");
  app.option(
      "--debounce-ms",
      [&](const std::string& v) { o.debounce_ms = cli::whole("--debounce-ms", v, 0, 60000); },
      "quiet time that ends a burst of file events (default 15)");
  app.flag("--exit-after-frames", o.exit_after_frames,
           "window mode: close after --frames N presented frames");
  app.flag("!--no-ui", o.ui, "window mode without the parameter panel (Dear ImGui)");
  app.flag("--ui-rows", o.ui_rows,
           "window mode: print the panel's rows, group by group, when they change");
  app.option(
      "--script",
      [&](const std::string& v) {
        check_script(v);
        o.scripts.emplace_back("script", v);
      },
      "run automation commands from FILE ('-': stdin) instead of the default frames; --command "
      "LINE runs one (both may repeat, in order). Commands: scene, size, set KEY VALUE, get, "
      "view, frame, render [N], screenshot PATH.png, timings, reload, wait_reload [MS], edit "
      "FILE [MS], replace FILE OLD NEW, expect_reload_ok, expect_reload_error TEXT, "
      "expect_rebuilt NAME..., echo, quit (docs/hot-reload.md)");
  app.option(
      "--command", [&](const std::string& v) { o.scripts.emplace_back("command", v); },
      "one automation command (as in --script)");
  app.option(
      "--set", [&](const std::string& v) { o.sets.push_back(penumbra::scene::split_set_flag(v)); },
      "override a parameter-table key after loading, e.g. --set shadows.resolution=4096 "
      "(docs/scenes.md lists the keys)");
  app.option(
      "--move",
      [&](const std::string& v) {
        const auto m = cli::triple("--move", v);
        o.move = glm::dvec3(m[0], m[1], m[2]);
      },
      "move the whole scene (objects, lights, camera) by X,Y,Z metres after loading: the same "
      "world far from the origin",
      "X,Y,Z");
  app.parse(argc, argv);
  if (o.move && !o.scripts.empty())
    throw Error("--move does not combine with --script or --command");
  if (!o.sets.empty() && !o.scripts.empty())
    throw Error(
        "--set does not combine with --script or --command (use the command 'set KEY "
        "VALUE' there)");
  if (o.truth && !o.scripts.empty())
    throw Error("--truth reports what each reload did: it does not combine with --script");
  if (o.truth && o.headless && !o.watch)
    throw Error("--truth reports what each reload did: headless, it needs --watch");
  return o;
}

}  // namespace penumbra::runtime
