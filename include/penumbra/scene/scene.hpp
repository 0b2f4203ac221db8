#pragma once

// A scene: camera, lights, meshes, materials, instances and the shadow techniques with their
// parameters, as read from a TOML scene file (docs/scenes.md describes the format). Angles here
// are degrees (as in the file), lengths metres, directions unit vectors in a right-handed, +Y-up
// world.

#include <cstdint>
#include <filesystem>
#include <glm/glm.hpp>
#include <memory>
#include <optional>
#include <penumbra/scene/mesh.hpp>
#include <penumbra/shadow/cascades.hpp>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::scene {

enum class AlphaMode { opaque, masked };

// The alpha mask of a masked material, evaluated at uv * mask_scale (see docs/scenes.md):
// texture: the coverage channel of mask_texture (MaskImage); stripes: bars across u (half of
// each period is cut out); checker: a checkerboard (every other cell cut out); circles: a grid of
// round holes.
enum class MaskPattern { none, texture, stripes, checker, circles };

// The masks of shaders/penumbra/material.glsl, operation for operation in float (the ray-traced
// reference evaluates masked occluders with these; a GPU test checks they agree): coverage in
// [0, 1] of `pattern` at uv * scale. MaskPattern::texture gives 1 here, as procedural_mask does
// in the shaders: texture masks go through texture_mask.
float procedural_mask(glm::vec2 uv, MaskPattern pattern, glm::vec2 scale);
// True where the alpha test cuts the surface out (coverage < cutoff).
bool alpha_test_discards(glm::vec2 uv, MaskPattern pattern, glm::vec2 scale, float cutoff);

// A mask texture: one 8-bit coverage channel of a PNG (its alpha where the PNG has one, else its
// first channel), rows top to bottom: uv (0, 0) is the image's top-left corner.
struct MaskImage {
  std::filesystem::path source;
  std::uint32_t width = 0, height = 0;
  std::vector<std::uint8_t> texels;  // row-major, width x height
};
inline constexpr std::uint32_t kMaxMaskImageSize = 8192;        // texels a side
inline constexpr std::uintmax_t kMaxMaskFileBytes = 64u << 20;  // a PNG larger is refused
// Reads a PNG mask (a regular file of at most kMaxMaskFileBytes, at most kMaxMaskImageSize texels
// a side). Throws penumbra::Error naming the file and what is wrong with it.
MaskImage load_mask_image(const std::filesystem::path& file);
// The coverage of `image` at uv * scale as the renderer samples it (material.glsl's texture_mask
// through a linear, repeating sampler at level 0): bilinear between texel centres, wrapping at
// the edges. Non-finite uv gives 1 (opaque).
float texture_mask(const MaskImage& image, glm::vec2 uv, glm::vec2 scale);

struct Material {
  std::string name;
  glm::vec3 albedo{0.8f};
  AlphaMode alpha = AlphaMode::opaque;
  MaskPattern mask = MaskPattern::none;         // none <=> alpha == opaque
  std::filesystem::path mask_texture;           // absolute; set only for MaskPattern::texture
  std::shared_ptr<const MaskImage> mask_image;  // mask_texture's texels (MaskPattern::texture)
  glm::vec2 mask_scale{1.0f};                   // repetitions of the pattern over uv [0, 1]
  float alpha_cutoff = 0.5f;                    // in (0, 1): mask < cutoff is cut out
};

// A material's coverage at uv (its texture or its procedural pattern; 1 when opaque), and whether
// the alpha test cuts it out there.
float mask_coverage(const Material& material, glm::vec2 uv);
bool alpha_test_discards(const Material& material, glm::vec2 uv);

// How an instance moves over the frames (a scene file's `move`, `move_frames` and `spin`; the
// frame index drives it, Scene::pose). Frame k's transform is the placement `base`, turned by
// k·spin degrees about its origin (x, then y, then z, world axes) and moved by t(k)·move, where
// t goes from 0 to 1 over move_frames frames and back (a back-and-forth walk).
struct Motion {
  glm::mat4 base{1.0f};      // the placement at frame 0 (object -> world)
  glm::vec3 move{0.0f};      // metres: the far end of the translation
  std::uint32_t move_frames = 0;  // frames from one end to the other (> 0 with a move)
  glm::vec3 spin{0.0f};      // degrees per frame
  bool moves() const;
  // The transform at frame k (computed in double, rounded to float once).
  glm::mat4 transform_at(std::uint32_t frame) const;
};

