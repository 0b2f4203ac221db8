#pragma once

// penumbra-view's automation mode: one command per line (from --script FILE, stdin or
// --command), run headless against a Session. Blank lines and `#` comments are skipped;
// arguments are separated by spaces, "double quotes" group (with \" \\ \n \t escapes).
//
//   scene NAME|PATH             load a shipped scene or a .toml file (a new renderer)
//   size WxH                    render at this size (a new renderer)
//   set KEY VALUE               a parameter by its scene-file name: shadows.filter pcss,
//                               contact.steps 0, shadows.resolution 4096, camera.position 0,2,6 ...
//   get KEY                     print a parameter
//   view NAME                   lit, shadow_factor, cascades, contact_mask, texel_density, penumbra,
//                               redrawn
//   frame N                     the frame index the noise patterns use (default 0)
//   render [N]                  render N frames (default 1); edits are reloaded before each
//   screenshot PATH.png         the last frame (renders one first if there is none)
//   timings                     print the last frame's per-pass GPU timings
//   reload FILE...              reload these files now (paths relative to the shader dir)
//   wait_reload [TIMEOUT_MS]    wait for an edit that touches a pipeline, reload, render a frame
//   edit FILE [TIMEOUT_MS]      the same, for an (external) edit of FILE
//   replace FILE OLD NEW [TIMEOUT_MS]
//                               edit FILE in the shader tree (first OLD -> NEW, saved
//                               atomically: temp file + rename) and wait for its reload; only
//                               on a copy of the tree (--shader-dir), never the repo's shaders/
//   expect_reload_ok            the last reload succeeded and no pipeline is in error
//   expect_reload_error TEXT    a pipeline is in error and the error text contains TEXT
//   expect_rebuilt NAME...      the last reload rebuilt exactly these pipelines (names, or their
//                               first word: "forward-opaque" matches its variant's full name)
//   echo TEXT                   print TEXT
//   quit                        stop here
//
// Every error (unknown command, key or value, failed expectation, timeout) is a penumbra::Error
// naming the script and line: "check.txt:7: set: unknown parameter 'shadows.filtr' ...".

#include <chrono>
#include <istream>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "session.hpp"

namespace penumbra::runtime {

struct ScriptSetup {
  std::string scene = "default";             // until a `scene` command
  SessionOptions session;                    // shader_dir, size, debounce, log
  std::chrono::milliseconds timeout{10000};  // wait_reload / edit / replace default
  // `set` commands applied to the session when it is created (penumbra-view's --filter, --view).
  std::vector<std::pair<std::string, std::string>> initial_settings;
};

// Splits a command line into arguments (see above). Throws penumbra::Error on an unterminated
// quote.
std::vector<std::string> split_command(const std::string& line);

class Script {
 public:
  Script(gpu::Context& ctx, ScriptSetup setup);
  ~Script();

  // Runs every line of `in`; errors are prefixed with "name:line: ". Returns false when a
  // `quit` was read.
  bool run(std::istream& in, const std::string& name);
  // One line; `where` prefixes errors ("script.txt:3").
  bool run_line(const std::string& line, const std::string& where);

  // The session, created (with the current scene and size) on first use.
  Session& session();
  bool has_session() const { return session_ != nullptr; }

 private:
  bool execute(const std::vector<std::string>& args);
  std::filesystem::path shader_file(const std::string& arg);

  gpu::Context& ctx_;
  ScriptSetup setup_;
  std::unique_ptr<Session> session_;
};

}  // namespace penumbra::runtime
