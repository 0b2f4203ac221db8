#include "session.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <penumbra/core/error.hpp>
#include <penumbra/core/stats.hpp>
#include <penumbra/render/contact_shadows.hpp>
#include <penumbra/scene/params.hpp>
#include <set>
#include <sstream>
#include <thread>

namespace penumbra::runtime {
namespace fs = std::filesystem;

double median(std::vector<double> v) {
  return v.empty() ? 0.0 : stats::median(std::move(v));
}

namespace {

double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

std::string join(const std::vector<std::string>& v, const char* sep = ", ") {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : sep) + x;
  return s;
}

// "forward-opaque PENUMBRA_SUN_SHADOWS=1 ..." -> "forward-opaque", for the log.
std::vector<std::string> short_names(const std::vector<std::string>& names) {
  std::vector<std::string> out;
  for (const auto& n : names) out.push_back(n.substr(0, n.find(' ')));
  return out;
}

}  // namespace

// ---- session -------------------------------------------------------------------------------

Session::Session(gpu::Context& ctx, scene::Scene scene, SessionOptions options)
    : ctx_(ctx),
      options_(std::move(options)),
      // Absolute and canonical: the watcher's events, the registry's dependencies and a
      // script's file arguments then name the same file the same way, whatever the working
      // directory and however --shader-dir was written (relative, with a symlink).
      shader_dir_([&] {
        std::error_code ec;
        const fs::path dir =
            options_.shader_dir.empty() ? render::default_shader_dir() : options_.shader_dir;
        const fs::path canonical = fs::weakly_canonical(fs::absolute(dir, ec), ec);
        return canonical.empty() ? dir : canonical;
      }()),
      library_dirs_([&] {
        std::vector<fs::path> dirs;
        for (const fs::path& d : options_.library_shader_dirs) {
          std::error_code ec;
          fs::path c = fs::weakly_canonical(fs::absolute(d, ec), ec);
          if (c.empty()) c = d;
          if (c != shader_dir_ && std::find(dirs.begin(), dirs.end(), c) == dirs.end())
            dirs.push_back(c);
        }
        return dirs;
      }()),
      width_(options_.width),
      height_(options_.height) {
  if (!options_.log) {
    options_.log = [](const std::string& line) {
      std::printf("%s\n", line.c_str());
      std::fflush(stdout);
    };
  }
  // The watcher starts first: an edit made while the renderer is being built is not lost.
  if (options_.watch) {
    WatcherOptions wo;
    wo.debounce = options_.debounce;
    wo.max_delay = std::max(wo.max_delay, options_.debounce);  // a longer debounce is kept
    std::vector<fs::path> dirs{shader_dir_};
    dirs.insert(dirs.end(), library_dirs_.begin(), library_dirs_.end());
    watcher_ = std::make_unique<Watcher>(dirs, wo);
  }
  render::RendererOptions ro;
  ro.shader_dir = shader_dir_;
  ro.library_shader_dirs = library_dirs_;
  ro.visibility_output = options_.visibility_output;
  ro.width = width_;
  ro.height = height_;
  renderer_ = std::make_unique<render::Renderer>(ctx_, scene, ro);
  watch_outside_files();
}

Session::~Session() = default;

bool Session::outside_tree(const fs::path& file) const {
  return layer_of(file).empty();
}

fs::path Session::layer_of(const fs::path& file) const {
  std::vector<fs::path> layers{shader_dir_};
  layers.insert(layers.end(), library_dirs_.begin(), library_dirs_.end());
  for (const fs::path& dir : layers) {
    const fs::path rel = file.lexically_relative(dir);
    if (!rel.empty() && rel.native().rfind("..", 0) != 0) return dir;
  }
  return {};
}

bool Session::shadowed(const fs::path& file) const {
  const fs::path layer = layer_of(file);
  if (layer.empty() || layer == shader_dir_) return false;
  std::error_code ec;
  return fs::exists(shader_dir_ / file.lexically_relative(layer), ec);
}

std::optional<fs::path> Session::library_counterpart(const fs::path& file) const {
  if (library_dirs_.empty() || layer_of(file) != shader_dir_) return std::nullopt;
  const fs::path rel = file.lexically_relative(shader_dir_);
  for (const fs::path& dir : library_dirs_) {
    std::error_code ec;
    if (fs::is_regular_file(dir / rel, ec)) return dir / rel;
  }
  return std::nullopt;
}

