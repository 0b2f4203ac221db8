// The scene parameter table (include/penumbra/scene/params.hpp): looking a key up (a light's by
// index), parsing and formatting values as scenes, scripts and the panel write them, the docs'
// rows and why a row does nothing for a scene. The rows themselves: param_table.cpp.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <penumbra/core/error.hpp>
#include <penumbra/scene/filters.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <sstream>

#include "param_access.hpp"

namespace penumbra::scene {
namespace {

using detail::number_text;
using namespace ranges;

[[noreturn]] void bad(const Param& p, std::string_view text) {
  throw Error(std::string(p.key) + " " +
              (text.empty() ? std::string("(empty)") : std::string(text)) + ": expected " +
              expectation(p));
}

std::optional<double> parse_number(std::string_view text) {
  const std::string s(text);
  char* end = nullptr;
  const double x = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(x)) return std::nullopt;
  // As the scene file reader: the value must survive being stored as a 32-bit float.
  const float stored = static_cast<float>(x);
  if (!std::isfinite(stored) ||
      (x != 0.0 && (stored == 0.0f || std::fpclassify(stored) == FP_SUBNORMAL))) {
    return std::nullopt;
  }
  return x;
}

std::string join(const std::vector<std::string_view>& words) {
  std::string out;
  for (std::string_view w : words) out += (out.empty() ? "" : ", ") + std::string(w);
  return out;
}

}  // namespace

std::string ParamRange::text() const {
  if (hi == kInf && lo == -kInf) return "finite";
  if (hi == kInf) return std::string(lo_open ? "> " : ">= ") + number_text(lo);
  if (lo == -kInf) return std::string(hi_open ? "< " : "<= ") + number_text(hi);
  return std::string(lo_open ? "in (" : "in [") + number_text(lo) + ", " + number_text(hi) +
         (hi_open ? ")" : "]");
}

namespace {

// "spot[1].range" -> the row key "spot.range" and the index 1; nullopt when the key has no
// brackets; throws when they are malformed.
struct Bracketed {
  std::string row;
  std::size_t light = 0;
};
std::optional<Bracketed> bracketed(std::string_view key) {
  const auto open = key.find('[');
  if (open == std::string_view::npos) return std::nullopt;
  const auto close = key.find(']', open);
  const std::string_view digits =
      close == std::string_view::npos ? std::string_view() : key.substr(open + 1, close - open - 1);
  const bool ok = open > 0 && close != std::string_view::npos && close + 2 < key.size() &&
                  key[close + 1] == '.' && !digits.empty() && digits.size() <= 4 &&
                  std::all_of(digits.begin(), digits.end(),
                              [](char c) { return c >= '0' && c <= '9'; });
  if (!ok)
    throw Error("parameter '" + std::string(key) +
                "': expected TABLE[INDEX].NAME for a light's key, e.g. spot[0].resolution");
  return Bracketed{std::string(key.substr(0, open)) + "." + std::string(key.substr(close + 2)),
                   std::size_t(std::stoul(std::string(digits)))};
}

}  // namespace

const Param* find_param(std::string_view key) {
  std::optional<Bracketed> b;
  try {
    b = bracketed(key);
  } catch (const Error&) {
    return nullptr;
  }
  const std::string_view row = b ? std::string_view(b->row) : key;
  for (const Param& p : params())
    if (p.key == row) return b && !p.per_light() ? nullptr : &p;
  return nullptr;
}

const Param& param(std::string_view key) {
  if (const Param* p = find_param(key)) return *p;
  const std::optional<Bracketed> b = bracketed(key);  // throws when malformed
  const std::string row = b ? b->row : std::string(key);
  if (b) {
    if (const Param* p = find_param(row); p && !p->per_light())
      throw Error("parameter '" + std::string(key) + "': [" + std::string(p->table()) +
                  "] is one table, not one per light; the key is '" + row + "'");
  }
  // A "did you mean": the known key sharing the longest prefix.
  const Param* best = nullptr;
  std::size_t best_len = 0;
  std::string all;
  for (const Param& p : params()) {
    if (!p.settable()) continue;
    std::size_t n = 0;
    while (n < p.key.size() && n < row.size() && p.key[n] == row[n]) ++n;
    if (n > best_len) best_len = n, best = &p;
    all += (all.empty() ? "" : ", ") +
           (p.per_light() ? light_key(p, 0) : std::string(p.key));
  }
  std::string msg = "unknown parameter '" + std::string(key) + "'";
  if (best && best_len >= 3)
    msg += " (did you mean '" +
           (best->per_light() ? light_key(*best, b ? b->light : 0) : std::string(best->key)) +
           "'?)";
  throw Error(msg + "; known: " + all);
}

