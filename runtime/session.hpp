#pragma once

// A live penumbra-view session: a scene, its renderer, a watcher on the shader tree and the
// reload loop between frames.
//
//   runtime::Session s(ctx, scene::load_scene(file), {.shader_dir = copy_of_shaders});
//   s.render();                        // polls the watcher first: edits are picked up here
//   s.wait_reload(2000ms);             // or block until the next edit is reloaded (+ 1 frame)
//   s.set("shadows.filter", "pcss");   // parameters, by their scene-file names
//   s.screenshot("out.png");
//
// Reload: the files of a finished burst go to Renderer::reload, which rebuilds exactly the
// pipelines that read them. A pipeline whose new source fails to compile keeps running as it
// was; its error (file:line) stays in errors() until a later reload rebuilds it. The files of a
// failed batch are passed again with every later batch until it succeeds, so fixing an error
// in a file the last good pipeline did not read yet (a new #include) also clears it. Deleted
// files are reported and skipped; their pipelines keep running until the file is back.
//
// Latency: from the moment the watcher saw the first event of a burst to the end of the first
// frame rendered with the rebuilt pipelines.
//
// A burst compiles while it settles: as soon as the watcher sees its first event, the files as
// they stand are compiled (Renderer::prepare_reload, on a worker) while the debounce runs. When
// the burst is handed out with no change after that look (Watcher::change_count), those
// pipelines are swapped in; otherwise they are dropped and the batch compiles again. What is
// swapped in was always read after the burst's last change.

#include <chrono>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <penumbra/gpu/context.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/scene/scene.hpp>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "watcher.hpp"

namespace penumbra::runtime {

struct SessionOptions {
  std::filesystem::path shader_dir;     // empty: the repo's shaders/ (compiled in)
  // Under shader_dir, in order: files shader_dir lacks are read from here (penumbra-view
  // --shader-dir DIR puts the installed library here, so DIR may hold only the files a user
  // changed). Watched too.
  std::vector<std::filesystem::path> library_shader_dirs;
  std::uint32_t width = 0, height = 0;  // 0: the scene's [render] size
  bool watch = true;                    // false: no watcher (reload only through reload())
  bool visibility_output = false;       // the renderer writes each light's visibility (--truth)
  std::chrono::milliseconds debounce = kDefaultDebounce;
  // Compile a burst's files while it settles (see the top); false: only once it is handed out
  // (penumbra-reload-bench --late-compile measures the difference).
  bool compile_early = true;
  // Every line the session prints ("[reload] ..."); default: stdout, flushed.
  std::function<void(const std::string&)> log;
};

// One batch of changed files and what the reload did with it.
struct ReloadRecord {
  std::vector<std::filesystem::path> changed;  // existing files passed to Renderer::reload
  std::vector<std::filesystem::path> deleted;  // gone when polled (only those a pipeline reads)
  render::ReloadResult result;
  // Renderer::reload (compile + pipeline creation); for a burst that finished while a frame ran
  // (compiled during it), until its pipelines were swapped in after that frame.
  double reload_ms = 0.0;
  // First event -> batch handed out: the debounce, and for a burst that finished between
  // frames, the wait for the next poll.
  double waited_ms = 0.0;
  bool during_frame = false;  // compiled while a frame ran, swapped in after it
  // Compiled while the burst settled (before the watcher handed it out): reload_ms counts from
  // the start of that compile, and waited_ms up to it.
  bool compiled_early = false;
  Clock::time_point event;  // the first event of the burst, as the watcher saw it
  std::optional<double> latency_ms;  // event -> end of the first frame with the new pipelines
  // Whether the batch touched a pipeline (rebuilt, failed or lost a file it reads).
  bool relevant() const {
    return !result.rebuilt.empty() || !result.failed.empty() || !deleted.empty();
  }
};

class Session {
 public:
  Session(gpu::Context& ctx, scene::Scene scene, SessionOptions options = {});
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  render::Renderer& renderer() { return *renderer_; }
  const scene::Scene& scene() { return renderer_->scene(); }
  std::filesystem::path shader_dir() const { return shader_dir_; }
  // Where files shader_dir lacks are read from (SessionOptions::library_shader_dirs).
  const std::vector<std::filesystem::path>& library_dirs() const { return library_dirs_; }
  Watcher* watcher() { return watcher_.get(); }

  // Replaces the scene (a new renderer; the size given in the options is kept). On a failure
  // the old scene and renderer stay.
  void load_scene(const scene::Scene& scene);
  // Renders at this size from now on (a new renderer).
  void resize(std::uint32_t width, std::uint32_t height);

  // Sets a parameter by its scene-file name ("shadows.filter", "contact.steps", "camera.position",
  // "render.view", "spot[0].resolution", ...; see keys()). Throws penumbra::Error naming the key and value when the
  // key is unknown or the value invalid. Parameters the frame reads (filters, biases, camera,
  // view) apply to the next frame; those that change what is built (cascades, resolution,
  // contact.*, reverse_z) rebuild the renderer, keeping the old one if that fails.
  void set(const std::string& key, const std::string& value);
  std::string get(const std::string& key);
  // Every settable key of this scene (scene::scene_keys: a light's as spot[0].resolution).
  std::vector<std::string> keys();

