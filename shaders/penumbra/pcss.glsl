// Percentage-closer soft shadows (PCSS) for a directional light with an orthographic projection
// (one cascade): blocker search, penumbra estimate from the light's angular diameter,
// variable-radius Vogel-disk PCF, quality tiers, early-outs and a confidence fade. Every function
// is pure: maps, parameters and the noise rotation come in as arguments. No #version here:
// include this from a stage file.
//
// Conventions (see pcf.glsl for coord, texel_size, compare samplers and the lit-when-invalid rule)
// - Depth convention: `reverse_z` true (the default convention) means near = 1, far = 0: a stored
//   depth is closer to the light than the receiver when it is larger. Standard depth: smaller.
// - Orthographic light: depth is linear in the distance along the light, so a depth difference
//   dz is a world distance dz * |depth_far - depth_near| (the light projection's near/far planes,
//   CascadeGpu.params.yz).
// - Penumbra width: for a light of angular diameter theta (the sun: about 0.53 degrees) and a
//   blocker edge at distance d above the receiver (along the light), the penumbra on a receiver
//   perpendicular to the light is w = 2 d tan(theta / 2) wide in world units: the full width of
//   the region between full shadow and full light (the rays through the blocker edge at angles
//   +-theta/2 around the light direction reach the receiver d tan(theta / 2) either side of the
//   hard-shadow edge). In texels: w / texel_world_size.
// - Filter: a receiver point sees the blocker plane (distance d above it) through the sun's cone,
//   a disk of radius d tan(theta / 2) = w / 2 around the point directly above it. The visible
//   fraction of the sun is therefore the lit fraction of that disk in the shadow map: a uniformly
//   weighted disk kernel of radius w / 2, which pcf_vogel samples (plus the one-texel bilinear
//   tent of its compare taps). Its shadow-factor profile across a straight edge goes from 0 to 1
//   over exactly w.
// - Blocker search region: any blocker that can hide part of the sun lies between the receiver
//   and the light's near plane, at most d_max = (depth distance to the near plane) * range above
//   it, and then within d_max tan(theta / 2) of the point (same cone). The search disk has that
//   radius: d_max tan(theta / 2) / texel_world_size texels (in uv: tan(theta / 2) * d_max /
//   frustum width), clamped to max_search_texels.
// - A blocker is a search sample strictly closer to the light than the receiver (apply depth
//   bias to the receiver depth before calling). The blocker depth is their mean.
// - Continuity at the degenerate ends: pcss_shadow searches at least min_filter_texels + 1
//   texels (pcss_search_radius_bounded) and filters at most as far as it searched, so angular
//   diameter 0 and receivers at the near plane degrade to PCF with the minimum filter, and a
//   search clamped below the filter narrows the penumbra instead of cutting its outer part off.
// - Early-outs: no blocker -> 1.0 (lit, no filtering). Every search sample a blocker and the
//   filter disk inside the search disk (filter radius <= search radius) -> 0.0 (fully shadowed,
//   no filtering): the filter region was searched and found all blockers.
// - Confidence fade: with few blockers the mean blocker depth rests on few samples (a stray
//   texel, acne, a thin twig at the search edge), so the result fades towards lit:
//   result = mix(1, filtered, confidence), confidence = clamp(blockers / max(fraction * search
//   taps, 1), 0, 1). confidence_fraction 0 (or anything up to 1 / search taps) disables the fade.

#ifndef PENUMBRA_PCSS_GLSL
#define PENUMBRA_PCSS_GLSL

#include "penumbra/bias.glsl"
#include "penumbra/noise.glsl"
#include "penumbra/pcf.glsl"

// PCSS parameters of one directional-light cascade. All lengths are positive.
struct PcssParams {
  float tan_half_angle;     // tan(theta / 2), theta the light's angular diameter (ShadowGpu.pcss.x)
  float texel_world_size;   // world size of one shadow-map texel (CascadeGpu.params.x)
  float depth_near;         // light projection near plane, world units along the light
  float depth_far;          // light projection far plane
  float max_search_texels;  // upper bound of the blocker-search radius, texels
  float min_filter_texels;  // lower bound of the filter radius, texels (e.g. 0.5)
  float max_filter_texels;  // upper bound of the filter radius, texels
  float confidence_fraction;  // blockers / search taps needed for full confidence (0: no fade)
};