KeyRef parse_key(std::string_view key) {
  const Param& p = param(key);
  const std::optional<Bracketed> b = bracketed(key);
  if (p.per_light() && !b)
    throw Error("parameter '" + std::string(key) + "': name the " +
                (p.table() == "object" ? "object" : "light") + ", e.g. " + light_key(p, 0));
  return {&p, b ? b->light : 0};
}

std::size_t light_count(const Scene& scene, std::string_view table) {
  if (table == "spot") return scene.spots.size();
  if (table == "point") return scene.points.size();
  if (table == "object") return scene.instances.size();
  return 0;
}

std::string light_key(const Param& p, std::size_t light) {
  return std::string(p.table()) + "[" + std::to_string(light) + "]." + std::string(p.name());
}

std::vector<std::string> scene_keys(const Scene& scene, bool settable_only) {
  std::vector<std::string> out;
  for (const Param& p : params())
    if (!p.per_light() && (!settable_only || p.settable())) out.emplace_back(p.key);
  // The lights' keys after the singleton tables', light by light; then the objects that move
  // (any object's can be set: a scene of 200 asteroids does not list 600 keys).
  for (std::string_view table : {"spot", "point", "object"})
    for (std::size_t i = 0; i < light_count(scene, table); ++i) {
      if (table == "object" && !scene.instances[i].motion) continue;
      for (const Param* p : params_of(table))
        if (!settable_only || p->settable()) out.push_back(light_key(*p, i));
    }
  return out;
}

std::vector<const Param*> params_of(std::string_view table) {
  std::vector<const Param*> out;
  for (const Param& p : params())
    if (p.table() == table) out.push_back(&p);
  return out;
}

std::string expectation(const Param& p) {
  switch (p.type) {
    case ParamType::number:
      return "a number " + p.range.text();
    case ParamType::integer:
      return "an integer in [" + std::to_string(std::int64_t(p.range.lo)) + ", " +
             std::to_string(std::int64_t(p.range.hi)) + "]";
    case ParamType::boolean:
      return "true or false";
    case ParamType::choice:
      return "one of " + join(p.choices) +
             (p.ordinal_alias ? " or 0.." + std::to_string(p.choices.size() - 1) : "");
    case ParamType::vec3:
      return "three numbers, e.g. 0,2,6" +
             (p.range.lo == -kInf ? std::string() : ", each " + p.range.text());
    case ParamType::direction:
      return "three numbers, not all zero, e.g. 0,-1,0";
  }
  return "";
}

std::string format_value(const Param& p, const ParamValue& value) {
  const auto g = [](double v) {
    std::ostringstream s;
    s << static_cast<float>(v);
    return s.str();
  };
  switch (p.type) {
    case ParamType::number:
      return g(std::get<double>(value));
    case ParamType::integer:
      return std::to_string(std::get<std::int64_t>(value));
    case ParamType::boolean:
      return std::get<bool>(value) ? "true" : "false";
    case ParamType::choice: {
      const auto i = std::get<std::int64_t>(value);
      return i >= 0 && std::size_t(i) < p.choices.size() ? std::string(p.choices[std::size_t(i)])
                                                         : std::to_string(i);
    }
    case ParamType::vec3:
    case ParamType::direction: {
      const glm::dvec3 v = std::get<glm::dvec3>(value);
      return g(v.x) + "," + g(v.y) + "," + g(v.z);
    }
  }
  return "";
}

ParamValue parse_value(const Param& p, std::string_view text) {
  switch (p.type) {
    case ParamType::number: {
      const auto x = parse_number(text);
      // The range holds for the value as it is stored (a 32-bit float), as in scene files.
      if (!x || !p.range.contains(*x) || !p.range.contains(double(static_cast<float>(*x))))
        bad(p, text);
      return *x;
    }
    case ParamType::integer: {
      const std::string s(text);
      char* end = nullptr;
      const long long x = std::strtoll(s.c_str(), &end, 10);
      if (s.empty() || end != s.c_str() + s.size() || double(x) < p.range.lo ||
          double(x) > p.range.hi)
        bad(p, text);
      return static_cast<std::int64_t>(x);
    }
    case ParamType::boolean:
      if (text == "true" || text == "1" || text == "on") return true;
      if (text == "false" || text == "0" || text == "off") return false;
      bad(p, text);
    case ParamType::choice:
      for (std::size_t i = 0; i < p.choices.size(); ++i)
        if (p.choices[i] == text) return static_cast<std::int64_t>(i);
      if (p.ordinal_alias && text.size() == 1 && text[0] >= '0' &&
          std::size_t(text[0] - '0') < p.choices.size())
        return static_cast<std::int64_t>(text[0] - '0');
      bad(p, text);
    case ParamType::vec3:
    case ParamType::direction: {
      std::string s(text);
      for (char& c : s)
        if (c == ',' || c == '[' || c == ']') c = ' ';
      std::istringstream in(s);
      std::vector<std::string> parts;
      for (std::string part; in >> part;) parts.push_back(part);
      if (parts.size() != 3) bad(p, text);
      glm::dvec3 v(0.0);
      for (int i = 0; i < 3; ++i) {
        const auto x = parse_number(parts[std::size_t(i)]);
        if (!x || !p.range.contains(*x)) bad(p, text);
        v[i] = *x;
      }
      if (p.type == ParamType::direction) {
        const double len = glm::length(v);
        if (!(len > 1e-9)) bad(p, text);
        v /= len;
      }
      return v;
    }
  }
  bad(p, text);
}

