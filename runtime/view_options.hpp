#pragma once
// penumbra-view's command line: its options, their parsing and checks (every value is checked
// with an error naming the flag), and the names of --view and --filter (the parameter table's
// choices).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <penumbra/scene/scene.hpp>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "watcher.hpp"

namespace penumbra::runtime {

struct Options {
  std::string scene = "default";
  bool headless = false;
  uint32_t frames = 0;  // 0: the scene's [render] frames
  std::filesystem::path out;
  std::string view;  // empty: lit plus every debug view
  std::string filter;
  uint32_t width = 0, height = 0;
  bool list_devices = false;
  bool list_params = false;
  std::filesystem::path shader_dir;  // empty: the repo's shaders/
  bool watch = false;
  bool truth = false;  // --truth: deltas against the ray-traced truth after every reload
  std::string truth_flicker;  // --truth-flicker PATH: and the flicker along that camera path
  bool exit_after_frames = false;  // window: close after --frames presented frames
  bool ui = true;                  // window: the Dear ImGui parameter panel
  bool ui_rows = false;            // window: print the panel's rows (--ui-rows)
  uint32_t debounce_ms = uint32_t(penumbra::runtime::kDefaultDebounce.count());
  // Automation: --script FILE ("-": stdin) and --command LINE, in the order given.
  std::vector<std::pair<std::string, std::string>> scripts;  // (kind, file or line)
  std::vector<std::pair<std::string, std::string>> sets;     // --set KEY=VALUE, in order
  std::optional<glm::dvec3> move;  // --move X,Y,Z: the whole scene moved (translate_scene)
};

// The names of --view and --filter: the parameter table's choices, in their order.
const std::vector<std::string>& views();
const std::vector<std::string>& filters();
// The debug view of a --view name (checked against views() when the flag is read).
scene::DebugView view_of(const std::string& name);
// Parses and checks argv; throws penumbra::Error naming the flag and value. --help prints the
// usage and exits.
Options parse_options(int argc, char** argv);

}  // namespace penumbra::runtime