struct Instance {
  std::uint32_t mesh = 0;      // index into Scene::meshes
  std::uint32_t material = 0;  // index into Scene::materials
  glm::mat4 transform{1.0f};   // object -> world, at the frame the scene is posed at
  bool casts_shadows = true;
  // > 0 (analytic_shadow = true): a sphere of this object-space radius about the object's origin,
  // under a uniform scale, whose shadow is computed in closed form (penumbra/sphere_shadow.glsl)
  // instead of being drawn into the shadow maps. The reference traces its mesh as any other.
  float analytic_sphere_radius = 0.0f;
  std::optional<Motion> motion;  // set: the instance moves (Scene::pose sets transform)
  // Whether the instance is drawn into the shadow maps.
  bool in_shadow_maps() const { return casts_shadows && !(analytic_sphere_radius > 0.0f); }
};

// At most this many analytic spheres per scene (a uniform buffer of vec4s; every shadowed pixel
// loops over them for every light).
inline constexpr std::uint32_t kMaxAnalyticSpheres = 256;

struct Camera {
  glm::vec3 position{0.0f, 2.0f, 6.0f};
  glm::vec3 target{0.0f};
  glm::vec3 up{0.0f, 1.0f, 0.0f};
  float fov_y_degrees = 60.0f;  // full vertical field of view, in (0, 180)
  float near = 0.1f;            // 0 < near < far
  float far = 500.0f;
  // A walk: the camera (position and target together) moves by t(k)·move at frame k, t going
  // from 0 to 1 over move_frames frames and back (Motion's walk). move_frames = 0: still.
  glm::vec3 move{0.0f};
  std::uint32_t move_frames = 0;
  // The position and target at frame k: the ones above (frame 0) moved by the walk.
  glm::vec3 position_at(std::uint32_t frame) const;
  glm::vec3 target_at(std::uint32_t frame) const;
  Camera at(std::uint32_t frame) const;  // this camera with position and target at frame k
};

// t(k) of a back-and-forth walk over `frames` frames: 0 at k = 0, 1 at k = frames, 0 again at
// 2·frames (exact at those frames); 0 for frames = 0.
double walk_fraction(std::uint32_t frame, std::uint32_t frames);

struct Sun {
  // Unit; points FROM the sun TOWARD the scene (the direction the light travels).
  glm::vec3 direction{0.0f, -1.0f, 0.0f};
  glm::vec3 color{1.0f};
  float intensity = 3.0f;
  float angular_diameter_degrees = 0.53f;  // in [0, 90); 0 = hard shadows
  bool shadows = true;
};

// evsm2: exponential variance shadow maps: the sun's cascades, and a spot or point light's maps
// when the light asks for it itself (its own filter); a spot or point light without a filter of
// its own uses pcf under the scene's evsm2.
enum class Filter { hard, pcf, pcss, poisson, evsm2, vogel };

// How many spot and point lights the renderer shades (render::kMaxSpotLights and
// kMaxPointLights, the frame's LightGpu arrays): a scene file with more is an error.
inline constexpr std::size_t kMaxSpotLights = 2;
inline constexpr std::size_t kMaxPointLights = 2;
// Instances per scene ([[object]]s and [[scatter]] counts together): each is a draw call in
// every pass; 10,000 take ~2 s for one 320x180 frame with a sun on lavapipe (2 cores).
inline constexpr std::size_t kMaxInstances = 20000;