// Quality tiers: (search taps, filter taps) = (8, 16), (16, 32), (32, 64).
const int kPcssTierLow = 0;
const int kPcssTierMedium = 1;
const int kPcssTierHigh = 2;
const int kPcssMaxSearchTaps = 64;

// Returns the blocker-search tap count of a tier (clamped to low..high): 8, 16 or 32.
int pcss_search_tap_count(int tier) {
  return 8 << clamp(tier, kPcssTierLow, kPcssTierHigh);
}

// Returns the filter tap count of a tier (clamped to low..high): 16, 32 or 64.
int pcss_filter_tap_count(int tier) {
  return 16 << clamp(tier, kPcssTierLow, kPcssTierHigh);
}

// Returns |depth_far - depth_near|: the world distance of a depth difference of 1.
float pcss_depth_range(PcssParams params) {
  return abs(params.depth_far - params.depth_near);
}

// Returns true when `stored` is strictly closer to the light than `receiver`.
bool pcss_is_blocker(float stored, float receiver, bool reverse_z) {
  return reverse_z ? stored > receiver : stored < receiver;
}

// Returns the blocker-search radius in texels for a receiver at receiver_depth: the distance
// from the receiver to the near plane times tan(theta / 2), in texels, clamped to
// [0, max_search_texels] (0 when a parameter makes it NaN).
float pcss_search_radius_texels(float receiver_depth, PcssParams params, bool reverse_z) {
  float depth = clamp(receiver_depth, 0.0, 1.0);
  float to_near = reverse_z ? 1.0 - depth : depth;
  float radius =
      to_near * pcss_depth_range(params) * params.tan_half_angle / params.texel_world_size;
  float hi = penumbra_is_nan(params.max_search_texels) ? 0.0 : max(params.max_search_texels, 0.0);
  return penumbra_is_finite(radius) ? clamp(radius, 0.0, hi) : 0.0;
}

// Returns the search radius the filters use: radius_texels clamped to
// [min_filter_texels + 1, max(max_search_texels, min_filter_texels + 1)], the upper bound for a
// NaN or infinite radius. The lower bound keeps PCSS continuous at its degenerate ends (a light
// of angular diameter 0, a receiver at the light's near plane): a search disk that shrank to a
// point would find no blocker at a shadow edge and jump to lit, where the filter of
// min_filter_texels (plus its taps' one-texel bilinear tent) sees the edge. Negative and NaN
// bounds count as 0.
float pcss_search_radius_bounded(float radius_texels, float min_filter_texels,
                                 float max_search_texels) {
  float lo = (penumbra_is_finite(min_filter_texels) ? max(min_filter_texels, 0.0) : 0.0) + 1.0;
  float hi = max(penumbra_is_finite(max_search_texels) ? max_search_texels : 0.0, lo);
  return penumbra_is_finite(radius_texels) ? clamp(radius_texels, lo, hi) : hi;
}

// Returns the world distance along the light from the receiver up to the blocker (0 when the
// blocker depth is not closer to the light than the receiver).
float pcss_blocker_distance(float receiver_depth, float blocker_depth, PcssParams params,
                            bool reverse_z) {
  float closer = reverse_z ? blocker_depth - receiver_depth : receiver_depth - blocker_depth;
  return max(closer, 0.0) * pcss_depth_range(params);
}

// Returns the penumbra width in world units, 2 d tan(theta / 2), for a blocker at distance d
// above a receiver perpendicular to the light (negative distances count as 0).
float pcss_penumbra_width(float blocker_distance, float tan_half_angle) {
  return 2.0 * max(blocker_distance, 0.0) * tan_half_angle;
}

// Returns the penumbra width in texels of this cascade for a receiver and a blocker depth.
float pcss_penumbra_width_texels(float receiver_depth, float blocker_depth, PcssParams params,
                                 bool reverse_z) {
  float d = pcss_blocker_distance(receiver_depth, blocker_depth, params, reverse_z);
  return pcss_penumbra_width(d, params.tan_half_angle) / params.texel_world_size;
}

