#pragma once

// Error of a GPU visibility image V against the ray-traced reference R (pure C++, no GPU).
// Over the receivers of one light: mean |V−R|, RMSE, p99 |V−R|, and the two directions kept
// apart: false light (V > R + t: peter-panning, light leaking) and false shadow (V < R − t:
// acne, over-darkening), as fractions of the receivers. Receivers that face away from the light
// are reported apart (their lighting is 0 whatever the shadow says).

#include <cstdint>
#include <penumbra/reference/reference.hpp>
#include <span>
#include <string>
#include <vector>

namespace penumbra::reference {

// Per receiver: what the light does there.
enum class ReceiverClass : uint8_t {
  none = 0,         // sky, outside the light's range or cone, or not a usable receiver
  lit = 1,          // the light reaches it and it faces the light: measured
  facing_away = 2,  // the light reaches it but n·l <= 0: reported apart
};

// Classifies each receiver for one of the scene's lights: in range (spot, point), inside the
// spot's cone, facing the light's centre.
// With n_dot_l, also each receiver's cosine to the light's centre (0 where not reached).
std::vector<ReceiverClass> classify_receivers(const Receivers& receivers,
                                              const scene::Scene& scene, const LightRef& light,
                                              std::vector<float>* n_dot_l = nullptr);

struct MetricsOptions {
  double threshold = 0.1;  // t of false light / false shadow
};

struct Metrics {
  std::string light;
  bool hard = false;
  uint64_t receivers = 0;    // ReceiverClass::lit pixels with a finite V and R
  uint64_t facing_away = 0;  // ReceiverClass::facing_away pixels
  uint64_t non_finite = 0;   // ReceiverClass::lit pixels whose GPU visibility is NaN or inf
  double mean_abs = 0.0;     // mean |V − R|
  // mean |V − R| weighted by n·l: the error as the light's diffuse term shows it (errors where
  // the light grazes the surface count little); 0 without weights.
  double mean_abs_lit = 0.0;
  double rmse = 0.0;
  double p99_abs = 0.0;        // 99th percentile of |V − R|
  double false_light = 0.0;    // fraction with V > R + t
  double false_shadow = 0.0;   // fraction with V < R − t
  // The same weighted by n·l: the share of the light's diffuse term that errs. Surfaces the
  // light grazes (a vertical wall under a sun exactly overhead, n·l ~ 1e-7) count little; 0
  // without weights.
  double false_light_lit = 0.0, false_shadow_lit = 0.0;
  double misclassified = 0.0;  // hard lights: (V >= 0.5) != (R >= 0.5); NaN for area lights
  double mean_abs_facing_away = 0.0;
  // The reference's own noise: the share of receivers it found partly visible (0 < R < 1, the
  // penumbrae), and the mean standard error over those. Receivers whose first rays all agreed
  // stop there (TraceOptions::adaptive) and are not counted in either.
  double reference_partial_fraction = 0.0;
  double reference_std_error = 0.0;
  double shadowed_fraction = 0.0;    // of receivers with R < 0.5 (how much shadow there is)
  std::string to_json() const;
  std::string to_line() const;  // one line for stdout
};

// v: the GPU's visibility per pixel; classes (and n_dot_l, optional: empty for none) from
// classify_receivers.
Metrics compute_metrics(std::span<const float> v, const Visibility& reference,
                        std::span<const ReceiverClass> classes, bool hard,
                        const MetricsOptions& options = {},
                        std::span<const float> n_dot_l = {});

// ---- images (RGBA8, row-major) ----------------------------------------------------------------
// A visibility image in grey over receivers; other pixels show the frame dimmed.
std::vector<uint8_t> visibility_image(std::span<const float> visibility,
                                      std::span<const ReceiverClass> classes,
                                      std::span<const uint8_t> frame_rgba);
// Signed heat map over a grey copy of the frame: too dark (V < R) in blue, too light (V > R) in
// red, opaque at |V − R| >= 0.5; |V − R| < 0.02 left grey. Facing-away pixels are not painted.
std::vector<uint8_t> error_image(std::span<const float> v, std::span<const float> reference,
                                 std::span<const ReceiverClass> classes,
                                 std::span<const uint8_t> frame_rgba);

}  // namespace penumbra::reference
