#pragma once

// Ground truth: ray-traced visibility of a scene's lights, as area lights, at the GPU's own
// receivers (Embree 3). Visibility is the fraction of the light's disk (the sun) or sphere
// (spot and point lights) that a receiver sees past the shadow casters. docs/accuracy.md
// describes the method, the sampling and its noise.

#include <array>
#include <cstdint>
#include <filesystem>
#include <glm/glm.hpp>
#include <memory>
#include <optional>
#include <penumbra/scene/scene.hpp>
#include <span>
#include <string>
#include <vector>

namespace penumbra::reference {

enum class LightKind { sun, spot, point };

// One of a scene's lights: the sun, spots[index] or points[index].
struct LightRef {
  LightKind kind = LightKind::sun;
  uint32_t index = 0;
  std::string name() const;  // "sun", "spot0", "point1"
};

// Every light of the scene, in the order sun, spots, points.
std::vector<LightRef> scene_lights(const scene::Scene& scene);

// What the tracer samples for a light.
//   sun:   a disk of angular radius `angular_radius` around `direction_to_light`, sampled
//          uniformly in the plane tangent to that direction (the projection PCSS assumes);
//   spot, point: a sphere of `radius` around `position` (world), sampled uniformly over the
//          solid angle it subtends; rays end at its surface.
// Hard (angular_radius or radius 0): one ray to the centre.
struct AreaLight {
  LightKind kind = LightKind::sun;
  glm::dvec3 direction_to_light{0.0, 1.0, 0.0};  // sun: unit
  double angular_radius = 0.0;                   // sun: radians, half the angular diameter
  glm::dvec3 position{0.0};                      // spot, point: world
  double radius = 0.0;                           // spot, point: metres
  bool hard() const;
};
// Throws penumbra::Error naming the light when the scene does not have it.
AreaLight area_light(const scene::Scene& scene, const LightRef& light);

// Where the shadow rays of a receiver on a smooth-shaded mesh start.
//   smooth:    on the smooth surface the interpolated normals describe: the point is moved
//              out of its flat triangle by the shadow-terminator offset (Hanika 2021,
//              "Hacking the shadow terminator": the barycentric blend of its projections onto
//              the three vertices' tangent planes, outward only), and the rays ignore the
//              triangle they start on. What the shading (n·l with the interpolated normal)
//              and the shadow maps (biased along that normal) assume; the default.
//   geometric: on the flat triangle: the facets of a low-poly mesh shadow each other near the
//              terminator, where the interpolated normal still faces the light.
// Flat meshes (vertex normals equal to the face normal) give the same result either way.
enum class Terminator { smooth, geometric };

struct TraceOptions {
  uint32_t samples = 256;         // rays per receiver where visibility is partial (>= 1)
  uint32_t initial_samples = 16;  // adaptive: stop after these when they all agree
  bool adaptive = true;
  uint64_t seed = 1;      // same seed, same bits
  uint32_t threads = 0;   // 0: every hardware thread
  bool progress = false;  // a progress bar on stderr when it is a terminal
  std::string progress_label = "reference";
  Terminator terminator = Terminator::smooth;
  // Every receiver draws the same light samples (the pattern depends on the seed only, not on
  // the receiver). The estimate is then a deterministic function of the receiver's position:
  // two frames that see the same surface point give it the same value, where independent
  // patterns differ by their Monte Carlo noise (~0.03 at 256 samples). For measuring the
  // truth's own flicker; the error is structured (banding) rather than noise.
  bool shared_pattern = false;
};

// Per receiver. Non-receivers (sky, NaN input) hold NaN value and 0 samples.
struct Visibility {
  std::vector<float> value;      // visible fraction of the light in [0, 1]
  std::vector<float> std_error;  // per receiver: sqrt(max(p(1-p), 1/n) / n), p = value
  std::vector<uint32_t> samples;
  uint64_t rays = 0;
  double seconds = 0.0;
  bool from_cache = false;
};

// Receivers: positions relative to the render origin (double) and unit normals; a receiver
// with valid == 0 is not traced (sky).
struct Receivers {
  uint32_t width = 0, height = 0;    // an image's size, or count × 1 for explicit points
  glm::dvec3 origin{0.0};            // world position of the relative space's origin
  std::vector<glm::dvec3> position;  // relative to origin
  std::vector<glm::dvec3> normal;    // world orientation, unit
  std::vector<uint8_t> valid;
  // G-buffer receivers: the camera (relative to origin) and, per receiver, how far along its
  // view ray the stored depth may put it from the surface (4 float steps of the stored depth
  // either way, in metres). The tracer moves such a receiver onto the first caster surface
  // within that distance along its view ray, so a receiver that the depth buffer's rounding put
  // inside its caster (standard depth at near 1e-4 / far 1e6: centimetres at 5 m) is not
  // shadowed by the caster itself. Empty for explicit points: they are used as given.
  std::optional<glm::dvec3> eye;
  std::vector<float> depth_tolerance;
  // Geometry pixels (or given points) left out for a non-finite position or normal.
  size_t rejected = 0;
  size_t size() const { return position.size(); }
};

// Explicit world points (for tests and tools); origin: the relative space (the camera, say).
Receivers receivers_from_points(std::span<const glm::dvec3> world_points,
                                std::span<const glm::dvec3> normals, glm::dvec3 origin);

// The GPU's G-buffer: depth (as stored: reverse-Z or standard, Vulkan [0, 1]), view-space
// normals with alpha 1 on geometry, and the float camera matrices the GPU used (widened to
// double), row-major with the top row first. Positions are reconstructed in double.
Receivers receivers_from_gbuffer(uint32_t width, uint32_t height, std::span<const float> depth,
                                 std::span<const glm::vec4> normal_view, const glm::dmat4& view,
                                 const glm::dmat4& proj, glm::dvec3 origin);

// The shadow casters of a scene in a BVH: the meshes the rasterizer draws, after the same
// transforms (relative to `origin`, rounded to float like the GPU's model matrices); instances
// with casts_shadows = false left out; masked materials alpha-tested at each hit with
// scene::procedural_mask.
class Tracer {
 public:
  Tracer(const scene::Scene& scene, glm::dvec3 origin);
  ~Tracer();
  Tracer(const Tracer&) = delete;
  Tracer& operator=(const Tracer&) = delete;

