// Depth-buffer helpers: linearization for reverse-Z (the default) and standard-Z perspective
// projections with finite and infinite far planes, the inverse mappings, NDC <-> UV, and
// view/world position reconstruction. Every function is pure. No #version here: include it from
// a file that has one.
//
// Conventions
// - View space is right-handed and the camera looks down -Z (as GLM's lookAt): a point in front
//   of the camera has view.z < 0. "View distance" is the distance along the view axis,
//   -view.z > 0 (not the Euclidean distance to the camera).
// - Vulkan clip space: depth d = clip.z / clip.w in [0, 1]. Standard-Z maps the near plane to 0
//   and the far plane to 1; reverse-Z maps near to 1 and far to 0 (an infinite far plane to 0),
//   which spreads float precision evenly over distance.
//     standard: d = far * (z - near) / (z * (far - near))    infinite far: d = 1 - near / z
//     reverse:  d = near * (far - z) / (z * (far - near))    infinite far: d = near / z
// - Vulkan NDC y = -1 is the top row of the framebuffer (with a positive viewport height), and
//   uv = (0, 0) is the top-left corner, uv = (1, 1) the bottom-right: uv = ndc.xy * 0.5 + 0.5,
//   with no y flip. A projection therefore maps view +Y (up) to NDC -Y: a GLM projection needs
//   proj[1][1] *= -1 (or a negative viewport height, which this file does not assume).
// - Depth arguments are clamped to [0, 1]; a NaN depth counts as the far plane (the clear value
//   of the convention), so the linearizations never return NaN.
// - Plane distances: 0 < near < far, with near * far and far * far below the float maximum
//   (far up to ~1e19); the products stay finite, and are not rewritten as extra divisions.

#ifndef PENUMBRA_DEPTH_GLSL
#define PENUMBRA_DEPTH_GLSL

#include "penumbra/common.glsl"

// d clamped to [0, 1]; NaN becomes the far plane's depth (0 for reverse-Z, 1 for standard).
float saturate_depth(float d, bool reverse_z) {
  if (d >= 0.0) return min(d, 1.0);
  return d < 0.0 ? 0.0 : (reverse_z ? 0.0 : 1.0);
}

// The positive view distance (-view.z) of depth d under a perspective projection with planes at
// near and far (0 < near < far): near at the near plane's depth, far at the far plane's. Relative
// error < 6.5 * 2^-23 for every d in [0, 1]: both weights are non-negative, so nothing cancels,
// even for standard-Z at d -> 1.
float linearize_depth(float d, float near, float far, bool reverse_z) {
  float s = saturate_depth(d, reverse_z);
  // z = near * far / (far * w_far + near * w_near), with w_far the weight of the far plane.
  float w_far = reverse_z ? s : 1.0 - s;
  float w_near = reverse_z ? 1.0 - s : s;
  return (near * far) / (far * w_far + near * w_near);
}

// The positive view distance of depth d under an infinite-far perspective projection
// (reverse: d = near / z; standard: d = 1 - near / z). The far plane's depth (0 reverse, 1
// standard) and NaN give +infinity, never NaN. Relative error < 3.5 * 2^-23 (1 - d and the
// division).
float linearize_depth_infinite(float d, float near, bool reverse_z) {
  float s = saturate_depth(d, reverse_z);
  float w = reverse_z ? s : 1.0 - s;
  return w > 0.0 ? near / w : kInfinity;
}

// The depth of a point at positive view distance z (the inverse of linearize_depth): in [0, 1]
// for z in [near, far], outside it beyond the planes (as the projection gives before clipping).
// Relative error < 6.5 * 2^-23 for finite z > 0 where z * (far - near) is finite, < 8 * 2^-23
// beyond; z = 0 gives an infinity (+ reverse, - standard);
// z = +infinity (and NaN) gives the limit at infinity, -near / (far - near) for reverse-Z and
// far / (far - near) for standard-Z.
float view_distance_to_depth(float z, float near, float far, bool reverse_z) {
  float range = far - near;
  if (!(z <= kFloatMax)) return reverse_z ? -near / range : far / range;
  // The products of differences keep full relative precision near either plane (where reverse-Z
  // depths approach 0, a form like far / z - 1 would cancel).
  float num = reverse_z ? near * (far - z) : far * (z - near);
  float den = z * range;
  if (abs(num) <= kFloatMax && den <= kFloatMax) return num / den;
  // A z so large that a product overflows (from about 1e36 when range > 1: inf / inf was NaN):
  // the same value as a product of ratios, which cannot overflow (two divisions: < 8 * 2^-23).
  return reverse_z ? (near / range) * ((far - z) / z) : (far / range) * ((z - near) / z);
}

