// Shadow-map biases: normal offset (world space), slope-scaled depth bias, receiver-plane depth
// bias from screen-space gradients passed in as arguments (Isidoro 2006), and applying a depth
// bias in either depth convention. Every function is pure. No #version here: include this from a
// stage file.
//
// Conventions:
// - `normal` need not be unit length; `to_light` is the direction *towards* the light (for a
//   directional light ShadowGpu.light_dir_angular.xyz), need not be unit length either.
// - theta is the angle between the normal and the light direction, cos(theta) = N.L. Back faces
//   (N.L <= 0) are treated as grazing (theta = 90 degrees): the largest normal offset, and the
//   maximum slope-scaled bias.
// - Depth biases are positive amounts that move the receiver *towards the light*;
//   apply_depth_bias turns one into a depth in either convention (reverse-Z: near = 1).

#ifndef PENUMBRA_BIAS_GLSL
#define PENUMBRA_BIAS_GLSL

#include "penumbra/finite.glsl"

// Smallest normal float. A squared vector length below it (zero, or a denormal the GPU may flush
// to zero) makes the vector degenerate; an N.L below it makes tan(theta) unbounded.
const float kBiasMinNormal = 1.175494351e-38;

// A uv Jacobian whose determinant is within this fraction of its two products
// (|det| <= kReceiverPlaneMinDet * (|du/dx dv/dy| + |du/dy dv/dx|)) is treated as singular: the
// screen-space footprint is edge-on in the shadow map and the plane's gradient is meaningless.
// At this threshold, rounding in the determinant (a few float ULPs of the products) changes the
// gradient by at most ~0.1%.
const float kReceiverPlaneMinDet = 1.0e-4;

// Vulkan guarantees the 2.5 ULP accuracy of x / y only for |y| in [2^-126, 2^126] (a GPU may
// divide by multiplying with a reciprocal, which flushes to 0 beyond). Divisors above this,
// 2^100, are first scaled by 2^-64 together with their dividends (exact: a power of two).
const float kBiasLargeDivisor = 1.2676506e30;

// Returns v scaled by a power of two (exactly, with ldexp) so that its largest component's
// magnitude lies in [0.5, 1), or vec3(0) when v is degenerate: a NaN or infinite component, or
// every component below FLT_MIN in magnitude (zero or denormal, which a GPU may flush). Any other
// length, 1e-30 or 1e30, then normalizes without its squared length under- or overflowing.
vec3 bias_rescaled(vec3 v) {
  if (!penumbra_is_finite(v.x) || !penumbra_is_finite(v.y) || !penumbra_is_finite(v.z))
    return vec3(0.0);
  vec3 a = abs(v);
  float m = max(max(a.x, a.y), a.z);
  if (!(m >= kBiasMinNormal)) return vec3(0.0);
  int e;
  frexp(m, e);
  return ldexp(v, ivec3(-e));
}

// Returns sin(theta) in [0, 1] between normal and to_light: |N x L| for unit N, L when N.L > 0,
// and 1 (grazing) when N.L <= 0, when to_light is degenerate (bias_rescaled: non-finite, or zero
// or denormal in every component) and when normal is degenerate (the offset along a degenerate
// normal is zero anyway). Both vectors may have any other length.
float normal_offset_scale(vec3 normal, vec3 to_light) {
  vec3 rn = bias_rescaled(normal);
  vec3 rl = bias_rescaled(to_light);
  // Rescaled, a usable vector's squared length is in [0.25, 3).
  float nn = dot(rn, rn);
  float ll = dot(rl, rl);
  if (!(nn > 0.0) || !(ll > 0.0)) return 1.0;
  vec3 n = rn * inversesqrt(nn);
  vec3 l = rl * inversesqrt(ll);
  if (!(dot(n, l) > 0.0)) return 1.0;
  // |N x L| rather than sqrt(1 - (N.L)^2): accurate near theta = 0, where N.L rounds to 1.
  // sqrt is 1 / inversesqrt in Vulkan, and inversesqrt(0) is undefined: 0 is handled apart.
  vec3 c = cross(n, l);
  float cc = dot(c, c);
  return cc > 0.0 ? min(sqrt(cc), 1.0) : 0.0;
}

