// Percentage-closer filtering (PCF) with hardware 2x2 compare taps: a box-filtered texel grid
// (radius 0..5, i.e. 1x1 .. 11x11 texels) and rotated Poisson / Vogel disk kernels, each for a
// sampler2DShadow and a sampler2DArrayShadow (one layer per cascade). Every function is pure:
// the map, its texel size and every parameter come in as arguments. No #version here: include
// this from a stage file.
//
// Conventions
// - coord = vec3(uv, receiver depth) in shadow-map space: uv in [0, 1] with texel i covering
//   [i, i + 1] * texel_size (centre at (i + 0.5) * texel_size); texel_size = 1 / resolution.
// - Results are shadow factors: 1 = lit, 0 = fully shadowed.
// - The depth comparison is the compare sampler's own: create it with
//   VK_COMPARE_OP_GREATER_OR_EQUAL under reverse-Z (the default: near = 1, lit when the receiver
//   is at least as close to the light as the stored depth) or VK_COMPARE_OP_LESS_OR_EQUAL under
//   standard depth, linear filtering (one texture() call is then a bilinear 2x2 compare tap:
//   compare each texel, then filter) and clamp-to-edge addressing.
// - The receiver depth is clamped to [0, 1] before comparing (what a fixed-point depth format
//   does anyway), so depths beyond the planes behave alike on every implementation.
// - A coord with a NaN or infinite component, or with uv outside [0, 1], is lit (1.0): the point
//   lies outside this map. The test is on the bits, so no fast-math assumption can drop it. (A
//   denormal just below 0 may be flushed to -0 by the device and then counts as inside.)
// - Taps near the map's edge read the edge texels (clamp to edge).
// - Windowed lookups (the _array functions' `window` overloads): the map is an N x N window of a
//   toroidal image of the same size, sampled in place with repeat addressing: map texel t is
//   image texel (t + o) mod N. window = vec4(o, 1, 0), o whole texels in [0, N); window.z = 0 is
//   the map itself. Each tap's uv is clamped to the edge texels' centres, then moved by o, so a
//   tap reads what clamp-to-edge addressing of the map would (a bilinear tap at an edge texel's
//   centre weighs its neighbour by 0).

#ifndef PENUMBRA_PCF_GLSL
#define PENUMBRA_PCF_GLSL

#include "penumbra/finite.glsl"

#include "penumbra/noise.glsl"

// Largest grid radius: radius 5 filters an 11x11-texel box.
const int kPcfMaxRadius = 5;
// Largest tap counts of the disk kernels (the Poisson table has 32 entries).
const int kPcfMaxPoissonTaps = 32;
const int kPcfMaxVogelTaps = 64;

// Returns true when coord (uv, depth) is finite and its uv lies inside [0, 1]^2; the filters
// treat every other coord as lit.
bool pcf_coord_in_map(vec3 coord) {
  bool finite = penumbra_is_finite(coord.x) && penumbra_is_finite(coord.y) && penumbra_is_finite(coord.z);
  return finite && coord.x >= 0.0 && coord.x <= 1.0 && coord.y >= 0.0 && coord.y <= 1.0;
}

// Returns v clamped to [0, 1], or 1 (lit) when v is NaN or infinite: the last step of every
// filter, so that no input (a zero texel size, say) can turn into a NaN shadow factor.
float pcf_saturate_or_lit(float v) {
  return penumbra_is_finite(v) ? clamp(v, 0.0, 1.0) : 1.0;
}

// Returns the uv to sample for map uv through `window` (see the conventions above): uv itself
// when window.z is 0.
vec2 pcf_window_uv(vec2 uv, vec4 window, vec2 texel_size) {
  if (window.z == 0.0) return uv;
  return clamp(uv, 0.5 * texel_size, 1.0 - 0.5 * texel_size) + window.xy * texel_size;
}

// Returns the grid radius clamped to [0, kPcfMaxRadius].
int pcf_clamp_radius(int radius) {
  return clamp(radius, 0, kPcfMaxRadius);
}

// Returns (offset, weight) of tap `pair` (0..radius) of the 1D box kernel, per axis.
//
// The box grid filter is exact box filtering of the nearest-texel compare function: the result
// is the lit fraction of the (2r+1) x (2r+1)-texel square centred at uv, every texel counting as
// a constant square. Along one axis, with f = uv / texel_size - 0.5 (texel-centre coordinates),
// x0 = floor(f) and a = f - x0, the square overlaps texels x0 - r .. x0 + r + 1 with weights
// 1 - a, 1, ..., 1, a (sum 2r + 1). Neighbouring texels are paired, (x0 - r + 2j, x0 - r + 2j + 1)
// for j = 0..r, and each pair is one bilinear tap placed at the fraction w_hi / (w_lo + w_hi)
// between their centres with weight w_lo + w_hi: r + 1 taps per axis, (r + 1)^2 compare taps in
// all (radius 0: one tap at uv itself). offset is the tap's texel-centre coordinate minus x0 - r.
vec2 pcf_box_pair(int pair, int radius, float a) {
  float w_lo = (pair == 0) ? 1.0 - a : 1.0;
  float w_hi = (pair == radius) ? a : 1.0;
  float w = w_lo + w_hi;
  return vec2(float(2 * pair) + w_hi / w, w);
}

