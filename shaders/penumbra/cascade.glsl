// Cascade (CSM) and clipmap-level selection, cascade blending, distance fade, and world ->
// shadow-map coordinates for orthographic (directional) and perspective (spot) light projections.
// Every function is pure: parameters and resources come in as arguments. No #version here:
// include this from a stage file.
//
// Conventions (they match include/penumbra/shadow/gpu_types.hpp and shadow_types.glsl):
// - View depth is the positive distance along the camera's forward axis,
//   dot(p - camera_position, camera_forward).
// - Split distances are passed as `vec4 splits[2]`, exactly ShadowGpu.splits: the far view
//   distance of cascade i is splits[i / 4][i % 4], non-decreasing over [0, count); entries at and
//   after count are never read. Functions for 1..4 cascades also take a single vec4.
// - Cascade i owns the depths (far of i - 1, far of i]: a depth exactly at a split belongs to the
//   nearer cascade. Cascade 0 also owns every depth below its far split (0, negative, -Inf).
// - Selection returns `count` for "in no cascade" (beyond the last split, NaN depth, contained in
//   no level); callers treat it as lit (and fade towards it, see shadow_distance_fade).
// - count is clamped to [0, kCascadeMaxCount], so a result is always in [0, count].
// - Shadow-map coordinates are vec3(uv, depth) with uv = ndc.xy * 0.5 + 0.5 (no Y flip) and
//   depth = ndc.z (either depth convention; the projection decides). Vulkan's viewport maps NDC
//   y = -1 to framebuffer row 0 (y grows downward) and texture coordinate v = 0 addresses row 0,
//   so this uv samples exactly the texel the shadow pass rasterized at that NDC position; the
//   same holds for x. A point with clip w < FLT_MIN (behind a perspective light, at it, or a
//   denormal w) or with a non-finite coordinate maps to kShadowCoordOutside, which no bounds
//   test accepts.

#ifndef PENUMBRA_CASCADE_GLSL
#define PENUMBRA_CASCADE_GLSL

#include "penumbra/finite.glsl"

// The most cascades or clipmap levels of one light (kMaxCascades on the C++ side).
const int kCascadeMaxCount = 8;

// Smallest normal float. A clip w below it (zero, a denormal the GPU may flush, negative) is
// "at or behind the light"; a blend or fade band narrower than it is "no band" (a hard switch),
// so a GPU that flushes denormals decides the same way as one that keeps them.
const float kCascadeMinNormal = 1.175494351e-38;

// Vulkan guarantees the 2.5 ULP accuracy of x / y only for |y| in [2^-126, 2^126] (a GPU may
// divide by multiplying with a reciprocal, which flushes to 0 beyond). Divisors above this,
// 2^100, are first scaled by 2^-64 together with their dividends (exact: a power of two).
const float kCascadeLargeDivisor = 1.2676506e30;

// What world_to_shadow_coord returns for a point with no valid shadow-map position.
const vec3 kShadowCoordOutside = vec3(-1.0);

// Returns the far split distance of cascade i (0 <= i < 8) from splits[2].
float cascade_split(vec4 splits[2], int i) {
  return splits[i >> 2][i & 3];
}

// Returns the same from the two vec4 of splits[2]: first = splits[0] (cascades 0-3), second =
// splits[1] (4-7). The functions below take the splits in this form too: a caller reading them
// from a uniform block passes its two members, and the driver sees no array copied by value and
// indexed at run time. llvmpipe lowers such a copy into a local array on every lane; passing the
// sun resolve's splits that way cost about 50 ms of LLVM on each new version of the resolve
// (docs/hot-reload.md).
float cascade_split(vec4 first, vec4 second, int i) {
  vec4 four = i < 4 ? first : second;
  return four[i & 3];
}

// Returns the first cascade in [0, count) whose far split is >= view_depth (a depth exactly at a
// split belongs to the nearer cascade), or count when view_depth is beyond the last split or NaN.
// count is clamped to [0, 8].
int select_cascade_by_depth(float view_depth, vec4 first, vec4 second, int count) {
  int n = clamp(count, 0, kCascadeMaxCount);
  if (penumbra_is_nan(view_depth)) return n;
  for (int i = 0; i < n; ++i) {
    if (view_depth <= cascade_split(first, second, i)) return i;
  }
  return n;
}
int select_cascade_by_depth(float view_depth, vec4 splits[2], int count) {
  return select_cascade_by_depth(view_depth, splits[0], splits[1], count);
}