// Returns the world-space offset to add to a receiver's position before projecting it into the
// shadow map: normalize(normal) * offset_texels * texel_world_size * sin(theta), theta the angle
// to the light (normal_offset_scale: 0 facing the light, the full offset at grazing angles and on
// back faces; finite at N.L = 0). The normal may have any finite length (1e-30 and 1e30 alike);
// vec3(0) for a degenerate normal (bias_rescaled: non-finite, or zero or denormal in every
// component). texel_world_size is the cascade's CascadeGpu.params.x.
vec3 normal_offset(vec3 normal, vec3 to_light, float texel_world_size, float offset_texels) {
  vec3 rn = bias_rescaled(normal);
  float nn = dot(rn, rn);
  if (!(nn > 0.0)) return vec3(0.0);
  float distance = offset_texels * texel_world_size * normal_offset_scale(normal, to_light);
  return rn * (inversesqrt(nn) * distance);
}

// Returns the normal offset, in texels, for a filter whose taps reach reach_texels from the
// receiver's own texel: base_texels (shadows.normal_offset_texels, chosen for filters that reach
// one texel: hard and PCF up to radius 1) plus the reach beyond that one texel. Moved off its
// surface by k texels (normal_offset), a receiver lies k * texel * tan(theta) in front of its own
// plane along the light, and the plane's depth changes by d * texel * tan(theta) across d
// texels: with k >= d the plane stays behind every tap at any angle theta, so a wide kernel does
// not shadow its own receiver. NaN or negative parameters count as 0.
float filter_normal_offset_texels(float base_texels, float reach_texels) {
  float base = penumbra_is_nan(base_texels) ? 0.0 : max(base_texels, 0.0);
  float reach = penumbra_is_nan(reach_texels) ? 0.0 : max(reach_texels, 0.0);
  return base + max(reach - 1.0, 0.0);
}

// Returns min(constant_bias + slope_scale * tan(theta), max_bias) with cos(theta) = n_dot_l
// (clamped to at most 1); max_bias when n_dot_l <= 0 (back face or grazing), NaN, or below
// FLT_MIN, where tan(theta) is unbounded. Never NaN or infinite for finite parameters. The result
// is in the units of constant_bias and max_bias (depth units, or world units along the light).
float slope_scaled_bias(float n_dot_l, float constant_bias, float slope_scale, float max_bias) {
  if (penumbra_is_nan(n_dot_l) || !(n_dot_l >= kBiasMinNormal)) return max_bias;
  float c = min(n_dot_l, 1.0);  // also maps +Inf to 1
  // tan(acos(c)) = sqrt(1 - c^2) / c, with 1 - c^2 factored to stay accurate near c = 1. With
  // c >= FLT_MIN the quotient is at most 1 / FLT_MIN, finite; the product may overflow to +Inf,
  // which min() clamps to max_bias.
  float tan_theta = sqrt(max((1.0 - c) * (1.0 + c), 0.0)) / c;
  return min(constant_bias + slope_scale * tan_theta, max_bias);
}

// Returns (dz/du, dz/dv), the depth gradient of the receiver plane in shadow-map uv, from the
// screen-space derivatives of the receiver's shadow coordinate (u, v, depth) along screen x
// (coord_ddx) and y (coord_ddy) (Isidoro 2006, "Shadow Mapping: GPU-based Tips and Techniques"):
// with J = [du/dx du/dy; dv/dx dv/dy], (dz/du, dz/dv) = (dz/dx, dz/dy) J^-1. vec2(0) (no
// receiver-plane bias) when J is singular (see kReceiverPlaneMinDet), when its products
// du/dx dv/dy and du/dy dv/dx or its determinant underflow (< FLT_MIN) or overflow, when any input
// is not finite, or when the gradient overflows. The gradient is in the depth convention of the
// coords (no sign change is needed for reverse-Z).
vec2 receiver_plane_depth_gradient(vec3 coord_ddx, vec3 coord_ddy) {
  if (!penumbra_is_finite(coord_ddx) || !penumbra_is_finite(coord_ddy)) return vec2(0.0);
  float ad = coord_ddx.x * coord_ddy.y;  // du/dx * dv/dy
  float bc = coord_ddy.x * coord_ddx.y;  // du/dy * dv/dx
  float size = abs(ad) + abs(bc);
  // Products that underflow (denormal or zero: flushed on some GPUs, not on others) or overflow
  // carry no usable determinant.
  if (!(size >= kBiasMinNormal) || !penumbra_is_finite(size)) return vec2(0.0);
  float det = ad - bc;
  // A determinant below FLT_MIN is outside the divide's accurate range (and flushed by some GPUs).
  if (!(abs(det) > kReceiverPlaneMinDet * size) || !(abs(det) >= kBiasMinNormal)) {
    return vec2(0.0);
  }
  vec2 numerator = vec2(coord_ddy.y * coord_ddx.z - coord_ddx.y * coord_ddy.z,
                        coord_ddx.x * coord_ddy.z - coord_ddy.x * coord_ddx.z);
  if (abs(det) > kBiasLargeDivisor) {
    numerator = ldexp(numerator, ivec2(-64));
    det = ldexp(det, -64);
  }
  vec2 gradient = numerator / det;
  if (!penumbra_is_finite(gradient.x) || !penumbra_is_finite(gradient.y)) return vec2(0.0);
  return gradient;
}