struct SpotLight {
  glm::vec3 position{0.0f};
  glm::vec3 direction{0.0f, -1.0f, 0.0f};  // unit, the cone's axis
  glm::vec3 color{1.0f};
  float intensity = 20.0f;
  float outer_degrees = 30.0f;  // half-angle of the cone, in (0, 90)
  float inner_degrees = 25.0f;  // full intensity inside, in [0, outer]
  float range = 20.0f;          // > 0; the light (and its shadow map's far plane) ends here
  float radius = 0.0f;          // >= 0: the emitting sphere's radius; 0 = a point (hard shadows)
  bool shadows = true;
  std::uint32_t resolution = 1024;
  std::optional<Filter> filter;  // this light's filter; unset: [shadows] filter
};

struct PointLight {
  glm::vec3 position{0.0f};
  glm::vec3 color{1.0f};
  float intensity = 20.0f;
  float range = 20.0f;
  float radius = 0.0f;  // >= 0: the emitting sphere's radius; 0 = a point (hard shadows)
  bool shadows = true;
  std::uint32_t resolution = 512;  // of each cube face
  std::optional<Filter> filter;    // this light's filter; unset: [shadows] filter
  // The cube fit to what the camera sees (shadow::fit_point_shadow): only the faces that see an
  // object in the camera's view up to shadows.max_distance are drawn, and the stored linear
  // depth spans those objects instead of the light's range.
  bool fit_to_camera = false;
};

// One enum for the concept: the cascade math's (docs/cascades.md).
using CascadeFit = shadow::CascadeFit;
using CascadeSelection = shadow::CascadeSelection;
using ShadowLayout = shadow::ShadowLayout;

// The cascade layout's defaults are the shadow library's (shadow::ShadowConfig), defined there
// once; the scene adds the filter and the biases. Ranges, meanings and keys: params.hpp.
inline constexpr shadow::ShadowConfig kCascadeDefaults{};

struct ShadowSettings {
  Filter filter = Filter::pcf;
  std::uint32_t cascades = kCascadeDefaults.cascade_count;  // sun cascades, in [1, 4]
  float split_lambda = float(kCascadeDefaults.split_lambda);
  float max_distance = float(kCascadeDefaults.max_distance);  // view distance, > 0
  std::uint32_t resolution = kCascadeDefaults.resolution;
  CascadeFit fit = kCascadeDefaults.fit;
  CascadeSelection selection = kCascadeDefaults.selection;
  // The sun's maps: PSSM cascades over view distance, or a clipmap (camera-centred nested
  // squares, level i 2^i times as wide as level 0, selected by position; docs/cascades.md).
  ShadowLayout layout = ShadowLayout::cascades;
  std::uint32_t clipmap_levels = 6;                       // in [1, 8]
  float clipmap_extent = 16.0f;                           // metres: the full width of level 0, > 0
  bool snap_to_texels = kCascadeDefaults.snap_to_texels;  // cascades move by whole texels
  bool cache = true;  // redraw a shadow map only when what it holds changed
  int pcf_radius = 1;                                     // PCF kernel radius in texels, in [0, 5]
  // PCF and Poisson keep their world width across cascades (a disk sized in cascade 0's texels).
  bool constant_filter_width = false;
  int pcss_quality = 1;             // 0 low, 1 medium, 2 high
  std::uint32_t poisson_taps = 16;  // taps of the Poisson filter, in [1, 32]
  float pcss_search_texels = float(kCascadeDefaults.pcss.blocker_search_texels);
  float pcss_min_filter_texels = float(kCascadeDefaults.pcss.min_filter_texels);
  float pcss_max_filter_texels = float(kCascadeDefaults.pcss.max_filter_texels);
  // Fraction of the blocker-search taps that must find a blocker before PCSS filters at all.
  float pcss_confidence = 0.1f;
  float blend_band = float(kCascadeDefaults.blend_fraction);  // in [0, 0.5]
  float fade_band = float(kCascadeDefaults.fade_fraction);    // of max_distance, in [0, 1]
  // World-unit biases (docs/accuracy.md has the measurements behind the defaults).
  float normal_offset_texels = 0.75f;  // texels at the receiver, >= 0
  float slope_bias = 2.0f;             // texels of depth change across one texel, >= 0
  float max_slope_bias = 4.0f;         // bound of the slope term, texels, >= 0
  float constant_bias = 0.0005f;       // metres along the light, >= 0
  bool reverse_z = true;
  // Temporal accumulation of every light's visibility (the shadow-temporal pass): each pixel
  // blends its visibility into the last frame's, reprojected through the depth buffer and
  // clamped to this frame's 3x3 neighbourhood. temporal_weight is the new frame's share, in
  // (0, 1]. docs/accuracy.md has the measurements behind the defaults.
  bool temporal = false;
  float temporal_weight = 0.2f;
  // filter = evsm2 (the sun): the cascades' depths become moments of the positive EVSM warp
  // exp(c x) (the evsm pass), blurred with a separable box of evsm_blur texels a side, and the
  // resolve evaluates the Chebyshev bound with light-bleed reduction. evsm_fp16 stores the
  // moments in 16-bit floats (c is clamped to 5.54 for them, 42 for fp32).
  // Defaults from a sweep against the reference (docs/accuracy.md, "EVSM2 on the sun").
  bool evsm_fp16 = true;
  float evsm_exponent = 40.0f;        // c, in (0, 42]; clamped for the moment format
  int evsm_blur = 0;                  // box radius in texels, in [0, 8]
  float evsm_bleed_reduction = 0.2f;  // in [0, 1)
  float evsm_min_variance = 1e-6f;    // depth units squared, in [0, 0.01]
  // The sun's moments get a full mip chain, and the resolve reads each receiver's screen
  // footprint in the map through it (trilinear, textureGrad) instead of one bilinear read.
  bool evsm_mips = false;
};

