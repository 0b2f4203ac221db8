// The parameter table's rows (include/penumbra/scene/params.hpp): one row per scene key (key,
// type, range, accessor, rebuild flag, docs line, the panel's slider range), the singleton
// tables' and the per-light tables'. Parsing, formatting and lookup: params.cpp.

#include <penumbra/core/error.hpp>
#include <penumbra/scene/filters.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>

#include "param_access.hpp"

namespace penumbra::scene {
namespace {

using namespace detail;

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

// A light's own filter must take the light's maps (the filter table: 2D maps, cubes).
template <auto Lights, LightKind Kind>
std::string light_filter_violation(const Scene& s, std::size_t i) {
  if (i >= (s.*Lights).size() || !(s.*Lights)[i].filter) return "";
  const Filter f = *(s.*Lights)[i].filter;
  if (filter_accepts(f, Kind)) return "";
  std::string takes;
  for (const FilterSpec& spec : filter_table())
    if (filter_accepts(spec.filter, Kind)) takes += (takes.empty() ? "" : ", ") + std::string(spec.name);
  return "filter = '" + std::string(filter_spec(f).name) + "' does not take " +
         (Kind == LightKind::point ? "a point light's cube maps" : "2D shadow maps") +
         " (a " + (Kind == LightKind::point ? "point" : "spot") + " light takes " + takes + ")";
}

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
  const std::vector<std::string_view> filters = filter_names();  // the filter table's order
  std::vector<std::string_view> local_filters{"inherit"};
  local_filters.insert(local_filters.end(), filters.begin(), filters.end());
  const std::vector<std::string_view> fits{"box", "camera_sphere", "slice_sphere"};
  const std::vector<std::string_view> selections{"depth", "containment"};
  const std::vector<std::string_view> layouts{"cascades", "clipmap"};
  const std::vector<std::string_view> views{"lit",          "shadow_factor", "cascades",
                                            "contact_mask", "texel_density", "penumbra",
                                            "redrawn"};
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
      {"camera.move",
       T::vec3,
       closed(-1e5, 1e5),
       field<&S::camera, &Camera::move>(),
       A::frame,
       "metres: a walk; the camera (position and target) goes to position + move over "
       "`move_frames` frames and back, the frame index driving it",
       {},
       slider(-10.0, 10.0)},
      {"camera.move_frames",
       T::integer,
       closed(0, 1000000),
       field<&S::camera, &Camera::move_frames>(),
       A::frame,
       "frames from one end of the walk to the other; 0: the camera stays put",
       {},
       slider(0.0, 600.0)},
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
       .choices = local_filters, .at = light_filter<&S::spots>(),
       .check_at = light_filter_violation<&S::spots, LightKind::spot>},
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
       .choices = local_filters, .at = light_filter<&S::points>(),
       .check_at = light_filter_violation<&S::points, LightKind::point>},
      {.key = "point.fit_to_camera", .type = T::boolean, .range = kAny, .apply = A::rebuild,
       .doc = "fit the cube to the camera (`shadow::fit_point_shadow`): only the faces that see "
              "an object in view, each object clipped to the view's box, are drawn (the others "
              "stay cleared: lit), and the stored distance spans the objects in view and their "
              "possible casters instead of the light's `range`",
       .at = light_field<&S::points, &PointLight::fit_to_camera>()},
      // [[object]]: the motion of every object, set as object[i].<name> (i counts the scene's
      // objects in file order, a [[scatter]]'s after them); the other keys are the file's.
      {.key = "object.move", .type = T::vec3, .range = closed(-1e5, 1e5), .apply = A::rebuild,
       .doc = "metres: the object walks to `position` + `move` over `move_frames` frames and "
              "back, the frame index driving it (the file needs `move_frames` with it); its "
              "origin must stay within the still objects' bounds grown by its own size",
       .widget = slider(-10.0, 10.0), .at = motion_field<&Motion::move>(),
       .check_at = motion_bounds_violation},
      {.key = "object.move_frames", .type = T::integer, .range = closed(0, 1000000),
       .apply = A::rebuild,
       .doc = "frames from one end of the move to the other; 0: the object stays put",
       .widget = slider(0.0, 600.0), .at = motion_field<&Motion::move_frames>()},
      {.key = "object.spin", .type = T::vec3, .range = closed(-360.0, 360.0), .apply = A::rebuild,
       .doc = "degrees per frame about the object's position (x, then y, then z, world axes); "
              "not with `analytic_shadow`",
       .widget = slider(-10.0, 10.0), .at = motion_field<&Motion::spin>(),
       .check_at = motion_spin_violation},
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
      {"shadows.cache", T::boolean, kAny, field<&S::shadows, &ShadowSettings::cache>(),
       A::rebuild,
       "draw a shadow map again only where what it holds changed (its light, its bounds, a "
       "caster in it, a reload); moving casters are drawn over a copy of the still ones each "
       "frame. The images are the same bit for bit as with `false`, which redraws every map "
       "every frame"},
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

}  // namespace

const std::vector<Param>& params() {
  static const std::vector<Param> table = make_params();
  return table;
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

}  // namespace penumbra::scene