  Visibility trace(const Receivers& receivers, const AreaLight& light,
                   const TraceOptions& options) const;

  // One shadow ray: true when a caster lies on the segment from `origin_relative` (relative to
  // origin()) along unit `direction` up to `tfar` (inf: unbounded). Masks are alpha-tested as in
  // trace(); no triangle is ignored. Thread-safe.
  bool blocked(const glm::dvec3& origin_relative, const glm::dvec3& direction, double tfar) const;

  size_t triangle_count() const;
  glm::dvec3 origin() const;
  // A hash of everything in the BVH (vertices, indices, masks): part of the cache key.
  uint64_t geometry_hash() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// The ray origin offset along the receiver's normal, in metres: kRayOffsetRelative times the
// largest coordinate magnitude of the position relative to the render origin, at least
// kRayOffsetMin. Large enough to clear the depth reconstruction's rounding, small against any
// caster the scenes have (see docs/accuracy.md).
inline constexpr double kRayOffsetRelative = 2e-5;
inline constexpr double kRayOffsetMin = 1e-5;
double ray_offset(const glm::dvec3& relative_position);

// The shadow-terminator offset (Terminator::smooth) of point p on a triangle with the given
// corners, unit vertex normals (turned to the side the rays leave from) and p's barycentric
// coordinates: the barycentric blend of p's projections onto the three tangent planes, each
// only where p lies below that plane. Zero on a flat triangle (normals equal to the face
// normal) and at the corners; continuous across shared edges.
glm::dvec3 terminator_offset(const std::array<glm::dvec3, 3>& vertex,
                             const std::array<glm::dvec3, 3>& normal, const glm::dvec3& p,
                             const glm::dvec3& barycentric);

// ---- sampling (exposed for tests) -------------------------------------------------------------
// Point i of the 2D Sobol (0,2)-sequence, Owen-scrambled by hashing (a nested uniform scramble
// seeded by `seed`): in [0, 1)².
glm::dvec2 sobol_owen(uint32_t i, uint64_t seed);
// Shirley–Chiu concentric map of the unit square onto the unit disk (area-preserving).
glm::dvec2 concentric_disk(glm::dvec2 u);

// ---- the on-disk cache ------------------------------------------------------------------------
// Key: the tracer's geometry, the receivers, the light and the options that change the result.
uint64_t cache_key(const Tracer& tracer, const Receivers& receivers, const AreaLight& light,
                   const TraceOptions& options);
// $PENUMBRA_REFERENCE_CACHE, else $XDG_CACHE_HOME/penumbra/reference, else
// ~/.cache/penumbra/reference.
std::filesystem::path default_cache_dir();
// A cached result for the key (nullopt when absent, unreadable or for other receivers).
std::optional<Visibility> cache_load(const std::filesystem::path& dir, uint64_t key, size_t count);
// Writes atomically (a temporary file, then rename); throws penumbra::Error naming the path.
void cache_store(const std::filesystem::path& dir, uint64_t key, const Visibility& v);
// trace() through the cache: a hit returns the stored bits (from_cache = true).
Visibility trace_cached(const Tracer& tracer, const Receivers& receivers, const AreaLight& light,
                        const TraceOptions& options, const std::filesystem::path& cache_dir);

}  // namespace penumbra::reference