// Returns the same as above for 1..4 cascades whose far splits are splits.x .. splits.w; count is
// clamped to [0, 4].
int select_cascade_by_depth(float view_depth, vec4 splits, int count) {
  int n = clamp(count, 0, 4);
  if (penumbra_is_nan(view_depth)) return n;
  for (int i = 0; i < n; ++i) {
    if (view_depth <= splits[i]) return i;
  }
  return n;
}

// Returns a ramp that is 0 up to end - width, rises linearly to exactly 1 at end, and stays 1
// beyond; a hard step (1 only where x > end) when width < FLT_MIN (zero, negative, denormal) or
// end/width is not finite (so no division by zero, and no smoothstep with equal edges). x must
// not be NaN.
float cascade_end_ramp(float x, float end, float width) {
  if (!(width >= kCascadeMinNormal) || !penumbra_is_finite(width) || !penumbra_is_finite(end)) {
    return x > end ? 1.0 : 0.0;
  }
  if (x >= end) return 1.0;
  // Far before the band (and -Inf) without arithmetic on infinities. Not `x <= end - width`:
  // end - width rounds by up to half an ULP of end, which can be many ULPs of the ramp.
  if (!(x > end - 2.0 * width)) return 0.0;
  if (width > kCascadeLargeDivisor) {
    x = ldexp(x, -64);
    end = ldexp(end, -64);
    width = ldexp(width, -64);
  }
  // 1 - (distance to the end in band widths): end - x is exact near the end (Sterbenz), and the
  // result is exactly 1 at the end, where the next cascade takes over, so the blend is
  // continuous across the split.
  return clamp(1.0 - (end - x) / width, 0.0, 1.0);
}

// Returns the weight in [0, 1] of the next cascade at view_depth for a cascade covering
// [cascade_near, cascade_far]: 0 before the blend band, which is the last band_fraction (clamped
// to [0, 1]) of the cascade's range, rising linearly to 1 at cascade_far and staying 1 beyond.
// band_fraction 0 (or a band narrower than FLT_MIN, an empty range) gives a hard switch: 0 up
// to and including cascade_far, 1 beyond. A NaN depth gives 0. The ramp is linear; for an eased
// one apply smoothstep(0.0, 1.0, weight) (distinct edges, so always defined).
float cascade_blend_weight(float view_depth, float cascade_near, float cascade_far,
                           float band_fraction) {
  if (penumbra_is_nan(view_depth)) return 0.0;
  float fraction = band_fraction > 0.0 ? min(band_fraction, 1.0) : 0.0;
  return cascade_end_ramp(view_depth, cascade_far, fraction * (cascade_far - cascade_near));
}

// Returns the weight in [0, 1] of cascade `cascade + 1` when shading at view_depth with cascade
// `cascade` (as chosen by select_cascade_by_depth): cascade_blend_weight over the cascade's range,
// whose near end is camera_near for cascade 0 and the previous split otherwise. 0 for the last
// cascade (the distance fade takes over there) and for a cascade index outside [0, count - 1).
// Blended visibility: mix(visibility[cascade], visibility[cascade + 1], weight).
float cascade_blend_to_next(float view_depth, vec4 first, vec4 second, int cascade, int count,
                            float camera_near, float band_fraction) {
  int n = clamp(count, 0, kCascadeMaxCount);
  if (cascade < 0 || cascade >= n - 1) return 0.0;
  float near = cascade == 0 ? camera_near : cascade_split(first, second, cascade - 1);
  return cascade_blend_weight(view_depth, near, cascade_split(first, second, cascade),
                              band_fraction);
}
float cascade_blend_to_next(float view_depth, vec4 splits[2], int cascade, int count,
                            float camera_near, float band_fraction) {
  return cascade_blend_to_next(view_depth, splits[0], splits[1], cascade, count, camera_near,
                               band_fraction);
}

// Returns how far shadows have faded to lit at view_depth, in [0, 1]: 0 (full shadow) up to
// max_distance * (1 - fade_fraction), rising linearly to 1 (lit) at max_distance and beyond.
// fade_fraction is clamped to [0, 1]; 0 (or a band narrower than FLT_MIN) gives a hard cut: 1
// only beyond max_distance, so a depth exactly at max_distance, which selection gives to the
// last cascade, stays shadowed. A NaN depth gives 1. Faded visibility: mix(visibility, 1.0, fade).
float shadow_distance_fade(float view_depth, float max_distance, float fade_fraction) {
  if (penumbra_is_nan(view_depth)) return 1.0;
  float fraction = fade_fraction > 0.0 ? min(fade_fraction, 1.0) : 0.0;
  return cascade_end_ramp(view_depth, max_distance, fraction * max_distance);
}

