#include "session.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <penumbra/core/error.hpp>
#include <penumbra/render/contact_shadows.hpp>
#include <sstream>

namespace penumbra::runtime {
namespace fs = std::filesystem;

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
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

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// ---- parameter values --------------------------------------------------------------------

[[noreturn]] void bad(const std::string& key, const std::string& value, const std::string& want) {
  throw Error(key + " " + (value.empty() ? "(empty)" : value) + ": expected " + want);
}

double number(const std::string& key, const std::string& v, double lo, double hi,
              const std::string& range) {
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (v.empty() || end != v.c_str() + v.size() || !std::isfinite(x) || x < lo || x > hi)
    bad(key, v, "a number in " + range);
  return x;
}

float number_f(const std::string& key, const std::string& v, double lo, double hi,
               const std::string& range) {
  return static_cast<float>(number(key, v, lo, hi, range));
}

float positive(const std::string& key, const std::string& v) {
  const double x = number(key, v, 0.0, 1e30, "(0, inf)");
  if (!(x > 0.0)) bad(key, v, "a number > 0");
  return static_cast<float>(x);
}

long integer(const std::string& key, const std::string& v, long lo, long hi) {
  char* end = nullptr;
  const long x = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || end != v.c_str() + v.size() || x < lo || x > hi)
    bad(key, v, "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return x;
}

bool boolean(const std::string& key, const std::string& v) {
  if (v == "true" || v == "1" || v == "on") return true;
  if (v == "false" || v == "0" || v == "off") return false;
  bad(key, v, "true or false");
}

glm::vec3 vec3(const std::string& key, const std::string& v) {
  std::string s = v;
  for (char& c : s)
    if (c == ',' || c == '[' || c == ']') c = ' ';
  std::istringstream in(s);
  std::vector<std::string> parts;
  for (std::string p; in >> p;) parts.push_back(p);
  if (parts.size() != 3) bad(key, v, "three numbers, e.g. 0,2,6");
  glm::vec3 r;
  for (int i = 0; i < 3; ++i) r[i] = number_f(key, parts[size_t(i)], -1e30, 1e30, "(-inf, inf)");
  return r;
}

std::string vec3_text(glm::vec3 v) {
  return fmt(v.x) + "," + fmt(v.y) + "," + fmt(v.z);
}

template <class E, size_t N>
E enumerated(const std::string& key, const std::string& v, const E (&all)[N]) {
  std::string names;
  for (E e : all) {
    if (scene::to_string(e) == v) return e;
    names += (names.empty() ? "" : ", ") + std::string(scene::to_string(e));
  }
  bad(key, v, "one of " + names);
}

constexpr scene::Filter kFilters[] = {scene::Filter::hard, scene::Filter::pcf, scene::Filter::pcss,
                                      scene::Filter::poisson};
constexpr scene::CascadeFit kFits[] = {scene::CascadeFit::box, scene::CascadeFit::camera_sphere,
                                       scene::CascadeFit::slice_sphere};
constexpr scene::DebugView kViews[] = {
    scene::DebugView::lit,          scene::DebugView::shadow_factor, scene::DebugView::cascades,
    scene::DebugView::contact_mask, scene::DebugView::texel_density, scene::DebugView::penumbra};

struct Param {
  const char* key;
  bool rebuild;  // changes what the renderer builds
  void (*set)(scene::Scene&, const std::string& key, const std::string& value);
  std::string (*get)(const scene::Scene&);
};

scene::Sun& sun(scene::Scene& s, const std::string& key) {
  if (!s.sun) throw Error(key + ": the scene '" + s.name + "' has no [sun]");
  return *s.sun;
}
std::string sun_get(const scene::Scene& s, std::string (*f)(const scene::Sun&)) {
  return s.sun ? f(*s.sun) : "(no sun)";
}

// Parameters by their scene-file names (docs/scenes.md), with the file's ranges.
const std::vector<Param>& params() {
  using S = scene::Scene;
  using K = const std::string&;
  static const std::vector<Param> p = {
      {"camera.position", false,
       [](S& s, K k, K v) {
         const auto x = vec3(k, v);
         if (x == s.camera.target) bad(k, v, "a point other than camera.target");
         s.camera.position = x;
       },
       [](const S& s) { return vec3_text(s.camera.position); }},
      {"camera.target", false,
       [](S& s, K k, K v) {
         const auto x = vec3(k, v);
         if (x == s.camera.position) bad(k, v, "a point other than camera.position");
         s.camera.target = x;
       },
       [](const S& s) { return vec3_text(s.camera.target); }},
      {"camera.fov_y", false,
       [](S& s, K k, K v) {
         s.camera.fov_y_degrees = number_f(k, v, 0.0, 180.0, "(0, 180)");
         if (!(s.camera.fov_y_degrees > 0.0f && s.camera.fov_y_degrees < 180.0f))
           bad(k, v, "a number in (0, 180)");
       },
       [](const S& s) { return fmt(s.camera.fov_y_degrees); }},
      {"sun.direction", false,
       [](S& s, K k, K v) {
         const auto d = vec3(k, v);
         if (glm::length(d) == 0.0f) bad(k, v, "a non-zero direction");
         sun(s, k).direction = glm::normalize(d);
       },
       [](const S& s) {
         return sun_get(s, [](const scene::Sun& x) { return vec3_text(x.direction); });
       }},
      {"sun.intensity", false,
       [](S& s, K k, K v) { sun(s, k).intensity = number_f(k, v, 0.0, 1e30, "[0, inf)"); },
       [](const S& s) { return sun_get(s, [](const scene::Sun& x) { return fmt(x.intensity); }); }},
      {"sun.angular_diameter", false,
       [](S& s, K k, K v) {
         const float x = number_f(k, v, 0.0, 90.0, "[0, 90)");
         if (!(x < 90.0f)) bad(k, v, "a number in [0, 90)");
         sun(s, k).angular_diameter_degrees = x;
       },
       [](const S& s) {
         return sun_get(s, [](const scene::Sun& x) { return fmt(x.angular_diameter_degrees); });
       }},
      {"sun.shadows", true, [](S& s, K k, K v) { sun(s, k).shadows = boolean(k, v); },
       [](const S& s) {
         return sun_get(
             s, [](const scene::Sun& x) { return std::string(x.shadows ? "true" : "false"); });
       }},
      {"shadows.filter", false,
       [](S& s, K k, K v) { s.shadows.filter = enumerated(k, v, kFilters); },
       [](const S& s) { return std::string(scene::to_string(s.shadows.filter)); }},
      {"shadows.cascades", true,
       [](S& s, K k, K v) { s.shadows.cascades = static_cast<uint32_t>(integer(k, v, 1, 4)); },
       [](const S& s) { return std::to_string(s.shadows.cascades); }},
      {"shadows.lambda", false,
       [](S& s, K k, K v) { s.shadows.split_lambda = number_f(k, v, 0.0, 1.0, "[0, 1]"); },
       [](const S& s) { return fmt(s.shadows.split_lambda); }},
      {"shadows.max_distance", false,
       [](S& s, K k, K v) { s.shadows.max_distance = positive(k, v); },
       [](const S& s) { return fmt(s.shadows.max_distance); }},
      {"shadows.resolution", true,
       [](S& s, K k, K v) {
         s.shadows.resolution = static_cast<uint32_t>(integer(k, v, 16, 16384));
       },
       [](const S& s) { return std::to_string(s.shadows.resolution); }},
      {"shadows.fit", false, [](S& s, K k, K v) { s.shadows.fit = enumerated(k, v, kFits); },
       [](const S& s) { return std::string(scene::to_string(s.shadows.fit)); }},
      {"shadows.pcf_radius", false,
       [](S& s, K k, K v) { s.shadows.pcf_radius = static_cast<int>(integer(k, v, 0, 8)); },
       [](const S& s) { return std::to_string(s.shadows.pcf_radius); }},
      {"shadows.pcss_quality", false,
       [](S& s, K k, K v) {
         if (v == "low")
           s.shadows.pcss_quality = 0;
         else if (v == "medium")
           s.shadows.pcss_quality = 1;
         else if (v == "high")
           s.shadows.pcss_quality = 2;
         else if (v.size() == 1 && v[0] >= '0' && v[0] <= '2')
           s.shadows.pcss_quality = v[0] - '0';
         else
           bad(k, v, "low, medium, high or 0, 1, 2");
       },
       [](const S& s) { return std::to_string(s.shadows.pcss_quality); }},
      {"shadows.blend_band", false,
       [](S& s, K k, K v) { s.shadows.blend_band = number_f(k, v, 0.0, 0.5, "[0, 0.5]"); },
       [](const S& s) { return fmt(s.shadows.blend_band); }},
      {"shadows.fade_band", false,
       [](S& s, K k, K v) { s.shadows.fade_band = number_f(k, v, 0.0, 1.0, "[0, 1]"); },
       [](const S& s) { return fmt(s.shadows.fade_band); }},
      {"shadows.normal_offset_texels", false,
       [](S& s, K k, K v) {
         s.shadows.normal_offset_texels = number_f(k, v, 0.0, 1e30, "[0, inf)");
       },
       [](const S& s) { return fmt(s.shadows.normal_offset_texels); }},
      {"shadows.slope_bias", false,
       [](S& s, K k, K v) { s.shadows.slope_bias = number_f(k, v, 0.0, 1e30, "[0, inf)"); },
       [](const S& s) { return fmt(s.shadows.slope_bias); }},
      {"shadows.constant_bias", false,
       [](S& s, K k, K v) { s.shadows.constant_bias = number_f(k, v, 0.0, 1e30, "[0, inf)"); },
       [](const S& s) { return fmt(s.shadows.constant_bias); }},
      {"shadows.reverse_z", true, [](S& s, K k, K v) { s.shadows.reverse_z = boolean(k, v); },
       [](const S& s) { return std::string(s.shadows.reverse_z ? "true" : "false"); }},
      {"contact.steps", true,
       [](S& s, K k, K v) { s.contact.steps = static_cast<uint32_t>(integer(k, v, 0, scene::kMaxContactSteps)); },
       [](const S& s) { return std::to_string(s.contact.steps); }},
      {"contact.max_distance", true,
       [](S& s, K k, K v) { s.contact.max_distance = positive(k, v); },
       [](const S& s) { return fmt(s.contact.max_distance); }},
      {"contact.thickness", true, [](S& s, K k, K v) { s.contact.thickness = positive(k, v); },
       [](const S& s) { return fmt(s.contact.thickness); }},
      {"contact.intensity", true,
       [](S& s, K k, K v) { s.contact.intensity = number_f(k, v, 0.0, 1.0, "[0, 1]"); },
       [](const S& s) { return fmt(s.contact.intensity); }},
      {"render.view", false, [](S& s, K k, K v) { s.render.view = enumerated(k, v, kViews); },
       [](const S& s) { return std::string(scene::to_string(s.render.view)); }},
      {"render.exposure", false, [](S& s, K k, K v) { s.render.exposure = positive(k, v); },
       [](const S& s) { return fmt(s.render.exposure); }},
  };
  return p;
}

const Param& param(const std::string& key) {
  for (const auto& p : params())
    if (key == p.key) return p;
  // A "did you mean": the known key sharing the longest prefix.
  const Param* best = nullptr;
  size_t best_len = 0;
  for (const auto& p : params()) {
    const std::string k = p.key;
    size_t n = 0;
    while (n < k.size() && n < key.size() && k[n] == key[n]) ++n;
    if (n > best_len) best_len = n, best = &p;
  }
  std::string msg = "unknown parameter '" + key + "'";
  if (best && best_len >= 3) msg += " (did you mean '" + std::string(best->key) + "'?)";
  std::string all;
  for (const auto& p : params()) all += (all.empty() ? "" : ", ") + std::string(p.key);
  throw Error(msg + "; known: " + all);
}

}  // namespace