// Returns the box-grid PCF shadow factor: the lit fraction of the (2r+1) x (2r+1)-texel square
// centred at coord.xy (r = radius clamped to 0..5), from (r+1)^2 bilinear compare taps.
float pcf_grid(sampler2DShadow map, vec3 coord, int radius, vec2 texel_size) {
  if (!pcf_coord_in_map(coord)) return 1.0;
  int r = pcf_clamp_radius(radius);
  float depth = clamp(coord.z, 0.0, 1.0);
  vec2 f = coord.xy / texel_size - 0.5;
  vec2 x0 = floor(f);
  vec2 a = f - x0;
  vec2 origin = x0 - float(r) + 0.5;  // + 0.5: texel-centre coordinate -> texel-space position
  float sum = 0.0;
  for (int j = 0; j <= r; ++j) {
    vec2 ty = pcf_box_pair(j, r, a.y);
    for (int i = 0; i <= r; ++i) {
      vec2 tx = pcf_box_pair(i, r, a.x);
      vec2 uv = (origin + vec2(tx.x, ty.x)) * texel_size;
      sum += tx.y * ty.y * texture(map, vec3(uv, depth));
    }
  }
  float n = float(2 * r + 1);
  return pcf_saturate_or_lit(sum / (n * n));
}

// Returns the box-grid PCF shadow factor of pcf_grid in layer `layer` of an array map (one
// cascade per layer), read through `window` (see the conventions above).
float pcf_grid_array(sampler2DArrayShadow map, vec3 coord, int layer, int radius, vec2 texel_size,
                     vec4 window) {
  if (!pcf_coord_in_map(coord)) return 1.0;
  int r = pcf_clamp_radius(radius);
  float depth = clamp(coord.z, 0.0, 1.0);
  vec2 f = coord.xy / texel_size - 0.5;
  vec2 x0 = floor(f);
  vec2 a = f - x0;
  vec2 origin = x0 - float(r) + 0.5;
  float sum = 0.0;
  for (int j = 0; j <= r; ++j) {
    vec2 ty = pcf_box_pair(j, r, a.y);
    for (int i = 0; i <= r; ++i) {
      vec2 tx = pcf_box_pair(i, r, a.x);
      vec2 uv = pcf_window_uv((origin + vec2(tx.x, ty.x)) * texel_size, window, texel_size);
      sum += tx.y * ty.y * texture(map, vec4(uv, float(layer), depth));
    }
  }
  float n = float(2 * r + 1);
  return pcf_saturate_or_lit(sum / (n * n));
}

// Returns pcf_grid_array of the map itself.
float pcf_grid_array(sampler2DArrayShadow map, vec3 coord, int layer, int radius, vec2 texel_size) {
  return pcf_grid_array(map, coord, layer, radius, texel_size, vec4(0.0));
}

// Returns radius_texels made safe for tap offsets: negative or non-finite radii count as 0.
float pcf_safe_radius(float radius_texels) {
  return penumbra_is_finite(radius_texels) ? max(radius_texels, 0.0) : 0.0;
}

// Returns (cos, sin) of a rotation angle; a non-finite angle counts as 0.
vec2 pcf_rotation_cos_sin(float rotation) {
  return rotate2(vec2(1.0, 0.0), penumbra_is_finite(rotation) ? rotation : 0.0);
}

// Returns the uv offset of Poisson tap `index`: kPoissonDisk32[index] rotated by the angle whose
// (cos, sin) is cos_sin, times radius_texels texels.
vec2 pcf_poisson_offset(int index, vec2 cos_sin, float radius_texels, vec2 texel_size) {
  return rotate2_cos_sin(poisson_disk_sample(index), cos_sin) * radius_texels * texel_size;
}

