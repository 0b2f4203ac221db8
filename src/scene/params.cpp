// The scene parameter table (include/penumbra/scene/params.hpp): the rows, and parsing and
// formatting values as scripts and the panel write them. Over 600 lines because the table is
// here, one row (key, type, range, accessor, rebuild flag, docs line) per scene key.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <penumbra/core/error.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <sstream>
#include <type_traits>

namespace penumbra::scene {
namespace {

using namespace ranges;
// The panel's slider range of a row.
constexpr ParamRange slider(double lo, double hi) {
  return closed(lo, hi);
}

std::string number_text(double v) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%g", v);
  return buffer;
}

// ---- field accessors: the value types of ParamValue from the fields' own types ------------

template <class T>
ParamValue to_value(const T& v) {
  if constexpr (std::is_same_v<T, bool>) {
    return v;
  } else if constexpr (std::is_enum_v<T>) {
    return static_cast<std::int64_t>(v);
  } else if constexpr (std::is_integral_v<T>) {
    return static_cast<std::int64_t>(v);
  } else if constexpr (std::is_floating_point_v<T>) {
    return static_cast<double>(v);
  } else {
    return glm::dvec3(v);
  }
}

template <class T>
T from_value(const ParamValue& v) {
  if constexpr (std::is_same_v<T, bool>) {
    return std::get<bool>(v);
  } else if constexpr (std::is_enum_v<T> || std::is_integral_v<T>) {
    return static_cast<T>(std::get<std::int64_t>(v));
  } else if constexpr (std::is_floating_point_v<T>) {
    return static_cast<T>(std::get<double>(v));
  } else {
    return T(std::get<glm::dvec3>(v));
  }
}

struct Access {
  std::optional<ParamValue> (*get)(const Scene&);
  void (*set)(Scene&, const ParamValue&);
};

// A field of one of Scene's always-present tables.
template <auto Table, auto Field>
Access field() {
  return {[](const Scene& s) -> std::optional<ParamValue> { return to_value((s.*Table).*Field); },
          [](Scene& s, const ParamValue& v) {
            auto& f = (s.*Table).*Field;
            f = from_value<std::remove_cvref_t<decltype(f)>>(v);
          }};
}

// A field of the optional [sun].
template <auto Field>
Access sun_field() {
  return {[](const Scene& s) -> std::optional<ParamValue> {
            if (!s.sun) return std::nullopt;
            return to_value((*s.sun).*Field);
          },
          [](Scene& s, const ParamValue& v) {
            if (!s.sun) throw Error("the scene '" + s.name + "' has no [sun]");
            auto& f = (*s.sun).*Field;
            f = from_value<std::remove_cvref_t<decltype(f)>>(v);
          }};
}

// A field of every light of one kind ([[spot]] or [[point]]: Scene::spots or Scene::points);
// get and set are the first light's.
struct IndexedAccess {
  std::optional<ParamValue> (*get_at)(const Scene&, std::size_t) = nullptr;
  void (*set_at)(Scene&, std::size_t, const ParamValue&) = nullptr;
  std::optional<ParamValue> (*get)(const Scene&) = nullptr;
  void (*set)(Scene&, const ParamValue&) = nullptr;
};

template <auto List>
auto& light_at(Scene& s, std::size_t i) {
  auto& list = s.*List;
  if (i >= list.size()) {
    const std::string kind =
        std::is_same_v<std::remove_cvref_t<decltype(list)>, std::vector<SpotLight>> ? "spot"
                                                                                     : "point";
    throw Error("the scene '" + s.name + "' has " + std::to_string(list.size()) + " " + kind +
                " light" + (list.size() == 1 ? "" : "s") + ": no " + kind + "[" +
                std::to_string(i) + "]");
  }
  return list[i];
}

template <auto List, auto Field>
std::optional<ParamValue> light_get(const Scene& s, std::size_t i) {
  if (i >= (s.*List).size()) return std::nullopt;
  return to_value((s.*List)[i].*Field);
}
template <auto List, auto Field>
void light_set(Scene& s, std::size_t i, const ParamValue& v) {
  auto& f = light_at<List>(s, i).*Field;
  f = from_value<std::remove_cvref_t<decltype(f)>>(v);
}

// A light's own filter: choice 0 ("inherit") is none, [shadows] filter's; i is Filter(i - 1).
template <auto List>
std::optional<ParamValue> filter_get(const Scene& s, std::size_t i) {
  if (i >= (s.*List).size()) return std::nullopt;
  const std::optional<Filter>& f = (s.*List)[i].filter;
  return f ? std::int64_t(*f) + 1 : std::int64_t(0);
}
template <auto List>
void filter_set(Scene& s, std::size_t i, const ParamValue& v) {
  const std::int64_t choice = std::get<std::int64_t>(v);
  light_at<List>(s, i).filter =
      choice == 0 ? std::nullopt : std::optional<Filter>(Filter(choice - 1));
}

template <auto GetAt>
std::optional<ParamValue> first_get(const Scene& s) {
  return GetAt(s, 0);
}
template <auto SetAt>
void first_set(Scene& s, const ParamValue& v) {
  SetAt(s, 0, v);
}

template <auto GetAt, auto SetAt>
IndexedAccess indexed() {
  return {GetAt, SetAt, first_get<GetAt>, first_set<SetAt>};
}
template <auto List, auto Field>
IndexedAccess light_field() {
  return indexed<light_get<List, Field>, light_set<List, Field>>();
}
template <auto List>
IndexedAccess light_filter() {
  return indexed<filter_get<List>, filter_set<List>>();
}

std::string spot_angle_violation(const Scene& s, std::size_t i) {
  if (i >= s.spots.size()) return "";
  const SpotLight& l = s.spots[i];
  if (l.inner_degrees > l.outer_degrees)
    return "inner_angle = " + number_text(l.inner_degrees) + " must not exceed outer_angle = " +
           number_text(l.outer_degrees);
  return "";
}

struct Row {
  std::string_view key;
  ParamType type;
  ParamRange range;
  Access access;
  ParamApply apply;
  std::string_view doc;
  std::vector<std::string_view> choices = {};
  ParamRange widget = {0.0, 0.0};
  std::string (*check)(const Scene&) = nullptr;
  bool ordinal_alias = false;
  bool custom_read = false;
  IndexedAccess at = {};
  std::string (*check_at)(const Scene&, std::size_t) = nullptr;
  bool required = false;
};

std::string pcss_violation(const Scene& s) {
  if (s.shadows.pcss_min_filter_texels > s.shadows.pcss_max_filter_texels)
    return "shadows.pcss_min_filter_texels = " + number_text(s.shadows.pcss_min_filter_texels) +
           " must not exceed pcss_max_filter_texels = " +
           number_text(s.shadows.pcss_max_filter_texels);
  return "";
}

std::vector<Param> make_params() {
  using S = Scene;
  using A = ParamApply;
  using T = ParamType;
  const std::vector<std::string_view> filters{"hard", "pcf", "pcss", "poisson", "evsm2"};
  const std::vector<std::string_view> local_filters{"inherit", "hard",    "pcf",
                                                    "pcss",    "poisson", "evsm2"};
  const std::vector<std::string_view> fits{"box", "camera_sphere", "slice_sphere"};
  const std::vector<std::string_view> selections{"depth", "containment"};
  const std::vector<std::string_view> layouts{"cascades", "clipmap"};
  const std::vector<std::string_view> views{"lit",          "shadow_factor", "cascades",
                                            "contact_mask", "texel_density", "penumbra"};
  const std::vector<Row> rows = {
      // [camera]
      {"camera.position",
       T::vec3,
       kAny,
       field<&S::camera, &Camera::position>(),
       A::frame,
       "world position of the eye",
       {},
       {},
       camera_violation},
      {"camera.target",
       T::vec3,
       kAny,
       field<&S::camera, &Camera::target>(),
       A::frame,
       "the point looked at; not equal to `position`",
       {},
       {},
       camera_violation},
      {"camera.up",
       T::direction,
       kAny,
       field<&S::camera, &Camera::up>(),
       A::frame,
       "non-zero, not parallel to the view direction",
       {},
       {},
       camera_violation},
      {"camera.fov_y",
       T::number,
       ParamRange{0.0, 180.0, true, true},
       field<&S::camera, &Camera::fov_y_degrees>(),
       A::frame,
       "degrees, full vertical field of view",
       {},
       slider(10.0, 120.0)},
      {"camera.near",
       T::number,
       kPositive,
       field<&S::camera, &Camera::near>(),
       A::frame,
       "metres; less than `far`",
       {},
       {},
       camera_violation},
      {"camera.far",
       T::number,
       kPositive,
       field<&S::camera, &Camera::far>(),
       A::frame,
       "metres; greater than `near`",
       {},
       {},
       camera_violation},
      // [sun]
      {"sun.direction",
       T::direction,
       kAny,
       sun_field<&Sun::direction>(),
       A::frame,
       "non-zero; the direction the light **travels** (from the sun toward the scene), so a sun "
       "above the horizon has y < 0; or give `elevation` and `azimuth`",
       {},
       {},
       nullptr,
       false,
       true},
      {"sun.color", T::vec3, kNonNegative, sun_field<&Sun::color>(), A::frame, "linear RGB"},
      {"sun.intensity",
       T::number,
       kNonNegative,
       sun_field<&Sun::intensity>(),
       A::frame,
       "irradiance on a surface facing the sun",
       {},
       slider(0.0, 20.0)},
      {"sun.angular_diameter",
       T::number,
       ParamRange{0.0, 90.0, false, true},
       sun_field<&Sun::angular_diameter_degrees>(),
       A::frame,
       "degrees; the real sun: 0.53; 0 = hard shadows",
       {},
       slider(0.0, 10.0)},
      {"sun.shadows", T::boolean, kAny, sun_field<&Sun::shadows>(), A::rebuild,
       "false: lit but casts no shadows (no cascades are built)"},
      // [[spot]]: one row for every spot light, set as spot[i].<name>
      {.key = "spot.position", .type = T::vec3, .range = kAny, .apply = A::frame,
       .doc = "world position", .at = light_field<&S::spots, &SpotLight::position>(),
       .required = true},
      {.key = "spot.direction", .type = T::direction, .range = kAny, .apply = A::frame,
       .doc = "non-zero; the cone's axis; or give `target`, a point the cone aims at",
       .custom_read = true, .at = light_field<&S::spots, &SpotLight::direction>()},
      {.key = "spot.color", .type = T::vec3, .range = kNonNegative, .apply = A::frame,
       .doc = "linear RGB", .at = light_field<&S::spots, &SpotLight::color>()},
      {.key = "spot.intensity", .type = T::number, .range = kNonNegative, .apply = A::frame,
       .doc = "irradiance at about 1 m", .widget = slider(0.0, 100.0),
       .at = light_field<&S::spots, &SpotLight::intensity>()},
      {.key = "spot.outer_angle", .type = T::number, .range = open(0.0, 90.0), .apply = A::frame,
       .doc = "degrees, half-angle of the cone", .widget = slider(1.0, 89.0),
       .at = light_field<&S::spots, &SpotLight::outer_degrees>()},
      {.key = "spot.inner_angle", .type = T::number, .range = kNonNegative, .apply = A::frame,
       .doc = "degrees, full intensity inside; at most `outer_angle` (a file that gives only a "
              "smaller `outer_angle` gets that)",
       .widget = slider(0.0, 89.0), .at = light_field<&S::spots, &SpotLight::inner_degrees>(),
       .check_at = spot_angle_violation},  // outer_angle's too: the file's error is at inner's line
      {.key = "spot.range", .type = T::number, .range = kPositive, .apply = A::frame,
       .doc = "metres; the light ends here (smoothly), and so does its shadow map",
       .widget = slider(0.5, 50.0), .at = light_field<&S::spots, &SpotLight::range>()},
      {.key = "spot.radius", .type = T::number, .range = kNonNegative, .apply = A::frame,
       .doc = "metres: the light is a sphere of this radius (the ray-traced reference samples "
              "it; see docs/accuracy.md); 0 = a point, hard shadows",
       .widget = slider(0.0, 1.0), .at = light_field<&S::spots, &SpotLight::radius>()},
      {.key = "spot.shadows", .type = T::boolean, .range = kAny, .apply = A::rebuild,
       .doc = "a shadow map for this light", .at = light_field<&S::spots, &SpotLight::shadows>()},
      {.key = "spot.resolution", .type = T::integer, .range = closed(16, 16384),
       .apply = A::rebuild, .doc = "shadow-map texels per side",
       .at = light_field<&S::spots, &SpotLight::resolution>()},
      {.key = "spot.filter", .type = T::choice, .range = kAny, .apply = A::frame,
       .doc = "this light's own filter; `inherit`: `[shadows]` `filter` (`evsm2`: EVSM2 moments "
              "of the map's linear depth, built for the lights that ask; `[shadows]` `evsm_*` "
              "keys apply)",
       .choices = local_filters, .at = light_filter<&S::spots>()},
      // [[point]]: one row for every point light, set as point[i].<name>
      {.key = "point.position", .type = T::vec3, .range = kAny, .apply = A::frame,
       .doc = "world position", .at = light_field<&S::points, &PointLight::position>(),
       .required = true},
      {.key = "point.color", .type = T::vec3, .range = kNonNegative, .apply = A::frame,
       .doc = "linear RGB", .at = light_field<&S::points, &PointLight::color>()},
      {.key = "point.intensity", .type = T::number, .range = kNonNegative, .apply = A::frame,
       .doc = "irradiance at about 1 m", .widget = slider(0.0, 100.0),
       .at = light_field<&S::points, &PointLight::intensity>()},
      {.key = "point.range", .type = T::number, .range = kPositive, .apply = A::frame,
       .doc = "metres; the light ends here (smoothly)", .widget = slider(0.5, 50.0),
       .at = light_field<&S::points, &PointLight::range>()},
      {.key = "point.radius", .type = T::number, .range = kNonNegative, .apply = A::frame,
       .doc = "metres: the light is a sphere of this radius (the ray-traced reference samples "
              "it; see docs/accuracy.md); 0 = a point, hard shadows",
       .widget = slider(0.0, 1.0), .at = light_field<&S::points, &PointLight::radius>()},
      {.key = "point.shadows", .type = T::boolean, .range = kAny, .apply = A::rebuild,
       .doc = "a shadow cube map for this light",
       .at = light_field<&S::points, &PointLight::shadows>()},
      {.key = "point.resolution", .type = T::integer, .range = closed(16, 8192),
       .apply = A::rebuild, .doc = "texels per cube face",
       .at = light_field<&S::points, &PointLight::resolution>()},
      {.key = "point.filter", .type = T::choice, .range = kAny, .apply = A::frame,
       .doc = "this light's own filter; `inherit`: `[shadows]` `filter` (`evsm2`: EVSM2 moments "
              "of the cube, built for the lights that ask; `[shadows]` `evsm_*` keys apply)",
       .choices = local_filters, .at = light_filter<&S::points>()},
      {.key = "point.fit_to_camera", .type = T::boolean, .range = kAny, .apply = A::rebuild,
       .doc = "fit the cube to the camera (`shadow::fit_point_shadow`): only the faces that see "
              "an object in view, each object clipped to the view's box, are drawn (the others "
              "stay cleared: lit), and the stored distance spans the objects in view and their "
              "possible casters instead of the light's `range`",
       .at = light_field<&S::points, &PointLight::fit_to_camera>()},
      // [shadows]
      {"shadows.filter", T::choice, kAny, field<&S::shadows, &ShadowSettings::filter>(), A::frame,
       "how shadow maps are filtered (`evsm2`: the sun's cascades; a spot or point light takes "
       "it as its own `filter`; spot and point lights without a filter of their own then use "
       "`pcf`)",
       filters},
      {"shadows.cascades", T::integer, closed(1, 4),
       field<&S::shadows, &ShadowSettings::cascades>(), A::rebuild, "sun cascades"},
      {"shadows.lambda", T::number, kUnit, field<&S::shadows, &ShadowSettings::split_lambda>(),
       A::frame, "PSSM split blend: 0 uniform, 1 logarithmic"},
      {"shadows.max_distance",
       T::number,
       kPositive,
       field<&S::shadows, &ShadowSettings::max_distance>(),
       A::frame,
       "metres; sun shadows end at this view distance",
       {},
       slider(1.0, 500.0)},
      {"shadows.resolution", T::integer, closed(16, 16384),
       field<&S::shadows, &ShadowSettings::resolution>(), A::rebuild, "texels per cascade side"},
      {"shadows.fit", T::choice, kAny, field<&S::shadows, &ShadowSettings::fit>(), A::frame,
       "how a cascade is fit to its slice (docs/cascades.md)", fits},
      {"shadows.selection", T::choice, kAny, field<&S::shadows, &ShadowSettings::selection>(),
       A::frame,
       "how a receiver's cascade is chosen: by view distance, or the finest cascade whose map "
       "holds it with the filter's reach (docs/cascades.md)",
       selections},
      {"shadows.layout", T::choice, kAny, field<&S::shadows, &ShadowSettings::layout>(), A::frame,
       "the sun's maps: `cascades` over view distance, or a `clipmap` of camera-centred squares "
       "selected by position (docs/cascades.md)",
       layouts},
      {"shadows.clipmap_levels", T::integer, closed(1, 8),
       field<&S::shadows, &ShadowSettings::clipmap_levels>(), A::rebuild,
       "`clipmap`: levels, level i 2^i times as wide as level 0"},
      {"shadows.clipmap_extent",
       T::number,
       kPositive,
       field<&S::shadows, &ShadowSettings::clipmap_extent>(),
       A::frame,
       "metres: `clipmap` level 0's full width",
       {},
       slider(1.0, 256.0)},
      {"shadows.snap_to_texels", T::boolean, kAny,
       field<&S::shadows, &ShadowSettings::snap_to_texels>(), A::frame,
       "cascades move by whole texels, so static edges do not shimmer; off only to compare"},
      {"shadows.pcf_radius", T::integer, closed(0, shadow::kPcfMaxRadius),
       field<&S::shadows, &ShadowSettings::pcf_radius>(), A::frame,
       "texels: the box filter is (2 `pcf_radius` + 1) texels wide (`kPcfMaxRadius` = 5 in "
       "pcf.glsl)"},
      {"shadows.constant_filter_width", T::boolean, kAny,
       field<&S::shadows, &ShadowSettings::constant_filter_width>(), A::frame,
       "`pcf` and `poisson` keep their width in metres across cascades: a Poisson disk of "
       "(`pcf_radius` + 0.5) texels of cascade 0, so the penumbra does not widen at each split"},
      {"shadows.poisson_taps", T::integer, closed(1, shadow::kPcfMaxPoissonTaps),
       field<&S::shadows, &ShadowSettings::poisson_taps>(), A::frame,
       "taps of the `poisson` filter (its radius is `pcf_radius` + 0.5 texels)"},
      {"shadows.pcss_quality",
       T::choice,
       kAny,
       field<&S::shadows, &ShadowSettings::pcss_quality>(),
       A::frame,
       "blocker-search and filter tap counts (or 0, 1, 2)",
       {"low", "medium", "high"},
       {},
       nullptr,
       true},
      {"shadows.pcss_search_texels",
       T::number,
       kPositive,
       field<&S::shadows, &ShadowSettings::pcss_search_texels>(),
       A::frame,
       "texels of a cascade: half-width of the PCSS blocker search",
       {},
       slider(1.0, 64.0)},
      {"shadows.pcss_min_filter_texels",
       T::number,
       kNonNegative,
       field<&S::shadows, &ShadowSettings::pcss_min_filter_texels>(),
       A::frame,
       "texels: the smallest PCSS filter radius; at most `pcss_max_filter_texels`",
       {},
       slider(0.0, 8.0),
       pcss_violation},
      {"shadows.pcss_max_filter_texels",
       T::number,
       kNonNegative,
       field<&S::shadows, &ShadowSettings::pcss_max_filter_texels>(),
       A::frame,
       "texels: the largest PCSS filter radius",
       {},
       slider(0.0, 64.0),
       pcss_violation},
      {"shadows.pcss_confidence", T::number, kUnit,
       field<&S::shadows, &ShadowSettings::pcss_confidence>(), A::frame,
       "fraction of blocker-search taps that must find a blocker before PCSS filters at all"},
      {"shadows.blend_band", T::number, closed(0.0, 0.5),
       field<&S::shadows, &ShadowSettings::blend_band>(), A::frame,
       "fraction of a cascade blended into the next"},
      {"shadows.fade_band", T::number, kUnit, field<&S::shadows, &ShadowSettings::fade_band>(),
       A::frame, "fraction of `max_distance` over which shadows fade out"},
      {"shadows.normal_offset_texels",
       T::number,
       kNonNegative,
       field<&S::shadows, &ShadowSettings::normal_offset_texels>(),
       A::frame,
       "texels: the receiver moves along its normal by this many shadow-map texels (their size "
       "at the receiver, for every light type), scaled by sin(angle to the light), plus the "
       "filter's reach beyond one texel (PCF or Poisson radius - 1)",
       {},
       slider(0.0, 4.0)},
      {"shadows.slope_bias",
       T::number,
       kNonNegative,
       field<&S::shadows, &ShadowSettings::slope_bias>(),
       A::frame,
       "texels: slope-scaled depth bias, `slope_bias` x texel size x tan(angle to the light), "
       "in metres along the light",
       {},
       slider(0.0, 8.0)},
      {"shadows.max_slope_bias",
       T::number,
       kNonNegative,
       field<&S::shadows, &ShadowSettings::max_slope_bias>(),
       A::frame,
       "texels: the slope term's bound (grazing angles and back faces get it)",
       {},
       slider(0.0, 32.0)},
      {"shadows.constant_bias",
       T::number,
       kNonNegative,
       field<&S::shadows, &ShadowSettings::constant_bias>(),
       A::frame,
       "metres: the receiver moves this far towards the light before its depth is compared "
       "(every light type)",
       {},
       slider(0.0, 0.1)},
      {"shadows.reverse_z", T::boolean, kAny, field<&S::shadows, &ShadowSettings::reverse_z>(),
       A::rebuild, "the depth convention of every depth buffer and shadow map"},
      {"shadows.temporal", T::boolean, kAny, field<&S::shadows, &ShadowSettings::temporal>(),
       A::rebuild,
       "accumulate every light's visibility over frames (reprojected through the depth "
       "buffer, clamped to the frame's 3x3 neighbourhood): less flicker, a lag behind moving "
       "shadows"},
      {"shadows.temporal_weight",
       T::number,
       ParamRange{0.0, 1.0, true, false},
       field<&S::shadows, &ShadowSettings::temporal_weight>(),
       A::frame,
       "the new frame's share of the accumulated visibility with `temporal` (1: no history)",
       {},
       slider(0.02, 1.0)},
      {"shadows.evsm_fp16", T::boolean, kAny, field<&S::shadows, &ShadowSettings::evsm_fp16>(),
       A::rebuild,
       "`evsm2`: store the moments in 16-bit floats (half the memory and bandwidth; the exponent "
       "is then clamped to 5.54, against 42 in 32-bit floats)"},
      {"shadows.evsm_mips", T::boolean, kAny, field<&S::shadows, &ShadowSettings::evsm_mips>(),
       A::rebuild,
       "`evsm2`: give the sun's moments mips and read each pixel's footprint in the map through "
       "them (prefiltered where a pixel covers many texels: distant and grazing ground)"},
      {"shadows.evsm_exponent",
       T::number,
       ParamRange{0.0, 42.0, true, false},
       field<&S::shadows, &ShadowSettings::evsm_exponent>(),
       A::frame,
       "`evsm2`: the warp's exponent c (larger: less light bleeding, more precision needed); "
       "clamped for the moment format",
       {},
       slider(1.0, 42.0)},
      {"shadows.evsm_blur", T::integer, closed(0, 8),
       field<&S::shadows, &ShadowSettings::evsm_blur>(), A::frame,
       "`evsm2`: texels of the separable box blur of the moments on each side (0: none); the "
       "penumbra's width in texels"},
      {"shadows.evsm_bleed_reduction",
       T::number,
       ParamRange{0.0, 1.0, false, true},
       field<&S::shadows, &ShadowSettings::evsm_bleed_reduction>(),
       A::frame,
       "`evsm2`: visibility below this is cut to 0 and the rest rescaled (hides light bleeding, "
       "hardens penumbrae)",
       {},
       slider(0.0, 0.9)},
      {"shadows.evsm_min_variance",
       T::number,
       closed(0.0, 0.01),
       field<&S::shadows, &ShadowSettings::evsm_min_variance>(),
       A::frame,
       "`evsm2`: the smallest variance in depth units squared (against acne on slopes)",
       {},
       slider(0.0, 1e-4)},
      // [contact]
      {"contact.steps", T::integer, closed(0, kMaxContactSteps),
       field<&S::contact, &ContactSettings::step_count>(), A::rebuild,
       "march steps per pixel; **0 turns the contact-shadow pass off**"},
      {"contact.max_distance",
       T::number,
       kPositive,
       field<&S::contact, &ContactSettings::max_distance>(),
       A::rebuild,
       "metres marched toward the light",
       {},
       slider(0.0, 2.0)},
      {"contact.thickness",
       T::number,
       kPositive,
       field<&S::contact, &ContactSettings::thickness>(),
       A::rebuild,
       "metres: how deep an occluder is assumed behind its visible surface",
       {},
       slider(0.0, 0.5)},
      {"contact.intensity", T::number, kUnit, field<&S::contact, &ContactSettings::intensity>(),
       A::rebuild, "mask = 1 - intensity x occlusion"},
      {"contact.depth_bias",
       T::number,
       ParamRange{0.0, 1.0, false, true},
       field<&S::contact, &ContactSettings::depth_bias>(),
       A::rebuild,
       "depth tolerance as a fraction of the receiver's view depth, over max(N.L, 0.25)",
       {},
       slider(0.0, 0.02)},
      {"contact.step_exponent", T::number, closed(1.0, 8.0),
       field<&S::contact, &ContactSettings::step_exponent>(), A::rebuild,
       "steps at t = ((i + noise) / N)^step_exponent: larger packs them near the receiver"},
      {"contact.edge_fade", T::number, closed(0.0, 0.5),
       field<&S::contact, &ContactSettings::edge_fade>(), A::rebuild,
       "fraction of the screen at its borders over which occlusion fades out"},
      // [render]
      {"render.width", T::integer, closed(16, 16384), field<&S::render, &RenderSettings::width>(),
       A::file_only, "pixels (headless; `--size` and the window override it)"},
      {"render.height", T::integer, closed(16, 16384), field<&S::render, &RenderSettings::height>(),
       A::file_only, "pixels"},
      {"render.frames", T::integer, closed(1, 10000), field<&S::render, &RenderSettings::frames>(),
       A::file_only,
       "frames to render headless, for the timings' medians (`--frames` overrides it)"},
      {"render.view", T::choice, kAny, field<&S::render, &RenderSettings::view>(), A::frame,
       "what the image shows: the lit image or a debug view", views},
      {"render.exposure",
       T::number,
       kPositive,
       field<&S::render, &RenderSettings::exposure>(),
       A::frame,
       "multiplies the linear colour before tonemapping",
       {},
       slider(0.0, 8.0)},
  };
  std::vector<Param> out;
  for (const Row& r : rows) {
    Param p;
    p.key = r.key;
    p.type = r.type;
    p.range = r.range;
    p.choices = r.choices;
    p.ordinal_alias = r.ordinal_alias;
    p.apply = r.apply;
    p.doc = r.doc;
    p.widget = r.widget;
    p.custom_read = r.custom_read;
    p.get = r.access.get;
    p.set = r.access.set;
    p.check = r.check;
    p.required = r.required;
    p.get_at = r.at.get_at;
    p.set_at = r.at.set_at;
    p.check_at = r.check_at;
    if (p.per_light()) {  // get and set: the first light's
      p.get = r.at.get;
      p.set = r.at.set;
    }
    out.push_back(p);
  }
  return out;
}

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

const std::vector<Param>& params() {
  static const std::vector<Param> table = make_params();
  return table;
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
    throw Error("parameter '" + std::string(key) + "': name the light, e.g. " + light_key(p, 0));
  return {&p, b ? b->light : 0};
}

std::size_t light_count(const Scene& scene, std::string_view table) {
  if (table == "spot") return scene.spots.size();
  if (table == "point") return scene.points.size();
  return 0;
}

std::string light_key(const Param& p, std::size_t light) {
  return std::string(p.table()) + "[" + std::to_string(light) + "]." + std::string(p.name());
}

std::vector<std::string> scene_keys(const Scene& scene, bool settable_only) {
  std::vector<std::string> out;
  for (const Param& p : params())
    if (!p.per_light() && (!settable_only || p.settable())) out.emplace_back(p.key);
  // The lights' keys after the singleton tables', light by light.
  for (std::string_view table : {"spot", "point"})
    for (std::size_t i = 0; i < light_count(scene, table); ++i)
      for (const Param* p : params_of(table))
        if (!settable_only || p->settable()) out.push_back(light_key(*p, i));
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
    throw Error("--set " + std::string(value) + ": expected KEY=VALUE, e.g. shadows.pcf_radius=2");
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

std::string camera_violation(const Scene& scene) {
  const Camera& c = scene.camera;
  const glm::vec3 view = c.target - c.position;
  if (!(glm::length(view) > 1e-6f)) return "the camera's target equals its position";
  if (glm::length(glm::cross(glm::normalize(view), c.up)) < 1e-4f)
    return "camera.up is parallel to the view direction (target - position)";
  if (!(c.far > c.near))
    return "camera.far = " + number_text(c.far) +
           " must be greater than near = " + number_text(c.near);
  return "";
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
  if (name.starts_with("pcss_") && !uses(Filter::pcss)) return none_uses("pcss");
  if (name == "poisson_taps" && !uses(Filter::poisson)) return none_uses("poisson");
  if ((name == "pcf_radius" || name == "constant_filter_width") && !uses(Filter::pcf) &&
      !uses(Filter::poisson))
    return none_uses("pcf or poisson");
  if (name.starts_with("evsm_") && !uses(Filter::evsm2)) return none_uses("evsm2");
  if (name == "temporal_weight" && !scene.shadows.temporal) return "temporal is off";
  return "";
}

}  // namespace penumbra::scene