// Returns vec3(uv, depth) of position in the shadow map of light_view_proj (orthographic or
// perspective; clip = light_view_proj * vec4(position, 1)): uv = ndc.xy * 0.5 + 0.5, depth =
// ndc.z after the perspective divide. kShadowCoordOutside when clip w < FLT_MIN (behind or at a
// perspective light) or when any result would be NaN or infinite.
vec3 world_to_shadow_coord(mat4 light_view_proj, vec3 position) {
  vec4 clip = light_view_proj * vec4(position, 1.0);
  if (!(clip.w >= kCascadeMinNormal) || !penumbra_is_finite(clip.w)) return kShadowCoordOutside;
  if (clip.w > kCascadeLargeDivisor) clip = ldexp(clip, ivec4(-64));
  vec3 ndc = clip.xyz / clip.w;
  vec3 coord = vec3(ndc.xy * 0.5 + 0.5, ndc.z);
  if (!penumbra_is_finite(coord.x) || !penumbra_is_finite(coord.y) || !penumbra_is_finite(coord.z)) {
    return kShadowCoordOutside;
  }
  return coord;
}

// Returns true when coord (uv, depth) lies in a shadow map of resolution x resolution texels
// with at least border_texels texels to spare on each side (uv * resolution and
// (1 - uv) * resolution both >= border_texels; bounds inclusive) and depth in [0, 1]; false for
// non-finite components. resolution > 0.
bool shadow_coord_in_bounds(vec3 coord, float border_texels, float resolution) {
  if (!penumbra_is_finite(coord.x) || !penumbra_is_finite(coord.y) || !penumbra_is_finite(coord.z)) {
    return false;
  }
  // Texels to the near and far edges; no division, so the test is exact for texel-aligned uvs.
  vec2 to_low = coord.xy * resolution;
  vec2 to_high = (1.0 - coord.xy) * resolution;
  return all(greaterThanEqual(to_low, vec2(border_texels))) &&
         all(greaterThanEqual(to_high, vec2(border_texels))) && coord.z >= 0.0 && coord.z <= 1.0;
}

// Returns the finest (first) level in [0, count) whose shadow-map coordinate coords[i] passes
// shadow_coord_in_bounds, or count when none does. count is clamped to [0, 8].
int select_cascade_by_containment(vec3 coords[8], int count, float border_texels,
                                  float resolution) {
  int n = clamp(count, 0, kCascadeMaxCount);
  for (int i = 0; i < n; ++i) {
    if (shadow_coord_in_bounds(coords[i], border_texels, resolution)) return i;
  }
  return n;
}

// Returns the finest (first) level in [0, count) whose light view-projection contains position
// (world_to_shadow_coord, then shadow_coord_in_bounds), or count when none does; coord receives
// that level's shadow-map coordinate (kShadowCoordOutside when none). count is clamped to [0, 8].
// Cost: a caller that fills a local mat4[8] per pixel pays for it in the driver's compiler
// (llvmpipe lowers the dynamic index into selects: ~2 s of LLVM per new shader version). A stage
// whose matrices sit in a uniform block is better served by the same loop over the block
// (render/shadow_resolve.comp does that).
int select_cascade_by_position(vec3 position, mat4 view_proj[8], int count, float border_texels,
                               float resolution, out vec3 coord) {
  int n = clamp(count, 0, kCascadeMaxCount);
  for (int i = 0; i < n; ++i) {
    vec3 c = world_to_shadow_coord(view_proj[i], position);
    if (shadow_coord_in_bounds(c, border_texels, resolution)) {
      coord = c;
      return i;
    }
  }
  coord = kShadowCoordOutside;
  return n;
}

// Returns the same level as above, without its coordinate.
int select_cascade_by_position(vec3 position, mat4 view_proj[8], int count, float border_texels,
                               float resolution) {
  vec3 unused;
  return select_cascade_by_position(position, view_proj, count, border_texels, resolution, unused);
}

#endif  // PENUMBRA_CASCADE_GLSL
