#pragma once

// The scene parameters: one row per key of the singleton tables ([camera], [sun], [shadows],
// [contact], [render]) and of the per-light tables ([[spot]], [[point]]: one row serves every
// light of its kind, named by index in set/get: "spot[0].resolution"). Each row carries the key as written in scene files and scripts
// ("shadows.cascades"), its type, range, choice names, whether a change needs a rebuild of
// the renderer or only a new frame, its documentation line and an accessor on Scene. The scene
// file reader, the runtime's set/get, the ImGui panel, penumbra-view's --view/--filter names and
// the key tables of docs/scenes.md all come from it (a test walks it against each of them).
// Adding a key is one row here (and its packing in src/render/frame_pack.cpp).
//
// Defaults are not repeated here: they are the member initializers of the structs in scene.hpp,
// read back from a default Scene (default_text).

#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace penumbra::scene {

struct Scene;

// An allowed numeric range; an infinite bound is open-ended.
struct ParamRange {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;

  bool contains(double v) const {
    return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
  }
  // "finite", "> 0", ">= 0", "in [0, 1]", "in (0, 180)".
  std::string text() const;
};

// The ranges the table and the scene file's other keys use.
namespace ranges {
inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr ParamRange kAny{};
inline constexpr ParamRange kPositive{0.0, kInf, true, false};
inline constexpr ParamRange kNonNegative{0.0, kInf, false, false};
inline constexpr ParamRange kUnit{0.0, 1.0, false, false};
constexpr ParamRange closed(double lo, double hi) {
  return ParamRange{lo, hi, false, false};
}
constexpr ParamRange open(double lo, double hi) {
  return ParamRange{lo, hi, true, true};
}
}  // namespace ranges

enum class ParamType {
  number,   // a float field
  integer,  // an integer field, range [lo, hi]
  boolean,
  choice,     // an enum, by name; choices[i] is ordinal i
  vec3,       // three numbers, each in range
  direction,  // three numbers, non-zero, stored normalized
};

// What a change does in a running session.
enum class ParamApply {
  frame,      // the next frame uses it
  rebuild,    // the renderer is rebuilt (images, pipelines or passes change)
  file_only,  // read from scene files only; a session's window or flags decide it
};

using ParamValue = std::variant<double, std::int64_t, bool, glm::dvec3>;

struct Param {
  std::string_view key;  // "<table>.<name>"
  ParamType type = ParamType::number;
  ParamRange range;  // number, integer (closed), vec3 (each element)
  std::vector<std::string_view> choices;
  bool ordinal_alias = false;  // a choice that also accepts its ordinal (pcss_quality = 2)
  ParamApply apply = ParamApply::frame;
  std::string_view doc;  // the docs/scenes.md line (range and meaning)
  // The panel's slider range (lo < hi), when narrower than the range or the range is open.
  ParamRange widget{0.0, 0.0};
  // Read by its table's own code in the scene file (the sun's direction, given as a vector or
  // as elevation and azimuth); still set/get like any other row.
  bool custom_read = false;

  // The scene file must give it (a light's position).
  bool required = false;

  // nullopt when the table is absent from the scene (a scene without a [sun]). A per-light row's
  // get and set are those of the first light.
  std::optional<ParamValue> (*get)(const Scene&) = nullptr;
  // Throws penumbra::Error when the table is absent.
  void (*set)(Scene&, const ParamValue&) = nullptr;
  // A constraint across keys, checked after a set; the violation as text, or "".
  std::string (*check)(const Scene&) = nullptr;
  // A per-light row ([[spot]], [[point]]): the value of light i (nullopt when there is no light
  // i), set it (throws penumbra::Error when there is none), and a cross-key check (a set of any
  // row of the table runs every row's check_at; a file's violation is at this row's line).
  std::optional<ParamValue> (*get_at)(const Scene&, std::size_t) = nullptr;
  void (*set_at)(Scene&, std::size_t, const ParamValue&) = nullptr;
  std::string (*check_at)(const Scene&, std::size_t) = nullptr;