std::string default_text(const Param& p) {
  if (p.required) return "required";
  Scene defaults;
  defaults.sun = Sun{};
  defaults.spots.emplace_back();
  defaults.points.emplace_back();
  defaults.instances.emplace_back();
  const auto v = p.get(defaults);
  return v ? format_value(p, *v) : "";
}

std::string markdown_row(const Param& p) {
  std::string type, def = default_text(p), range;
  const auto quote = [](std::string_view w) { return "`" + std::string(w) + "`"; };
  switch (p.type) {
    case ParamType::number:
      type = "number";
      range = p.range.text();
      if (range.rfind("in ", 0) == 0) range = range.substr(3);
      break;
    case ParamType::integer:
      type = "integer";
      range = "[" + std::to_string(std::int64_t(p.range.lo)) + ", " +
              std::to_string(std::int64_t(p.range.hi)) + "]";
      break;
    case ParamType::boolean:
      type = "bool";
      break;
    case ParamType::choice:
      type = p.ordinal_alias ? "string or integer" : "string";
      def = "`\"" + def + "\"`";
      for (std::string_view c : p.choices) range += (range.empty() ? "" : ", ") + quote(c);
      break;
    case ParamType::vec3:
    case ParamType::direction: {
      type = p.name() == "color" ? "[r, g, b]" : "[x, y, z]";
      std::string v;
      for (char c : def) v += c == ',' ? std::string(", ") : std::string(1, c);
      def = "[" + v + "]";
      if (p.range.lo != -kInf) range = p.range.text();
      break;
    }
  }
  if (p.custom_read) def = "—";
  if (p.required) def = "required";
  const std::string meaning =
      range.empty() ? std::string(p.doc) : range + "; " + std::string(p.doc);
  return "| " + quote(p.name()) + " | " + type + " | " + def + " | " + meaning + " |";
}

std::string markdown_rows(std::string_view table) {
  std::string out;
  for (const Param* p : params_of(table)) out += markdown_row(*p) + "\n";
  return out;
}

std::string get_param(const Scene& scene, std::string_view key) {
  const auto [pp, light] = parse_key(key);
  const Param& p = *pp;
  const auto v = p.per_light() ? p.get_at(scene, light) : p.get(scene);
  if (!v)
    return "(no " + std::string(p.table()) + (p.per_light() ? "[" + std::to_string(light) + "]" : "") +
           ")";
  return format_value(p, *v);
}

std::pair<std::string, std::string> split_set_flag(std::string_view value) {
  const auto eq = value.find('=');
  if (eq == std::string_view::npos || eq == 0)
    throw Error("--set " + std::string(value) + ": expected KEY=VALUE, e.g. shadows.resolution=4096");
  return {std::string(value.substr(0, eq)), std::string(value.substr(eq + 1))};
}

void set_params(Scene& scene, const std::vector<std::pair<std::string, std::string>>& sets) {
  for (const auto& [key, text] : sets) {
    try {
      set_param(scene, key, text);
    } catch (const std::exception& e) {
      throw Error("--set " + key + "=" + text + ": " + e.what());
    }
  }
}

