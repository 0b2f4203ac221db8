#pragma once

// The shadow filters, one row each: everything the C++ side knows of a filter is read from
// filter_table() — the parameter table's choices, the scene reader, the frame packing (the
// shader constant is the row's index), the panel's relevance of the keys, the cascade border
// (reach), the bench's fetch count, the moments pass, and the GLSL constants
// (shaders/penumbra/filters.glsl is generated from it: `penumbra-filters --glsl`). The shaders
// filter through one dispatch per map kind (shaders/penumbra/shadow_filter.glsl).
//
// Adding a filter: its value in scene::Filter (scene.hpp, last), its row here
// (src/scene/filters.cpp), its GLSL function and its case in shadow_filter.glsl, its tests and
// its docs row (docs/filters.md). docs/architecture.md lists the places.

#include <cstdint>
#include <glm/glm.hpp>
#include <optional>
#include <penumbra/scene/scene.hpp>
#include <span>
#include <string>
#include <string_view>

namespace penumbra::scene {

struct FilterSpec {
  Filter filter;
  std::string_view name;      // in scene files, --filter, --set and the panel ("pcf")
  std::string_view constant;  // its GLSL constant ("kFilterPcf"); the value is its row index
  bool maps = true;           // takes 2D shadow maps (the sun's cascades, spot lights)
  bool cubes = true;          // takes cube maps (point lights)
  bool moments = false;       // reads prefiltered moments: a moments pass runs before the resolve
  // What a light resolves with when it cannot use this filter: it inherits [shadows] filter
  // but no moments are made for it, or its maps are of a kind the filter does not take.
  std::optional<Filter> fallback;
  // The [shadows] keys it reads (the panel lists the others as doing nothing for the scene).
  std::span<const std::string_view> keys;
  // Shadow-map fetches per shaded pixel of one evaluation (penumbra-bench's roofline column).
  int (*fetches_per_pixel)(const ShadowSettings& shadows, bool cube) = nullptr;
  // Texels it reads beyond the receiver's own, as the sun's resolve counts them for cascade
  // containment (shadow_resolve.comp's filter_reach_texels).
  double (*reach_texels)(const ShadowSettings& shadows) = nullptr;
  std::string_view doc;  // one line: what it does
};

// Every filter, in scene::Filter's order (row i is Filter(i); a test checks it).
std::span<const FilterSpec> filter_table();
const FilterSpec& filter_spec(Filter filter);
// The shader's constant of a filter (FrameGpu::mode.z, LightGpu::params.w): its row index.
std::uint32_t filter_index(Filter filter);
// Whether a light of this kind can use the filter (sun and spot: 2D maps; point: cubes).
enum class LightKind { sun, spot, point };
bool filter_accepts(Filter filter, LightKind kind);
// The filters' names in order (the parameter table's choices).
std::vector<std::string_view> filter_names();

// What the shaders read of the filters' keys (FrameGpu::filter_params): x the PCF box radius,
// y the PCSS tier, z the Poisson taps, w the Poisson disk's radius in texels (at least 1).
glm::vec4 filter_params(const ShadowSettings& shadows);

// The text of shaders/penumbra/filters.glsl.
std::string filters_glsl();
// The filters' table in docs/scenes.md (markdown, one row per filter).
std::string filters_markdown();

// Shadow-map fetches per shaded pixel of one evaluation of a light's filter, as the library's
// filters take them: hard 1; box-grid PCF (r+1)^2 bilinear compare taps on 2D maps
// (pcf_grid_array) and (2r+1)^2 one texel apart on cubes (pcf_cube_array); Poisson its taps;
// PCSS the tier's search plus filter taps (8+16, 16+32, 32+64), an upper bound: pixels with no
// blocker or a full one skip the filter. Cascade blend bands evaluate the sun's filter twice
// and are not counted.
int filter_fetches_per_pixel(Filter filter, const ShadowSettings& shadows, bool cube);
// Texels a filter reads beyond the receiver's own: hard 1 (a bilinear compare tap), PCF r + 1,
// Poisson its disk's radius + 1, PCSS the wider of its blocker search and its largest filter
// + 1, EVSM2 its blur + 1.
double filter_reach_texels(Filter filter, const ShadowSettings& shadows);

}  // namespace penumbra::scene