  std::string_view table() const { return key.substr(0, key.find('.')); }
  std::string_view name() const { return key.substr(key.find('.') + 1); }
  bool settable() const { return apply != ParamApply::file_only; }
  bool per_light() const { return get_at != nullptr; }
};

// The lights of a per-light table in the scene ("spot": scene.spots.size()).
std::size_t light_count(const Scene& scene, std::string_view table);
// The key of light i's row as set/get take it: "spot[0].resolution".
std::string light_key(const Param& p, std::size_t light);
// Every key set/get take for this scene: the singleton rows' keys and, per light, light_key.
std::vector<std::string> scene_keys(const Scene& scene, bool settable_only = true);

// Every row, in the order of docs/scenes.md.
const std::vector<Param>& params();
// nullptr when unknown. A light's key ("spot[1].range") finds its row ("spot.range").
const Param* find_param(std::string_view key);
// Throws penumbra::Error "unknown parameter 'KEY' (did you mean '...'?); known: ..." .
const Param& param(std::string_view key);
// A key as set/get take it: its row and, for a per-light row, the light's index. Throws as
// param() does, and for a per-light row without an index ("spot.range": "name the light:
// spot[0].range").
struct KeyRef {
  const Param* param = nullptr;
  std::size_t light = 0;
};
KeyRef parse_key(std::string_view key);
// The rows of one table ("shadows"), in order.
std::vector<const Param*> params_of(std::string_view table);

// The value as set/get and the panel show it: "0.75", "pcf", "true", "0,2,6".
std::string format_value(const Param& p, const ParamValue& value);
// Parses text as set takes it; throws penumbra::Error "KEY TEXT: expected ..." .
ParamValue parse_value(const Param& p, std::string_view text);
// What the value must be: "an integer in [0, 8]", "one of hard, pcf, pcss, poisson".
std::string expectation(const Param& p);
// The default as docs/scenes.md writes it, from a default Scene (and a default Sun).
std::string default_text(const Param& p);

// The docs/scenes.md row of a key: "| `cascades` | integer | 4 | [1, 4]; sun cascades |"; and every
// row of a table, one per line (a test checks docs/scenes.md holds each).
std::string markdown_row(const Param& p);
std::string markdown_rows(std::string_view table);
// Every row as a JSON array: key, type, apply, range (lo, hi: null when open-ended; lo_open,
// hi_open), choices, doc, default (as docs/scenes.md writes it) and, with a scene, its value
// as get shows it (null where its table is absent); a per-light row ([[spot]], [[point]]) has
// per_light: true, its value is the first light's and values lists every light's (spot[i]).
// penumbra-view --list-params prints it.
std::string params_json(const Scene* scene);

// get/set by key and text ("shadows.cascades", "spot[0].resolution"), with the row's checks;
// set leaves the scene unchanged on error, and names the light that is not there.
std::string get_param(const Scene& scene, std::string_view key);
void set_param(Scene& scene, std::string_view key, std::string_view text);

// A command line's "--set KEY=VALUE": split_set_flag splits the flag's value (throws
// penumbra::Error "--set V: expected KEY=VALUE, ..." without an '=' or a key); set_params
// applies them in order with set_param, its errors prefixed "--set KEY=VALUE: ".
std::pair<std::string, std::string> split_set_flag(std::string_view value);
void set_params(Scene& scene, const std::vector<std::pair<std::string, std::string>>& sets);

// Why a row does nothing for this scene as it is now, or "" when it matters: "no sun", "no
// shadowed light", "no light uses pcss", "layout is cascades", "temporal is off", "contact
// steps is 0". The panel lists such rows apart, so it shows first what the scene models.
// A [shadows] row of the sun's map alone (cascades, resolution, layout, ...): the panel shows it
// with the sun.
bool sun_map_row(const Param& p);
// For a per-light row, of light `light`: "the light casts no shadows", "its filter is pcf".
std::string unused_reason(const Scene& scene, const Param& p, std::size_t light = 0);

// The constraints of [camera] across keys ("" when they hold): target != position, up not
// parallel to the view, far > near. The scene file and set_param both use it.
std::string camera_violation(const Scene& scene);

}  // namespace penumbra::scene