// ---- session -------------------------------------------------------------------------------

Session::Session(gpu::Context& ctx, scene::Scene scene, SessionOptions options)
    : ctx_(ctx),
      options_(std::move(options)),
      shader_dir_(options_.shader_dir.empty() ? render::default_shader_dir() : options_.shader_dir),
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
    watcher_ = std::make_unique<Watcher>(std::vector<fs::path>{shader_dir_}, wo);
  }
  render::RendererOptions ro;
  ro.shader_dir = shader_dir_;
  ro.width = width_;
  ro.height = height_;
  renderer_ = std::make_unique<render::Renderer>(ctx_, scene, ro);
}

Session::~Session() = default;

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
  ro.width = width;
  ro.height = height;
  std::unique_ptr<render::Renderer> fresh;
  try {
    fresh = std::make_unique<render::Renderer>(ctx_, scene, ro);
  } catch (const Error& e) {
    throw Error(std::string("the renderer could not be rebuilt (the old one keeps running): ") +
                e.what());
  }
  renderer_ = std::move(fresh);
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
  std::vector<std::string> k;
  for (const auto& p : params()) k.push_back(p.key);
  return k;
}

void Session::set(const std::string& key, const std::string& value) {
  const Param& p = param(key);
  if (!p.rebuild) {
    // Validate on a copy: a bad value leaves the scene untouched.
    scene::Scene copy = renderer_->scene();
    p.set(copy, key, value);
    p.set(renderer_->scene(), key, value);
    return;
  }
  scene::Scene next = renderer_->scene();
  p.set(next, key, value);
  rebuild(next, width_, height_);
}

