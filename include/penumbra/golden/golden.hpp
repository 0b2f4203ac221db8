#pragma once

// Full-frame render checks: reviewed golden images, compared where the shadows are.
//
// A golden is one case (a scene, its --set overrides and a size; tests/golden/cases.toml) as
// one device class rendered it and a person accepted it: the lit frame, each light's visibility
// as the lighting used it (16-bit PNG), and each light's region mask (umbra, penumbra band, lit,
// silhouette) from the ray-traced reference and the depth buffer. Goldens live in
// tests/golden/<device class>/<case>/, are written only by `penumbra-golden update` (never by a
// test), and only when the frame is within the accuracy budget against the reference.
//
// compare() holds a new frame to a golden region by region: tight where the reference says the
// light is fully visible or fully hidden, looser in penumbra bands and along silhouettes (where
// one texel or one rasterized edge moves many values). The tolerances are calibrated from
// run-to-run and device-to-device differences (docs/accuracy.md, "Render checks").

#include <cstdint>
#include <filesystem>
#include <optional>
#include <penumbra/gpu/context.hpp>
#include <penumbra/reference/frame.hpp>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::golden {

// Where a pixel is, for one light. Stored in regions-<light>.png as the grey levels below.
enum class Region : uint8_t {
  none = 0,        // sky, not reached by the light, or facing away: visibility not compared
  umbra = 64,      // the reference: fully hidden (R <= 0.02)
  penumbra = 128,  // partly visible, or within RegionOptions::band pixels of a shadow edge
  silhouette = 192,  // within one pixel of a depth discontinuity (or of the sky)
  lit = 255,         // the reference: fully visible (R >= 0.98)
};
const char* to_string(Region r);
inline constexpr Region kRegions[] = {Region::umbra, Region::lit, Region::penumbra,
                                      Region::silhouette, Region::none};

struct RegionOptions {
  float umbra_max = 0.02f;  // R at or below: umbra
  float lit_min = 0.98f;    // R at or above: lit
  uint32_t band = 1;        // pixels around a shadow edge that count as penumbra
  // A depth discontinuity: neighbours whose distances to the eye differ by more than this
  // fraction of the nearer one.
  double depth_jump = 0.03;
};

// Per pixel, for one measured light: the reference's verdict and the G-buffer's silhouettes.
std::vector<Region> classify_regions(const reference::Receivers& receivers,
                                     const reference::LightMeasurement& light,
                                     const RegionOptions& options = {});

// ---- cases ----------------------------------------------------------------------------------
struct Case {
  std::string name;
  std::string scene;  // a shipped scene's name or a .toml path relative to the source tree
  std::vector<std::pair<std::string, std::string>> sets;  // parameter-table overrides
  glm::dvec3 origin{0.0};  // the whole scene moved by this (scene::translate_scene)
  uint32_t width = 480, height = 270;
  std::string description;
  reference::AccuracyBudget budget;  // the issue-13 budget unless the case says why not
};

// The cases of a cases.toml; throws naming the file, line and key on a bad entry.
std::vector<Case> load_cases(const std::filesystem::path& file);
// tests/golden of the source tree (or $PENUMBRA_GOLDEN_DIR).
std::filesystem::path golden_root();
// "lavapipe" for Mesa's llvmpipe, "gpu-nvidia", "gpu-amd", "gpu-intel", "gpu-<vendor id>".
std::string device_class(const gpu::DeviceInfo& info);

// ---- frames and goldens ---------------------------------------------------------------------
struct LightImage {
  std::string light;              // "sun", "spot0", …
  std::vector<float> visibility;  // as the forward pass used it
  std::vector<Region> regions;    // goldens only (empty in a fresh frame)
  std::optional<reference::Metrics> metrics;  // goldens: against the reference when accepted
};

struct Frame {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> lit;  // RGBA8
  std::vector<LightImage> lights;
};

// Renders a case (scene, overrides, size) with each light's visibility output; shader_dir as
// in RendererOptions (empty: the source tree's shaders).
Frame render_case(gpu::Context& ctx, const Case& c, const std::filesystem::path& shader_dir = {});

// Renders a case and measures it against the reference (MeasureOptions as penumbra-reference
// takes them): the frame with each light's regions and metrics, the measurement itself, and
// what of it exceeds the case's budget ("sun: false light 1.30% > 1.00%"; empty: acceptable).
struct CaseMeasurement {
  Frame frame;
  reference::FrameMeasurement measurement;
  std::vector<std::string> over_budget;
};
CaseMeasurement measure_case(gpu::Context& ctx, const Case& c,
                             const reference::MeasureOptions& options,
                             const RegionOptions& regions = {});

struct Golden {
  std::string case_name;
  std::string device_class, device, driver;  // who rendered it
  Frame frame;
};

// Reads tests/golden/<class>/<case>/ (golden.toml, lit.png, visibility-*.png, regions-*.png);
// nullopt when the directory does not exist; throws naming the file on anything unreadable.
std::optional<Golden> load_golden(const std::filesystem::path& dir);
// Writes a golden's files, each atomically (a reader never sees half a file).
void write_golden(const std::filesystem::path& dir, const Golden& golden);

