#pragma once

// Directional-light shadow maps: PSSM cascades (three fitting modes) and clipmap levels, with
// texel snapping, reverse-Z and depth clamp. All math in double; GPU data comes from pack.hpp.
// docs/cascades.md describes the algorithms and what the tests guarantee.

#include <cstdint>
#include <glm/glm.hpp>
#include <penumbra/shadow/math.hpp>
#include <penumbra/shadow/types.hpp>
#include <vector>

namespace penumbra::shadow {

// How each cascade's light-space rectangle is fit to its slice of the camera frustum.
enum class CascadeFit : std::uint32_t {
  // Tight light-space box around the slice's 8 corners. Best texel density; the texel size
  // changes when the camera turns (shimmering edges while turning), not when it moves.
  box = 0,
  // Sphere centred on the camera, radius = distance to the slice's far corners, computed from
  // the slice distances, fov and aspect only. Turning the camera in place leaves every cascade
  // matrix bit-identical; covers all directions, so it wastes the most texels.
  camera_sphere = 1,
  // The smallest sphere around the slice (centre on the view axis), "stable CSM": constant
  // texel size, so neither turning nor moving the camera makes edges shimmer (the grid stays
  // fixed in the world); the matrices do change when the camera turns.
  slice_sphere = 2,
};

// Soft-shadow (PCSS) constants passed through to the GPU (ShadowGpu::pcss).
struct PcssOptions {
  // Half-width of the blocker search region, in shadow-map texels of the cascade, > 0.
  double blocker_search_texels = 16.0;
  // Clamp of the filter radius, in texels: 0 <= min_filter_texels <= max_filter_texels.
  double min_filter_texels = 1.0;
  double max_filter_texels = 32.0;
};

// Directional-light cascade options, Filament ShadowOptions style: every field has a default
// that works for a human-scale outdoor scene.
// How the resolve picks a cascade for a receiver.
enum class CascadeSelection : std::uint32_t {
  depth = 0,        // by view distance against the splits (the slice the cascade was fit to)
  containment = 1,  // the finest cascade whose map holds the receiver (with the filter's reach)
};

struct ShadowConfig {
  // Number of cascades, in [1, kMaxCascades].
  std::uint32_t cascade_count = 4;
  // PSSM blend between uniform (0) and logarithmic (1) split placement, in [0, 1].
  double split_lambda = 0.75;
  // Shadows end at min(Camera.far, max_distance) metres of view distance; finite, > 0 and
  // > Camera.near.
  double max_distance = 150.0;
  // Shadow map resolution (square), in [16, 16384].
  std::uint32_t resolution = 2048;
  CascadeFit fit = CascadeFit::slice_sphere;
  DepthConvention depth = DepthConvention::reverse_z;
  // Depth clamp ("pancaking"): the near plane of each cascade is put at its receivers (the
  // fitted slice, or its sphere) instead of the scene bounds; casters in front of it are
  // clamped to depth 1 (reverse-Z) by VkPipelineRasterizationStateCreateInfo::depthClampEnable,
  // which the shadow depth pass enables. More depth precision; no caster is lost.
  bool depth_clamp = true;
  // Move each cascade by whole texels (so static geometry does not shimmer). Off only for
  // comparisons.
  bool snap_to_texels = true;
  // Texels kept free on each side of the fitted region (PCF footprint), in [0, resolution / 8].
  std::uint32_t guard_texels = 1;
  // Cascade i > 0 is also fit to the last blend_fraction of slice i - 1, so the resolve can
  // blend between the two there; in [0, 0.5].
  double blend_fraction = 0.1;
  // Shadows fade out over the last fade_fraction of max_distance; in [0, 1].
  double fade_fraction = 0.1;
  PcssOptions pcss;
  CascadeSelection selection = CascadeSelection::depth;
};

// Clipmap levels: concentric squares centred on the camera, level i twice as wide as level i-1,
// for open worlds seen from above (selection by light-space position, not view distance).
struct ClipmapConfig {
  // Number of levels, in [1, kMaxCascades].
  std::uint32_t level_count = 6;
  // Full width of level 0 in metres (level i: base_extent * 2^i); finite, > 0.
  double base_extent = 32.0;
  // Shadow map resolution per level, in [16, 16384].
  std::uint32_t resolution = 2048;
  DepthConvention depth = DepthConvention::reverse_z;
  bool snap_to_texels = true;
  PcssOptions pcss;
};

// One cascade (or clipmap level).
struct Cascade {
  glm::dmat4 view{1.0};        // world -> light space (rotation only; origin = world origin)
  glm::dmat4 projection{1.0};  // light-space box -> clip
  glm::dmat4 view_proj{1.0};   // world -> clip
  // The light-space box: x, y texel-snapped (width = resolution * texel_world_size), z the depth
  // range (distance along the light direction).
  glm::dvec3 box_min{0.0};
  glm::dvec3 box_max{0.0};
  // World size of one texel (square texels).
  double texel_world_size = 0.0;
  // View distances of the slice this cascade was fit to (fit_near < split_near when blending).
  // Clipmaps: 0 and the level's guaranteed coverage radius.
  double fit_near = 0.0;
  double fit_far = 0.0;
  // The sphere used by the sphere fits (world centre, radius); radius 0 for box and clipmap.
  glm::dvec3 sphere_center{0.0};
  double sphere_radius = 0.0;
};

enum class ShadowLayout : std::uint32_t {
  cascades = 0,  // select by view distance against `splits`
  clipmap = 1,   // select the finest level whose box contains the point
};

struct CascadeSet {
  ShadowLayout layout = ShadowLayout::cascades;
  CascadeFit fit = CascadeFit::box;
  DepthConvention depth = DepthConvention::reverse_z;
  std::uint32_t resolution = 0;
  Basis light_basis;              // z = the light's (unit) travel direction
  double angular_diameter = 0.0;  // of the light
  std::vector<Cascade> cascades;  // 1..kMaxCascades
  // Cascades: count + 1 view distances [camera near, s1, ..., max distance]; cascade i serves
  // [splits[i], splits[i + 1]]. Clipmaps: count + 1 values [0, r0, ..., r(n-1)], r_i the radius
  // (light-space xy, around the camera) that level i is guaranteed to cover.
  std::vector<double> splits;
  double blend_fraction = 0.0;
  double fade_fraction = 0.0;
  PcssOptions pcss;
  CascadeSelection selection = CascadeSelection::depth;  // cascades only (clipmaps: by position)
  glm::dvec3 camera_position{0.0};
  glm::dvec3 camera_forward{0.0, 0.0, -1.0};  // unit
};

// PSSM split distances: count + 1 values from near to far, split_i = lambda * near *
// (far/near)^(i/count) + (1 - lambda) * (near + (far - near) * i/count); the first is exactly
// near and the last exactly far; strictly increasing. Throws penumbra::Error on invalid input.
std::vector<double> pssm_splits(double near, double far, std::uint32_t count, double lambda);

// Throw penumbra::Error naming the field and value ("ShadowConfig.cascade_count = 0: must be in
// [1, 8]") for an invalid input; return normally otherwise.
void validate(const ShadowConfig& config);
void validate(const ClipmapConfig& config);
void validate(const Camera& camera);
void validate(const DirectionalLight& light);
void validate_scene_bounds(const Aabb& bounds);

// Cascades for one directional light. scene_bounds bounds every caster and receiver; the depth
// range of every cascade covers it (with depth_clamp only on the far side: nearer casters are
// clamped, see ShadowConfig::depth_clamp). Validates all inputs; never returns a non-finite
// matrix (throws instead).
CascadeSet compute_cascades(const ShadowConfig& config, const Camera& camera,
                            const DirectionalLight& light, const Aabb& scene_bounds);

// Clipmap levels around camera_position. The depth range of every level covers scene_bounds.
CascadeSet compute_clipmap(const ClipmapConfig& config, const glm::dvec3& camera_position,
                           const DirectionalLight& light, const Aabb& scene_bounds);

}  // namespace penumbra::shadow