// The most contact-shadow march steps (what contact_shadows.comp can march).
inline constexpr std::uint32_t kMaxContactSteps = 64;

// Screen-space contact shadows: the scene's [contact] table and the contact pass's options
// (render::ContactShadowSettings is this type).
struct ContactSettings {
  // The most steps per pixel, in [0, kMaxContactSteps]; fewer on rays shorter than that many
  // pixels. 0 disables contact shadows: no pipelines, no images, no dispatch.
  std::uint32_t step_count = 16;
  // Ray length in world (view-space) units, > 0.
  float max_distance = 0.3f;
  // How deep an occluder is assumed behind its visible surface, world units, > 0.
  float thickness = 0.05f;
  // mask = 1 - intensity * occlusion; in [0, 1].
  float intensity = 1.0f;
  // Depth tolerance as a fraction of the receiver's view depth, divided by max(N.L, 0.25);
  // in [0, 1).
  float depth_bias = 0.002f;
  // Steps at t = ((i + noise) / N)^step_exponent; in [1, 8].
  float step_exponent = 2.0f;
  // Occlusion fades out over this fraction of the screen at its borders; in [0, 0.5].
  float edge_fade = 0.05f;
};

enum class DebugView {
  lit,
  shadow_factor,
  cascades,
  contact_mask,
  texel_density,
  penumbra,
  redrawn,
};

struct RenderSettings {
  std::uint32_t width = 1280, height = 720;
  std::uint32_t frames = 1;
  DebugView view = DebugView::lit;
  float exposure = 1.0f;
};

struct Scene {
  std::filesystem::path source;  // the file it was read from (as given)
  std::string name;
  Camera camera;
  std::optional<Sun> sun;
  std::vector<SpotLight> spots;
  std::vector<PointLight> points;
  std::vector<Mesh> meshes;  // each used by at least one instance
  std::vector<Material> materials;
  std::vector<Instance> instances;
  ShadowSettings shadows;
  ContactSettings contact;
  RenderSettings render;

  // Poses the moving instances at frame k: sets each one's transform from its Motion. The
  // renderer does it for every frame it renders (the camera's walk it reads itself:
  // Camera::position_at); instances without motion are left as they are.
  void pose(std::uint32_t k);
  bool has_motion() const;  // an instance moves or the camera walks
  // Drops every motion, the objects' and the camera's walk: the scene as frame 0 has it, at
  // every frame (what a measure of the shadows' own stability holds a shipped scene to).
  void hold_still();