// Returns the PCF disk radius in texels: half the penumbra width, clamped to
// [min_filter_texels, max(max_filter_texels, min_filter_texels)] (the minimum when NaN; a NaN
// bound counts as 0 for the minimum and as the minimum for the maximum).
float pcss_filter_radius_texels(float receiver_depth, float blocker_depth, PcssParams params,
                                bool reverse_z) {
  float radius = 0.5 * pcss_penumbra_width_texels(receiver_depth, blocker_depth, params, reverse_z);
  float lo = penumbra_is_nan(params.min_filter_texels) ? 0.0 : max(params.min_filter_texels, 0.0);
  float hi = penumbra_is_nan(params.max_filter_texels) ? lo : max(params.max_filter_texels, lo);
  return penumbra_is_finite(radius) ? clamp(radius, lo, hi) : lo;
}

// Returns the confidence in [0, 1] of a blocker search that found blocker_count blockers among
// search_taps samples (see the header: full from confidence_fraction * search_taps blockers on;
// the fraction is clamped to [0, 1], NaN counts as 0).
float pcss_confidence(int blocker_count, int search_taps, float confidence_fraction) {
  float fraction = penumbra_is_nan(confidence_fraction) ? 0.0 : clamp(confidence_fraction, 0.0, 1.0);
  float needed = max(fraction * float(search_taps), 1.0);
  return clamp(float(blocker_count) / needed, 0.0, 1.0);
}

// Returns the raw depth of the texel holding uv (nearest, clamped to the edge), read with
// texelFetch so the selected texel is exactly floor(uv * size) on every implementation.
float pcss_fetch_depth(sampler2D depth_map, vec2 uv) {
  vec2 size = vec2(textureSize(depth_map, 0));
  vec2 texel = clamp(floor(uv * size), vec2(0.0), size - 1.0);
  return texelFetch(depth_map, ivec2(texel), 0).r;
}

// Returns the raw depth of pcss_fetch_depth in layer `layer` of an array map. The layer is
// clamped to the map's layers, as texture() does for the compare taps of the same map (Vulkan
// clamps the array coordinate of a sampled lookup, while texelFetch out of range is undefined):
// PCSS and PCF then read the same layer for any layer argument. Through `window` (pcf.glsl's
// windowed lookups) the map's texel t is the image's (t + o) mod N.
float pcss_fetch_depth_array(sampler2DArray depth_map, vec2 uv, int layer, vec4 window) {
  ivec3 size = textureSize(depth_map, 0);
  vec2 n = vec2(size.xy);
  vec2 texel = clamp(floor(uv * n), vec2(0.0), n - 1.0);
  if (window.z != 0.0) texel = mod(texel + window.xy, n);
  return texelFetch(depth_map, ivec3(ivec2(texel), clamp(layer, 0, size.z - 1)), 0).r;
}

// Returns pcss_fetch_depth_array of the map itself.
float pcss_fetch_depth_array(sampler2DArray depth_map, vec2 uv, int layer) {
  return pcss_fetch_depth_array(depth_map, uv, layer, vec4(0.0));
}

// Returns the uv of blocker-search tap `index` of `count`: a Vogel disk of radius_texels texels.
vec2 pcss_search_uv(vec2 uv, int index, int count, float radius_texels, float rotation,
                    vec2 texel_size) {
  return uv + vogel_disk_sample(index, count, rotation) * radius_texels * texel_size;
}

// Blocker search: reads tap_count (clamped to 1..64) raw depths (non-compare sampler of the
// same map) at a Vogel disk of radius_texels around coord.xy, rotated by `rotation` radians.
// Returns in blocker_count how many are strictly closer to the light than coord.z (clamped to
// [0, 1]) and in average_depth their mean depth (coord.z when there is none). An invalid coord
// (see pcf.glsl) finds no blocker.
void pcss_blocker_search(sampler2D depth_map, vec3 coord, float radius_texels, int tap_count,
                         float rotation, vec2 texel_size, bool reverse_z, out float average_depth,
                         out int blocker_count) {
  float depth = clamp(coord.z, 0.0, 1.0);
  average_depth = penumbra_is_finite(depth) ? depth : 0.0;
  blocker_count = 0;
  if (!pcf_coord_in_map(coord)) return;
  int n = clamp(tap_count, 1, kPcssMaxSearchTaps);
  float radius = pcf_safe_radius(radius_texels);
  float angle = penumbra_is_finite(rotation) ? rotation : 0.0;
  float sum = 0.0;
  for (int i = 0; i < n; ++i) {
    float stored =
        pcss_fetch_depth(depth_map, pcss_search_uv(coord.xy, i, n, radius, angle, texel_size));
    if (pcss_is_blocker(stored, depth, reverse_z)) {
      sum += stored;
      ++blocker_count;
    }
  }
  if (blocker_count > 0) average_depth = sum / float(blocker_count);
}

