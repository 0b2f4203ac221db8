// The TOML scene file: strict reading (every key known, every value typed and range-checked) with
// errors that name the file, line, table and key. docs/scenes.md is the format's reference.

#include <toml++/toml.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <limits>
#include <map>
#include <optional>
#include <penumbra/core/error.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#ifndef PENUMBRA_MODEL_DIR
#define PENUMBRA_MODEL_DIR "/usr/share/glmark2/models"
#endif

namespace penumbra::scene {
namespace {

namespace fs = std::filesystem;
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---- small helpers ---------------------------------------------------------------------------

std::string format_number(double value) {
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%g", value);
  return buffer;
}

std::string describe(const toml::node& node) {
  std::ostringstream out;
  node.visit([&](const auto& v) {
    if constexpr (toml::is_string<decltype(v)>) {
      out << "'" << v.get() << "'";
    } else if constexpr (toml::is_number<decltype(v)>) {
      out << format_number(static_cast<double>(v.get()));
    } else {
      out << v;
    }
  });
  std::string text = out.str();
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  return text;
}

std::string type_name(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::string:
      return "a string";
    case toml::node_type::integer:
      return "an integer";
    case toml::node_type::floating_point:
      return "a floating-point number";
    case toml::node_type::boolean:
      return "a boolean";
    case toml::node_type::array:
      return "an array";
    case toml::node_type::table:
      return "a table";
    default:
      return "a date/time";
  }
}

// Optimal string alignment distance (Levenshtein with adjacent transpositions).
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[a.size()][b.size()];
}

// " (did you mean 'color'?)" for the closest candidate, or "" when none is close.
std::string did_you_mean(std::string_view word, const std::vector<std::string_view>& candidates) {
  std::string_view best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  for (std::string_view candidate : candidates) {
    std::size_t distance = edit_distance(word, candidate);
    const bool prefix =
        word.size() >= 3 && (candidate.starts_with(word) || word.starts_with(candidate));
    if (prefix) distance = std::min<std::size_t>(distance, 1);
    if (distance < best_distance) {
      best_distance = distance;
      best = candidate;
    }
  }
  const std::size_t limit = word.size() <= 3 ? 1 : word.size() <= 6 ? 2 : 3;
  if (best.empty() || best_distance > limit) return "";
  return " (did you mean '" + std::string(best) + "'?)";
}

std::string join(const std::vector<std::string_view>& words) {
  std::string out;
  for (std::string_view w : words) {
    if (!out.empty()) out += ", ";
    out += w;
  }
  return out;
}

using Range = ParamRange;

constexpr Range kAny{};
constexpr Range kPositive{0.0, kInf, true, false};
constexpr Range kNonNegative{0.0, kInf, false, false};
constexpr Range kUnit{0.0, 1.0, false, false};
constexpr Range closed(double lo, double hi) {
  return Range{lo, hi, false, false};
}
constexpr Range open(double lo, double hi) {
  return Range{lo, hi, true, true};
}

template <class E>
using Names = std::vector<std::pair<std::string_view, E>>;

const Names<AlphaMode> kAlphaModes{{"opaque", AlphaMode::opaque}, {"masked", AlphaMode::masked}};
const Names<MaskPattern> kMasks{{"none", MaskPattern::none},
                                {"texture", MaskPattern::texture},
                                {"stripes", MaskPattern::stripes},
                                {"checker", MaskPattern::checker},
                                {"circles", MaskPattern::circles}};

template <class E>
std::string_view name_of(const Names<E>& names, E value) {
  for (const auto& [name, v] : names) {
    if (v == value) return name;
  }
  return "?";
}

// ---- reading one table -----------------------------------------------------------------------

struct Context {
  std::string file;  // for messages
  fs::path base_dir;
};

class Reader {
 public:
  Reader(const Context& ctx, const toml::table& table, std::string label)
      : ctx_(ctx), table_(table), label_(std::move(label)) {}

  const std::string& label() const { return label_; }
  const toml::table& table() const { return table_; }
  const Context& context() const { return ctx_; }

  std::uint32_t line_of(const toml::node* node) const {
    const toml::node& n = node != nullptr ? *node : static_cast<const toml::node&>(table_);
    return n.source().begin.line;
  }
  // "[sun] intensity" (or just the key at the top level).
  std::string name(std::string_view key) const {
    return label_.empty() ? std::string(key) : label_ + " " + std::string(key);
  }
  [[noreturn]] void fail_at(const toml::node* node, const std::string& text) const {
    throw Error(ctx_.file + ":" + std::to_string(line_of(node)) + ": " + text);
  }
  [[noreturn]] void fail_key(std::string_view key, const std::string& text) const {
    fail_at(table_.get(key), name(key) + ": " + text);
  }
  // "[camera] fov_y = 200 is out of range; must be in (0, 180)".
  [[noreturn]] void fail_range(std::string_view key, const toml::node& node,
                               const std::string& requirement) const {
    fail_at(&node, name(key) + " = " + describe(node) + " is out of range; " + requirement);
  }

  const toml::node* get(std::string_view key) const { return table_.get(key); }
  bool has(std::string_view key) const { return table_.contains(key); }

