// Variance shadow maps (VSM) and exponential variance shadow maps (EVSM2 with the positive warp,
// EVSM4 with positive and negative warps): moments to store, the Chebyshev upper bound with a
// minimum variance, light-bleed reduction, and exponent limits per moment format. Every function
// is pure. No #version here: include this from a stage file.
//
// Conventions
// - Shadow factors: 1 = lit, 0 = shadowed. Depths are clamped to [0, 1].
// - Depth convention: `reverse_z` true (the default) means near = 1, far = 0, so a receiver is
//   behind the occluders when its depth is smaller than their mean. vsm_moments stores the raw
//   depth (d, d^2) in either convention and vsm_shadow mirrors the test (Chebyshev's one-sided
//   bound holds on either side of the mean). EVSM warps the distance from the light instead,
//   x = 2 f - 1 with f = depth (standard) or 1 - depth (reverse-Z), so the positive warp
//   exp(c x) always stretches the far side where receivers lie: pass the same reverse_z to
//   evsm_moments and to the evaluation.
// - Exponents: the positive warp reaches exp(c) and its second moment exp(2 c); exp(2 c) must fit
//   the moment format: c <= ln(65504) / 2 = 5.545 for fp16 (evsm_max_exponent(true) = 5.54) and
//   c <= ln(FLT_MAX) / 2 = 44.36 for fp32 (42, leaving headroom for filtering sums). The moment
//   format is part of every EVSM call (`fp16`: the map stores 16-bit floats): the exponents are
//   clamped for it (evsm_clamp_exponents), the same way when the moments are written and when
//   they are read. An exponent of 0 makes the warp constant (lit).
// - min_variance is in depth units squared; EVSM scales it into warped space by the warp's
//   slope at the receiver: (dw/df)^2 = (2 c w)^2 (as a standard deviation, so it never
//   overflows).
// - NaN or infinite receiver depths or moments, and uvs outside [0, 1], give 1.0 (lit).

#ifndef PENUMBRA_VSM_GLSL
#define PENUMBRA_VSM_GLSL

#include "penumbra/depth.glsl"
#include "penumbra/finite.glsl"

// Exponent limits of the EVSM warps (see the header).
const float kEvsmMaxExponentFp32 = 42.0;
const float kEvsmMaxExponentFp16 = 5.54;

// Returns v clamped to [0, 1], or 1 (lit) when v is NaN or infinite.
float vsm_saturate_or_lit(float v) {
  return penumbra_is_finite(v) ? clamp(v, 0.0, 1.0) : 1.0;
}

// Returns min_variance made safe: negative or NaN values count as 0.
float vsm_min_variance(float min_variance) {
  return penumbra_is_nan(min_variance) ? 0.0 : max(min_variance, 0.0);
}

// Returns the moments to store for a depth: (depth, depth^2), depth clamped to [0, 1].
vec2 vsm_moments(float depth) {
  float d = clamp(depth, 0.0, 1.0);
  return vec2(d, d * d);
}

// Returns the one-sided Chebyshev (Cantelli) upper bound on the fraction of the distribution
// with moments (mean, E[x^2]) that lies at or beyond t, given a lower bound min_sigma on the
// standard deviation: 1 when t <= mean, else 1 / (1 + (d / sigma)^2) = var / (var + d^2) with
// d = t - mean and sigma = max(sqrt(E[x^2] - mean^2), min_sigma). Evaluated through d / sigma so
// nothing is squared at full scale: EVSM's warped values reach exp(42) ~ 1.7e18, whose squares
// sit near FLT_MAX. Zero sigma with the receiver behind the mean gives 0. The variance is
// `precise` (no fused multiply-add), so moments (m, m * m) of one depth have variance exactly 0
// on every device. Non-finite inputs give 1.
float chebyshev_bound_min_sigma(vec2 moments, float t, float min_sigma) {
  if (!(penumbra_is_finite(moments.x) && penumbra_is_finite(moments.y) && penumbra_is_finite(t))) return 1.0;
  float d = t - moments.x;
  if (d <= 0.0) return 1.0;
  precise float variance = moments.y - moments.x * moments.x;
  float sigma = max(sqrt(max(variance, 0.0)), penumbra_is_nan(min_sigma) ? 0.0 : min_sigma);
  if (!(sigma > 0.0)) return 0.0;
  float r = d / sigma;
  return vsm_saturate_or_lit(1.0 / (1.0 + r * r));
}

// Returns the one-sided Chebyshev (Cantelli) upper bound on the fraction of the distribution
// with moments (mean, E[x^2]) that lies at or beyond t: 1 when t <= mean, else
// var / (var + (t - mean)^2) with var = max(E[x^2] - mean^2, min_variance) (see
// chebyshev_bound_min_sigma). Non-finite inputs give 1.
float chebyshev_upper_bound(vec2 moments, float t, float min_variance) {
  return chebyshev_bound_min_sigma(moments, t, sqrt(vsm_min_variance(min_variance)));
}

