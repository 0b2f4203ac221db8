#pragma once

// Temporal stability: how much a frame's shadows change when the camera or the sun moves a
// little. A still scene seen from a moving camera should keep every surface point's visibility;
// what changes is flicker (cascades re-fitted, texels snapping, per-frame noise).
//
// For each pair of consecutive frames, each pixel of the later frame is reprojected into the
// earlier one through the depth buffers: its world position projected with the earlier camera,
// onto the four nearest pixels. Those with any bilinear weight (above 0.001) must lie on the
// same surface (within 2% of the distance to the camera plus 2 mm, normals within 26 degrees:
// not across a crease), and their visibilities give
// the earlier frame's range there (a TAA resolve's neighbourhood clamp: a point-sampled edge
// seen from a camera moved a fraction of a pixel stays inside it). Shadow-edge pixels are those
// whose 3x3 neighbourhood's visibility spans 0.5 or more, or whose own visibility is in
// (0.02, 0.98) (the penumbrae). Flicker is the fraction of them whose visibility lies outside
// the earlier range by more than `threshold` (8/255 by default).

#include <filesystem>
#include <optional>
#include <penumbra/reference/reference.hpp>
#include <penumbra/render/renderer.hpp>
#include <span>
#include <string>
#include <vector>

namespace penumbra::reference {

enum class Motion {
  translate,    // the camera and its target move sideways (along the view's right vector)
  yaw,          // the camera turns about the scene's up axis
  sun_azimuth,  // the sun turns about the world's up axis (no sun: not measured)
};

struct CameraPath {
  std::string name;  // "translate-1mm"
  Motion motion = Motion::translate;
  double step = 0.0;  // per frame: metres (translate) or degrees (yaw, sun_azimuth)
};

// The paths of the render checks: 1 mm and 1 cm sideways, 0.05 degrees of yaw, and the sun's
// azimuth turning 0.05 degrees a frame.
std::vector<CameraPath> standard_paths();
// The path named `name` among standard_paths(); throws penumbra::Error listing them.
CameraPath find_path(const std::string& name);

struct FlickerOptions {
  uint32_t frames = 16;             // rendered along the path (>= 2): frames - 1 pairs
  float threshold = 8.0f / 255.0f;  // a change above this is flicker
  // When set, the reference is traced at every frame's receivers as well (with these options;
  // shared_pattern is forced on, so the truth has no frame-to-frame Monte Carlo noise) and
  // measured the same way. The truth flickers too where shadow detail is finer than a pixel
  // (pixel centres land on other holes of a perforated screen as the camera moves) and where
  // the shadows themselves move (a turning sun): Flicker::truth_* counts that, and
  // Flicker::excess_* the renderer's flicker where the truth held still.
  std::optional<TraceOptions> truth;
  // Where the truth of each frame is cached (trace_cached): it depends on the scene, the camera
  // path and the frame's receivers, not on the shadow settings, so a sweep along the same path
  // traces it once. nullopt: traced every time.
  std::optional<std::filesystem::path> cache_dir;
};

struct Flicker {
  std::string path;
  std::string light;       // "sun", "spot0", …
  size_t edge_pixels = 0;  // shadow-edge pixels reprojected, over every pair of frames
  size_t changed = 0;      // of those, changed by more than the threshold
  uint32_t width = 0, height = 0;
  std::vector<uint32_t> changed_per_pixel;  // how many of the frame pairs flickered there
  // The same counts weighted by each pixel's n·l to the light (facing away: 0): flicker as the
  // lit frame shows it. A wall the sun grazes (n·l ~ 1e-7 under a sun straight overhead) may
  // flip its visibility every frame without a visible change.
  double edge_weight = 0.0, changed_weight = 0.0;
  double fraction() const { return edge_pixels ? double(changed) / double(edge_pixels) : 0.0; }
  double fraction_lit() const { return edge_weight > 0.0 ? changed_weight / edge_weight : 0.0; }