void Session::watch_outside_files() {
  if (!watcher_) return;
  for (const fs::path& f : renderer_->shader_files()) {
    if (!outside_tree(f)) continue;
    try {
      if (watcher_->watch_directory(f.parent_path()))
        log("[watch] also watching " + f.parent_path().string() + ": " + f.filename().string() +
            " is read through a symlink in the shader tree");
    } catch (const Error& e) {
      log(std::string("[watch] ") + e.what() + " (edits there are not seen)");
    }
  }
}

void Session::log(const std::string& line) const {
  options_.log(line);
}

std::string Session::relative(const fs::path& file) const {
  std::error_code ec;
  const fs::path base = fs::weakly_canonical(shader_dir_, ec);
  const fs::path rel = file.lexically_relative(base);
  return rel.empty() || rel.native().rfind("..", 0) == 0 ? file.string() : rel.string();
}

void Session::rebuild(const scene::Scene& scene, uint32_t width, uint32_t height) {
  render::RendererOptions ro;
  ro.shader_dir = shader_dir_;
  ro.library_shader_dirs = library_dirs_;
  ro.visibility_output = options_.visibility_output;
  ro.width = width;
  ro.height = height;
  std::unique_ptr<render::Renderer> fresh;
  try {
    fresh = std::make_unique<render::Renderer>(ctx_, scene, ro);
  } catch (const Error& e) {
    throw Error(std::string("the renderer could not be rebuilt (the old one keeps running): ") +
                e.what());
  }
  early_.reset();  // made by the old renderer: dropped before it goes
  renderer_ = std::move(fresh);
  watch_outside_files();
  width_ = width;
  height_ = height;
  rendered_ = false;
  // The new renderer compiled every pipeline from the current tree.
  errors_.clear();
  retry_.clear();
  awaiting_frame_.clear();
}

void Session::load_scene(const scene::Scene& scene) {
  rebuild(scene, width_, height_);
}

void Session::resize(uint32_t width, uint32_t height) {
  if (width == 0 || height == 0 || width > 16384 || height > 16384)
    throw Error("size " + std::to_string(width) + "x" + std::to_string(height) +
                ": expected sides in [1, 16384]");
  rebuild(renderer_->scene(), width, height);
}

std::vector<std::string> Session::keys() {
  return scene::scene_keys(renderer_->scene());
}

// The parameter table (scene/params.hpp) parses, range-checks and applies the value; a bad value
// leaves the scene untouched. Keys that change what is built rebuild the renderer.
void Session::set(const std::string& key, const std::string& value) {
  const scene::Param& p = scene::param(key);
  if (p.apply != scene::ParamApply::rebuild) {
    // A frame-time key can still change what the scene requires (filter = evsm2 needs the
    // moments): then the renderer is rebuilt.
    const auto before = renderer_->scene().requirements();
    const std::string old = scene::get_param(renderer_->scene(), key);
    scene::set_param(renderer_->scene(), key, value);
    if (renderer_->scene().requirements() == before) {
      // A filter the resolves do not compile yet compiles them again (Renderer::prepare): when
      // that fails, the key keeps its value and the running pipelines stay.
      try {
        renderer_->prepare();
      } catch (const Error&) {
        scene::set_param(renderer_->scene(), key, old);
        throw;
      }
      return;
    }
    try {
      rebuild(renderer_->scene(), width_, height_);
    } catch (const Error&) {
      scene::set_param(renderer_->scene(), key, old);  // the old renderer, as it was
      throw;
    }
    return;
  }
  scene::Scene next = renderer_->scene();
  scene::set_param(next, key, value);
  rebuild(next, width_, height_);
}

std::string Session::get(const std::string& key) {
  return scene::get_param(renderer_->scene(), key);
}

ReloadRecord Session::apply(const std::vector<FileChange>& changes,
                            std::optional<std::uint64_t> count) {
  ReloadRecord rec = collect(changes);
  finish(rec, count);
  return rec;
}