std::string Session::get(const std::string& key) {
  return param(key).get(renderer_->scene());
}

ReloadRecord Session::apply(const std::vector<FileChange>& changes) {
  ReloadRecord rec;
  rec.event = Clock::now();
  std::set<fs::path> files = retry_;
  const auto read = renderer_->shader_files();
  for (const auto& c : changes) {
    rec.event = std::min(rec.event, c.first_seen);
    if (c.exists) {
      files.insert(c.path);
    } else if (std::find(read.begin(), read.end(), c.path) != read.end()) {
      rec.deleted.push_back(c.path);
    }
  }
  // A batch of deletions only: nothing to compile (the failed files are retried with the next
  // batch that brings a file back or changes one).
  if (std::none_of(changes.begin(), changes.end(), [](const FileChange& c) { return c.exists; }))
    files.clear();
  // A retried file that is gone now: its pipelines wait for it to come back.
  for (auto it = files.begin(); it != files.end();) {
    std::error_code ec;
    it = fs::exists(*it, ec) ? std::next(it) : files.erase(it);
  }
  rec.changed.assign(files.begin(), files.end());
  rec.waited_ms = ms_since(rec.event);
  for (const auto& d : rec.deleted) {
    log("[reload] " + relative(d) + " was deleted; " +
        join(short_names(renderer_->pipelines_reading(d))) + " keep running until it is back");
  }
  if (rec.changed.empty()) return rec;

  const auto t0 = Clock::now();
  try {
    rec.result = renderer_->reload(rec.changed);
  } catch (const Error& e) {
    // A stage file that cannot be read (deleted between poll and reload): every pipeline
    // reading one of the files is reported as failed; they keep their last good state.
    std::set<std::string> names;
    for (const auto& f : rec.changed)
      for (const auto& n : renderer_->pipelines_reading(f)) names.insert(n);
    rec.result.failed.assign(names.begin(), names.end());
    rec.result.errors.assign(names.size(), e.what());
  }
  rec.reload_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();

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
  }
  return rec;
}