  // Every key must be one of `allowed`; the first unknown key (by line) is reported, with a
  // suggestion. `explain` may give a more specific message for a known-but-misplaced key.
  template <class Explain>
  void check_keys(const std::vector<std::string_view>& allowed, Explain explain) const {
    const toml::key* worst = nullptr;
    for (const auto& [key, value] : table_) {
      if (std::find(allowed.begin(), allowed.end(), key.str()) != allowed.end()) continue;
      if (worst == nullptr || key.source().begin.line < worst->source().begin.line) worst = &key;
    }
    if (worst == nullptr) return;
    const std::string_view key = worst->str();
    std::string where = label_.empty() ? "at the top level" : "in " + label_;
    std::string text = explain(key);
    if (text.empty()) {
      text = "unknown key '" + std::string(key) + "' " + where + did_you_mean(key, allowed);
    }
    throw Error(ctx_.file + ":" + std::to_string(worst->source().begin.line) + ": " + text);
  }
  void check_keys(const std::vector<std::string_view>& allowed) const {
    check_keys(allowed, [](std::string_view) { return std::string(); });
  }

  std::optional<double> opt_number(std::string_view key, Range range = kAny) const {
    const toml::node* node = get(key);
    if (node == nullptr) return std::nullopt;
    return number_of(key, *node, range, "");
  }
  double number(std::string_view key, double fallback, Range range = kAny) const {
    return opt_number(key, range).value_or(fallback);
  }
  float numberf(std::string_view key, float fallback, Range range = kAny) const {
    return static_cast<float>(number(key, fallback, range));
  }