  void set_frame_index(std::uint32_t index) { frame_index_ = index; }

  // Polls the watcher (never blocks) and applies a finished burst. Returns the batch applied.
  std::optional<ReloadRecord> poll_reload();
  // Applies these files as if the watcher had reported them (now).
  ReloadRecord reload(const std::vector<std::filesystem::path>& files);
  // Waits up to timeout for a relevant burst (one that touches a pipeline; with `file`, one
  // that contains it), applies it and renders one frame, so the record has its latency.
  // Returns nullopt on timeout.
  std::optional<ReloadRecord> wait_reload(std::chrono::milliseconds timeout,
                                          const std::optional<std::filesystem::path>& file = {});

  // Renders `count` frames; a finished burst of edits is reloaded before each. A burst that
  // finishes while the GPU renders a frame is compiled then, on another thread, and swapped in
  // when the frame is done: the next frame has it (the compile no longer waits for the frame).
  void render(std::uint32_t count = 1);
  bool rendered() const { return rendered_; }
  std::vector<std::uint8_t> pixels();  // the last frame, RGBA8
  void screenshot(const std::filesystem::path& png);

  // The pipelines whose last reload failed and their errors (file:line: error: ...).
  const std::map<std::string, std::string>& errors() const { return errors_; }
  // The errors joined, one per distinct message; empty when every pipeline is good.
  std::string error_text() const;
  const std::vector<ReloadRecord>& reloads() const { return reloads_; }
  // A compile begun while a burst settles is waiting for its batch (see the top).
  bool compiled_early_waiting() const { return early_.has_value(); }
  const ReloadRecord* last_reload() const { return reloads_.empty() ? nullptr : &reloads_.back(); }
  std::vector<double> latencies_ms() const;
  double median_latency_ms() const;

  // "name ms" lines of the last frame's GPU timings.
  std::string timings_text() const;
  void log(const std::string& line) const;
  std::string relative(const std::filesystem::path& file) const;

 private:
  // count: the watcher's change count as of the batch (nullopt: not from the watcher).
  ReloadRecord apply(const std::vector<FileChange>& changes, std::optional<std::uint64_t> count);
  // apply() in steps: the files of a burst (rec.changed; deletions logged unless quiet), then
  // the reload (finish: the compile begun early when it still holds, else one now), then the
  // errors, the retries and the log (conclude).
  ReloadRecord collect(const std::vector<FileChange>& changes, bool quiet = false);
  void finish(ReloadRecord& rec, std::optional<std::uint64_t> count);
  void conclude(ReloadRecord& rec);
  // A compile of a burst's files begun before the batch is handed out (see the top).
  struct Early {
    std::uint64_t count = 0;  // the watcher's change count when the files were read
    std::vector<std::filesystem::path> files;
    Clock::time_point started;
    bool looked = false;  // read from a look at the burst before it was handed out
    bool during_frame = false;
    std::optional<shader::PreparedReload> prepared;
    std::exception_ptr failure;
  };
  // The files of the burst in progress and the count of that look; empty files: nothing to do.
  Early look_at_pending();
  // Makes e the early compile and starts it on a worker (Renderer::prepare_reload into
  // early_); join the worker before anything else touches the renderer or early_.
  std::thread start_early_compile(Early e, bool during_frame);
  // An early compile whose look no change has come after.
  bool early_is_current() const;
  // A reload that threw (a stage file that cannot be read): every pipeline reading one of the
  // files failed with that message, and keeps its last good state.
  void failed(ReloadRecord& rec, const Error& e);
  // Watches the directories of the files the pipelines read outside the shader tree (the
  // targets of symlinked shaders), so editing a target reloads too.
  void watch_outside_files();
  // Outside shader_dir and the library directories (read through a symlink).
  bool outside_tree(const std::filesystem::path& file) const;
  // The directory of shader_dir and the library directories that holds file; empty: none.
  std::filesystem::path layer_of(const std::filesystem::path& file) const;
  // A library file that shader_dir has a file of the same name for.
  bool shadowed(const std::filesystem::path& file) const;
  // For a file of shader_dir, the library's file of the same name, when there is one.
  std::optional<std::filesystem::path> library_counterpart(const std::filesystem::path& file) const;
  void rebuild(const scene::Scene& scene, std::uint32_t width, std::uint32_t height);

  gpu::Context& ctx_;
  SessionOptions options_;
  std::filesystem::path shader_dir_;
  std::vector<std::filesystem::path> library_dirs_;  // weakly canonical, without shader_dir_
  std::unique_ptr<render::Renderer> renderer_;
  std::unique_ptr<Watcher> watcher_;
  std::uint32_t width_ = 0, height_ = 0;
  std::uint32_t frame_index_ = 0;
  bool rendered_ = false;
  std::map<std::string, std::string> errors_;
  std::set<std::filesystem::path> retry_;  // files of failed batches, passed again
  std::vector<ReloadRecord> reloads_;
  std::vector<std::size_t> awaiting_frame_;  // indices in reloads_ waiting for their first frame
  std::optional<Early> early_;  // prepared, waiting for its batch (no thread runs on it)
};

// The median of v (0 for an empty v).
double median(std::vector<double> v);

}  // namespace penumbra::runtime