// The depth of a point at positive view distance z under an infinite-far projection (the inverse
// of linearize_depth_infinite): reverse near / z, standard 1 - near / z; z = +infinity (and
// NaN) gives the far plane's depth exactly (0 reverse, 1 standard), z = 0 an infinity.
float view_distance_to_depth_infinite(float z, float near, bool reverse_z) {
  float q = z <= kFloatMax ? near / z : 0.0;
  return reverse_z ? q : 1.0 - q;
}

// Normalized device coordinates (x, y in [-1, 1], y = -1 at the top) to texture coordinates
// (uv = (0, 0) top-left). Within 1 ULP (the multiply by 0.5 is exact).
vec2 ndc_to_uv(vec2 ndc) {
  return ndc * 0.5 + 0.5;
}

// Texture coordinates (uv = (0, 0) top-left) to normalized device coordinates (y = -1 at the
// top). Within 1 ULP (the multiply by 2 is exact).
vec2 uv_to_ndc(vec2 uv) {
  return uv * 2.0 - 1.0;
}

// The view-space position seen at texture coordinate uv with depth d, through the inverse of the
// projection matrix (any projection: reverse- or standard-Z, finite or infinite far, the y flip
// included in the matrix). The product is written as columns times scalars (the SPIR-V
// operations with specified precision). A point on an infinite far plane (w = 0) has no finite
// position; use view_position_from_view_distance there. Under standard-Z the homogeneous w
// cancels towards the far plane (relative error ~ z / near ULPs); reverse-Z avoids that.
vec3 view_position_from_depth(vec2 uv, float d, mat4 inv_proj) {
  vec2 ndc = uv_to_ndc(uv);
  vec4 h = inv_proj[0] * ndc.x + inv_proj[1] * ndc.y + inv_proj[2] * d + inv_proj[3];
  return h.xyz / h.w;
}

// The view-space position seen at texture coordinate uv at positive view distance z, for a
// symmetric perspective projection with vertical half-angle tan_half_fov_y = tan(fovy / 2) and
// aspect = width / height, y flipped for Vulkan (view +Y is the top of the image, uv.y = 0):
// (ndc.x * aspect * t * z, -ndc.y * t * z, -z). Pair with linearize_depth(_infinite) to
// reconstruct from a depth buffer without the inverse-matrix round trip. Relative error
// < 4 * 2^-23 per component for these inputs.
vec3 view_position_from_view_distance(vec2 uv, float z, float tan_half_fov_y, float aspect) {
  vec2 ndc = uv_to_ndc(uv);
  vec2 tangent = vec2(ndc.x * (aspect * tan_half_fov_y), -ndc.y * tan_half_fov_y);
  return vec3(tangent * z, -z);
}

// The world-space position of a view-space position, given the inverse view (camera-to-world)
// matrix, an affine transform (its last row is (0, 0, 0, 1)). Columns times scalars, as above.
vec3 world_position_from_view(vec3 view_position, mat4 inv_view) {
  return inv_view[0].xyz * view_position.x + inv_view[1].xyz * view_position.y +
         inv_view[2].xyz * view_position.z + inv_view[3].xyz;
}

// Returns where the ray from eye through `through` meets the plane through p with normal n (need
// not be unit), for a screen-space footprint: with `through` a neighbouring pixel's point, the
// difference from p is how far the surface moves across one pixel (a compute pass has no
// derivatives). The move is capped at max_stretch times |through - p|: a ray that grazes the
// plane, runs parallel to it or meets it behind the eye gives the capped move along its own
// direction from p instead of an unbounded one. max_stretch >= 1.
vec3 ray_plane_point(vec3 eye, vec3 through, vec3 p, vec3 n, float max_stretch) {
  vec3 dir = through - eye;
  vec3 step = through - p;
  float cap = max_stretch * length(step);
  float denom = dot(dir, n);
  float t = dot(p - eye, n) / denom;  // t = 1 at `through`
  vec3 hit = eye + dir * t;
  vec3 move = hit - p;
  float moved = length(move);
  if (!(t > 0.0) || !(moved <= cap)) {  // behind the eye, parallel (inf / NaN) or too far
    float len = length(dir);
    return len > 0.0 ? p + dir * (cap / len) : p;
  }
  return hit;
}

#endif  // PENUMBRA_DEPTH_GLSL