// Blocker search against the receiver's plane, in layer `layer` of an array map: as
// pcss_blocker_search, but a tap is a blocker only when it is closer to the light than the
// receiver's plane there, coord.z + receiver_plane_depth_offset(plane_gradient, tap - coord.xy)
// (bias.glsl; plane_gradient from receiver_plane_depth_gradient, in coord's depth convention).
// A receiver tilted away from the light then does not find its own surface as a blocker across
// a wide search disk. vec2(0): the flat search of pcss_blocker_search; a non-finite gradient
// counts as vec2(0). Average depths are the blockers' stored depths, as there.
// Through `window` (pcf.glsl's windowed lookups).
void pcss_blocker_search_plane_array(sampler2DArray depth_map, vec3 coord, int layer,
                                     float radius_texels, int tap_count, float rotation,
                                     vec2 texel_size, bool reverse_z, vec2 plane_gradient,
                                     vec4 window, out float average_depth,
                                     out int blocker_count) {
  float depth = clamp(coord.z, 0.0, 1.0);
  average_depth = penumbra_is_finite(depth) ? depth : 0.0;
  blocker_count = 0;
  if (!pcf_coord_in_map(coord)) return;
  vec2 g = penumbra_is_finite(plane_gradient.x) && penumbra_is_finite(plane_gradient.y)
               ? plane_gradient
               : vec2(0.0);
  int n = clamp(tap_count, 1, kPcssMaxSearchTaps);
  float radius = pcf_safe_radius(radius_texels);
  float angle = penumbra_is_finite(rotation) ? rotation : 0.0;
  float sum = 0.0;
  for (int i = 0; i < n; ++i) {
    vec2 uv = pcss_search_uv(coord.xy, i, n, radius, angle, texel_size);
    float stored = pcss_fetch_depth_array(depth_map, uv, layer, window);
    float plane = depth + receiver_plane_depth_offset(g, uv - coord.xy);
    if (pcss_is_blocker(stored, plane, reverse_z)) {
      sum += stored;
      ++blocker_count;
    }
  }
  if (blocker_count > 0) average_depth = sum / float(blocker_count);
}

// pcss_blocker_search_plane_array of the map itself.
void pcss_blocker_search_plane_array(sampler2DArray depth_map, vec3 coord, int layer,
                                     float radius_texels, int tap_count, float rotation,
                                     vec2 texel_size, bool reverse_z, vec2 plane_gradient,
                                     out float average_depth, out int blocker_count) {
  pcss_blocker_search_plane_array(depth_map, coord, layer, radius_texels, tap_count, rotation,
                                  texel_size, reverse_z, plane_gradient, vec4(0.0), average_depth,
                                  blocker_count);
}

// Blocker search of pcss_blocker_search in layer `layer` of an array map, through `window`
// (pcf.glsl's windowed lookups).
void pcss_blocker_search_array(sampler2DArray depth_map, vec3 coord, int layer, float radius_texels,
                               int tap_count, float rotation, vec2 texel_size, bool reverse_z,
                               vec4 window, out float average_depth, out int blocker_count) {
  pcss_blocker_search_plane_array(depth_map, coord, layer, radius_texels, tap_count, rotation,
                                  texel_size, reverse_z, vec2(0.0), window, average_depth,
                                  blocker_count);
}

// Blocker search of pcss_blocker_search in layer `layer` of an array map.
void pcss_blocker_search_array(sampler2DArray depth_map, vec3 coord, int layer, float radius_texels,
                               int tap_count, float rotation, vec2 texel_size, bool reverse_z,
                               out float average_depth, out int blocker_count) {
  pcss_blocker_search_array(depth_map, coord, layer, radius_texels, tap_count, rotation,
                            texel_size, reverse_z, vec4(0.0), average_depth, blocker_count);
}

