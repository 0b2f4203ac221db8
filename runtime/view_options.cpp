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

bool contains(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

std::string keys(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& k : names) s += (s.empty() ? "" : ", ") + k;
  return s;
}

// A whole number in [lo, hi], or an error naming the flag, the value and the range.
uint32_t parse_uint(const std::string& flag, const std::string& v, uint32_t lo = 0,
                    uint32_t hi = 100000) {
  unsigned long x = 0;
  try {
    size_t used = 0;
    if (v.empty() || v[0] == '-' || v[0] == '+') throw std::invalid_argument(v);
    x = std::stoul(v, &used);
    if (used != v.size()) throw std::invalid_argument(v);
  } catch (const std::exception&) {
    throw Error(flag + " " + v + ": expected a whole number in [" + std::to_string(lo) + ", " +
                std::to_string(hi) + "]");
  }
  if (x < lo || x > hi) {
    throw Error(flag + " " + v + ": out of range; must be in [" + std::to_string(lo) + ", " +
                std::to_string(hi) + "]");
  }
  return static_cast<uint32_t>(x);
}

void usage() {
  std::printf(
      "usage: penumbra-view [--scene NAME|FILE] [--headless] [--frames N] [--out DIR]\n"
      "                     [--view VIEW] [--filter FILTER] [--size WxH] [--list-devices]\n"
      "                     [--list-params]\n"
      "                     [--shader-dir DIR] [--watch] [--truth] [--debounce-ms N]\n"
      "                     [--exit-after-frames] [--no-ui] [--ui-rows]\n"
      "                     [--script FILE|-] [--command LINE]... [--set KEY=VALUE]...\n"
      "  --scene       a shipped scene (default, grazing, space, indoor) or a .toml file\n"
      "  --headless    render offscreen and write PNGs (the default when there is no display)\n"
      "  window mode   (a display and no --headless): the live view with hot reload; left drag\n"
      "                orbits, right drag looks, WASD/QE fly (Shift: faster), scroll zooms,\n"
      "                V / F cycle the view / filter, R resets the camera, Esc closes\n"
      "  --exit-after-frames  window mode: close after --frames N presented frames\n"
      "  --no-ui       window mode without the parameter panel (Dear ImGui)\n"
      "  --ui-rows     window mode: print the panel's rows, group by group, when they change\n"
      "  --out         where PNGs and timings go (default out/<scene name>; an existing\n"
      "                directory is reused and its files of the same names replaced)\n"
      "  --view        %s (default: lit, then every debug view)\n"
      "  --filter      %s (default: the scene's)\n"
      "  --set         override a parameter-table key after loading, e.g.\n"
      "                --set shadows.pcf_radius=2 (docs/scenes.md lists the keys)\n"
      "  --list-params print the parameter table as JSON (key, type, range, choices, doc,\n"
      "                default) with the scene's values after --set, and exit\n"
      "  --shader-dir  a shader tree to compile and watch over the library (the repo's or the\n"
      "                installed shaders/): files in DIR win, the rest are read from the library\n"
      "  --watch       after the frames, keep running: shader edits are hot-reloaded and the\n"
      "                view's PNG rewritten after each (Ctrl-C stops)\n"
      "  --truth       after every reload, the GPU ms and the error against the ray-traced\n"
      "                truth (per light: mean |dV|, false light and shadow, acne, contact gap)\n"
      "                before -> after, and each light's error heat map; the truth is traced\n"
      "                once. Window: a table of the last saves in the panel, T shows the heat\n"
      "                maps; headless: needs --watch, prints them and writes truth-error*.png\n"
      "  --truth-flicker PATH  --truth, and the flicker and error along a camera path\n"
      "                (translate-1mm, translate-1cm, yaw-0.05deg, sun-0.05deg)\n"
      "  --debounce-ms quiet time that ends a burst of file events (default 15)\n"
      "  --script      run automation commands from FILE ('-': stdin) instead of the default\n"
      "                frames; --command LINE runs one (both may repeat, in order). Commands:\n"
      "                scene, size, set KEY VALUE, get, view, frame, render [N], screenshot\n"
      "                PATH.png, timings, reload, wait_reload [MS], edit FILE [MS], replace FILE\n"
      "                OLD NEW, expect_reload_ok, expect_reload_error TEXT, expect_rebuilt\n"
      "                NAME..., echo, quit (docs/hot-reload.md)\n"
      "  PENUMBRA_DEVICE=lavapipe|gpu|<index>|<name>, PENUMBRA_VALIDATION=1\n",
      keys(views()).c_str(), keys(filters()).c_str());
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

Options parse_options(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw Error(a + ": missing value");
      return argv[++i];
    };
    if (a == "--scene")
      o.scene = value();
    else if (a == "--headless")
      o.headless = true;
    else if (a == "--frames")
      o.frames = parse_uint(a, value(), 1, 10000);  // render.frames' range
    else if (a == "--out")
      o.out = value();
    else if (a == "--view") {
      o.view = value();
      if (!contains(views(), o.view))
        throw Error("--view " + o.view + ": expected one of " + keys(views()));
    } else if (a == "--filter") {
      o.filter = value();
      if (!contains(filters(), o.filter))
        throw Error("--filter " + o.filter + ": expected one of " + keys(filters()));
    } else if (a == "--size") {
      const std::string v = value();
      const auto x = v.find('x');
      if (x == std::string::npos) throw Error("--size " + v + ": expected WxH, e.g. 1280x720");
      // The scene file's range for render.width and render.height; the device's own limits are
      // checked once it is known (check_size).
      o.width = parse_uint("--size " + v + ": width", v.substr(0, x), 16, 16384);
      o.height = parse_uint("--size " + v + ": height", v.substr(x + 1), 16, 16384);
    } else if (a == "--list-devices")
      o.list_devices = true;
    else if (a == "--list-params")
      o.list_params = true;
    else if (a == "--shader-dir") {
      o.shader_dir = value();
      std::error_code ec;
      if (!fs::is_directory(o.shader_dir, ec)) {
        const std::string problem = penumbra::file_problem(o.shader_dir);
        throw Error("--shader-dir " + penumbra::printable(o.shader_dir.string()) + ": " +
                    (problem == "not found" ? problem
                     : problem.empty()
                         ? std::string("is a file, not a directory")
                         : problem.substr(0, problem.find(',')) + ", not a directory"));
      }
    } else if (a == "--watch")
      o.watch = true;
    else if (a == "--truth")
      o.truth = true;
    else if (a == "--truth-flicker") {
      o.truth_flicker = value();
      penumbra::reference::find_path(o.truth_flicker);  // an unknown path names the known ones
      o.truth = true;
    }
    else if (a == "--exit-after-frames")
      o.exit_after_frames = true;
    else if (a == "--ui-rows")
      o.ui_rows = true;
    else if (a == "--no-ui")
      o.ui = false;
    else if (a == "--debounce-ms")
      o.debounce_ms = parse_uint(a, value(), 0, 60000);
    else if (a == "--script") {
      const std::string file = value();
      std::error_code ec;
      // A regular file or a pipe (--script <(...)); a directory or a device (/dev/zero would
      // be read for ever) is refused, saying which.
      if (const std::string problem = penumbra::file_problem(file);
          file != "-" && !problem.empty() && problem.find("FIFO") == std::string::npos) {
        throw Error("--script " + penumbra::printable(file) + ": " +
                    (problem == "not found"
                         ? std::string("no such file")
                         : problem.substr(0, problem.find(',')) + ", not a script file"));
      }
      o.scripts.emplace_back("script", file);
    } else if (a == "--command")
      o.scripts.emplace_back("command", value());
    else if (a == "--set")
      o.sets.push_back(penumbra::scene::split_set_flag(value()));
    else if (a == "--help" || a == "-h") {
      usage();
      std::exit(0);
    } else
      throw Error("unknown argument '" + a + "' (try --help)");
  }
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