// Returns the rotated Poisson-disk PCF shadow factor: the mean of tap_count (clamped to 1..32)
// bilinear compare taps at coord.xy + rotate(kPoissonDisk32[i], rotation) * radius_texels
// texels. rotation is in radians (e.g. 2 pi * interleaved_gradient_noise(pixel)); a negative or
// non-finite radius counts as 0 and a non-finite rotation as 0.
float pcf_poisson(sampler2DShadow map, vec3 coord, int tap_count, float radius_texels,
                  float rotation, vec2 texel_size) {
  if (!pcf_coord_in_map(coord)) return 1.0;
  int n = clamp(tap_count, 1, kPcfMaxPoissonTaps);
  float depth = clamp(coord.z, 0.0, 1.0);
  float radius = pcf_safe_radius(radius_texels);
  vec2 cos_sin = pcf_rotation_cos_sin(rotation);
  float sum = 0.0;
  for (int i = 0; i < n; ++i) {
    vec2 uv = coord.xy + pcf_poisson_offset(i, cos_sin, radius, texel_size);
    sum += texture(map, vec3(uv, depth));
  }
  return pcf_saturate_or_lit(sum / float(n));
}

// Returns the shadow factor of pcf_poisson in layer `layer` of an array map, read through
// `window` (see the conventions above).
float pcf_poisson_array(sampler2DArrayShadow map, vec3 coord, int layer, int tap_count,
                        float radius_texels, float rotation, vec2 texel_size, vec4 window) {
  if (!pcf_coord_in_map(coord)) return 1.0;
  int n = clamp(tap_count, 1, kPcfMaxPoissonTaps);
  float depth = clamp(coord.z, 0.0, 1.0);
  float radius = pcf_safe_radius(radius_texels);
  vec2 cos_sin = pcf_rotation_cos_sin(rotation);
  float sum = 0.0;
  for (int i = 0; i < n; ++i) {
    vec2 uv = coord.xy + pcf_poisson_offset(i, cos_sin, radius, texel_size);
    sum += texture(map, vec4(pcf_window_uv(uv, window, texel_size), float(layer), depth));
  }
  return pcf_saturate_or_lit(sum / float(n));
}

// Returns pcf_poisson_array of the map itself.
float pcf_poisson_array(sampler2DArrayShadow map, vec3 coord, int layer, int tap_count,
                        float radius_texels, float rotation, vec2 texel_size) {
  return pcf_poisson_array(map, coord, layer, tap_count, radius_texels, rotation, texel_size,
                           vec4(0.0));
}

// Returns the Vogel-disk PCF shadow factor: the mean of tap_count (clamped to 1..64) bilinear
// compare taps at coord.xy + vogel_disk_sample(i, n, rotation) * radius_texels texels. The
// Vogel spiral covers the disk with uniform density, so this approximates a uniformly weighted
// disk kernel of that radius (convolved with the taps' one-texel bilinear tent). Used by PCSS
// for its variable radius; negative or non-finite radius and rotation as in pcf_poisson.
float pcf_vogel(sampler2DShadow map, vec3 coord, int tap_count, float radius_texels, float rotation,
                vec2 texel_size) {
  if (!pcf_coord_in_map(coord)) return 1.0;
  int n = clamp(tap_count, 1, kPcfMaxVogelTaps);
  float depth = clamp(coord.z, 0.0, 1.0);
  float radius = pcf_safe_radius(radius_texels);
  float angle = penumbra_is_finite(rotation) ? rotation : 0.0;
  float sum = 0.0;
  for (int i = 0; i < n; ++i) {
    vec2 uv = coord.xy + vogel_disk_sample(i, n, angle) * radius * texel_size;
    sum += texture(map, vec3(uv, depth));
  }
  return pcf_saturate_or_lit(sum / float(n));
}

// Returns the shadow factor of pcf_vogel in layer `layer` of an array map, read through
// `window` (see the conventions above).
float pcf_vogel_array(sampler2DArrayShadow map, vec3 coord, int layer, int tap_count,
                      float radius_texels, float rotation, vec2 texel_size, vec4 window) {
  if (!pcf_coord_in_map(coord)) return 1.0;
  int n = clamp(tap_count, 1, kPcfMaxVogelTaps);
  float depth = clamp(coord.z, 0.0, 1.0);
  float radius = pcf_safe_radius(radius_texels);
  float angle = penumbra_is_finite(rotation) ? rotation : 0.0;
  float sum = 0.0;
  for (int i = 0; i < n; ++i) {
    vec2 uv = coord.xy + vogel_disk_sample(i, n, angle) * radius * texel_size;
    sum += texture(map, vec4(pcf_window_uv(uv, window, texel_size), float(layer), depth));
  }
  return pcf_saturate_or_lit(sum / float(n));
}

// Returns pcf_vogel_array of the map itself.
float pcf_vogel_array(sampler2DArrayShadow map, vec3 coord, int layer, int tap_count,
                      float radius_texels, float rotation, vec2 texel_size) {
  return pcf_vogel_array(map, coord, layer, tap_count, radius_texels, rotation, texel_size,
                         vec4(0.0));
}

#endif  // PENUMBRA_PCF_GLSL