void Session::finish(ReloadRecord& rec, std::optional<std::uint64_t> count) {
  std::optional<Early> early = std::move(early_);
  early_.reset();
  if (rec.changed.empty()) return;
  // The compile begun while the burst settled holds when no change came after its look and it
  // read the same files; otherwise it is dropped (its pipelines with it) and this batch compiles.
  if (early && count && early->count == *count && early->files == rec.changed &&
      (early->prepared || early->failure)) {
    rec.compiled_early = early->looked;
    rec.during_frame = rec.during_frame || early->during_frame;
    if (early->looked)
      rec.waited_ms = std::max(
          0.0, std::chrono::duration<double, std::milli>(early->started - rec.event).count());
    try {
      if (early->failure) std::rethrow_exception(early->failure);
      rec.result = renderer_->finish_reload(std::move(*early->prepared));
    } catch (const Error& e) {
      failed(rec, e);
    }
    rec.reload_ms = ms_since(early->started);
  } else {
    const auto t0 = Clock::now();
    try {
      rec.result = renderer_->reload(rec.changed);
    } catch (const Error& e) {
      failed(rec, e);
    }
    rec.reload_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  }
  conclude(rec);
}

Session::Early Session::look_at_pending() {
  Early e;
  if (!watcher_) return e;
  const auto changes = watcher_->pending(&e.count, kEarlyQuiet);
  if (changes.empty()) return e;
  e.files = collect(changes, true).changed;
  e.looked = true;
  return e;
}

void Session::failed(ReloadRecord& rec, const Error& e) {
  std::set<std::string> names;
  for (const auto& f : rec.changed)
    for (const auto& n : renderer_->pipelines_reading(f)) names.insert(n);
  rec.result = {};
  rec.result.failed.assign(names.begin(), names.end());
  rec.result.errors.assign(names.size(), e.what());
}

ReloadRecord Session::collect(const std::vector<FileChange>& changes, bool quiet) {
  ReloadRecord rec;
  rec.event = Clock::now();
  std::set<fs::path> files = retry_;
  std::vector<fs::path> overlay_removed;
  const auto read = renderer_->shader_files();
  for (const auto& c : changes) {
    // Another file in the directory of a symlinked shader's target: not ours.
    if (outside_tree(c.path) && std::find(read.begin(), read.end(), c.path) == read.end()) continue;
    // A library file that the overlay has its own copy of: nothing reads it.
    if (shadowed(c.path)) continue;
    rec.event = std::min(rec.event, c.first_seen);
    if (c.exists) {
      files.insert(c.path);
    } else if (const auto library = library_counterpart(c.path)) {
      // An overlay's file removed: the programs that read it now read the library's.
      files.insert(*library);
      overlay_removed.push_back(c.path);
    } else if (std::find(read.begin(), read.end(), c.path) != read.end()) {
      rec.deleted.push_back(c.path);
    }
  }
  // A batch of deletions only: nothing to compile (the failed files are retried with the next
  // batch that brings a file back or changes one).
  if (overlay_removed.empty() &&
      std::none_of(changes.begin(), changes.end(), [](const FileChange& c) { return c.exists; }))
    files.clear();
  if (!quiet)
    for (const auto& f : overlay_removed)
      log("[reload] " + relative(f) + " was removed from " + shader_dir_.string() +
          ": the library's copy is read instead");
  // A retried file that is gone now: its pipelines wait for it to come back.
  for (auto it = files.begin(); it != files.end();) {
    std::error_code ec;
    it = fs::exists(*it, ec) ? std::next(it) : files.erase(it);
  }
  rec.changed.assign(files.begin(), files.end());
  rec.waited_ms = ms_since(rec.event);
  if (quiet) return rec;
  for (const auto& d : rec.deleted) {
    log("[reload] " + relative(d) + " was deleted; " +
        join(short_names(renderer_->pipelines_reading(d))) + " keep running until it is back");
  }
  return rec;
}