  // Of all instances, transformed to world space, over their whole motion: a moving instance
  // adds every place it passes through (the sun's cascades take their depth range from this,
  // so that a moving object does not change them frame to frame).
  Bounds world_bounds() const;
  // A moving instance's bounds over its whole motion (a static one's: its bounds).
  Bounds motion_bounds(const Instance& instance) const;
  // Each instance's world bounds at the posed frame (a missing mesh: empty bounds).
  std::vector<Bounds> instance_world_bounds() const;
  // Of the instances with casts_shadows.
  Bounds caster_bounds() const;
  // The analytic spheres' world centres (xyz) and radii (w), in instance order.
  std::vector<glm::vec4> analytic_spheres() const;

  // What the scene requires; the renderer creates passes, images and variants only for these.
  struct Requirements {
    bool sun_shadows = false;  // a sun with shadows = true
    // sun_shadows: shadows.cascades, or shadows.clipmap_levels with the clipmap layout; else 0
    std::uint32_t cascades = 0;
    std::uint32_t spot_shadow_maps = 0;    // spots with shadows = true
    std::uint32_t point_shadow_cubes = 0;  // points with shadows = true
    bool contact_pass = false;             // contact.step_count > 0 and the scene has a light
    bool masked_materials = false;         // an instance uses a masked material
    std::uint32_t mask_textures = 0;       // distinct mask textures those materials sample
    bool temporal = false;                 // shadows.temporal and a shadowed light
    bool sun_moments = false;              // sun_shadows with filter = evsm2: the evsm pass
    // A shadowed point (spot) light's own filter is evsm2: implies point_shadow_cubes
    // (spot_shadow_maps) > 0.
    bool point_moments = false;
    bool spot_moments = false;
    std::uint32_t analytic_spheres = 0;  // instances with analytic_shadow, if a light is shadowed
    bool operator==(const Requirements&) const = default;
  };
  Requirements requirements() const;
  // The distinct mask textures of the materials instances use, in material order (the renderer's
  // mask texture array), and where a material's is in that list (-1: none).
  std::vector<std::shared_ptr<const MaskImage>> mask_images() const;
  int mask_image_index(std::uint32_t material) const;
  // The same against a list mask_images() returned (computed once for many materials).
  int mask_image_index(std::uint32_t material,
                       const std::vector<std::shared_ptr<const MaskImage>>& images) const;
};

// Moves the whole scene by `offset` metres: the camera's position and target, every instance,
// spot and point light (the sun has no position). Each value is moved in double and rounded to
// float once, as a scene file that wrote the moved positions would give them; the far-from-origin
// checks (tests/golden's `origin`, the extremes matrix) use it.
void translate_scene(Scene& scene, const glm::dvec3& offset);

// Reads and validates a scene file. Throws penumbra::Error with "<file>:<line>: <what>" naming
// the key and value (unknown keys come with a "did you mean" suggestion).
Scene load_scene(const std::filesystem::path& file);
// The same from text: name_for_errors prefixes messages (and is Scene::source), base_dir
// resolves relative mesh and texture paths.
Scene parse_scene(std::string_view toml_text, const std::filesystem::path& name_for_errors,
                  const std::filesystem::path& base_dir);

// "default" -> <repo>/scenes/default.toml (the compiled-in scene directory, then ./scenes).
// Anything with a '/' or a ".toml" suffix, or an existing file, is a path and is returned as
// is. Throws penumbra::Error listing the shipped scenes when a name is not found.
std::filesystem::path find_scene(std::string_view name_or_path);
// The names of the shipped scenes (the compiled-in scene directory's *.toml stems, sorted).
std::vector<std::string> shipped_scenes();

// A filter's fetches, reach and the rest: filters.hpp.

// The names used in scene files, for printing.
std::string_view to_string(Filter filter);
std::string_view to_string(CascadeFit fit);
std::string_view to_string(DebugView view);
std::string_view to_string(AlphaMode mode);
std::string_view to_string(MaskPattern pattern);

}  // namespace penumbra::scene
