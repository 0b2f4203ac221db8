#pragma once

// Spot and point light shadow matrices (double), Vulkan conventions (see math.hpp).
//
// Point lights use the linear-distance convention: the depth pass writes
//     t = clamp((|p - light| - depth_near) / (depth_far - depth_near), 0, 1)
//     gl_FragDepth = reverse_z ? 1 - t : t
// (point_shadow_depth() is the reference), so a plain point light with range R stores
// |p - light| / R. The face matrices are used for rasterization and clipping only.

#include <array>
#include <cstdint>
#include <glm/glm.hpp>
#include <penumbra/shadow/math.hpp>
#include <penumbra/shadow/types.hpp>
#include <span>

namespace penumbra::shadow {

struct SpotLight {
  glm::dvec3 position{0.0};
  glm::dvec3 direction{0.0, -1.0, 0.0};  // need not be unit; finite, non-zero
  // Half-angle of the outer cone, in (0, 1.55] radians (just under 90 degrees).
  double outer_angle = 0.7853981633974483;  // 45 degrees
  // Far plane, > near.
  double range = 20.0;
};

struct SpotShadowConfig {
  std::uint32_t resolution = 1024;  // [16, 16384]
  double near = 0.05;               // near plane, in (0, range)
  DepthConvention depth = DepthConvention::reverse_z;
};

struct SpotShadow {
  Basis basis;  // z = light direction
  glm::dvec3 position{0.0};
  glm::dmat4 view{1.0};
  glm::dmat4 projection{1.0};
  glm::dmat4 view_proj{1.0};
  double near = 0.0;
  double far = 0.0;
  double tan_half_angle = 0.0;  // the cone edge maps to NDC +-1 on x and y
  std::uint32_t resolution = 0;
  DepthConvention depth = DepthConvention::reverse_z;
};

// Vulkan cube-map face order (layer index of a cube image).
enum class CubeFace : std::uint32_t {
  positive_x = 0,
  negative_x = 1,
  positive_y = 2,
  negative_y = 3,
  positive_z = 4,
  negative_z = 5,
};

struct PointLight {
  glm::dvec3 position{0.0};
  double range = 10.0;  // > near
};

struct PointShadowConfig {
  std::uint32_t resolution = 512;  // per face, [16, 16384]
  // Smallest projection near plane, > 0. Casters closer than this to the light are clipped.
  double near = 0.05;
  DepthConvention depth = DepthConvention::reverse_z;
};

struct PointShadow {
  glm::dvec3 position{0.0};
  // Face f: world -> face view (see cube_face_view) and world -> clip. Sampling a samplerCube
  // with direction p - position reads the texel that face_view_proj[major face] rasterized p
  // to. The face views are mirrored (determinant -1, as every cube map face is), so the depth
  // pass must use cullMode NONE or swap frontFace for point-light faces.
  std::array<glm::dmat4, 6> face_view{};
  glm::dmat4 projection{1.0};  // 90 degrees, clip_near .. depth_far
  std::array<glm::dmat4, 6> face_view_proj{};
  // Linear distance range stored in depth (see the top of this file).
  double depth_near = 0.0;
  double depth_far = 0.0;
  // Projection near plane: depth_near / sqrt(3) (a point at distance depth_near in a face's
  // corner direction lies at view z = depth_near / sqrt(3)), at least PointShadowConfig::near.
  double clip_near = 0.0;
  // Bit f set: face f must be rendered (all six for a plain point light).
  std::uint32_t face_mask = 0x3fu;
  std::uint32_t resolution = 0;
  DepthConvention depth = DepthConvention::reverse_z;
};

// Perspective shadow for a spot light: a square frustum whose side planes touch the cone.
SpotShadow compute_spot_shadow(const SpotLight& light, const SpotShadowConfig& config);

// The six 90-degree faces of a point light, depth_near = 0, depth_far = range (so the stored
// depth is distance / range).
PointShadow compute_point_shadow(const PointLight& light, const PointShadowConfig& config);

// A point light whose map is fit to what the camera sees (a star lighting a field of
// asteroids, no ground plane). `objects` bounds every caster/receiver. Receivers are the
// objects that intersect the camera frustum up to min(camera.far, max_distance); depth_far is
// the farthest receiver corner from the light, depth_near the nearest point of any object
// closer than depth_far (conservatively: every object that might shadow a receiver), and only
// the faces that see a receiver are set in face_mask (0 when nothing is visible; the matrices
// are still finite). The linear range then spans the field, not the distance to the star.
PointShadow fit_point_shadow(const glm::dvec3& light_position, const Camera& camera,
                             double max_distance, std::span<const Aabb> objects,
                             const PointShadowConfig& config);

// The value the point-light depth pass stores for world point p (the linear-distance
// convention).
double point_shadow_depth(const PointShadow& shadow, const glm::dvec3& p);

// World -> view for one cube face at `position`: view = (sc, tc, ma) of the Vulkan cube-map
// face selection table for that face, so ndc = (sc / ma, tc / ma) and uv = ndc * 0.5 + 0.5 =
// (s, t) exactly as the sampler computes them.
glm::dmat4 cube_face_view(CubeFace face, const glm::dvec3& position);

// The face a samplerCube selects for direction d (largest |component|; ties go to z, then y,
// like common hardware). d must be non-zero.
CubeFace cube_face_for_direction(const glm::dvec3& d);

void validate(const SpotLight& light, const SpotShadowConfig& config);
void validate(const PointLight& light, const PointShadowConfig& config);

}  // namespace penumbra::shadow