// ---- comparison -----------------------------------------------------------------------------
struct Tolerance {
  float max_diff = 0.0f;          // |actual − expected| above this counts
  double allowed_fraction = 0.0;  // of the region's pixels that may count …
  uint64_t min_allowed = 0;       // … but at least this many (small regions)
  uint64_t allowed(uint64_t pixels) const;
};

// Calibrated on the shipped cases at 480x270 (docs/accuracy.md, "Render checks"): run to run,
// lavapipe and the H200 each repeat their frames bit for bit; lavapipe against the H200 — two
// implementations further apart than any driver update within a device class — differ by at
// most 0 / 1 / 2 / 5 pixels over 0.02 in umbra / lit / penumbra / silhouette, and 4 frame
// pixels over 0.1 at edges (standard depth at near 1e-4 excepted: each device's rounding picks
// its own acne, hence goldens per device class). Each bound sits 2x or more above that, usually
// 5-40x; the mutations the goldens must catch (PCF radius + 1, depth bias x 2, normal offset
// x 2, a swapped compare) exceed it 2.5x or more.
struct Tolerances {
  // Visibility (0..1).
  Tolerance umbra{0.02f, 0.0005, 2}, lit{0.02f, 0.0005, 2}, penumbra{0.05f, 0.005, 4},
      silhouette{0.1f, 0.005, 4};
  // The lit frame, by the loosest region any light gives the pixel: the largest RGB channel
  // difference (4/255: more than rounding) away from shadow edges, 0.1 at them.
  Tolerance frame_tight{4.0f / 255.0f, 0.0005, 4}, frame_loose{0.1f, 0.005, 4};
  const Tolerance& of(Region r) const;
};

// The thresholds of RegionResult::histogram (|difference|, visibility or frame channel).
inline constexpr float kHistogramThresholds[] = {1.0f / 255.0f, 0.02f, 0.1f, 0.25f, 0.5f};

struct RegionResult {
  std::string image;   // "sun", "spot0", … or "frame" (the lit image)
  std::string region;  // to_string(Region), or the frame's "away from shadow edges" / "shadow
                       // edges and silhouettes" (penumbra or silhouette for any light)
  Tolerance tolerance;
  uint64_t pixels = 0, over = 0, allowed = 0;
  float worst = 0.0f;  // the largest |difference|
  uint32_t worst_x = 0, worst_y = 0;
  float expected = 0.0f, actual = 0.0f;  // at the worst pixel (the frame: the worst channel)
  uint64_t non_finite = 0;               // NaN or inf in the new frame: always a failure
  uint64_t histogram[5] = {};  // pixels differing by more than each kHistogramThresholds[k]
  bool passed() const { return over <= allowed && non_finite == 0; }
  std::string to_line() const;  // "sun penumbra: 153 of 2311 pixels differ by more than …"
};

struct Comparison {
  std::vector<RegionResult> results;  // per image and region with pixels
  std::vector<std::string> structural;  // size or light-set mismatches: failures by themselves
  bool passed() const;
  std::vector<std::string> failures() const;  // one line per failing region
  std::string summary() const;                // every region, one line each
};

Comparison compare(const Frame& golden, const Frame& actual, const Tolerances& tolerances = {});

// ---- what people look at --------------------------------------------------------------------
// Regions in colour over the frame's grey: umbra blue, penumbra orange, silhouette magenta, lit
// pale yellow, none left grey.
std::vector<uint8_t> region_image(const std::vector<Region>& regions,
                                  const std::vector<uint8_t>& frame_rgba);
// actual − expected visibility where it is compared (regions other than none): lighter than
// expected red, darker blue, full at |difference| >= 0.25; equal pixels show the frame dimmed.
std::vector<uint8_t> visibility_difference_image(const std::vector<float>& expected,
                                                 const std::vector<float>& actual,
                                                 const std::vector<Region>& regions,
                                                 const std::vector<uint8_t>& frame_rgba);
// |actual − expected| of the frames as a heat map (black → red → yellow → white, 0 → 32/255+).
std::vector<uint8_t> frame_difference_image(const Frame& expected, const Frame& actual);

struct ReportInfo {
  std::string title;     // "default (lavapipe)"
  std::string subtitle;  // device, command, …
  std::string before_label = "expected (golden)", after_label = "actual";
};
// Writes expected, actual, difference and region PNGs and index.html into dir (created);
// returns index.html's path. expected may be empty (no golden yet): only the new images.
std::filesystem::path write_report(const std::filesystem::path& dir, const ReportInfo& info,
                                   const std::optional<Frame>& expected, const Frame& actual,
                                   const std::optional<Comparison>& comparison);

// 16-bit greyscale PNG (libpng), value = round(clamp(v, 0, 1) · 65535); non-finite as 0.
void write_png16(const std::filesystem::path& path, uint32_t width, uint32_t height,
                 const std::vector<float>& values);
std::vector<float> read_png16(const std::filesystem::path& path, uint32_t& width,
                              uint32_t& height);
// Any PNG as RGBA8 (libpng); throws naming the path when it cannot be read.
std::vector<uint8_t> read_png_rgba8(const std::filesystem::path& path, uint32_t& width,
                                    uint32_t& height);

}  // namespace penumbra::golden
