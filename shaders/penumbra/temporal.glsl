// Temporal accumulation of a per-pixel signal (shadow visibility): the last frame's value at a
// surface point, reprojected through the depth buffer, is clamped to the range of this frame's
// neighbourhood and blended with this frame's value. Every function is pure. No #version here:
// include this from a stage file.
//
// Conventions
// - Pixel coordinates are centre coordinates: pixel (i, j) has its centre at (i, j); a point
//   with clip coordinates c lies at ((c.xy / c.w) * 0.5 + 0.5) * size - 0.5.
// - Normals are unit vectors, stored as two octahedral coordinates in [-1, 1].

#ifndef PENUMBRA_TEMPORAL_GLSL
#define PENUMBRA_TEMPORAL_GLSL

#include "penumbra/finite.glsl"

// Returns the octahedral coordinates of unit vector n (in [-1, 1]^2). A zero or non-finite n
// gives (0, 0) (decodes to +Z).
vec2 oct_encode(vec3 n) {
  float l1 = abs(n.x) + abs(n.y) + abs(n.z);
  if (!(l1 > 0.0) || !penumbra_is_finite(l1)) return vec2(0.0);
  vec2 p = n.xy / l1;
  if (n.z < 0.0) {
    vec2 s = vec2(p.x >= 0.0 ? 1.0 : -1.0, p.y >= 0.0 ? 1.0 : -1.0);
    p = (1.0 - abs(p.yx)) * s;
  }
  return p;
}

// Returns the unit vector of octahedral coordinates e (oct_encode's inverse).
vec3 oct_decode(vec2 e) {
  vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
  if (n.z < 0.0) {
    vec2 s = vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    n.xy = (1.0 - abs(n.yx)) * s;
  }
  return normalize(n);
}

// Returns the pixel-centre coordinates in an image of `size` pixels of the view-space point
// view_pos under projection `proj`; w of the result is 1 when the point lies in front of the
// camera, 0 otherwise (xy then 0).
vec3 temporal_reproject(mat4 proj, vec3 view_pos, vec2 size) {
  vec4 c = proj * vec4(view_pos, 1.0);
  if (!(c.w > 0.0) || !penumbra_is_finite(c.w)) return vec3(0.0);
  return vec3((c.xy / c.w * 0.5 + 0.5) * size - 0.5, 1.0);
}

// Returns true when a pixel of the last frame holds the surface a reprojected point lies on:
// its distance to the last frame's eye (stored_distance, > 0 for geometry) within
// fraction x expected_distance + constant of the point's, and its normal within the cosine
// min_cos of the point's (both in the last frame's view space).
bool temporal_same_surface(float stored_distance, vec3 stored_normal, float expected_distance,
                           vec3 expected_normal, float fraction, float constant, float min_cos) {
  if (!(stored_distance > 0.0)) return false;
  float tolerance = fraction * expected_distance + constant;
  return abs(stored_distance - expected_distance) <= tolerance &&
         dot(stored_normal, expected_normal) >= min_cos;
}

// Returns the accumulated value: history clamped to [lo, hi] (this frame's neighbourhood), then
// moved towards current by weight (the new frame's share, in (0, 1]). A weight outside (0, 1]
// or non-finite, or a non-finite history, gives current.
vec4 temporal_blend(vec4 history, vec4 current, vec4 lo, vec4 hi, float weight) {
  bool finite = penumbra_is_finite(history.x) && penumbra_is_finite(history.y) &&
                penumbra_is_finite(history.z) && penumbra_is_finite(history.w);
  if (!finite || !(weight > 0.0 && weight <= 1.0)) return current;
  return mix(min(max(history, lo), hi), current, weight);  // lo > hi: hi (clamp is undefined)
}

#endif
