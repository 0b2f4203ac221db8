// The shadow filters' table (filters.hpp): one row per filter, read by everything on the C++
// side that depends on which filter a light uses.

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <penumbra/core/error.hpp>
#include <penumbra/scene/filters.hpp>
#include <penumbra/shadow/types.hpp>

namespace penumbra::scene {

namespace {

int pcf_radius(const ShadowSettings& s) {
  return std::clamp(s.pcf_radius, 0, shadow::kPcfMaxRadius);  // pcf_clamp_radius
}
int poisson_taps(const ShadowSettings& s) {
  return int(std::clamp(s.poisson_taps, 1u, std::uint32_t(shadow::kPcfMaxPoissonTaps)));
}
// A Poisson or Vogel disk's reach: its radius (pcf_radius + 0.5) rounded up, + 1 (bilinear).
double disk_reach(const ShadowSettings& s) {
  return std::ceil(std::max(1.0, double(s.pcf_radius) + 0.5)) + 1.0;
}

constexpr std::string_view kPcfKeys[] = {"pcf_radius", "constant_filter_width"};
constexpr std::string_view kPoissonKeys[] = {"pcf_radius", "constant_filter_width", "poisson_taps"};
constexpr std::string_view kVogelKeys[] = {"pcf_radius", "poisson_taps"};
constexpr std::string_view kPcssKeys[] = {"pcss_quality", "pcss_search_texels",
                                          "pcss_min_filter_texels", "pcss_max_filter_texels",
                                          "pcss_confidence"};
constexpr std::string_view kEvsmKeys[] = {
    "evsm_blur",         "evsm_exponent", "evsm_bleed_reduction",
    "evsm_min_variance", "evsm_fp16",     "evsm_mips"};

const FilterSpec kTable[] = {
    {.filter = Filter::hard,
     .name = "hard",
     .constant = "kFilterHard",
     .fetches_per_pixel = [](const ShadowSettings&, bool) { return 1; },
     .reach_texels = [](const ShadowSettings&) { return 1.0; },
     .doc = "one bilinear depth-compare tap (2x2 texels)"},
    {.filter = Filter::pcf,
     .name = "pcf",
     .constant = "kFilterPcf",
     .keys = kPcfKeys,
     .fetches_per_pixel =
         [](const ShadowSettings& s, bool cube) {
           const int r = pcf_radius(s);
           return cube ? (2 * r + 1) * (2 * r + 1) : (r + 1) * (r + 1);
         },
     .reach_texels = [](const ShadowSettings& s) { return double(pcf_radius(s)) + 1.0; },
     .doc = "a (2 pcf_radius + 1)-texel box of depth compares"},
    {.filter = Filter::pcss,
     .name = "pcss",
     .constant = "kFilterPcss",
     .keys = kPcssKeys,
     .fetches_per_pixel =
         [](const ShadowSettings& s, bool) {
           const int tier = std::clamp(s.pcss_quality, 0, 2);
           return (8 << tier) + (16 << tier);  // pcss_search_tap_count + pcss_filter_tap_count
         },
     .reach_texels =
         [](const ShadowSettings& s) {
           return std::ceil(
                      std::max(double(s.pcss_search_texels), double(s.pcss_max_filter_texels))) +
                  1.0;
         },
     .doc = "percentage-closer soft shadows: a blocker search sizes a Poisson filter"},
    {.filter = Filter::poisson,
     .name = "poisson",
     .constant = "kFilterPoisson",
     .keys = kPoissonKeys,
     .fetches_per_pixel = [](const ShadowSettings& s, bool) { return poisson_taps(s); },
     .reach_texels = disk_reach,
     .doc = "poisson_taps compares on a rotated Poisson disk (a Vogel disk on cubes) of radius "
            "pcf_radius + 0.5"},
    {.filter = Filter::evsm2,
     .name = "evsm2",
     .constant = "kFilterEvsm2",
     .moments = true,
     .fallback = Filter::pcf,
     .keys = kEvsmKeys,
     // One bilinear fetch of the blurred moments (the blur is its own pass).
     .fetches_per_pixel = [](const ShadowSettings&, bool) { return 1; },
     .reach_texels =
         [](const ShadowSettings& s) { return double(std::clamp(s.evsm_blur, 0, 8)) + 1.0; },
     .doc = "exponential variance shadow maps: blurred moments, one bilinear fetch"},
    {.filter = Filter::vogel,
     .name = "vogel",
     .constant = "kFilterVogel",
     .cubes = false,  // a point light's poisson is already a Vogel disk on its cube
     .fallback = Filter::poisson,
     .keys = kVogelKeys,
     .fetches_per_pixel = [](const ShadowSettings& s, bool) { return poisson_taps(s); },
     .reach_texels = disk_reach,
     .doc = "poisson_taps compares on a rotated Vogel (golden-angle) disk of radius pcf_radius + "
            "0.5: even coverage at any tap count"},
};

}  // namespace

std::span<const FilterSpec> filter_table() {
  return kTable;
}

const FilterSpec& filter_spec(Filter filter) {
  const auto i = std::size_t(filter);
  if (i >= std::size(kTable) || kTable[i].filter != filter)
    throw Error("filter_spec: filter " + std::to_string(i) + " has no row in the filter table");
  return kTable[i];
}

std::uint32_t filter_index(Filter filter) {
  return std::uint32_t(&filter_spec(filter) - kTable);
}

bool filter_accepts(Filter filter, LightKind kind) {
  const FilterSpec& f = filter_spec(filter);
  return kind == LightKind::point ? f.cubes : f.maps;
}

std::vector<std::string_view> filter_names() {
  std::vector<std::string_view> names;
  for (const FilterSpec& f : kTable) names.push_back(f.name);
  return names;
}

std::string filters_glsl() {
  std::string s =
      "// The shadow filters' constants: FrameGpu.mode.z (the sun's and the scene's filter) and\n"
      "// LightGpu.params.w (a light's own). Generated from the filter table\n"
      "// (src/scene/filters.cpp) by `penumbra-filters --glsl`; do not edit.\n"
      "// PenumbraFilters.GlslConstantsMatchTheTable fails when this file is out of date.\n"
      "#ifndef PENUMBRA_FILTERS_GLSL\n"
      "#define PENUMBRA_FILTERS_GLSL\n\n";
  for (std::size_t i = 0; i < std::size(kTable); ++i)
    s += "const uint " + std::string(kTable[i].constant) + " = " + std::to_string(i) + "u;  // " +
         std::string(kTable[i].name) + "\n";
  s += "const uint kFilterCount = " + std::to_string(std::size(kTable)) + "u;\n\n";
  s += "// The same numbers for #if: PENUMBRA_FILTERS_2D and PENUMBRA_FILTERS_CUBE "
       "(shadow_filter.glsl)\n"
       "// are bit sets of them.\n";
  for (std::size_t i = 0; i < std::size(kTable); ++i) {
    std::string name(kTable[i].name);
    for (char& c : name) c = char(std::toupper(static_cast<unsigned char>(c)));
    s += "#define PENUMBRA_FILTER_" + name + " " + std::to_string(i) + "\n";
  }
  s += "\n#endif\n";
  return s;
}

glm::vec4 filter_params(const ShadowSettings& s) {
  return glm::vec4(float(s.pcf_radius), float(s.pcss_quality), float(s.poisson_taps),
                   std::max(1.0f, float(s.pcf_radius) + 0.5f));
}

std::string filters_markdown() {
  const ShadowSettings defaults;
  std::string s =
      "| filter | lights | moments pass | keys it reads | fetches per pixel (defaults: 2D, "
      "cube) | reach in texels (defaults) | what it does |\n|---|---|---|---|---|---|---|\n";
  for (const FilterSpec& f : kTable) {
    std::string lights = f.maps ? "sun, spot" : "";
    if (f.cubes) lights += lights.empty() ? "point" : ", point";
    std::string keys;
    for (std::string_view k : f.keys) keys += (keys.empty() ? "`" : ", `") + std::string(k) + "`";
    char reach[32];
    std::snprintf(reach, sizeof reach, "%g", f.reach_texels(defaults));
    s += "| `" + std::string(f.name) + "` | " + lights + " | " +
         (f.moments ? "yes (without: `" + std::string(filter_spec(*f.fallback).name) + "`)"
                    : std::string("no")) +
         " | " + (keys.empty() ? "—" : keys) + " | " +
         std::to_string(f.fetches_per_pixel(defaults, false)) + ", " +
         std::to_string(f.fetches_per_pixel(defaults, true)) + " | " + reach + " | " +
         std::string(f.doc) +
         (f.fallback && !f.moments ? " (a light it cannot take uses `" +
                                         std::string(filter_spec(*f.fallback).name) + "`)"
                                   : "") +
         " |\n";
  }
  return s;
}

int filter_fetches_per_pixel(Filter filter, const ShadowSettings& shadows, bool cube) {
  return filter_spec(filter).fetches_per_pixel(shadows, cube);
}

double filter_reach_texels(Filter filter, const ShadowSettings& shadows) {
  return filter_spec(filter).reach_texels(shadows);
}

}  // namespace penumbra::scene