  // With FlickerOptions::truth. The truth's own flicker: its shadow-edge pixels (by its own
  // visibility) and how many of them changed.
  bool has_truth = false;
  size_t truth_edge_pixels = 0, truth_changed = 0;
  double truth_edge_weight = 0.0, truth_changed_weight = 0.0;
  // Of the renderer's changed edge pixels, those where the truth's visibility stayed within
  // its earlier range (by the same threshold) there and at the 8 neighbours: flicker the truth
  // does not have. Its fraction is over the truth's edge pixels, a count that is the same for
  // every technique: a blurrier or noisier frame has more edge pixels of its own (penumbrae,
  // acne), which lowers fraction() without anything changing less.
  size_t excess_changed = 0;
  double excess_changed_weight = 0.0;
  std::vector<uint32_t> excess_per_pixel;  // how many of the frame pairs flickered in excess
  double truth_fraction() const {
    return truth_edge_pixels ? double(truth_changed) / double(truth_edge_pixels) : 0.0;
  }
  double truth_fraction_lit() const {
    return truth_edge_weight > 0.0 ? truth_changed_weight / truth_edge_weight : 0.0;
  }
  // The mean |V - truth| over the reached receivers of frames 1 .. frames - 1: the error along
  // the path, where a lag behind moving shadows (shadows.temporal) shows.
  double path_mean_abs_error = 0.0;
  // The same weighted by n·l (as the lit frame shows it): a smear across a terminator, where
  // n·l is 0, does not show.
  double path_mean_abs_error_lit = 0.0;
  double excess_fraction() const {
    return truth_edge_pixels ? double(excess_changed) / double(truth_edge_pixels) : 0.0;
  }
  double excess_fraction_lit() const {
    return truth_edge_weight > 0.0 ? excess_changed_weight / truth_edge_weight : 0.0;
  }
};

// Renders options.frames frames along `path` (frame k: the scene's camera or sun moved k
// steps, render(k)), then puts the scene back as it was. The renderer needs
// RendererOptions::visibility_output. One result per light of the scene that the renderer
// draws (none for sun_azimuth in a scene without a sun).
std::vector<Flicker> measure_flicker(render::Renderer& renderer, const CameraPath& path,
                                     const FlickerOptions& options = {});

// One pair of frames: the counts for `current` against `previous` (exposed for tests).
struct FrameSample {
  Receivers receivers;            // from the frame's G-buffer
  render::FrameCamera camera;     // the matrices the GPU used
  std::vector<float> visibility;  // the light's, per pixel
  std::vector<uint8_t> reached;   // 1 where the light reaches the receiver
  std::vector<float> weight;      // n·l to the light per pixel (0 facing away); empty: all 1
};
// per_pixel (width x height of `current`), when given, counts the flickering pixels.
// edge_weight and changed_weight, when given, add up current.weight over the same pixels.
void count_flicker(const FrameSample& previous, const FrameSample& current, float threshold,
                   size_t& edge_pixels, size_t& changed, std::vector<uint32_t>* per_pixel = nullptr,
                   double* edge_weight = nullptr, double* changed_weight = nullptr);

// Per pixel of `current`: 1 where it reprojects onto the same surface in `previous` and its
// visibility lies outside the earlier range by more than `threshold`, whether or not it is a
// shadow edge (the truth's changes that excuse the renderer's).
std::vector<uint8_t> changed_pixels(const FrameSample& previous, const FrameSample& current,
                                    float threshold);
// Flicker::excess_*: adds the renderer's changed edge pixels where `excused` (the truth's
// changed_pixels) is 0 at the pixel and its 8 neighbours (aliasing of detail finer than a pixel
// picks neighbouring pixels at random).
void count_excess_flicker(const FrameSample& previous, const FrameSample& current, float threshold,
                          std::span<const uint8_t> excused, Flicker& flicker);

// The shadow-temporal pass (shadows.temporal, shaders/render/shadow_temporal.comp) on the CPU,
// in double, for tests: `current`'s visibility accumulated onto `previous`'s (the accumulated
// values of the last frame). Per pixel of `current`: its point projected into `previous`'s
// pixels; the bilinear taps (weight above 0.001) on the same surface (the distance to the
// last eye within 2% + 2 mm, the normals within 26 degrees) give the history when they carry
// half the weight or more; the history is clamped to the range of `current`'s 3x3 neighbourhood
// and moved towards the current value by `weight`. Without a history, the current value.
// Uses the receivers, cameras and visibility of the samples (not reached or weight).
std::vector<float> accumulate_visibility(const FrameSample& previous, const FrameSample& current,
                                         float weight);

// A picture of where a path flickered: the frame in grey, each pixel red in proportion to the
// pairs of frames in which it flickered (RGBA8, `lit` is the measured frame). With the truth
// measured, flicker the truth shares is blue and only the excess is red.
std::vector<uint8_t> flicker_image(const Flicker& flicker, std::span<const uint8_t> lit,
                                   uint32_t pairs);

}  // namespace penumbra::reference