// Returns linstep(amount, 1, p) = clamp((p - amount) / (1 - amount), 0, 1): light-bleed
// reduction, cutting the Chebyshev bound's tail below `amount` (clamped to [0, 1]; amount 1
// keeps only p = 1). amount 0 returns p unchanged.
float vsm_reduce_light_bleeding(float p, float amount) {
  float a = penumbra_is_finite(amount) ? clamp(amount, 0.0, 1.0) : 0.0;
  if (a >= 1.0) return p >= 1.0 ? 1.0 : 0.0;
  return clamp((p - a) / (1.0 - a), 0.0, 1.0);
}

// Returns the VSM shadow factor of a receiver at receiver_depth against filtered moments
// (E[d], E[d^2]) of vsm_moments: the Chebyshev bound on the lit fraction, then light-bleed
// reduction by bleed_reduction.
float vsm_shadow(vec2 moments, float receiver_depth, float min_variance, float bleed_reduction,
                 bool reverse_z) {
  if (!penumbra_is_finite(receiver_depth)) return 1.0;
  float t = clamp(receiver_depth, 0.0, 1.0);
  // Reverse-Z: the distribution of -d has mean -E[d] and the same variance.
  float p = reverse_z ? chebyshev_upper_bound(vec2(-moments.x, moments.y), -t, min_variance)
                      : chebyshev_upper_bound(moments, t, min_variance);
  return vsm_saturate_or_lit(vsm_reduce_light_bleeding(p, bleed_reduction));
}

// Returns the largest safe EVSM exponent for a moment format: 5.54 for fp16, 42 for fp32.
float evsm_max_exponent(bool fp16) {
  return fp16 ? kEvsmMaxExponentFp16 : kEvsmMaxExponentFp32;
}

// Returns (positive, negative) exponents clamped to [0, evsm_max_exponent(fp16)]; NaN gives 0.
vec2 evsm_clamp_exponents(vec2 exponents, bool fp16) {
  float hi = evsm_max_exponent(fp16);
  return vec2(penumbra_is_nan(exponents.x) ? 0.0 : clamp(exponents.x, 0.0, hi),
              penumbra_is_nan(exponents.y) ? 0.0 : clamp(exponents.y, 0.0, hi));
}

// Returns the warped depth (exp(c+ x), -exp(-c- x)), x = 2 f - 1 in [-1, 1], f the distance
// from the light (depth, or 1 - depth under reverse-Z, depth clamped to [0, 1]), exponents
// (c+, c-) clamped for the moment format (evsm_clamp_exponents(exponents, fp16)).
vec2 evsm_warp(float depth, vec2 exponents, bool reverse_z, bool fp16) {
  float d = clamp(depth, 0.0, 1.0);
  float x = 2.0 * (reverse_z ? 1.0 - d : d) - 1.0;
  vec2 c = evsm_clamp_exponents(exponents, fp16);
  return vec2(exp(c.x * x), -exp(-c.y * x));
}

// Returns the EVSM4 moments to store for a depth in a map of the given format: (w+, w+^2, w-,
// w-^2) of evsm_warp. EVSM2 stores the first two.
vec4 evsm_moments(float depth, vec2 exponents, bool reverse_z, bool fp16) {
  vec2 w = evsm_warp(depth, exponents, reverse_z, fp16);
  return vec4(w.x, w.x * w.x, w.y, w.y * w.y);
}

// Returns the minimum standard deviation in a warp's space at warped value w: sqrt(min_variance)
// (depth units) times the warp's slope |dw/df| = 2 c |w|, i.e. min_variance (2 c w)^2 as a
// variance, without forming that square (it can exceed FLT_MAX for c near 42).
float evsm_warped_min_sigma(float min_variance, float exponent, float w) {
  return sqrt(vsm_min_variance(min_variance)) * 2.0 * exponent * abs(w);
}

// Returns the EVSM2 shadow factor: the Chebyshev bound of the positive warp (exponent c+,
// moments (E[w+], E[w+^2])) at the receiver's warped depth, then light-bleed reduction; the
// exponent is clamped for the moment format.
float evsm2_shadow(vec2 moments, float receiver_depth, float exponent, float min_variance,
                   float bleed_reduction, bool reverse_z, bool fp16) {
  if (!penumbra_is_finite(receiver_depth)) return 1.0;
  float c = evsm_clamp_exponents(vec2(exponent, 0.0), fp16).x;
  float w = evsm_warp(receiver_depth, vec2(c, 0.0), reverse_z, fp16).x;
  float p = chebyshev_bound_min_sigma(moments, w, evsm_warped_min_sigma(min_variance, c, w));
  return vsm_saturate_or_lit(vsm_reduce_light_bleeding(p, bleed_reduction));
}

