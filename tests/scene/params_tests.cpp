// The parameter table (scene/params.hpp), walked row by row: every key parses from a scene file,
// round-trips through set/get (what the runtime's `set`/`get` and the panel call), is rejected
// out of range with the file's line and the key, and appears in docs/scenes.md as the table
// generates it.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <penumbra/scene/filters.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <set>
#include <sstream>
#include <string>

namespace penumbra::scene {
namespace {

using ::testing::HasSubstr;

const std::string kBox = "[[object]]\nmesh = \"box\"\n";
// A sun, a spot and a point light: every row's table is there.
const std::string kLit =
    "[sun]\ndirection = [0, -1, 0]\n[[spot]]\nposition = [0, 3, 0]\ndirection = [0, -1, 0]\n"
    "[[point]]\nposition = [1, 2, 0]\n" +
    kBox;

// The key as set and get take it: a per-light row's names the first light.
std::string key_of(const Param& p) {
  return p.per_light() ? light_key(p, 0) : std::string(p.key);
}

Scene parse(const std::string& text) {
  return parse_scene(text, "params.toml", ".");
}

std::string error_of(const std::string& text) {
  try {
    parse(text);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// set_param's error on `scene`, which must be left as it was.
std::string set_error_in(Scene& scene, const std::string& key, const std::string& text) {
  const Scene before = scene;
  try {
    set_param(scene, key, text);
  } catch (const Error& e) {
    for (const std::string& k : scene_keys(before, false))
      EXPECT_EQ(get_param(scene, k), get_param(before, k)) << key << ": a rejected set changed " << k;
    return e.what();
  }
  return "(no error)";
}

std::string set_error(const std::string& key, const std::string& text) {
  Scene scene = parse(kLit);
  return set_error_in(scene, key, text);
}

// A value in range and different from the default, as TOML and as `set` text.
struct Sample {
  std::string toml, text;
};

// Whether `value` set on the row keeps the row's cross-key checks against the other defaults.
bool passes_checks(const Param& p, const ParamValue& value) {
  Scene scene = parse(kLit);
  p.set(scene, value);
  std::string violation = p.check ? p.check(scene) : std::string();
  for (const Param* q : params_of(p.table()))  // a light's checks are its table's
    if (violation.empty() && q->check_at) violation = q->check_at(scene, 0);
  return violation.empty();
}

Sample sample(const Param& p) {
  const std::string def = default_text(p);
  switch (p.type) {
    case ParamType::number:
      for (double x : {0.37, 1.7, 3.25, 0.0125, 1e-4, 45.5, 5000.0}) {
        std::ostringstream s;
        s << x;
        if (!p.range.contains(x) || s.str() == def || !passes_checks(p, x)) continue;
        return {s.str(), s.str()};
      }
      break;
    case ParamType::integer: {
      const auto lo = static_cast<long long>(p.range.lo);
      const std::string v = std::to_string(std::to_string(lo) == def ? lo + 1 : lo);
      return {v, v};
    }
    case ParamType::boolean:
      return def == "true" ? Sample{"false", "false"} : Sample{"true", "true"};
    case ParamType::choice:
      // The last choice that is not the default and that the row's checks take (a point
      // light's filter must take cube maps).
      for (std::size_t i = p.choices.size(); i-- > 0;) {
        const std::string v(p.choices[i]);
        if (v == def || !passes_checks(p, static_cast<std::int64_t>(i))) continue;
        return {"\"" + v + "\"", v};
      }
      break;
    case ParamType::vec3:
      return {"[0.25, 0.5, 0.75]", "0.25,0.5,0.75"};
    case ParamType::direction:
      return {"[0, -2, 1]", "0,-2,1"};
  }
  ADD_FAILURE() << p.key << ": no in-range sample";
  return {};
}

// A value of the right type outside the range (empty when the range has no bound to cross).
std::string out_of_range(const Param& p) {
  switch (p.type) {
    case ParamType::number:
    case ParamType::integer: {
      std::ostringstream s;
      if (std::isfinite(p.range.hi))
        s << p.range.hi + 1.0;
      else if (std::isfinite(p.range.lo))
        s << (p.range.lo_open ? p.range.lo : p.range.lo - 1.0);
      return s.str();
    }
    case ParamType::choice:
      return "\"no_such_choice\"";
    case ParamType::vec3: {
      if (!std::isfinite(p.range.hi)) return std::isfinite(p.range.lo) ? "[-1, 0.5, 0.5]" : "";
      std::ostringstream s;
      s << "[" << p.range.hi + 1.0 << ", 0, 0]";
      return s.str();
    }
    case ParamType::direction:
      return "[0, 0, 0]";
    case ParamType::boolean:
      return "\"yes\"";
  }
  return "";
}

std::string file_of(const Param& p, const std::string& toml) {
  std::string prefix;
  if (p.table() != "sun") prefix = "[sun]\ndirection = [0, -1, 0]\n";
  const std::string key(p.custom_read ? "direction" : p.name());
  if (p.table() == "object") {  // a box, the other half of a move, then the row's
    const std::string partner = key == "move"          ? "move_frames = 60\n"
                                : key == "move_frames" ? "move = [0.5, 0, 0]\n"
                                                       : "";
    return prefix + kBox + partner + key + " = " + toml + "\n" + kBox;
  }
  if (p.per_light()) {  // the light's required keys, then the row's
    std::string light = "[[" + std::string(p.table()) + "]]\n";
    if (key != "position") light += p.table() == "spot" ? "position = [0, 3, 0]\n" : "position = [1, 2, 0]\n";
    if (p.table() == "spot" && key != "direction") light += "direction = [0, -1, 0]\n";
    return prefix + light + key + " = " + toml + "\n" + kBox;
  }
  return prefix + "[" + std::string(p.table()) + "]\n" +
         (p.table() == "sun" && key != "direction" ? "direction = [0, -1, 0]\n" : "") + key +
         " = " + toml + "\n" + kBox;
}

std::string docs_section(std::string_view table) {
  std::ifstream in(PENUMBRA_DOCS_DIR "/scenes.md");
  std::ostringstream text;
  text << in.rdbuf();
  const std::string all = text.str();
  const bool per_light = table == "spot" || table == "point" || table == "object";
  const std::string head = per_light ? "## `[[" + std::string(table) + "]]`"
                                     : "## `[" + std::string(table) + "]`";
  const auto start = all.find(head);
  if (start == std::string::npos) return "";
  const auto end = all.find("\n## ", start + head.size());
  return all.substr(start, end == std::string::npos ? std::string::npos : end - start);
}

TEST(Params, EveryKeyIsUniqueAndNamesItsTable) {
  std::set<std::string_view> seen;
  for (const Param& p : params()) {
    EXPECT_TRUE(seen.insert(p.key).second) << p.key;
    EXPECT_NE(p.key.find('.'), std::string_view::npos) << p.key;
    EXPECT_FALSE(p.doc.empty()) << p.key;
    ASSERT_NE(p.get, nullptr) << p.key;
    ASSERT_NE(p.set, nullptr) << p.key;
    EXPECT_EQ(find_param(p.key), &p);
    if (p.type == ParamType::choice) {
      EXPECT_GE(p.choices.size(), 2u) << p.key;
    }
  }
  EXPECT_GE(params().size(), 40u);
}

TEST(Params, EveryKeyParsesFromAFileAndRoundTripsThroughSetAndGet) {
  for (const Param& p : params()) {
    SCOPED_TRACE(std::string(p.key));
    const Sample s = sample(p);
    Scene from_file;
    ASSERT_NO_THROW(from_file = parse(file_of(p, s.toml))) << error_of(file_of(p, s.toml));
    const std::string read = get_param(from_file, key_of(p));
    EXPECT_NE(read, default_text(p)) << "the file's value was not applied";
    // The same value through set, then get, gives the same text; setting what get returned
    // changes nothing.
    if (!p.settable()) {
      Scene scene = parse(kBox);
      EXPECT_THROW(set_param(scene, key_of(p), s.text), Error);
      continue;
    }
    Scene scene = parse(kLit);
    set_param(scene, key_of(p), s.text);
    EXPECT_EQ(get_param(scene, key_of(p)), read);
    set_param(scene, key_of(p), get_param(scene, key_of(p)));
    EXPECT_EQ(get_param(scene, key_of(p)), read);
  }
}

TEST(Params, OutOfRangeValuesAreRejectedWithFileLineAndKey) {
  int checked = 0;
  for (const Param& p : params()) {
    SCOPED_TRACE(std::string(p.key));
    const std::string bad = out_of_range(p);
    if (bad.empty()) continue;
    const std::string text = file_of(p, bad);
    // The key's line in the file: its table's header is the line before it.
    std::istringstream lines(text);
    int line = 0, key_line = 0;
    const std::string key(p.custom_read ? "direction" : p.name());
    for (std::string l; std::getline(lines, l);) {
      ++line;
      if (l.rfind(key + " = " + bad, 0) == 0) key_line = line;
    }
    ASSERT_GT(key_line, 0);
    const std::string message = error_of(text);
    EXPECT_THAT(message, HasSubstr("params.toml:" + std::to_string(key_line) + ":"));
    EXPECT_THAT(message, HasSubstr(key));
    // set rejects the same value, naming the key, and leaves the scene as it was.
    if (p.settable()) {
      std::string set_text = bad;
      if (set_text.front() == '"') set_text = set_text.substr(1, set_text.size() - 2);
      if (set_text.front() == '[') set_text = set_text.substr(1, set_text.size() - 2);
      EXPECT_THAT(set_error(key_of(p), set_text), HasSubstr(key_of(p)));
    }
    ++checked;
  }
  EXPECT_GE(checked, 35);
}

// Numbers that a double holds but a 32-bit float does not (they overflow to inf, become 0 or a
// denormal) are refused in files (naming file:line and key) and in set, for every numeric key.
TEST(Params, NumbersThatDoNotFitAFloatAreRejected) {
  int checked = 0;
  for (const Param& p : params()) {
    if (p.type != ParamType::number && p.type != ParamType::vec3) continue;
    SCOPED_TRACE(std::string(p.key));
    for (const std::string v : {"1e39", "-1e39", "1e-50", "-5e-324", "1e-39"}) {
      const std::string value = p.type == ParamType::vec3 ? "[" + v + ", 0, 0]" : v;
      const std::string text = file_of(p, value);
      const std::string message = error_of(text);
      EXPECT_THAT(message, HasSubstr("params.toml:")) << v;
      EXPECT_THAT(message, HasSubstr(p.custom_read ? "direction" : std::string(p.name()))) << v;
      if (p.settable()) {
        const std::string set_text = p.type == ParamType::vec3 ? v + ",0,0" : v;
        EXPECT_THAT(set_error(key_of(p), set_text), HasSubstr(key_of(p))) << v;
      }
    }
    ++checked;
  }
  EXPECT_GE(checked, 20);
  // The message says why for an in-range-looking value.
  EXPECT_THAT(error_of(file_of(param("camera.near"), "1e-50")),
              HasSubstr("does not fit a 32-bit float"));
  // In range as a double, 180 as a float: refused in both places.
  EXPECT_THAT(error_of(file_of(param("camera.fov_y"), "179.99999999")),
              HasSubstr("as a 32-bit float it is 180"));
  EXPECT_THAT(set_error("camera.fov_y", "179.99999999"), HasSubstr("camera.fov_y"));
}

TEST(Params, CrossKeyChecksHoldInFilesAndSets) {
  EXPECT_THAT(
      error_of("[shadows]\npcss_min_filter_texels = 8\npcss_max_filter_texels = 4\n" + kBox),
      HasSubstr("params.toml:2: shadows.pcss_min_filter_texels = 8 must not exceed "
                "pcss_max_filter_texels = 4 (pcss_max_filter_texels at line 3)"));
  // Only the maximum given: at its line, the minimum named as the default.
  EXPECT_THAT(error_of("[shadows]\n\npcss_max_filter_texels = 0.5\n" + kBox),
              HasSubstr("params.toml:3: shadows.pcss_min_filter_texels = 1 must not exceed "
                        "pcss_max_filter_texels = 0.5 (pcss_min_filter_texels: the "
                        "default)"));
  EXPECT_THAT(set_error("shadows.pcss_min_filter_texels", "40"), HasSubstr("must not exceed"));
  EXPECT_THAT(set_error("camera.far", "0.01"), HasSubstr("must be greater than near"));
  EXPECT_THAT(set_error("camera.target", "0,2,6"), HasSubstr("target equals its position"));
  Scene no_sun = parse(kBox);
  EXPECT_THROW(set_param(no_sun, "sun.intensity", "2"), Error);
  EXPECT_EQ(get_param(no_sun, "sun.intensity"), "(no sun)");
}

// [[spot]] and [[point]] keys are rows too, one for every light, named by index.
TEST(Params, ALightsKeysAreSetAndReadByIndex) {
  Scene scene = parse(kLit + "[[spot]]\nposition = [2, 3, 0]\ntarget = [0, 0, 0]\n");
  ASSERT_EQ(scene.spots.size(), 2u);
  set_param(scene, "spot[1].resolution", "2048");
  EXPECT_EQ(scene.spots[1].resolution, 2048u);
  EXPECT_EQ(scene.spots[0].resolution, 1024u);
  EXPECT_EQ(get_param(scene, "spot[1].resolution"), "2048");
  set_param(scene, "point[0].filter", "pcss");
  EXPECT_EQ(scene.points[0].filter, Filter::pcss);
  set_param(scene, "point[0].filter", "inherit");
  EXPECT_FALSE(scene.points[0].filter.has_value());
  EXPECT_THAT(set_error("spot[1].range", "5"), HasSubstr("has 1 spot light: no spot[1]"));
  EXPECT_EQ(get_param(parse(kLit), "spot[1].range"), "(no spot[1])");
  EXPECT_THAT(set_error("spot.range", "5"), HasSubstr("name the light, e.g. spot[0].range"));
  EXPECT_THAT(set_error("spot[x].range", "5"), HasSubstr("expected TABLE[INDEX].NAME"));
  EXPECT_THAT(set_error("shadows[0].filter", "pcf"), HasSubstr("the key is 'shadows.filter'"));
  EXPECT_THAT(set_error("spot[0].rnage", "5"), HasSubstr("did you mean 'spot[0].range'"));
  EXPECT_THAT(set_error("spot[0].inner_angle", "40"),
              HasSubstr("inner_angle = 40 must not exceed outer_angle = 30"));
  EXPECT_THAT(set_error("spot[0].outer_angle", "10"),
              HasSubstr("inner_angle = 25 must not exceed outer_angle = 10"));
  // Every light's keys, after the singleton tables'.
  const std::vector<std::string> keys = scene_keys(scene);
  EXPECT_NE(std::find(keys.begin(), keys.end(), "spot[1].filter"), keys.end());
  EXPECT_NE(std::find(keys.begin(), keys.end(), "point[0].fit_to_camera"), keys.end());
  EXPECT_EQ(std::find(keys.begin(), keys.end(), "spot.filter"), keys.end());
  EXPECT_EQ(std::find(keys.begin(), keys.end(), "point[1].range"), keys.end());
}

// [[object]] motion keys, by the object's index: a still object set moving starts from where it
// is; the file's checks hold for set, naming the key; the listed keys are the moving objects'.
TEST(Params, AnObjectsMotionIsSetAndReadByIndex) {
  const std::string ground = "[[object]]\nmesh = \"plane\"\nsize = [40, 40]\n";
  Scene scene = parse(ground + "[[object]]\nmesh = \"box\"\nposition = [2, 0.5, 0]\n" +
                      "[[object]]\nmesh = \"sphere\"\nanalytic_shadow = true\n");
  const glm::mat4 rest = scene.instances[1].transform;
  EXPECT_FALSE(scene.instances[1].motion.has_value());
  EXPECT_EQ(get_param(scene, "object[1].move"), "0,0,0");
  const auto listed = [&](const std::string& key) {
    const std::vector<std::string> keys = scene_keys(scene);
    return std::find(keys.begin(), keys.end(), key) != keys.end();
  };
  EXPECT_FALSE(listed("object[1].move"));
  set_param(scene, "object[1].move", "3,0,0");
  set_param(scene, "object[1].move_frames", "10");
  ASSERT_TRUE(scene.instances[1].motion.has_value());
  EXPECT_EQ(scene.instances[1].motion->base, rest);
  EXPECT_EQ(get_param(scene, "object[1].move"), "3,0,0");
  EXPECT_EQ(get_param(scene, "object[1].move_frames"), "10");
  scene.pose(10);
  EXPECT_EQ(glm::vec3(scene.instances[1].transform[3]), glm::vec3(5.0f, 0.5f, 0.0f));
  EXPECT_TRUE(listed("object[1].spin"));
  EXPECT_FALSE(listed("object[0].spin"));
  // The file's checks, at set: out of the scene, a spinning analytic sphere, a missing object,
  // an out-of-range value.
  EXPECT_THAT(set_error_in(scene, "object[1].move", "0,0,500"),
              HasSubstr("object[1].move 0,0,500: the object's move takes it to [2, 0.5, 500]"));
  EXPECT_THAT(set_error_in(scene, "object[2].spin", "0,5,0"),
              HasSubstr("object[2].spin 0,5,0: an analytic sphere's shadow does not turn"));
  EXPECT_THAT(set_error_in(scene, "object[3].move", "1,0,0"), HasSubstr("has 3 objects: no object[3]"));
  EXPECT_THAT(set_error_in(scene, "object[1].spin", "400,0,0"), HasSubstr("object[1].spin"));
  EXPECT_THAT(set_error_in(scene, "object.move", "1,0,0"), HasSubstr("name the object, e.g. object[0].move"));
  EXPECT_EQ(get_param(scene, "object[1].move"), "3,0,0");
  EXPECT_EQ(get_param(scene, "object[3].move"), "(no object[3])");
}

TEST(Params, EveryKeyAppearsInDocsScenesMdAsTheTableGeneratesIt) {
  for (const Param& p : params()) {
    const std::string section = docs_section(p.table());
    ASSERT_FALSE(section.empty()) << "docs/scenes.md has no section ## `[" << p.table() << "]`";
    EXPECT_THAT(section, HasSubstr(markdown_row(p) + "\n"))
        << "docs/scenes.md is out of date; the [" << p.table() << "] rows are:\n"
        << markdown_rows(p.table());
  }
}

TEST(Params, ChoicesAreTheEnumsNames) {
  EXPECT_EQ(to_string(Filter::poisson), "poisson");
  EXPECT_EQ(to_string(CascadeFit::slice_sphere), "slice_sphere");
  EXPECT_EQ(to_string(DebugView::penumbra), "penumbra");
  EXPECT_EQ(to_string(DebugView::redrawn), "redrawn");
  EXPECT_EQ(param("render.view").choices.size(), std::size_t(DebugView::redrawn) + 1);
  EXPECT_EQ(param("shadows.filter").choices.size(), filter_table().size());
  EXPECT_THAT(
      [] {
        try {
          param("shadows.filtr");
        } catch (const Error& e) {
          return std::string(e.what());
        }
        return std::string();
      }(),
      HasSubstr("did you mean 'shadows.filter'"));
}

}  // namespace
}  // namespace penumbra::scene

namespace penumbra::scene {
namespace {

// The rows a scene does not use, and why: what the panel lists apart.
TEST(Params, UnusedRowsSayWhyForEachShippedScene) {
  const auto reason = [](const Scene& s, std::string_view key) {
    return unused_reason(s, param(key));
  };
  const Scene indoor = load_scene(find_scene("indoor"));  // a spot and a point light, no sun
  EXPECT_EQ(reason(indoor, "sun.intensity"), "no sun");
  EXPECT_EQ(reason(indoor, "shadows.cascades"), "no sun");
  EXPECT_EQ(reason(indoor, "shadows.pcss_search_texels"), "no light uses pcss");
  EXPECT_EQ(reason(indoor, "shadows.normal_offset_texels"), "");
  EXPECT_EQ(reason(indoor, "shadows.max_distance"), "") << "it fits point lights too";
  EXPECT_EQ(reason(indoor, "camera.fov_y"), "");

  const Scene def = load_scene(find_scene("default"));  // hard sun, cascades, temporal on
  EXPECT_EQ(reason(def, "shadows.cascades"), "");
  EXPECT_EQ(reason(def, "shadows.clipmap_levels"), "layout is cascades");
  std::string pcf_readers;  // the filters that read pcf_radius, as the filter table lists them
  for (const FilterSpec& f : filter_table())
    if (std::find(f.keys.begin(), f.keys.end(), "pcf_radius") != f.keys.end())
      pcf_readers += (pcf_readers.empty() ? "" : " or ") + std::string(f.name);
  EXPECT_EQ(pcf_readers.substr(0, 14), "pcf or poisson");
  EXPECT_EQ(reason(def, "shadows.pcf_radius"), "no light uses " + pcf_readers);
  EXPECT_EQ(reason(def, "shadows.evsm_blur"), "no light uses evsm2");
  EXPECT_EQ(reason(def, "shadows.temporal_weight"), "");
  EXPECT_EQ(reason(def, "contact.thickness"), "");

  const Scene space = load_scene(find_scene("space"));  // a point light, temporal off
  EXPECT_EQ(reason(space, "shadows.temporal_weight"), "temporal is off");
  EXPECT_EQ(reason(space, "shadows.cascades"), "no sun");

  const Scene grazing = load_scene(find_scene("grazing"));  // pcss, temporal, contact off
  EXPECT_EQ(reason(grazing, "shadows.pcss_quality"), "");
  EXPECT_EQ(reason(grazing, "shadows.temporal_weight"), "");
  EXPECT_EQ(reason(grazing, "contact.thickness"), "contact steps is 0");
  EXPECT_EQ(reason(grazing, "contact.steps"), "") << "the row that turns the pass on";

  Scene clip = def;
  set_param(clip, "shadows.layout", "clipmap");
  EXPECT_EQ(reason(clip, "shadows.clipmap_levels"), "");
  EXPECT_EQ(reason(clip, "shadows.lambda"), "layout is clipmap");
  set_param(clip, "sun.shadows", "false");
  EXPECT_EQ(reason(clip, "shadows.resolution"), "no shadowed light");
  EXPECT_EQ(reason(clip, "shadows.constant_bias"), "no shadowed light");
}

}  // namespace
}  // namespace penumbra::scene