// Returns the depth of the receiver plane at a filter tap offset by uv_offset from the centre,
// relative to the centre's depth: dot(gradient, uv_offset), gradient from
// receiver_plane_depth_gradient. Add it to the receiver's depth before comparing at that tap.
float receiver_plane_depth_offset(vec2 gradient, vec2 uv_offset) {
  return dot(gradient, uv_offset);
}

// Returns depth moved towards the light by bias (a positive amount in depth units): depth + bias
// under reverse-Z (near = 1, larger is closer), depth - bias under standard depth (near = 0).
// Not clamped: D32_SFLOAT compare references are not clamped to [0, 1] either.
float apply_depth_bias(float depth, float bias, bool reverse_z) {
  return reverse_z ? depth + bias : depth - bias;
}


// ---- Biases in world units -------------------------------------------------------------------
//
// A depth bias in depth-buffer units means a different world distance for every projection
// (orthographic cascades: linear in depth; perspective spot maps: growing with the square of the
// distance; cube maps storing linear distance). Penumbra's biases are world distances along the
// light ray instead, applied by moving the receiver towards the light before projecting it: the
// point stays on the same ray from the light (the same shadow-map uv under every projection),
// only its depth changes, by exactly bias_world metres. A blocker then shadows the receiver only
// when it is more than bias_world closer to the light, so a caster's shadow starts bias_world
// (measured along the light) from where the caster meets the receiver.

// Returns the depth bias in world units along the light ray: constant_world + slope_texels *
// texel_world * tan(theta) (cos(theta) = n_dot_l), at most constant_world + max_slope_texels *
// texel_world. A surface tilted by theta to the light changes its depth by texel_world *
// tan(theta) across one shadow-map texel of world size texel_world (the texel's footprint at the
// receiver), so slope_texels is in texels of that change. Back faces, N.L = 0 and NaN get the
// maximum (slope_scaled_bias). Negative or NaN parameters count as 0.
float world_depth_bias(float n_dot_l, float constant_world, float slope_texels,
                       float max_slope_texels, float texel_world) {
  float c = penumbra_is_nan(constant_world) ? 0.0 : max(constant_world, 0.0);
  float t = penumbra_is_nan(texel_world) ? 0.0 : max(texel_world, 0.0);
  float s = penumbra_is_nan(slope_texels) ? 0.0 : max(slope_texels, 0.0);
  float m = penumbra_is_nan(max_slope_texels) ? 0.0 : max(max_slope_texels, 0.0);
  return slope_scaled_bias(n_dot_l, c, s * t, c + m * t);
}

// Returns p moved towards the light by bias_world along to_light (the direction towards the
// light: for a directional light the light direction, for a spot or point light the direction
// from p to the light's position; need not be unit length). p itself for a degenerate to_light
// (zero, denormal length or non-finite), a bias <= 0 or NaN. The caller keeps bias_world below
// the distance to a local light.
vec3 bias_toward_light(vec3 p, vec3 to_light, float bias_world) {
  float ll = dot(to_light, to_light);
  if (!(ll >= kBiasMinNormal) || !penumbra_is_finite(ll) || !(bias_world > 0.0)) return p;
  return p + to_light * (inversesqrt(ll) * bias_world);
}

// Returns the world size of one texel of a perspective (spot) shadow map at a receiver at
// axial_distance along the light's axis: texel_at_unit_distance (SpotShadowGpu.params.z, the
// texel's size at distance 1) times that distance (0 behind the light or for NaN).
float perspective_texel_world_size(float texel_at_unit_distance, float axial_distance) {
  float d = penumbra_is_nan(axial_distance) ? 0.0 : max(axial_distance, 0.0);
  return texel_at_unit_distance * d;
}

// Returns the world size of one cube-map texel at a receiver at light_to_receiver from the
// light (need not be unit length): the face is chosen by the largest component m, where one
// face texel spans 2 m / resolution (its size on the face's axis; off-axis texels are seen
// obliquely and up to 1.7x larger, which the normal offset need not follow). 0 for NaN.
float cube_texel_world_size(vec3 light_to_receiver, float resolution) {
  vec3 a = abs(light_to_receiver);
  float m = max(max(a.x, a.y), a.z);
  return penumbra_is_nan(m) || !(resolution > 0.0) ? 0.0 : 2.0 * m / resolution;
}

#endif  // PENUMBRA_BIAS_GLSL