void Session::conclude(ReloadRecord& rec) {
  watch_outside_files();  // an edit may include a file through a new symlink

  const auto previous = errors_;
  for (const auto& r : rec.result.rebuilt) errors_.erase(r);
  for (size_t i = 0; i < rec.result.failed.size(); ++i)
    errors_[rec.result.failed[i]] = i < rec.result.errors.size() ? rec.result.errors[i] : "";
  if (rec.result.failed.empty()) {
    retry_.clear();
  } else {
    retry_.insert(rec.changed.begin(), rec.changed.end());
  }

  char ms[32];
  std::snprintf(ms, sizeof ms, "%.0f ms", rec.reload_ms);
  if (!rec.result.rebuilt.empty())
    log("[reload] rebuilt: " + join(short_names(rec.result.rebuilt)) + " (" + ms + ")");
  if (!rec.result.same_spirv.empty())
    log("[reload] the SPIR-V of " + join(short_names(rec.result.same_spirv)) +
        " did not change (the edit reaches no code they compile)");
  if (!rec.result.failed.empty()) {
    // New errors in full; an error that did not change (a retried file) in one line.
    std::set<std::string> shown;
    std::vector<std::string> unchanged;
    for (size_t i = 0; i < rec.result.failed.size(); ++i) {
      const std::string& name = rec.result.failed[i];
      const auto before = previous.find(name);
      if (before != previous.end() && before->second == errors_[name]) {
        unchanged.push_back(name);
        continue;
      }
      if (shown.empty())
        log("[reload] failed, the last good pipeline keeps running: " +
            join(short_names(rec.result.failed)));
      if (shown.insert(errors_[name]).second) log("[reload] error: " + errors_[name]);
    }
    if (shown.empty() && !unchanged.empty())
      log("[reload] still failing (same error): " + join(short_names(unchanged)));
    // A reload is all or nothing: what compiled waits for the failing ones.
    if (!rec.result.held.empty())
      log("[reload] not swapped in until every pipeline the edit reaches builds: " +
          join(short_names(rec.result.held)));
  }
}

std::optional<ReloadRecord> Session::poll_reload() {
  if (!watcher_) return std::nullopt;
  std::uint64_t count = 0;
  const auto changes = watcher_->poll_changes(&count);
  if (changes.empty()) return std::nullopt;
  ReloadRecord rec = apply(changes, count);
  if (!rec.result.rebuilt.empty()) awaiting_frame_.push_back(reloads_.size());
  reloads_.push_back(rec);
  return rec;
}

ReloadRecord Session::reload(const std::vector<fs::path>& files) {
  std::vector<FileChange> changes;
  const auto now = Clock::now();
  for (const auto& f : files) {
    std::error_code ec;
    const fs::path p = fs::weakly_canonical(fs::absolute(f), ec);
    changes.push_back({ec ? f : p, fs::exists(f, ec), now, now});
  }
  ReloadRecord rec = apply(changes, std::nullopt);
  if (!rec.result.rebuilt.empty()) awaiting_frame_.push_back(reloads_.size());
  reloads_.push_back(rec);
  return rec;
}

std::thread Session::start_early_compile(Early e, bool during_frame) {
  e.started = Clock::now();
  e.during_frame = during_frame;
  early_ = std::move(e);
  return std::thread([this] {
    try {
      early_->prepared = renderer_->prepare_reload(early_->files);
    } catch (...) {
      early_->failure = std::current_exception();
    }
  });
}

bool Session::early_is_current() const {
  return early_ && watcher_ && early_->count == watcher_->change_count();
}

std::optional<ReloadRecord> Session::wait_reload(std::chrono::milliseconds timeout,
                                                 const std::optional<fs::path>& file) {
  if (!watcher_) throw Error("wait_reload: this session has no watcher");
  // The file as written and as canonical: a change to a file that is (or became) a symlink is
  // reported under the name the watcher saw.
  std::set<fs::path> want;
  if (file) {
    std::error_code ec;
    const fs::path abs = file->is_absolute() ? *file : shader_dir_ / *file;
    want.insert(abs.lexically_normal());
    want.insert(fs::weakly_canonical(abs, ec));
  }
  const auto deadline = Clock::now() + timeout;
  const auto left = [&] {
    return std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
  };
  for (;;) {
    if (left().count() <= 0) return std::nullopt;
    // A burst has begun: its files compile now, while it settles (an early compile that a later
    // change made stale goes first).
    if (!early_is_current()) early_.reset();
    std::thread worker;
    if (options_.compile_early && !early_ && watcher_->wait_pending(left(), kEarlyQuiet)) {
      Early look = look_at_pending();
      if (!look.files.empty()) worker = start_early_compile(std::move(look), false);
    }
    std::uint64_t count = 0;
    std::vector<FileChange> changes;
    try {
      changes = watcher_->wait(std::max(left(), std::chrono::milliseconds(0)), &count);
    } catch (...) {
      if (worker.joinable()) worker.join();
      throw;
    }
    if (worker.joinable()) worker.join();
    if (changes.empty()) continue;
    ReloadRecord rec = apply(changes, count);
    if (!rec.result.rebuilt.empty()) awaiting_frame_.push_back(reloads_.size());
    reloads_.push_back(rec);
    const bool match =
        !want.empty() ? std::any_of(changes.begin(), changes.end(),
                                    [&](const FileChange& c) { return want.count(c.path) > 0; })
                      : rec.relevant();
    if (!match) continue;
    const size_t index = reloads_.size() - 1;
    render(1);
    return reloads_[index];
  }
}