// Returns the EVSM4 shadow factor: the smaller of the Chebyshev bounds of the positive warp
// (moments.xy) and the negative warp (moments.zw), then light-bleed reduction.
float evsm4_shadow(vec4 moments, float receiver_depth, vec2 exponents, float min_variance,
                   float bleed_reduction, bool reverse_z, bool fp16) {
  bool finite = penumbra_is_finite(moments.x) && penumbra_is_finite(moments.y) && penumbra_is_finite(moments.z) &&
                penumbra_is_finite(moments.w);
  if (!finite || !penumbra_is_finite(receiver_depth)) return 1.0;
  vec2 c = evsm_clamp_exponents(exponents, fp16);
  vec2 w = evsm_warp(receiver_depth, c, reverse_z, fp16);
  float positive =
      chebyshev_bound_min_sigma(moments.xy, w.x, evsm_warped_min_sigma(min_variance, c.x, w.x));
  float negative =
      chebyshev_bound_min_sigma(moments.zw, w.y, evsm_warped_min_sigma(min_variance, c.y, w.y));
  return vsm_saturate_or_lit(vsm_reduce_light_bleeding(min(positive, negative), bleed_reduction));
}

// Returns true when coord (uv, depth) is finite with uv inside [0, 1]^2. (A device may flush a
// negative denormal u or v to -0, which is inside.)
bool vsm_coord_in_map(vec3 coord) {
  bool finite = penumbra_is_finite(coord.x) && penumbra_is_finite(coord.y) && penumbra_is_finite(coord.z);
  return finite && coord.x >= 0.0 && coord.x <= 1.0 && coord.y >= 0.0 && coord.y <= 1.0;
}

// Returns the VSM shadow factor at coord = (uv, receiver depth) from a moment map (RG: E[d],
// E[d^2], filtered by its sampler); lit outside the map.
float vsm_sample_shadow(sampler2D moment_map, vec3 coord, float min_variance, float bleed_reduction,
                        bool reverse_z) {
  if (!vsm_coord_in_map(coord)) return 1.0;
  vec2 moments = texture(moment_map, coord.xy).xy;
  return vsm_shadow(moments, coord.z, min_variance, bleed_reduction, reverse_z);
}

// Returns the EVSM2 shadow factor at coord from a moment map (RG: E[w+], E[w+^2]) of the given
// format.
float evsm2_sample_shadow(sampler2D moment_map, vec3 coord, float exponent, float min_variance,
                          float bleed_reduction, bool reverse_z, bool fp16) {
  if (!vsm_coord_in_map(coord)) return 1.0;
  vec2 moments = texture(moment_map, coord.xy).xy;
  return evsm2_shadow(moments, coord.z, exponent, min_variance, bleed_reduction, reverse_z, fp16);
}

// Returns the EVSM2 shadow factor at coord from layer `layer` of a moment map array (a cascade's
// moments; RG: E[w+], E[w+^2]) of the given format.
float evsm2_sample_shadow_array(sampler2DArray moment_maps, vec3 coord, int layer, float exponent,
                                float min_variance, float bleed_reduction, bool reverse_z,
                                bool fp16) {
  if (!vsm_coord_in_map(coord)) return 1.0;
  vec2 moments = texture(moment_maps, vec3(coord.xy, float(layer))).xy;
  return evsm2_shadow(moments, coord.z, exponent, min_variance, bleed_reduction, reverse_z, fp16);
}

// Returns the EVSM2 shadow factor at coord from layer `layer` of a moment map array with mips,
// read over the receiver's footprint in the map: duv_dx and duv_dy are how far coord.xy moves
// across one screen pixel in x and in y. The level is the one whose texels match the footprint's
// shorter side (trilinear between levels): where a pixel covers many texels in both directions,
// the moments come prefiltered over them instead of from a 2x2 bilinear read. The shorter side,
// not the longer (textureGrad's choice without anisotropy): on grazing ground the longer one
// blurred the shadows twice as far from the reference (docs/accuracy.md, "EVSM2 mips").
float evsm2_sample_shadow_array_footprint(sampler2DArray moment_maps, vec3 coord, int layer,
                                          vec2 duv_dx, vec2 duv_dy, float exponent,
                                          float min_variance, float bleed_reduction,
                                          bool reverse_z, bool fp16) {
  if (!vsm_coord_in_map(coord)) return 1.0;
  vec2 size = vec2(textureSize(moment_maps, 0).xy);
  float texels = min(length(duv_dx * size), length(duv_dy * size));
  float lod = log2(max(texels, 1e-8));
  vec2 moments = textureLod(moment_maps, vec3(coord.xy, float(layer)), lod).xy;
  return evsm2_shadow(moments, coord.z, exponent, min_variance, bleed_reduction, reverse_z, fp16);
}