void set_param(Scene& scene, std::string_view key, std::string_view text) {
  const auto [pp, light] = parse_key(key);
  const Param& p = *pp;
  if (!p.settable())
    throw Error(std::string(key) + ": set in the scene file only (the session's size and frame " +
                "count come from its window or flags)");
  const ParamValue v = [&] {
    try {
      return parse_value(p, text);
    } catch (const Error& e) {  // named as the caller wrote it: spot[1].range, not spot.range
      const std::string message = e.what();
      if (!p.per_light() || !message.starts_with(p.key)) throw;
      throw Error(std::string(key) + message.substr(p.key.size()));
    }
  }();
  Scene next = scene;
  const auto apply = [&](Scene& s) {
    if (p.per_light())
      p.set_at(s, light, v);
    else
      p.set(s, v);
  };
  try {
    apply(next);
  } catch (const Error& e) {
    throw Error(std::string(key) + ": " + e.what());
  }
  // A light's checks are its table's (inner_angle's holds outer_angle too).
  std::string violation = p.check ? p.check(next) : std::string();
  if (p.per_light())
    for (const Param* q : params_of(p.table()))
      if (violation.empty() && q->check_at) violation = q->check_at(next, light);
  if (!violation.empty())
    throw Error(std::string(key) + " " + std::string(text) + ": " + violation);
  apply(scene);
}

bool sun_map_row(const Param& p) {
  // frame_pack.cpp's pack_sun: the sun's map alone (max_distance also fits point lights to
  // the camera, reverse_z every map's depth).
  static const std::vector<std::string_view> sun_rows{
      "cascades",       "lambda",         "resolution",     "fit",        "selection", "layout",
      "clipmap_levels", "clipmap_extent", "snap_to_texels", "blend_band", "fade_band"};
  return p.table() == "shadows" &&
         std::find(sun_rows.begin(), sun_rows.end(), p.name()) != sun_rows.end();
}

std::string unused_reason(const Scene& scene, const Param& p, std::size_t light) {
  const std::string_view table = p.table(), name = p.name();
  if (table == "camera" || table == "render") return "";
  if (p.per_light()) {
    if (light >= light_count(scene, table))
      return "no " + std::string(table) + "[" + std::to_string(light) + "]";
    if (table == "object") return "";
    const bool shadows = table == "spot" ? scene.spots[light].shadows : scene.points[light].shadows;
    if (!shadows && (name == "resolution" || name == "filter" || name == "fit_to_camera"))
      return "the light casts no shadows";
    return "";
  }
  if (table == "sun") return scene.sun ? "" : "no sun";
  if (table == "contact") {
    return name == "steps" || scene.contact.step_count > 0 ? "" : "contact steps is 0";
  }
  // [shadows]: what the shadowed lights use. The sun's map rows need a shadowed sun; a filter's
  // rows need a light whose filter (its own, or shadows.filter) it is.
  const bool sun = scene.sun && scene.sun->shadows;
  std::vector<Filter> filters;
  if (sun) filters.push_back(scene.shadows.filter);
  for (const SpotLight& l : scene.spots)
    if (l.shadows) filters.push_back(l.filter.value_or(scene.shadows.filter));
  for (const PointLight& l : scene.points)
    if (l.shadows) filters.push_back(l.filter.value_or(scene.shadows.filter));
  if (filters.empty()) return "no shadowed light";
  const auto uses = [&](Filter f) {
    return std::find(filters.begin(), filters.end(), f) != filters.end();
  };
  const auto none_uses = [](std::string_view what) { return "no light uses " + std::string(what); };
  const bool sun_row = sun_map_row(p);
  if (sun_row && !sun) return scene.sun ? "the sun casts no shadows" : "no sun";
  if (name == "filter" && !sun &&
      std::none_of(scene.spots.begin(), scene.spots.end(),
                   [](const SpotLight& l) { return l.shadows && !l.filter; }) &&
      std::none_of(scene.points.begin(), scene.points.end(),
                   [](const PointLight& l) { return l.shadows && !l.filter; }))
    return "every shadowed light has a filter of its own";
  const bool clipmap = scene.shadows.layout == ShadowLayout::clipmap;
  if ((name == "clipmap_levels" || name == "clipmap_extent") && !clipmap)
    return "layout is cascades";
  if ((name == "cascades" || name == "lambda" || name == "fit" || name == "selection" ||
       name == "blend_band") &&
      clipmap)
    return "layout is clipmap";
  // A filter's keys (the filter table's rows): something when no light uses a filter that reads
  // the key.
  std::string readers;
  bool read = false;
  for (const FilterSpec& f : filter_table())
    if (std::find(f.keys.begin(), f.keys.end(), name) != f.keys.end()) {
      readers += (readers.empty() ? "" : " or ") + std::string(f.name);
      read = read || uses(f.filter);
    }
  if (!readers.empty() && !read) return none_uses(readers);
  if (name == "temporal_weight" && !scene.shadows.temporal) return "temporal is off";
  return "";
}

}  // namespace penumbra::scene