// Returns true when a blocker search result needs filtering; false for the early-outs: no
// blocker (lit), or every search sample a blocker with the filter disk inside the searched disk
// (fully shadowed).
bool pcss_needs_filter(int blockers, int search_taps, float search_radius, float filter_radius) {
  return blockers > 0 && !(blockers >= search_taps && filter_radius <= search_radius);
}

// Returns the PCSS shadow factor in [0, 1] (1 lit): search (tier's tap count) over
// pcss_search_radius_texels, early-outs, then pcf_vogel (tier's tap count) with radius
// pcss_filter_radius_texels, faded by pcss_confidence. compare_map and depth_map are the same
// image through a compare sampler (linear) and a non-compare one; rotation (radians) rotates
// both tap sets (e.g. 2 pi * interleaved_gradient_noise(pixel)). Invalid coords are lit.
float pcss_shadow(sampler2DShadow compare_map, sampler2D depth_map, vec3 coord, vec2 texel_size,
                  PcssParams params, int tier, float rotation, bool reverse_z) {
  if (!pcf_coord_in_map(coord)) return 1.0;
  vec3 c = vec3(coord.xy, clamp(coord.z, 0.0, 1.0));
  int search_taps = pcss_search_tap_count(tier);
  float search_radius = pcss_search_radius_bounded(
      pcss_search_radius_texels(c.z, params, reverse_z), params.min_filter_texels,
      params.max_search_texels);
  float blocker_depth;
  int blockers;
  pcss_blocker_search(depth_map, c, search_radius, search_taps, rotation, texel_size, reverse_z,
                      blocker_depth, blockers);
  if (blockers == 0) return 1.0;
  float filter_radius =
      min(pcss_filter_radius_texels(c.z, blocker_depth, params, reverse_z), search_radius);
  if (!pcss_needs_filter(blockers, search_taps, search_radius, filter_radius)) return 0.0;
  float filtered =
      pcf_vogel(compare_map, c, pcss_filter_tap_count(tier), filter_radius, rotation, texel_size);
  float confidence = pcss_confidence(blockers, search_taps, params.confidence_fraction);
  return pcf_saturate_or_lit(mix(1.0, filtered, confidence));
}

// Returns the PCSS shadow factor of pcss_shadow in layer `layer` of array maps (one cascade per
// layer; params describe that cascade), read through `window` (pcf.glsl's windowed lookups).
float pcss_shadow_array(sampler2DArrayShadow compare_map, sampler2DArray depth_map, vec3 coord,
                        int layer, vec2 texel_size, PcssParams params, int tier, float rotation,
                        bool reverse_z, vec4 window) {
  if (!pcf_coord_in_map(coord)) return 1.0;
  vec3 c = vec3(coord.xy, clamp(coord.z, 0.0, 1.0));
  int search_taps = pcss_search_tap_count(tier);
  float search_radius = pcss_search_radius_bounded(
      pcss_search_radius_texels(c.z, params, reverse_z), params.min_filter_texels,
      params.max_search_texels);
  float blocker_depth;
  int blockers;
  pcss_blocker_search_array(depth_map, c, layer, search_radius, search_taps, rotation, texel_size,
                            reverse_z, window, blocker_depth, blockers);
  if (blockers == 0) return 1.0;
  float filter_radius =
      min(pcss_filter_radius_texels(c.z, blocker_depth, params, reverse_z), search_radius);
  if (!pcss_needs_filter(blockers, search_taps, search_radius, filter_radius)) return 0.0;
  float filtered = pcf_vogel_array(compare_map, c, layer, pcss_filter_tap_count(tier),
                                   filter_radius, rotation, texel_size, window);
  float confidence = pcss_confidence(blockers, search_taps, params.confidence_fraction);
  return pcf_saturate_or_lit(mix(1.0, filtered, confidence));
}

// Returns pcss_shadow_array of the maps themselves.
float pcss_shadow_array(sampler2DArrayShadow compare_map, sampler2DArray depth_map, vec3 coord,
                        int layer, vec2 texel_size, PcssParams params, int tier, float rotation,
                        bool reverse_z) {
  return pcss_shadow_array(compare_map, depth_map, coord, layer, texel_size, params, tier,
                           rotation, reverse_z, vec4(0.0));
}

#endif  // PENUMBRA_PCSS_GLSL