  std::optional<std::int64_t> opt_integer(std::string_view key, std::int64_t lo,
                                          std::int64_t hi) const {
    const toml::node* node = get(key);
    if (node == nullptr) return std::nullopt;
    const auto* value = node->as_integer();
    if (value == nullptr) {
      fail_at(node, name(key) + ": expected an integer, got " + type_name(*node) + " (" +
                        describe(*node) + ")");
    }
    const std::int64_t v = value->get();
    if (v < lo || v > hi) {
      fail_range(key, *node, "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
    return v;
  }
  std::uint32_t uint(std::string_view key, std::uint32_t fallback, std::int64_t lo,
                     std::int64_t hi) const {
    return static_cast<std::uint32_t>(opt_integer(key, lo, hi).value_or(fallback));
  }

  std::optional<bool> opt_bool(std::string_view key) const {
    const toml::node* node = get(key);
    if (node == nullptr) return std::nullopt;
    const auto* value = node->as_boolean();
    if (value == nullptr) {
      fail_at(node, name(key) + ": expected true or false, got " + type_name(*node) + " (" +
                        describe(*node) + ")");
    }
    return value->get();
  }
  bool boolean(std::string_view key, bool fallback) const {
    return opt_bool(key).value_or(fallback);
  }

  std::optional<std::string> opt_string(std::string_view key) const {
    const toml::node* node = get(key);
    if (node == nullptr) return std::nullopt;
    const auto* value = node->as_string();
    if (value == nullptr) {
      fail_at(node, name(key) + ": expected a string, got " + type_name(*node) + " (" +
                        describe(*node) + ")");
    }
    return value->get();
  }
  std::string required_string(std::string_view key) const {
    std::optional<std::string> s = opt_string(key);
    if (!s) missing(key);
    if (s->empty()) fail_key(key, "must not be empty");
    return *s;
  }

  template <int N>
  std::optional<glm::vec<N, double>> opt_vec(std::string_view key, Range range = kAny) const {
    const toml::node* node = get(key);
    if (node == nullptr) return std::nullopt;
    const auto* array = node->as_array();
    if (array == nullptr) {
      fail_at(node, name(key) + ": expected an array of " + std::to_string(N) + " numbers, got " +
                        type_name(*node) + " (" + describe(*node) + ")");
    }
    if (array->size() != N) {
      fail_at(node, name(key) + " = " + describe(*node) + " has " + std::to_string(array->size()) +
                        " elements; expected " + std::to_string(N));
    }
    glm::vec<N, double> out(0.0);
    for (int i = 0; i < N; ++i) {
      out[i] = number_of(key, *array->get(static_cast<std::size_t>(i)), kAny,
                         " element " + std::to_string(i + 1));
    }
    for (int i = 0; i < N; ++i) {
      if (!range.contains(out[i])) fail_range(key, *node, "every element must be " + range.text());
    }
    return out;
  }
  glm::vec3 vec3(std::string_view key, glm::vec3 fallback, Range range = kAny) const {
    const auto v = opt_vec<3>(key, range);
    return v ? glm::vec3(*v) : fallback;
  }
  glm::vec3 required_vec3(std::string_view key, Range range = kAny) const {
    const auto v = opt_vec<3>(key, range);
    if (!v) missing(key);
    return glm::vec3(*v);
  }
  // A unit direction; zero length is an error.
  std::optional<glm::vec3> opt_direction(std::string_view key) const {
    const auto v = opt_vec<3>(key);
    if (!v) return std::nullopt;
    const double len = glm::length(*v);
    if (!(len > 1e-9) || !std::isfinite(len)) {
      fail_at(get(key), name(key) + " = " + describe(*get(key)) +
                            " has zero length; a direction needs a non-zero vector");
    }
    return glm::vec3(*v / len);
  }

  template <class E>
  std::optional<E> opt_enum(std::string_view key, const Names<E>& names) const {
    const toml::node* node = get(key);
    if (node == nullptr) return std::nullopt;
    std::vector<std::string_view> valid;
    for (const auto& [n, v] : names) valid.push_back(n);
    const auto* value = node->as_string();
    if (value == nullptr) {
      fail_at(node, name(key) + ": expected a string (one of " + join(valid) + "), got " +
                        type_name(*node) + " (" + describe(*node) + ")");
    }
    for (const auto& [n, v] : names) {
      if (n == value->get()) return v;
    }
    fail_at(node, name(key) + ": unknown value '" + value->get() +
                      "'; valid values: " + join(valid) + did_you_mean(value->get(), valid));
  }

  [[noreturn]] void missing(std::string_view key, std::string_view alternative = {}) const {
    fail_at(nullptr, (label_.empty() ? std::string("the scene") : label_) +
                         ": missing required key '" + std::string(key) + "'" +
                         (alternative.empty() ? "" : " (or '" + std::string(alternative) + "')"));
  }

 private:
  double number_of(std::string_view key, const toml::node& node, Range range,
                   const std::string& element) const {
    double v = 0.0;
    if (const auto* i = node.as_integer()) {
      v = static_cast<double>(i->get());
    } else if (const auto* f = node.as_floating_point()) {
      v = f->get();
    } else {
      fail_at(&node, name(key) + element + ": expected a number, got " + type_name(node) + " (" +
                         describe(node) + ")");
    }
    if (!std::isfinite(v)) {
      fail_at(&node, name(key) + element + " = " + describe(node) + " is not finite");
    }
    if (!range.contains(v)) fail_range(key, node, "must be " + range.text());
    return v;
  }

  const Context& ctx_;
  const toml::table& table_;
  std::string label_;
};

// ---- the scene -------------------------------------------------------------------------------

const std::vector<std::string_view> kTopKeys{"name",     "camera",  "sun",     "spot",
                                             "point",    "shadows", "contact", "render",
                                             "material", "object",  "scatter"};

// A single table ([sun]); nullptr when absent.
const toml::table* single_table(const Context& ctx, const toml::table& root, std::string_view key) {
  const toml::node* node = root.get(key);
  if (node == nullptr) return nullptr;
  if (const auto* table = node->as_table()) return table;
  const std::string hint =
      node->is_array() ? " (write [" + std::string(key) + "], not [[" + std::string(key) + "]])"
                       : "";
  throw Error(ctx.file + ":" + std::to_string(node->source().begin.line) + ": '" +
              std::string(key) + "' must be a table, got " + type_name(*node) + hint);
}

// An array of tables ([[object]]); empty when absent.
std::vector<const toml::table*> table_array(const Context& ctx, const toml::table& root,
                                            std::string_view key) {
  std::vector<const toml::table*> out;
  const toml::node* node = root.get(key);
  if (node == nullptr) return out;
  const auto* array = node->as_array();
  if (array == nullptr) {
    const std::string hint =
        node->is_table() ? " (write [[" + std::string(key) + "]], not [" + std::string(key) + "])"
                         : "";
    throw Error(ctx.file + ":" + std::to_string(node->source().begin.line) + ": '" +
                std::string(key) + "' must be an array of tables, got " + type_name(*node) + hint);
  }
  for (const toml::node& element : *array) {
    const auto* table = element.as_table();
    if (table == nullptr) {
      throw Error(ctx.file + ":" + std::to_string(element.source().begin.line) + ": '" +
                  std::string(key) + "' must be an array of tables ([[" + std::string(key) +
                  "]]), but an element is " + type_name(element));
    }
    out.push_back(table);
  }
  return out;
}

std::string indexed_label(std::string_view key, std::size_t index) {
  return "[[" + std::string(key) + "]] #" + std::to_string(index + 1);
}

// The rows of the parameter table (params.hpp) that `table` holds, read into the scene with the
// Reader's typed, range-checked accessors; then the rows' cross-key checks (unless the table's
// own code makes them, with messages of its own).
std::vector<std::string_view> table_keys(std::string_view table,
                                         std::vector<std::string_view> extra = {}) {
  for (const Param* p : params_of(table)) extra.push_back(p->name());
  return extra;
}

void read_param(const Reader& r, const Param& p, Scene& scene) {
  const std::string_view key = p.name();
  const toml::node* node = r.get(key);
  if (node == nullptr) return;
  switch (p.type) {
    case ParamType::number:
      p.set(scene, *r.opt_number(key, p.range));
      break;
    case ParamType::integer:
      p.set(scene, *r.opt_integer(key, std::int64_t(p.range.lo), std::int64_t(p.range.hi)));
      break;
    case ParamType::boolean:
      p.set(scene, *r.opt_bool(key));
      break;
    case ParamType::choice: {
      if (p.ordinal_alias && node->is_integer()) {
        p.set(scene, *r.opt_integer(key, 0, std::int64_t(p.choices.size()) - 1));
        break;
      }
      Names<std::int64_t> names;
      for (std::size_t i = 0; i < p.choices.size(); ++i)
        names.emplace_back(p.choices[i], std::int64_t(i));
      p.set(scene, *r.opt_enum(key, names));
      break;
    }
    case ParamType::vec3:
      p.set(scene, *r.opt_vec<3>(key, p.range));
      break;
    case ParamType::direction:
      p.set(scene, glm::dvec3(*r.opt_direction(key)));
      break;
  }
}

void read_table(const Reader& r, std::string_view table, Scene& scene, bool checks = true) {
  for (const Param* p : params_of(table))
    if (!p->custom_read) read_param(r, *p, scene);
  if (!checks) return;
  for (const Param* p : params_of(table)) {
    if (p->check == nullptr || !r.has(p->name())) continue;
    const std::string violation = p->check(scene);
    if (!violation.empty()) r.fail_at(r.get(p->name()), violation);
  }
}

void read_camera(const Reader& r, Scene& scene) {
  r.check_keys(table_keys("camera"));
  read_table(r, "camera", scene, false);
  const Camera& camera = scene.camera;
  if (!(camera.far > camera.near)) {
    r.fail_at(r.get(r.has("far") ? "far" : "near"),
              r.name("far") + " = " + format_number(camera.far) +
                  " must be greater than near = " + format_number(camera.near));
  }
  const glm::vec3 view = camera.target - camera.position;
  if (!(glm::length(view) > 1e-6f)) {
    r.fail_key(r.has("target") ? "target" : "position",
               "the camera's target equals its position; it needs a view direction");
  }
  if (glm::length(glm::cross(glm::normalize(view), camera.up)) < 1e-4f) {
    r.fail_at(r.get(r.has("up") ? "up" : "target"),
              r.name("up") + " is parallel to the view direction (target - position)");
  }
}

void read_sun(const Reader& r, Scene& scene) {
  scene.sun = Sun{};
  Sun& sun = *scene.sun;
  r.check_keys(table_keys("sun", {"elevation", "azimuth"}));
  const bool angles = r.has("elevation") || r.has("azimuth");
  if (r.has("direction") && angles) {
    r.fail_key("direction", "give either 'direction' or 'elevation' and 'azimuth', not both");
  }
  if (const auto direction = r.opt_direction("direction")) {
    sun.direction = *direction;
  } else if (angles) {
    if (!r.has("elevation")) r.missing("elevation");
    const double elevation = glm::radians(*r.opt_number("elevation", closed(-90.0, 90.0)));
    const double azimuth = glm::radians(r.number("azimuth", 0.0));
    // Towards the sun: azimuth 0 = -Z (the default view direction), 90 = +X.
    const glm::dvec3 to_sun{std::sin(azimuth) * std::cos(elevation), std::sin(elevation),
                            -std::cos(azimuth) * std::cos(elevation)};
    sun.direction = glm::vec3(-glm::normalize(to_sun));
  } else {
    r.missing("direction", "elevation");
  }
  read_table(r, "sun", scene);
}

void read_spot(const Reader& r, SpotLight& spot) {
  r.check_keys({"position", "direction", "target", "color", "intensity", "outer_angle",
                "inner_angle", "range", "radius", "shadows", "resolution"});
  spot.position = r.required_vec3("position");
  if (r.has("direction") && r.has("target")) {
    r.fail_key("target", "give either 'direction' or 'target', not both");
  }
  if (const auto direction = r.opt_direction("direction")) {
    spot.direction = *direction;
  } else if (r.has("target")) {
    const glm::vec3 to_target = r.required_vec3("target") - spot.position;
    if (!(glm::length(to_target) > 1e-6f)) {
      r.fail_key("target", "equals the light's position; it needs a direction");
    }
    spot.direction = glm::normalize(to_target);
  } else {
    r.missing("direction", "target");
  }
  spot.color = r.vec3("color", spot.color, kNonNegative);
  spot.intensity = r.numberf("intensity", spot.intensity, kNonNegative);
  spot.outer_degrees = r.numberf("outer_angle", spot.outer_degrees, open(0.0, 90.0));
  spot.inner_degrees =
      r.numberf("inner_angle", std::min(spot.inner_degrees, spot.outer_degrees), kNonNegative);
  if (spot.inner_degrees > spot.outer_degrees) {
    r.fail_at(r.get(r.has("inner_angle") ? "inner_angle" : "outer_angle"),
              r.name("inner_angle") + " = " + format_number(spot.inner_degrees) +
                  " must not exceed outer_angle = " + format_number(spot.outer_degrees));
  }
  spot.range = r.numberf("range", spot.range, kPositive);
  spot.radius = r.numberf("radius", spot.radius, kNonNegative);
  spot.shadows = r.boolean("shadows", spot.shadows);
  spot.resolution = r.uint("resolution", spot.resolution, 16, 16384);
}

void read_point(const Reader& r, PointLight& point) {
  r.check_keys({"position", "color", "intensity", "range", "radius", "shadows", "resolution"});
  point.position = r.required_vec3("position");
  point.color = r.vec3("color", point.color, kNonNegative);
  point.intensity = r.numberf("intensity", point.intensity, kNonNegative);
  point.range = r.numberf("range", point.range, kPositive);
  point.radius = r.numberf("radius", point.radius, kNonNegative);
  point.shadows = r.boolean("shadows", point.shadows);
  point.resolution = r.uint("resolution", point.resolution, 16, 8192);
}

// [shadows], [contact] and [render] are the parameter table's rows and nothing else.
void read_plain_table(const Reader& r, std::string_view table, Scene& scene) {
  r.check_keys(table_keys(table));
  read_table(r, table, scene);
}

fs::path resolve(const Context& ctx, const std::string& path) {
  fs::path p(path);
  if (p.is_relative()) p = ctx.base_dir / p;
  std::error_code ec;
  fs::path absolute = fs::absolute(p, ec);
  return (ec ? p : absolute).lexically_normal();
}

Material read_material(const Reader& r) {
  r.check_keys({"name", "albedo", "alpha", "mask", "mask_texture", "mask_scale", "alpha_cutoff"});
  Material m;
  m.name = r.required_string("name");
  m.albedo = r.vec3("albedo", m.albedo, kUnit);
  const std::optional<AlphaMode> alpha = r.opt_enum("alpha", kAlphaModes);
  std::optional<MaskPattern> mask = r.opt_enum("mask", kMasks);
  if (r.has("mask_texture")) {
    if (mask && *mask != MaskPattern::texture) {
      r.fail_key("mask_texture", "only applies with mask = 'texture' (this material has mask = '" +
                                     std::string(name_of(kMasks, *mask)) + "')");
    }
    mask = MaskPattern::texture;
    const std::string given = *r.opt_string("mask_texture");
    m.mask_texture = resolve(r.context(), given);
    std::error_code ec;
    if (!fs::is_regular_file(m.mask_texture, ec)) {
      r.fail_key("mask_texture", "texture file '" + given + "' not found (resolved to " +
                                     m.mask_texture.string() + ")");
    }
  } else if (mask == MaskPattern::texture) {
    r.fail_key("mask", "mask = 'texture' needs a mask_texture file");
  }
  m.mask = mask.value_or(MaskPattern::none);
  m.alpha = alpha.value_or(m.mask == MaskPattern::none ? AlphaMode::opaque : AlphaMode::masked);
  if (m.alpha == AlphaMode::masked && m.mask == MaskPattern::none) {
    r.fail_key("alpha",
               "alpha = 'masked' needs a mask (mask = 'stripes', 'checker', 'circles' or "
               "'texture')");
  }
  if (m.alpha == AlphaMode::opaque && m.mask != MaskPattern::none) {
    r.fail_key(r.has("mask") ? "mask" : "mask_texture",
               "a mask has no effect on an opaque material (set alpha = 'masked' or leave alpha "
               "out)");
  }
  if (const auto scale = r.opt_vec<2>("mask_scale", kPositive)) m.mask_scale = glm::vec2(*scale);
  m.alpha_cutoff = r.numberf("alpha_cutoff", m.alpha_cutoff, open(0.0, 1.0));
  return m;
}

// ---- meshes and instances --------------------------------------------------------------------

const std::vector<std::string_view> kShapes{"plane", "box", "sphere", "post", "chair", "table"};
const std::vector<std::string_view> kShapeKeys{"size",     "subdivisions", "radius",
                                               "segments", "rings",        "height"};

std::vector<std::string_view> shape_keys(std::string_view kind, bool scatter) {
  if (kind == "plane") return {"size", "subdivisions"};
  if (kind == "box" || kind == "table") return {"size"};
  if (kind == "sphere") return {"radius", "segments", "rings"};
  if (kind == "post") return {"radius", "height", "segments"};
  if (kind == "chair") return {};
  // model: and file:
  if (scatter) return {"size"};
  return {"size", "height"};
}

std::vector<std::string> model_names(const fs::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string ext = entry.path().extension().string();
    if (ext == ".obj" || ext == ".3ds") names.push_back(entry.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

fs::path model_dir() {
  if (const char* env = std::getenv("PENUMBRA_MODEL_DIR"); env != nullptr && *env != '\0') {
    return env;
  }
  return PENUMBRA_MODEL_DIR;
}

std::string hex_float(float v) {
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%a", static_cast<double>(v));
  return buffer;
}

struct MeshUse {
  std::uint32_t mesh = 0;
  glm::mat4 normalize{1.0f};  // applied before the object's own transform
};

class Builder {
 public:
  Builder(const Context& ctx, Scene& scene) : ctx_(ctx), scene_(scene) {}

  void add_material(const Reader& r, Material material) {
    const std::uint32_t line = r.line_of(r.get("name"));
    if (const auto it = material_lines_.find(material.name); it != material_lines_.end()) {
      r.fail_key("name", "material '" + material.name + "' is already defined at line " +
                             std::to_string(it->second));
    }
    material_lines_[material.name] = line;
    scene_.materials.push_back(std::move(material));
  }

  std::uint32_t material(const Reader& r) {
    const std::string name = r.opt_string("material").value_or("default");
    for (std::size_t i = 0; i < scene_.materials.size(); ++i) {
      if (scene_.materials[i].name == name) return static_cast<std::uint32_t>(i);
    }
    if (name == "default") {  // the implicit default material
      scene_.materials.push_back(Material{.name = "default"});
      return static_cast<std::uint32_t>(scene_.materials.size() - 1);
    }
    std::vector<std::string_view> names;
    for (const Material& m : scene_.materials) names.push_back(m.name);
    r.fail_key("material",
               "unknown material '" + name + "'" + did_you_mean(name, names) +
                   (names.empty() ? "; no [[material]] is defined" : "; defined: " + join(names)));
  }

  // Reads `mesh` and its shape keys, checks the table's keys, and returns the (shared) mesh.
  MeshUse mesh(const Reader& r, const std::vector<std::string_view>& common, bool scatter) {
    const std::string spec = r.required_string("mesh");
    std::string kind = spec;
    if (spec.starts_with("model:")) kind = "model:";
    if (spec.starts_with("file:")) kind = "file:";
    const bool is_file = kind == "model:" || kind == "file:";
    if (!is_file && std::find(kShapes.begin(), kShapes.end(), kind) == kShapes.end()) {
      std::vector<std::string_view> valid = kShapes;
      r.fail_key("mesh", "unknown mesh '" + spec + "'; valid: " + join(valid) +
                             ", model:<name>, file:<path>" + did_you_mean(spec, valid));
    }
    std::vector<std::string_view> allowed = common;
    const std::vector<std::string_view> own = shape_keys(kind, scatter);
    allowed.insert(allowed.end(), own.begin(), own.end());
    r.check_keys(allowed, [&](std::string_view key) -> std::string {
      if (std::find(kShapeKeys.begin(), kShapeKeys.end(), key) == kShapeKeys.end()) return "";
      const std::string what = is_file ? "a mesh file" : "mesh '" + kind + "'";
      return "key '" + std::string(key) + "' does not apply to " + what + " in " + r.label() +
             " (" + what + " takes: " + (own.empty() ? "no shape keys" : join(own)) + ")";
    });

    MeshUse use;
    if (kind == "plane") {
      const auto size = r.opt_vec<2>("size", kPositive).value_or(glm::dvec2(10.0));
      const std::uint32_t sub = r.uint("subdivisions", 1, 1, 1024);
      const auto sx = static_cast<float>(size.x);
      const auto sz = static_cast<float>(size.y);
      use.mesh = shared("plane " + hex_float(sx) + " " + hex_float(sz) + " " + std::to_string(sub),
                        [&] { return make_plane(sx, sz, sub); });
    } else if (kind == "box" || kind == "table") {
      const glm::vec3 fallback = kind == "box" ? glm::vec3(1.0f) : glm::vec3(1.4f, 0.75f, 0.8f);
      const glm::vec3 size =
          r.vec3("size", fallback, kind == "box" ? kPositive : Range{0.1, kInf, true, false});
      const std::string key =
          kind + " " + hex_float(size.x) + " " + hex_float(size.y) + " " + hex_float(size.z);
      use.mesh = shared(key, [&] { return kind == "box" ? make_box(size) : make_table(size); });
    } else if (kind == "sphere") {
      const float radius = r.numberf("radius", 0.5f, kPositive);
      const std::uint32_t segments = r.uint("segments", 32, 3, 1024);
      const std::uint32_t rings = r.uint("rings", 16, 2, 1024);
      use.mesh = shared("sphere " + hex_float(radius) + " " + std::to_string(segments) + " " +
                            std::to_string(rings),
                        [&] { return make_sphere(radius, segments, rings); });
    } else if (kind == "post") {
      const float radius = r.numberf("radius", 0.05f, kPositive);
      const float height = r.numberf("height", 2.0f, kPositive);
      const std::uint32_t segments = r.uint("segments", 12, 3, 1024);
      use.mesh = shared(
          "post " + hex_float(radius) + " " + hex_float(height) + " " + std::to_string(segments),
          [&] { return make_post(radius, height, segments); });
    } else if (kind == "chair") {
      use.mesh = shared("chair", [] { return make_chair(); });
    } else {
      const fs::path file = mesh_file(r, spec, kind);
      use.mesh = shared("file " + file.string(), [&] {
        try {
          return load_mesh(file);
        } catch (const Error& e) {
          r.fail_key("mesh", e.what());
        }
      });
      const Bounds b = scene_.meshes[use.mesh].bounds;
      const glm::vec3 extent = b.size();
      if (r.has("size") && r.has("height")) {
        r.fail_key("height", "give either 'size' or 'height', not both");
      }
      if (const auto size = r.opt_number("size", kPositive)) {
        const float largest = std::max({extent.x, extent.y, extent.z});
        if (!(largest > 0.0f)) r.fail_key("size", "the mesh has no extent to scale");
        use.normalize =
            glm::scale(glm::mat4(1.0f), glm::vec3(static_cast<float>(*size) / largest)) *
            glm::translate(glm::mat4(1.0f), -b.center());
      } else if (const auto height = r.opt_number("height", kPositive)) {
        if (!(extent.y > 0.0f)) r.fail_key("height", "the mesh is flat in y");
        use.normalize =
            glm::scale(glm::mat4(1.0f), glm::vec3(static_cast<float>(*height) / extent.y)) *
            glm::translate(glm::mat4(1.0f), -glm::vec3(b.center().x, b.min.y, b.center().z));
      } else if (scatter) {
        use.normalize = glm::translate(glm::mat4(1.0f), -b.center());
      }
    }
    return use;
  }

  const Mesh& mesh_at(std::uint32_t index) const { return scene_.meshes[index]; }

 private:
  fs::path mesh_file(const Reader& r, const std::string& spec, const std::string& kind) const {
    if (kind == "file:") {
      const std::string given = spec.substr(5);
      if (given.empty()) r.fail_key("mesh", "'file:' needs a path, e.g. file:meshes/rock.obj");
      const fs::path file = resolve(ctx_, given);
      std::error_code ec;
      if (!fs::exists(file, ec)) {
        r.fail_at(r.get("mesh"), r.name("mesh") + ": mesh file '" + given +
                                     "' not found (resolved to " + file.string() + ")");
      }
      return file;
    }
    const std::string model = spec.substr(6);
    const fs::path dir = model_dir();
    std::error_code ec;
    if (!model.empty() && model.find('/') == std::string::npos) {
      if (fs::path(model).has_extension() && fs::exists(dir / model, ec)) return dir / model;
      for (const char* ext : {".obj", ".3ds"}) {
        if (fs::exists(dir / (model + ext), ec)) return dir / (model + ext);
      }
    }
    const std::vector<std::string> names = model_names(dir);
    std::vector<std::string_view> views(names.begin(), names.end());
    r.fail_key("mesh", "model '" + model + "' not found in " + dir.string() +
                           (names.empty() ? " (is glmark2-data installed?)"
                                          : "; available: " + join(views)) +
                           did_you_mean(model, views));
  }

  template <class Make>
  std::uint32_t shared(const std::string& key, Make make) {
    if (const auto it = mesh_ids_.find(key); it != mesh_ids_.end()) return it->second;
    scene_.meshes.push_back(make());
    const auto id = static_cast<std::uint32_t>(scene_.meshes.size() - 1);
    mesh_ids_[key] = id;
    return id;
  }

  const Context& ctx_;
  Scene& scene_;
  std::map<std::string, std::uint32_t> mesh_ids_;
  std::map<std::string, std::uint32_t> material_lines_;
};

glm::mat4 rotation_xyz(glm::vec3 degrees) {
  // Applied about x, then y, then z (world axes).
  glm::mat4 m(1.0f);
  m = glm::rotate(m, glm::radians(degrees.z), glm::vec3(0, 0, 1));
  m = glm::rotate(m, glm::radians(degrees.y), glm::vec3(0, 1, 0));
  m = glm::rotate(m, glm::radians(degrees.x), glm::vec3(1, 0, 0));
  return m;
}

void read_object(const Reader& r, Builder& builder, Scene& scene) {
  const MeshUse use = builder.mesh(
      r, {"mesh", "material", "position", "rotation", "scale", "casts_shadows"}, false);
  Instance instance;
  instance.mesh = use.mesh;
  instance.material = builder.material(r);
  glm::vec3 scale(1.0f);
  if (const toml::node* node = r.get("scale"); node != nullptr && node->is_array()) {
    scale = glm::vec3(*r.opt_vec<3>("scale", kPositive));
  } else {
    scale = glm::vec3(r.numberf("scale", 1.0f, kPositive));
  }
  const glm::vec3 position = r.vec3("position", glm::vec3(0.0f));
  const glm::vec3 rotation = r.vec3("rotation", glm::vec3(0.0f));
  instance.transform = glm::translate(glm::mat4(1.0f), position) * rotation_xyz(rotation) *
                       glm::scale(glm::mat4(1.0f), scale) * use.normalize;
  instance.casts_shadows = r.boolean("casts_shadows", true);
  scene.instances.push_back(instance);
}

// A deterministic generator (splitmix64), identical on every platform.
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

 private:
  std::uint64_t state_;
};

void read_scatter(const Reader& r, Builder& builder, Scene& scene) {
  const MeshUse use = builder.mesh(r,
                                   {"mesh", "material", "count", "seed", "center", "radius",
                                    "inner_radius", "flatten", "scale", "casts_shadows"},
                                   true);
  const std::uint32_t material = builder.material(r);
  if (!r.has("count")) r.missing("count");
  if (!r.has("radius")) r.missing("radius");
  const auto count = static_cast<std::uint32_t>(*r.opt_integer("count", 1, 100000));
  const auto seed = static_cast<std::uint64_t>(
      r.opt_integer("seed", 0, std::numeric_limits<std::int64_t>::max()).value_or(1));
  const glm::dvec3 center = r.opt_vec<3>("center").value_or(glm::dvec3(0.0));
  const double radius = *r.opt_number("radius", kPositive);
  const double inner = r.number("inner_radius", 0.0, kNonNegative);
  if (!(inner < radius)) {
    r.fail_at(r.get("inner_radius"), r.name("inner_radius") + " = " + format_number(inner) +
                                         " must be less than radius = " + format_number(radius));
  }
  const double flatten = r.number("flatten", 1.0, Range{0.0, 1.0, true, false});
  glm::dvec2 scale_range(1.0);
  if (const toml::node* node = r.get("scale"); node != nullptr && node->is_array()) {
    scale_range = *r.opt_vec<2>("scale", kPositive);
    if (scale_range.x > scale_range.y) {
      r.fail_at(node,
                r.name("scale") + " = " + describe(*node) + " must be [min, max] with min <= max");
    }
  } else {
    scale_range = glm::dvec2(r.number("scale", 1.0, kPositive));
  }
  const bool casts = r.boolean("casts_shadows", true);

  const Bounds local = transform_bounds(builder.mesh_at(use.mesh).bounds, use.normalize);
  const double unit_radius = 0.5 * glm::length(glm::dvec3(local.size()));
  Random random(seed);
  struct Placed {
    glm::dvec3 position;
    double radius;
  };
  // Avoid earlier instances too, except those whose bounding sphere holds the centre (a ground
  // plane, the room around the field).
  std::vector<Placed> placed;
  for (const Instance& other : scene.instances) {
    const Bounds b = transform_bounds(scene.meshes[other.mesh].bounds, other.transform);
    const Placed sphere{glm::dvec3(b.center()), 0.5 * glm::length(glm::dvec3(b.size()))};
    if (glm::length(sphere.position - center) > sphere.radius) placed.push_back(sphere);
  }
  const bool avoid_overlap = count + placed.size() <= 4000;
  for (std::uint32_t i = 0; i < count; ++i) {
    const double scale = scale_range.x + (scale_range.y - scale_range.x) * random.uniform();
    const double bounding = unit_radius * scale;
    glm::dvec3 position = center;
    for (int attempt = 0; attempt < 64; ++attempt) {
      const double z = 2.0 * random.uniform() - 1.0;
      const double phi = 2.0 * glm::pi<double>() * random.uniform();
      const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
      const double r3 = inner * inner * inner +
                        (radius * radius * radius - inner * inner * inner) * random.uniform();
      glm::dvec3 offset = std::cbrt(r3) * glm::dvec3(s * std::cos(phi), z, s * std::sin(phi));
      offset.y *= flatten;
      position = center + offset;
      bool ok = glm::length(offset) >= inner;
      if (ok && avoid_overlap) {
        for (const Placed& p : placed) {
          if (glm::length(p.position - position) < p.radius + bounding) {
            ok = false;
            break;
          }
        }
      }
      if (ok) break;
    }
    placed.push_back({position, bounding});
    // A uniformly random rotation (Shoemake).
    const double u1 = random.uniform();
    const double u2 = 2.0 * glm::pi<double>() * random.uniform();
    const double u3 = 2.0 * glm::pi<double>() * random.uniform();
    const glm::dquat q(std::sqrt(u1) * std::cos(u3), std::sqrt(1.0 - u1) * std::sin(u2),
                       std::sqrt(1.0 - u1) * std::cos(u2), std::sqrt(u1) * std::sin(u3));
    const glm::dmat4 transform = glm::translate(glm::dmat4(1.0), position) *
                                 glm::mat4_cast(glm::normalize(q)) *
                                 glm::scale(glm::dmat4(1.0), glm::dvec3(scale));
    scene.instances.push_back(
        Instance{use.mesh, material, glm::mat4(transform) * use.normalize, casts});
  }
}

}  // namespace

Scene parse_scene(std::string_view toml_text, const std::filesystem::path& name_for_errors,
                  const std::filesystem::path& base_dir) {
  const Context ctx{name_for_errors.string(), base_dir};
  toml::table root;
  try {
    root = toml::parse(toml_text, std::string_view(ctx.file));
  } catch (const toml::parse_error& e) {
    throw Error(ctx.file + ":" + std::to_string(e.source().begin.line) +
                ": TOML syntax error (column " + std::to_string(e.source().begin.column) +
                "): " + std::string(e.description()));
  }
  Scene scene;
  scene.source = name_for_errors;
  const Reader top(ctx, root, "");
  top.check_keys(kTopKeys);
  scene.name = top.opt_string("name").value_or(name_for_errors.stem().string());

  if (const toml::table* t = single_table(ctx, root, "camera")) {
    read_camera(Reader(ctx, *t, "[camera]"), scene);
  }
  if (const toml::table* t = single_table(ctx, root, "sun")) {
    read_sun(Reader(ctx, *t, "[sun]"), scene);
  }
  const auto spots = table_array(ctx, root, "spot");
  for (std::size_t i = 0; i < spots.size(); ++i) {
    SpotLight spot;
    read_spot(Reader(ctx, *spots[i], indexed_label("spot", i)), spot);
    scene.spots.push_back(spot);
  }
  const auto points = table_array(ctx, root, "point");
  for (std::size_t i = 0; i < points.size(); ++i) {
    PointLight point;
    read_point(Reader(ctx, *points[i], indexed_label("point", i)), point);
    scene.points.push_back(point);
  }
  if (const toml::table* t = single_table(ctx, root, "shadows")) {
    read_plain_table(Reader(ctx, *t, "[shadows]"), "shadows", scene);
  }
  if (const toml::table* t = single_table(ctx, root, "contact")) {
    read_plain_table(Reader(ctx, *t, "[contact]"), "contact", scene);
  }
  if (const toml::table* t = single_table(ctx, root, "render")) {
    read_plain_table(Reader(ctx, *t, "[render]"), "render", scene);
  }

  Builder builder(ctx, scene);
  const auto materials = table_array(ctx, root, "material");
  for (std::size_t i = 0; i < materials.size(); ++i) {
    const Reader r(ctx, *materials[i], indexed_label("material", i));
    builder.add_material(r, read_material(r));
  }
  const auto objects = table_array(ctx, root, "object");
  for (std::size_t i = 0; i < objects.size(); ++i) {
    read_object(Reader(ctx, *objects[i], indexed_label("object", i)), builder, scene);
  }
  const auto scatters = table_array(ctx, root, "scatter");
  for (std::size_t i = 0; i < scatters.size(); ++i) {
    read_scatter(Reader(ctx, *scatters[i], indexed_label("scatter", i)), builder, scene);
  }
  if (scene.instances.empty()) {
    throw Error(ctx.file + ": the scene has no geometry; add an [[object]] or a [[scatter]]");
  }
  return scene;
}

Scene load_scene(const std::filesystem::path& file) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) {
    throw Error("scene file '" + file.string() + "' not found" +
                (file.is_relative() ? " (resolved to " + fs::absolute(file, ec).string() + ")"
                                    : std::string()));
  }
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error("scene file '" + file.string() + "' cannot be opened");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Error("scene file '" + file.string() + "': read error");
  return parse_scene(text.str(), file, file.parent_path());
}

namespace {
std::string_view choice_name(std::string_view key, std::size_t ordinal) {
  const Param& p = param(key);
  return ordinal < p.choices.size() ? p.choices[ordinal] : std::string_view("?");
}
}  // namespace

std::string_view to_string(Filter filter) {
  return choice_name("shadows.filter", std::size_t(filter));
}
std::string_view to_string(CascadeFit fit) {
  return choice_name("shadows.fit", std::size_t(fit));
}
std::string_view to_string(DebugView view) {
  return choice_name("render.view", std::size_t(view));
}
std::string_view to_string(AlphaMode mode) {
  return name_of(kAlphaModes, mode);
}
std::string_view to_string(MaskPattern pattern) {
  return name_of(kMasks, pattern);
}

}  // namespace penumbra::scene