void Session::render(uint32_t count) {
  for (uint32_t i = 0; i < count; ++i) {
    poll_reload();
    // While the GPU renders, on a worker: the files of a burst that has begun (they compile
    // while it settles) or that finished during the frame (collected then). Swapped in after
    // the frame when the burst is handed out with no change since; before, the compile began
    // only once the frame was done, and only after the debounce.
    std::optional<ReloadRecord> during;
    std::uint64_t during_count = 0;
    std::thread worker;
    const auto while_busy = [&] {
      if (during || !watcher_) return;
      const auto changes = watcher_->poll_changes(&during_count);
      if (!changes.empty()) {
        during = collect(changes);
        if (during->changed.empty() || worker.joinable()) return;  // or compiled after the frame
        if (early_ && early_->count == during_count && early_->files == during->changed) return;
        Early batch;
        batch.count = during_count;
        batch.files = during->changed;
        worker = start_early_compile(std::move(batch), true);
        return;
      }
      if (!options_.compile_early || worker.joinable() || early_is_current()) return;
      Early look = look_at_pending();
      if (!look.files.empty()) worker = start_early_compile(std::move(look), true);
    };
    try {
      renderer_->render(frame_index_, while_busy);
    } catch (...) {
      if (worker.joinable()) worker.join();
      throw;
    }
    if (worker.joinable()) worker.join();
    rendered_ = true;
    for (const size_t index : awaiting_frame_) {
      ReloadRecord& rec = reloads_[index];
      rec.latency_ms = ms_since(rec.event);
      char line[200];
      const auto all = latencies_ms();
      std::snprintf(line, sizeof line,
                    "[reload] latency %.0f ms: file event -> first frame with the new pipelines "
                    "(waited %.0f + reload %.0f + frame %.0f); median %.0f ms over %zu",
                    *rec.latency_ms, rec.waited_ms, rec.reload_ms,
                    *rec.latency_ms - rec.waited_ms - rec.reload_ms, median(all), all.size());
      log(line);
    }
    awaiting_frame_.clear();
    if (!during) continue;
    finish(*during, during_count);
    if (!during->result.rebuilt.empty()) awaiting_frame_.push_back(reloads_.size());
    reloads_.push_back(*during);
  }
}

std::vector<uint8_t> Session::pixels() {
  if (!rendered_) render(1);
  return renderer_->read_rgba8();
}

void Session::screenshot(const fs::path& png) {
  const auto px = pixels();
  if (png.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(png.parent_path(), ec);
    if (ec) {
      throw Error(png.string() + ": cannot create the directory " + png.parent_path().string() +
                  ": " + ec.message());
    }
  }
  render::write_png(png, renderer_->width(), renderer_->height(), px);
}

std::string Session::error_text() const {
  std::vector<std::string> distinct;
  for (const auto& [name, e] : errors_)
    if (std::find(distinct.begin(), distinct.end(), e) == distinct.end()) distinct.push_back(e);
  return join(distinct, "\n");
}

std::vector<double> Session::latencies_ms() const {
  std::vector<double> v;
  for (const auto& r : reloads_)
    if (r.latency_ms) v.push_back(*r.latency_ms);
  return v;
}

double Session::median_latency_ms() const {
  return median(latencies_ms());
}

std::string Session::timings_text() const {
  std::string s;
  double total = 0;
  char line[96];
  for (const auto& t : renderer_->timings()) {
    std::snprintf(line, sizeof line, "  %-22s %9.3f ms\n", t.name.c_str(), t.gpu_ms);
    s += line;
    total += t.gpu_ms;
  }
  std::snprintf(line, sizeof line, "  %-22s %9.3f ms\n", "total", total);
  return s + line;
}

}  // namespace penumbra::runtime
