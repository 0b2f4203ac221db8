// The TOML scene file: strict reading (every key known, every value typed and range-checked) with
// errors that name the file, line, table and key. docs/scenes.md is the format's reference.
#include <algorithm>
#include <cctype>
#include <fstream>
#include <penumbra/core/file.hpp>
#include <sstream>

#include "toml_reader.hpp"

namespace penumbra::scene {
namespace {

using namespace file;
namespace fs = std::filesystem;

// ---- the scene -------------------------------------------------------------------------------

const std::vector<std::string_view> kTopKeys{"name",     "camera",  "sun",     "spot",
                                             "point",    "shadows", "contact", "render",
                                             "material", "object",  "scatter", "tune"};

// The rows of the parameter table (params.hpp) that `table` holds, read into the scene with the
// Reader's typed, range-checked accessors; then the rows' cross-key checks (unless the table's
// own code makes them, with messages of its own).
std::vector<std::string_view> table_keys(std::string_view table,
                                         std::vector<std::string_view> extra = {}) {
  for (const Param* p : params_of(table)) extra.push_back(p->name());
  return extra;
}

// A row's value from the file into the scene (for a per-light row, into light `light`).
void read_param(const Reader& r, const Param& p, Scene& scene, std::size_t light = 0) {
  const std::string_view key = p.name();
  const toml::node* node = r.get(key);
  if (node == nullptr) {
    if (p.required) r.missing(key);
    return;
  }
  const auto set = [&](const ParamValue& v) {
    if (p.per_light())
      p.set_at(scene, light, v);
    else
      p.set(scene, v);
  };
  switch (p.type) {
    case ParamType::number:
      set(*r.opt_number(key, p.range));
      break;
    case ParamType::integer:
      set(*r.opt_integer(key, std::int64_t(p.range.lo), std::int64_t(p.range.hi)));
      break;
    case ParamType::boolean:
      set(*r.opt_bool(key));
      break;
    case ParamType::choice: {
      if (p.ordinal_alias && node->is_integer()) {
        set(*r.opt_integer(key, 0, std::int64_t(p.choices.size()) - 1));
        break;
      }
      Names<std::int64_t> names;
      for (std::size_t i = 0; i < p.choices.size(); ++i)
        names.emplace_back(p.choices[i], std::int64_t(i));
      set(*r.opt_enum(key, names));
      break;
    }
    case ParamType::vec3:
      set(*r.opt_vec<3>(key, p.range));
      break;
    case ParamType::direction:
      set(glm::dvec3(*r.opt_direction(key)));
      break;
  }
}

void read_table(const Reader& r, std::string_view table, Scene& scene, bool checks = true,
                std::size_t light = 0) {
  for (const Param* p : params_of(table))
    if (!p->custom_read) read_param(r, *p, scene, light);
  if (!checks) return;
  // A check that spans keys (pcss_min_filter_texels <= pcss_max_filter_texels) fails at the
  // first of them the file gives, naming where each other one comes from: its line or the
  // default.
  for (const Param* p : params_of(table)) {
    if ((p->check == nullptr && p->check_at == nullptr) || !r.has(p->name())) continue;
    const std::string violation = p->check ? p->check(scene) : p->check_at(scene, light);
    if (violation.empty()) continue;
    std::string others;
    for (const Param* q : params_of(table)) {
      if (q == p || q->check != p->check || q->check_at != p->check_at) continue;
      others += std::string(others.empty() ? " (" : "; ") + std::string(q->name()) +
                (r.has(q->name()) ? " at line " + std::to_string(r.line_of(r.get(q->name())))
                                  : std::string(": the default"));
    }
    r.fail_at(r.get(p->name()), (p->per_light() ? r.label() + " " : std::string()) + violation +
                                    (others.empty() ? "" : others + ")"));
  }
}

void read_camera(const Reader& r, Scene& scene) {
  r.check_keys(table_keys("camera"));
  read_table(r, "camera", scene, false);
  const Camera& camera = scene.camera;
  if (!(camera.far > camera.near)) {
    // At near's line when the file gives near (far = 1000 is not wrong because near = 1e38 is),
    // naming far's line too when the file gives it; at far's line when only far is given.
    if (r.has("near")) {
      const std::string far = r.has("far")
                                  ? " (line " + std::to_string(r.line_of(r.get("far"))) + ")"
                                  : " (the default)";
      r.fail_at(r.get("near"), r.name("near") + " = " + format_number(camera.near) +
                                   " must be less than far = " + format_number(camera.far) + far);
    }
    r.fail_at(r.get("far"), r.name("far") + " = " + format_number(camera.far) +
                                " must be greater than near = " + format_number(camera.near) +
                                " (the default)");
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

// A [[spot]]: the parameter table's spot rows (read into light i), and `direction` or `target`.
void read_spot(const Reader& r, Scene& scene, std::size_t i) {
  r.check_keys(table_keys("spot", {"target"}));
  SpotLight& spot = scene.spots.emplace_back();
  // A file that gives only a smaller outer_angle gets it as the inner angle too.
  const std::optional<double> outer = r.opt_number("outer_angle", param("spot.outer_angle").range);
  if (outer && !r.has("inner_angle")) spot.inner_degrees = std::min(spot.inner_degrees, float(*outer));
  read_table(r, "spot", scene, true, i);
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
}

// A [[point]]: the parameter table's point rows, read into light i.
void read_point(const Reader& r, Scene& scene, std::size_t i) {
  r.check_keys(table_keys("point"));
  scene.points.emplace_back();
  read_table(r, "point", scene, true, i);
}

// [shadows], [contact] and [render] are the parameter table's rows and nothing else.
void read_plain_table(const Reader& r, std::string_view table, Scene& scene) {
  r.check_keys(table_keys(table));
  read_table(r, table, scene);
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
  // The name is a directory under out/: a plain name, never a path.
  {
    const std::string& n = scene.name;
    const bool plain =
        !n.empty() && n.size() <= 64 && n[0] != '.' && std::all_of(n.begin(), n.end(), [](char c) {
          return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
        });
    if (!plain) {
      const std::string shown = n.size() > 80 ? n.substr(0, 80) + "..." : n;
      const std::string text = "name = '" + shown +
                               "': must be a plain name of at most 64 letters, digits, '_', '-' "
                               "and '.' (not first); it names the output directory out/<name>";
      if (top.has("name")) top.fail_key("name", text);
      throw Error(ctx.file + ": " + text + " (from the file name; give a `name`)");
    }
  }

  if (const toml::table* t = single_table(ctx, root, "camera")) {
    read_camera(Reader(ctx, *t, "[camera]"), scene);
  }
  if (const toml::table* t = single_table(ctx, root, "sun")) {
    read_sun(Reader(ctx, *t, "[sun]"), scene);
  }
  const auto spots = table_array(ctx, root, "spot");
  for (std::size_t i = 0; i < spots.size(); ++i) {
    if (i == kMaxSpotLights) {
      const Reader extra(ctx, *spots[i], indexed_label("spot", i));
      extra.fail_at(nullptr, extra.label() + ": a scene has at most " +
                                 std::to_string(kMaxSpotLights) +
                                 " spot lights (the renderer shades that many); this one would "
                                 "be ignored");
    }
    read_spot(Reader(ctx, *spots[i], indexed_label("spot", i)), scene, i);
  }
  const auto points = table_array(ctx, root, "point");
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (i == kMaxPointLights) {
      const Reader extra(ctx, *points[i], indexed_label("point", i));
      extra.fail_at(nullptr, extra.label() + ": a scene has at most " +
                                 std::to_string(kMaxPointLights) +
                                 " point lights (the renderer shades that many); this one would "
                                 "be ignored");
    }
    read_point(Reader(ctx, *points[i], indexed_label("point", i)), scene, i);
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
  // [tune]: the budget the scene's settings were picked for (tools/penumbra-tune reads it; the
  // renderer does not). Checked here so that a typo is an error at its line like any other key.
  if (const toml::table* t = single_table(ctx, root, "tune")) {
    const Reader r(ctx, *t, "[tune]");
    r.check_keys({"budget_ms", "max_path_error", "max_flicker", "max_acne", "max_gap", "device"});
    r.opt_number("budget_ms", ranges::kPositive);
    for (std::string_view key : {"max_path_error", "max_flicker", "max_acne", "max_gap"})
      r.opt_number(key, ranges::kNonNegative);
    r.opt_string("device");
    if (!r.has("budget_ms") && !r.has("max_path_error") && !r.has("max_flicker") &&
        !r.has("max_acne") && !r.has("max_gap")) {
      r.fail_at(nullptr, "[tune] names no budget: give budget_ms or a max_* (docs/tuning.md)");
    }
  }

  read_geometry(ctx, root, scene);
  if (scene.instances.empty()) {
    throw Error(ctx.file + ": the scene has no geometry; add an [[object]] or a [[scatter]]");
  }
  return scene;
}

Scene load_scene(const std::filesystem::path& file) {
  std::error_code ec;
  if (const std::string problem = file_problem(file); !problem.empty()) {
    throw Error("scene file '" + printable(file.string()) + "' " + problem +
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
