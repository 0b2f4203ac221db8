// Golden cases, their storage (golden.toml + PNGs) and rendering a case.
#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <penumbra/golden/golden.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <sstream>
#include <system_error>

namespace penumbra::golden {
namespace fs = std::filesystem;

namespace {

std::string where(const fs::path& file, const toml::node& node) {
  return file.string() + ":" + std::to_string(node.source().begin.line);
}

const toml::table& table_at(const fs::path& file, const toml::node& node, const char* what) {
  const toml::table* t = node.as_table();
  if (!t) throw Error(where(file, node) + ": " + what + " must be a table");
  return *t;
}

std::string string_key(const fs::path& file, const toml::table& t, const char* key,
                       bool required) {
  const toml::node* n = t.get(key);
  if (!n) {
    if (required)
      throw Error(file.string() + ":" + std::to_string(t.source().begin.line) + ": missing key '" +
                  key + "'");
    return {};
  }
  if (!n->is_string()) throw Error(where(file, *n) + ": '" + key + "' must be a string");
  return n->as_string()->get();
}

double number_key(const fs::path& file, const toml::node& n, const std::string& key, double lo,
                  double hi) {
  const auto v = n.value<double>();
  if (!v || !std::isfinite(*v) || *v < lo || *v > hi) {
    std::ostringstream msg;
    msg << where(file, n) << ": '" << key << "' must be a number in [" << lo << ", " << hi << "]";
    throw Error(msg.str());
  }
  return *v;
}

}  // namespace

// ---- cases ----------------------------------------------------------------------------------
std::vector<Case> load_cases(const fs::path& file) {
  toml::table root;
  try {
    root = toml::parse_file(file.string());
  } catch (const toml::parse_error& e) {
    throw Error(file.string() + ":" + std::to_string(e.source().begin.line) + ": " +
                std::string(e.description()));
  }
  std::vector<Case> cases;
  for (const auto& [key, node] : root) {
    if (key.str() != "case")
      throw Error(where(file, node) + ": unknown key '" + std::string(key.str()) +
                  "' (expected [[case]] tables)");
  }
  const toml::array* list = root["case"].as_array();
  if (!list) throw Error(file.string() + ": no [[case]] tables");
  for (const toml::node& n : *list) {
    const toml::table& t = table_at(file, n, "[[case]]");
    Case c;
    for (const auto& [key, value] : t) {
      static const char* known[] = {"name",        "scene",  "set",   "size",
                                    "description", "budget", "origin"};
      if (std::none_of(std::begin(known), std::end(known),
                       [&](const char* k) { return key.str() == k; }))
        throw Error(where(file, value) + ": unknown key '" + std::string(key.str()) +
                    "' in [[case]] (known: name, scene, set, size, description, budget, origin)");
    }
    c.name = string_key(file, t, "name", true);
    if (c.name.empty() || c.name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789-_.") !=
                              std::string::npos)
      throw Error(where(file, *t.get("name")) + ": case name '" + c.name +
                  "' must be lower-case letters, digits, '-', '_' or '.'");
    if (std::any_of(cases.begin(), cases.end(), [&](const Case& o) { return o.name == c.name; }))
      throw Error(where(file, *t.get("name")) + ": a second case named '" + c.name + "'");
    c.scene = string_key(file, t, "scene", true);
    c.description = string_key(file, t, "description", false);
    if (const toml::node* s = t.get("set")) {
      const toml::array* a = s->as_array();
      if (!a) throw Error(where(file, *s) + ": 'set' must be an array of \"KEY=VALUE\" strings");
      for (const toml::node& e : *a) {
        if (!e.is_string())
          throw Error(where(file, e) + ": 'set' entries must be \"KEY=VALUE\" strings");
        try {
          c.sets.push_back(scene::split_set_flag(e.as_string()->get()));
        } catch (const Error& err) {
          throw Error(where(file, e) + ": " + err.what());
        }
      }
    }
    if (const toml::node* s = t.get("size")) {
      const toml::array* a = s->as_array();
      if (!a || a->size() != 2) throw Error(where(file, *s) + ": 'size' must be [width, height]");
      c.width = uint32_t(number_key(file, *a->get(0), "size", 16, 4096));
      c.height = uint32_t(number_key(file, *a->get(1), "size", 16, 4096));
    }
    if (const toml::node* s = t.get("origin")) {
      const toml::array* a = s->as_array();
      if (!a || a->size() != 3) throw Error(where(file, *s) + ": 'origin' must be [x, y, z]");
      for (int k = 0; k < 3; ++k)
        c.origin[k] = number_key(file, *a->get(size_t(k)), "origin", -1e7, 1e7);
    }
    if (const toml::node* b = t.get("budget")) {
      const toml::table& bt = table_at(file, *b, "'budget'");
      for (const auto& [key, value] : bt) {
        const std::string k(key.str());
        double* field = k == "false_light"     ? &c.budget.false_light
                        : k == "false_shadow"  ? &c.budget.false_shadow
                        : k == "misclassified" ? &c.budget.misclassified
                        : k == "mean_abs"      ? &c.budget.mean_abs
                        : k == "umbra_kept"    ? &c.budget.umbra_kept
                                               : nullptr;
        if (!field)
          throw Error(where(file, value) + ": unknown budget key '" + k +
                      "' (known: false_light, false_shadow, misclassified, mean_abs, umbra_kept)");
        *field = number_key(file, value, k, 0.0, 1.0);
      }
    }
    cases.push_back(std::move(c));
  }
  return cases;
}

fs::path golden_root() {
  if (const char* env = std::getenv("PENUMBRA_GOLDEN_DIR"); env && *env) return env;
  return PENUMBRA_GOLDEN_DIR_DEFAULT;
}

std::string device_class(const gpu::DeviceInfo& info) {
  auto lower = [](std::string s) {
    for (char& ch : s) ch = char(std::tolower(static_cast<unsigned char>(ch)));
    return s;
  };
  if (lower(info.name).find("llvmpipe") != std::string::npos ||
      lower(info.driver_name).find("llvmpipe") != std::string::npos)
    return "lavapipe";
  switch (info.vendor_id) {
    case 0x10DE:
      return "gpu-nvidia";
    case 0x1002:
      return "gpu-amd";
    case 0x8086:
      return "gpu-intel";
    default: {
      char buf[32];
      std::snprintf(buf, sizeof buf, "gpu-%04x", info.vendor_id);
      return buf;
    }
  }
}

// ---- rendering a case -----------------------------------------------------------------------
namespace {

scene::Scene case_scene(const Case& c) {
  fs::path scene_file = c.scene;
  if (c.scene.find(".toml") != std::string::npos && scene_file.is_relative())
    scene_file = fs::path(PENUMBRA_SOURCE_DIR) / scene_file;
  scene::Scene s = scene::load_scene(scene::find_scene(scene_file.string()));
  scene::set_params(s, c.sets);
  if (c.origin != glm::dvec3(0.0)) scene::translate_scene(s, c.origin);
  return s;
}

render::RendererOptions case_options(const Case& c, const fs::path& shader_dir) {
  render::RendererOptions ro;
  ro.shader_dir = shader_dir;
  ro.width = c.width;
  ro.height = c.height;
  ro.visibility_output = true;
  return ro;
}

}  // namespace

Frame render_case(gpu::Context& ctx, const Case& c, const fs::path& shader_dir) {
  const scene::Scene s = case_scene(c);
  render::Renderer r(ctx, s, case_options(c, shader_dir));
  r.render(0);
  Frame f;
  f.width = r.width();
  f.height = r.height();
  f.lit = r.read_rgba8();
  for (const auto& l : reference::scene_lights(s)) {
    if ((l.kind == reference::LightKind::spot && l.index >= render::kMaxSpotLights) ||
        (l.kind == reference::LightKind::point && l.index >= render::kMaxPointLights))
      continue;  // as measure_frame: the renderer draws at most kMax… lights of a kind
    LightImage li;
    li.light = l.name();
    li.visibility = r.read_visibility(reference::visibility_slot(l));
    f.lights.push_back(std::move(li));
  }
  return f;
}

CaseMeasurement measure_case(gpu::Context& ctx, const Case& c,
                             const reference::MeasureOptions& options,
                             const RegionOptions& region_options) {
  const scene::Scene s = case_scene(c);
  render::Renderer r(ctx, s, case_options(c, {}));
  r.render(0);
  CaseMeasurement out;
  out.measurement = reference::measure_frame(r, options);
  const auto& m = out.measurement;
  out.frame.width = m.width;
  out.frame.height = m.height;
  out.frame.lit = m.lit;
  for (const auto& l : m.lights) {
    LightImage li;
    li.light = l.light.name();
    li.visibility = l.gpu;
    li.regions = classify_regions(m.receivers, l, region_options);
    li.metrics = l.metrics;
    for (const auto& v : reference::budget_violations(l, c.budget))
      out.over_budget.push_back(li.light + ": " + v);
    out.frame.lights.push_back(std::move(li));
  }
  return out;
}

// ---- storage --------------------------------------------------------------------------------
namespace {

constexpr const char* kMetricKeys[] = {"mean_abs", "rmse", "p99_abs", "false_light",
                                       "false_shadow", "misclassified", "receivers"};

double metric(const reference::Metrics& m, std::string_view key) {
  if (key == "mean_abs") return m.mean_abs;
  if (key == "rmse") return m.rmse;
  if (key == "p99_abs") return m.p99_abs;
  if (key == "false_light") return m.false_light;
  if (key == "false_shadow") return m.false_shadow;
  if (key == "misclassified") return m.misclassified;
  return double(m.receivers);
}

void set_metric(reference::Metrics& m, std::string_view key, double v) {
  if (key == "mean_abs") m.mean_abs = v;
  if (key == "rmse") m.rmse = v;
  if (key == "p99_abs") m.p99_abs = v;
  if (key == "false_light") m.false_light = v;
  if (key == "false_shadow") m.false_shadow = v;
  if (key == "misclassified") m.misclassified = v;
  if (key == "receivers") m.receivers = uint64_t(v);
}

}  // namespace

std::optional<Golden> load_golden(const fs::path& dir) {
  const fs::path meta = dir / "golden.toml";
  std::error_code ec;
  if (!fs::exists(meta, ec)) return std::nullopt;
  toml::table root;
  try {
    root = toml::parse_file(meta.string());
  } catch (const toml::parse_error& e) {
    throw Error(meta.string() + ":" + std::to_string(e.source().begin.line) + ": " +
                std::string(e.description()));
  }
  Golden g;
  g.case_name = root["case"].value_or(std::string{});
  g.device_class = root["device_class"].value_or(std::string{});
  g.device = root["device"].value_or(std::string{});
  g.driver = root["driver"].value_or(std::string{});
  g.frame.lit = read_png_rgba8(dir / "lit.png", g.frame.width, g.frame.height);
  const toml::array* lights = root["light"].as_array();
  if (!lights) throw Error(meta.string() + ": no [[light]] tables");
  for (const toml::node& n : *lights) {
    const toml::table& t = table_at(meta, n, "[[light]]");
    LightImage li;
    li.light = string_key(meta, t, "name", true);
    uint32_t w = 0, h = 0;
    li.visibility = read_png16(dir / ("visibility-" + li.light + ".png"), w, h);
    if (w != g.frame.width || h != g.frame.height)
      throw Error((dir / ("visibility-" + li.light + ".png")).string() + ": " +
                  std::to_string(w) + "x" + std::to_string(h) + ", lit.png is " +
                  std::to_string(g.frame.width) + "x" + std::to_string(g.frame.height));
    const fs::path rp = dir / ("regions-" + li.light + ".png");
    const std::vector<float> codes = read_png16(rp, w, h);
    if (w != g.frame.width || h != g.frame.height)
      throw Error(rp.string() + ": not the size of lit.png");
    li.regions.resize(codes.size());
    for (size_t i = 0; i < codes.size(); ++i) {
      const int v = int(std::lround(codes[i] * 255.0f));
      if (v != 0 && v != 64 && v != 128 && v != 192 && v != 255)
        throw Error(rp.string() + ": pixel (" + std::to_string(i % w) + ", " +
                    std::to_string(i / w) + ") has grey level " + std::to_string(v) +
                    ", not a region (0, 64, 128, 192, 255)");
      li.regions[i] = Region(v);
    }
    if (const toml::table* mt = t["metrics"].as_table()) {
      reference::Metrics m;
      m.light = li.light;
      for (const char* k : kMetricKeys)
        if (auto v = (*mt)[k].value<double>()) set_metric(m, k, *v);
      li.metrics = m;
    }
    g.frame.lights.push_back(std::move(li));
  }
  return g;
}

void write_golden(const fs::path& dir, const Golden& g) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error("cannot create " + dir.string() + ": " + ec.message());
  const Frame& f = g.frame;
  render::write_png(dir / "lit.png", f.width, f.height, f.lit);
  toml::table root{{"case", g.case_name},
                   {"device_class", g.device_class},
                   {"device", g.device},
                   {"driver", g.driver},
                   {"width", int64_t(f.width)},
                   {"height", int64_t(f.height)}};
  toml::array lights;
  for (const auto& l : f.lights) {
    write_png16(dir / ("visibility-" + l.light + ".png"), f.width, f.height, l.visibility);
    std::vector<float> codes(l.regions.size());
    for (size_t i = 0; i < codes.size(); ++i) codes[i] = float(uint8_t(l.regions[i])) / 255.0f;
    // 8-bit levels stored in a 16-bit PNG: one reader for every golden image.
    write_png16(dir / ("regions-" + l.light + ".png"), f.width, f.height, codes);
    toml::table lt{{"name", l.light}};
    if (l.metrics) {
      toml::table mt;
      for (const char* k : kMetricKeys) {
        const double v = metric(*l.metrics, k);
        if (std::isfinite(v)) mt.insert(k, v);
      }
      lt.insert("metrics", std::move(mt));
    }
    lights.push_back(std::move(lt));
  }
  root.insert("light", std::move(lights));
  std::ostringstream out;
  out << "# Written by penumbra-golden update; review the PNGs, not this file.\n" << root << "\n";
  write_file_atomic(dir / "golden.toml", out.str());
  // Files of lights the scene no longer has would be read by nobody: remove them.
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    for (const char* prefix : {"visibility-", "regions-"}) {
      if (name.rfind(prefix, 0) != 0) continue;
      const std::string light = name.substr(std::string(prefix).size(),
                                            name.size() - std::string(prefix).size() - 4);
      if (std::none_of(f.lights.begin(), f.lights.end(),
                       [&](const LightImage& l) { return l.light == light; }))
        fs::remove(e.path(), ec);
    }
  }
}

}  // namespace penumbra::golden
