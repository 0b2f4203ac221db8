#pragma once

// A rendered frame measured against the reference: the renderer's G-buffer gives the
// receivers, its visibility output the GPU's V per light, the tracer R; metrics per light.

#include <filesystem>
#include <optional>
#include <penumbra/reference/failure_modes.hpp>
#include <penumbra/reference/metrics.hpp>
#include <penumbra/reference/reference.hpp>
#include <penumbra/render/renderer.hpp>

namespace penumbra::reference {

struct LightMeasurement {
  LightRef light;
  AreaLight area;
  Visibility reference;
  std::vector<float> gpu;  // the GPU's visibility of this light, per pixel
  std::vector<ReceiverClass> classes;
  std::vector<float> n_dot_l;  // cosine to the light's centre, 0 where it does not reach
  Metrics metrics;
  // Acne, leaks and the contact gap apart (failure_modes.hpp); with MeasureOptions::failure_modes.
  bool has_failure_modes = false;
  std::vector<float> texel_world;  // per receiver: one texel of this light's map there, metres
  CasterProbe probe;
  FailureModes failure;
  std::vector<FailureMode> modes;
};

struct FrameMeasurement {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> lit;  // the frame, RGBA8
  Receivers receivers;
  size_t triangles = 0;  // in the BVH
  std::vector<LightMeasurement> lights;
};

struct MeasureOptions {
  TraceOptions trace;
  MetricsOptions metrics;
  std::optional<std::filesystem::path> cache_dir;  // nullopt: no cache
  std::vector<std::string> lights;                 // names ("sun", "spot0"); empty: all
  // Tell acne, leaks and the contact gap apart (rays of its own per receiver: about as many as
  // a hard light's reference, more in the umbra).
  bool failure_modes = false;
  FailureModeOptions failure;
};

// The accuracy budget of a light against the reference (issue 13's, for every shipped scene):
// soft lights mean |dV| <= mean_abs, hard lights misclassified <= misclassified; false light and
// false shadow (t = MetricsOptions::threshold) each <= 1% of the receivers; and no lost shadows:
// of the receivers the reference finds in umbra (R < 0.5), at least umbra_kept are shadowed
// (V < 0.5) on the GPU. docs/accuracy.md lists the measured values the bounds sit above.
struct AccuracyBudget {
  double false_light = 0.01, false_shadow = 0.01, misclassified = 0.005, mean_abs = 0.02;
  double umbra_kept = 0.9;
};

// Of the receivers the reference finds in umbra (R < 0.5), the fraction the GPU shadows
// (V < 0.5); 1 when there is no umbra. umbra_count: how many there are (optional). With
// weighted, each receiver counts by its n·l (the light a lost shadow lets through).
double umbra_kept(const LightMeasurement& light, size_t* umbra_count = nullptr,
                  bool weighted = false);

// What of the light's measurement exceeds the budget, one line per bound ("false light 1.30% >
// 1.00%"); empty when it is within.
std::vector<std::string> budget_violations(const LightMeasurement& light,
                                           const AccuracyBudget& budget);

// Per receiver, the world size of one texel of the light's shadow map there (NaN where the
// light has no map or the receiver is outside it): the sun's from the cascade the GPU chose
// (shadow_info, as Renderer::read_shadow_info gives it), a spot's and a point light's from their
// projection at the receiver's depth along the map's axis.
std::vector<float> light_texel_sizes(const scene::Scene& scene, const LightRef& light,
                                     const Receivers& receivers, uint32_t width, uint32_t height,
                                     std::span<const float> shadow_info);

// The read_visibility() slot of a light.
uint32_t visibility_slot(const LightRef& light);

// Measures the renderer's last frame (render() first). The renderer must have been built with
// RendererOptions::visibility_output; throws penumbra::Error otherwise or for an unknown light.
FrameMeasurement measure_frame(render::Renderer& renderer, const MeasureOptions& options);

// Writes lit.png, and per light reference, visibility (the GPU's) and error PNGs (suffixed
// -<light> when the scene has several lights) and metrics.json into dir; returns the paths.
// images = false writes metrics.json alone (a tuning point: the numbers are what it keeps).
std::vector<std::filesystem::path> write_measurement(const FrameMeasurement& m,
                                                     const std::filesystem::path& dir,
                                                     const std::string& json_header,
                                                     bool images = true);

}  // namespace penumbra::reference
