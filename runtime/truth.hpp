#pragma once
// Deltas on save (penumbra-view --truth): what an edit did to the frame's GPU time and to its
// error against the ray-traced truth. A snapshot times the frame (the median of a few frames
// and their spread, so noise is not read as a change) and measures a fresh frame (history
// reset, the same frame index) against the reference, whose truth is traced once and then
// read from the reference cache (it depends on the receivers, not on the shaders).
#include <cmath>
#include <cstdint>
#include <optional>
#include <map>
#include <penumbra/reference/frame.hpp>
#include <penumbra/reference/temporal.hpp>
#include <string>
#include <vector>

#include "session.hpp"

namespace penumbra::runtime {

struct TruthLight {
  std::string name;
  double mean_abs = 0.0, false_light = 0.0, false_shadow = 0.0, acne = 0.0;
  double gap_texels = 0.0;  // NaN when the truth shows no contact
  // With a flicker path (--truth-flicker): the flicker the truth does not have along it, and
  // the error along it with the temporal history running; NaN without.
  double flicker = std::nan(""), path_error = std::nan("");
};

struct TruthSnapshot {
  double frame_ms = 0.0;   // median GPU ms per frame, every pass
  double spread_ms = 0.0;  // half the interquartile range of the frames' GPU ms
  std::map<std::string, double> pass_ms;
  std::vector<TruthLight> lights;
  std::vector<std::uint8_t> pixels;  // the measured frame, RGBA8
  std::uint32_t width = 0, height = 0;
  // Every parameter-table key of the measured scene with its value ("camera.position=0,2,6"),
  // sorted: two snapshots compare the same view only when these match.
  std::vector<std::string> settings;
  // Per light (in the order of `lights`): the error heat map against the truth over a grey copy
  // of the frame (reference::error_image: too dark in blue, too light in red), RGBA8.
  std::vector<std::vector<std::uint8_t>> heat;
};

// Whether a GPU-time change between two snapshots is noise: within both spreads, or under 3%
// of the frame (lavapipe's frames vary by a few percent between snapshots seconds apart).
bool gpu_change_is_noise(const TruthSnapshot& before, const TruthSnapshot& after);
// The keys whose values differ between two snapshots (the camera moved, a setting changed):
// their deltas then compare two views, not two versions of the shaders. Empty when none.
std::vector<std::string> changed_settings(const TruthSnapshot& before, const TruthSnapshot& after);

// The session's renderer must have been built with SessionOptions::visibility_output.
// With `path`, the flicker along it too (its truth traced once per frame, then cached).
TruthSnapshot measure_truth(Session& session, std::uint32_t frames,
                            const reference::MeasureOptions& options,
                            const std::optional<reference::CameraPath>& path = std::nullopt);

// "[truth] ..." lines: the baseline, and before -> after per pass and per light. A GPU-time
// change within the spreads of both, or under 3% of the frame, is reported as noise; a changed
// view or setting (changed_settings) is said first.
std::vector<std::string> truth_lines(const TruthSnapshot& now);
std::vector<std::string> truth_lines(const TruthSnapshot& before, const TruthSnapshot& after);
// One line: GPU time, each light's mean |dV| and the image against the first snapshot (an edit
// undone reads +0 and bit-identical).
std::vector<std::string> truth_since(const TruthSnapshot& start, const TruthSnapshot& now);

}  // namespace penumbra::runtime