std::optional<ReloadRecord> Session::poll_reload() {
  if (!watcher_) return std::nullopt;
  const auto changes = watcher_->poll_changes();
  if (changes.empty()) return std::nullopt;
  ReloadRecord rec = apply(changes);
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
  ReloadRecord rec = apply(changes);
  if (!rec.result.rebuilt.empty()) awaiting_frame_.push_back(reloads_.size());
  reloads_.push_back(rec);
  return rec;
}

std::optional<ReloadRecord> Session::wait_reload(std::chrono::milliseconds timeout,
                                                 const std::optional<fs::path>& file) {
  if (!watcher_) throw Error("wait_reload: this session has no watcher");
  std::optional<fs::path> want;
  if (file) {
    std::error_code ec;
    const fs::path abs = file->is_absolute() ? *file : shader_dir_ / *file;
    want = fs::weakly_canonical(abs, ec);
  }
  const auto deadline = Clock::now() + timeout;
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    if (left.count() <= 0) return std::nullopt;
    const auto changes = watcher_->wait(left);
    if (changes.empty()) continue;
    ReloadRecord rec = apply(changes);
    if (!rec.result.rebuilt.empty()) awaiting_frame_.push_back(reloads_.size());
    reloads_.push_back(rec);
    const bool match = want ? std::any_of(changes.begin(), changes.end(),
                                          [&](const FileChange& c) { return c.path == *want; })
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
    renderer_->render(frame_index_);
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
  }
}

std::vector<uint8_t> Session::pixels() {
  if (!rendered_) render(1);
  return renderer_->read_rgba8();
}

void Session::screenshot(const fs::path& png) {
  const auto px = pixels();
  if (png.has_parent_path()) fs::create_directories(png.parent_path());
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
    std::snprintf(line, sizeof line, "  %-18s %9.3f ms\n", t.name.c_str(), t.gpu_ms);
    s += line;
    total += t.gpu_ms;
  }
  std::snprintf(line, sizeof line, "  %-18s %9.3f ms\n", "total", total);
  return s + line;
}

}  // namespace penumbra::runtime