// Returns the EVSM2 shadow factor of a point light's cube `layer` of a moment cube array, seen
// along dir (light to receiver; need not be unit): ref is what the cube would store at the
// receiver (cube_compare_depth, local_shadow.glsl), in the depth convention the moments were
// warped with. The moments are sampled bilinearly across faces. A direction too short to address
// the cube is lit.
float evsm2_sample_shadow_cube_array(samplerCubeArray moment_cubes, vec3 dir, int layer, float ref,
                                     float exponent, float min_variance, float bleed_reduction,
                                     bool reverse_z, bool fp16) {
  if (!(dot(dir, dir) >= 1.175494351e-38)) return 1.0;
  vec2 moments = texture(moment_cubes, vec4(dir, float(layer))).xy;
  return evsm2_shadow(moments, ref, exponent, min_variance, bleed_reduction, reverse_z, fp16);
}

// Returns the EVSM2 moments (E[w+], E[w+^2]) of a row of a depth-map array averaged over
// 2 radius + 1 texels along x around texel t (xy texel, z layer), reads clamped to [0, size):
// the first half of a separable box blur of the moments (evsm_moments.comp's first pass). With
// `window`, the map is held as a window of a toroidal image (pcf.glsl's windowed lookups): map
// texel t is image texel (t + window) mod size, window whole texels in [0, size); the reads
// clamp at the map's edges before the offset.
vec2 evsm2_moments_box_x(sampler2DArray depth_map, ivec3 t, int radius, int size, float exponent,
                         bool reverse_z, bool fp16, ivec2 window) {
  vec2 sum = vec2(0.0);
  int y = (t.y + window.y) % size;
  for (int i = -radius; i <= radius; ++i) {
    int x = (clamp(t.x + i, 0, size - 1) + window.x) % size;
    float d = texelFetch(depth_map, ivec3(x, y, t.z), 0).r;
    sum += evsm_moments(d, vec2(exponent, 0.0), reverse_z, fp16).xy;
  }
  return sum / float(2 * radius + 1);
}

vec2 evsm2_moments_box_x(sampler2DArray depth_map, ivec3 t, int radius, int size, float exponent,
                         bool reverse_z, bool fp16) {
  return evsm2_moments_box_x(depth_map, t, radius, size, exponent, reverse_z, fp16, ivec2(0));
}

// The same for a perspective depth-map array (a spot light's maps): each depth is first made
// linear, (view depth - near) / (far - near) in [0, 1] (linearize_depth; 1 - that value under
// reverse-Z, so the stored convention is kept), so the warp spreads over distance instead of
// crowding where perspective depth does. The resolve compares the receiver's view depth mapped
// the same way.
vec2 evsm2_moments_box_x_linear(sampler2DArray depth_map, ivec3 t, int radius, int size,
                                float exponent, float near, float far, bool reverse_z,
                                bool fp16) {
  vec2 sum = vec2(0.0);
  for (int i = -radius; i <= radius; ++i) {
    float d = texelFetch(depth_map, ivec3(clamp(t.x + i, 0, size - 1), t.y, t.z), 0).r;
    float l = clamp((linearize_depth(d, near, far, reverse_z) - near) / (far - near), 0.0, 1.0);
    sum += evsm_moments(reverse_z ? 1.0 - l : l, vec2(exponent, 0.0), reverse_z, fp16).xy;
  }
  return sum / float(2 * radius + 1);
}

// Returns the moments of a moment-map array averaged over 2 radius + 1 texels along y around
// texel t, reads clamped to [0, size): the second half of the separable box blur.
vec2 moments_box_y(sampler2DArray moment_map, ivec3 t, int radius, int size) {
  vec2 sum = vec2(0.0);
  for (int j = -radius; j <= radius; ++j)
    sum += texelFetch(moment_map, ivec3(t.x, clamp(t.y + j, 0, size - 1), t.z), 0).xy;
  return sum / float(2 * radius + 1);
}

// Returns the EVSM4 shadow factor at coord from a moment map (RGBA: E[w+], E[w+^2], E[w-],
// E[w-^2]).
float evsm4_sample_shadow(sampler2D moment_map, vec3 coord, vec2 exponents, float min_variance,
                          float bleed_reduction, bool reverse_z, bool fp16) {
  if (!vsm_coord_in_map(coord)) return 1.0;
  vec4 moments = texture(moment_map, coord.xy);
  return evsm4_shadow(moments, coord.z, exponents, min_variance, bleed_reduction, reverse_z,
                      fp16);
}

#endif  // PENUMBRA_VSM_GLSL
