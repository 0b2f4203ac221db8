// Shadow filters of spot lights (perspective 2D maps) and point lights (cube maps storing linear
// distance): the same filters the sun's cascades get (hard, box-grid PCF, Poisson/Vogel disks,
// PCSS), with the penumbra estimate of a sphere light seen through a perspective projection.
// Every function is pure: maps, parameters and the noise rotation come in as arguments. No
// #version here: include this from a stage file.
//
// Conventions (pcf.glsl and pcss.glsl hold the shared ones: compare samplers, lit when invalid)
// - A spot map is perspective: its depth is not linear in distance. "Distance" below is the
//   distance along the spot's axis (the projection's view depth; linearize_depth of a stored
//   depth gives it back). near and far are the projection's planes.
// - A cube map stores t = (distance - near) / (far - near) in [0, 1] (1 - t under reverse-Z),
//   distance the Euclidean distance from the light (PointShadowGpu.depth_range).
// - Sphere light of radius R at the projection's centre. A receiver at distance z_r from the
//   light and a blocker at z_b: the receiver sees the light through a cone whose cross-section at
//   the blocker is a disk of radius R (z_r - z_b) / z_r; the projection maps a world length L at
//   distance z_b to L / (z_b * texel_at_unit) texels (texel_at_unit: a texel's world size at
//   distance 1). The PCF disk radius is therefore
//     R (z_r - z_b) / (z_r z_b texel_at_unit) texels,
//   which tends to the sun's tan(theta / 2) (z_r - z_b) / texel_world_size as the light moves
//   away (R / z_r -> tan(theta / 2), z_b texel_at_unit -> the orthographic texel size).
// - The blocker search covers the cone between the receiver and the near plane, R (z_r - near) /
//   (z_r near texel_at_unit) texels, clamped to max_search_texels.
// - Continuity at the degenerate ends (also in pcss.glsl's pcss_shadow for the sun): the search
//   radius is never below min_filter_texels + 1 (the filter's own footprint, one texel of bilinear
//   tent included), so a light of radius 0, or a receiver at the near plane, degrades to PCF with
//   the minimum filter instead of jumping to lit where the search disk shrinks to a point; and
//   the filter radius never exceeds the search radius, so the filter never reaches blockers the
//   search could not see (a search clamped below the filter narrows the penumbra smoothly instead
//   of cutting its outer part off).

#ifndef PENUMBRA_LOCAL_SHADOW_GLSL
#define PENUMBRA_LOCAL_SHADOW_GLSL

#include "penumbra/depth.glsl"
#include "penumbra/pcf.glsl"
#include "penumbra/pcss.glsl"

// Smallest normal float: a squared direction length below it cannot address a cube map.
const float kLocalMinNormal = 1.175494351e-38;

// PCSS parameters of one spot map or cube. All lengths are positive.
struct PcssLocalParams {
  float light_radius;         // R: world radius of the sphere light (0: a point light)
  float texel_at_unit;        // a texel's world size at distance 1 (spot: SpotShadowGpu.params.z;
                              // cube: 2 / resolution)
  float near;                 // spot: projection near plane; cube: depth_range.x
  float far;                  // spot: projection far plane; cube: depth_range.y
  float max_search_texels;    // upper bound of the blocker-search radius, texels
  float min_filter_texels;    // lower bound of the filter radius, texels
  float max_filter_texels;    // upper bound of the filter radius, texels
  float confidence_fraction;  // as PcssParams.confidence_fraction
};

// Returns a non-negative, finite copy of x (0 for NaN, negative or infinite values).
float local_nonneg(float x) {
  return penumbra_is_finite(x) ? max(x, 0.0) : 0.0;
}

// Returns the blocker-search radius in texels for a receiver at receiver_distance:
// R (z_r - near) / (z_r near texel_at_unit) clamped to max_search_texels, and never below
// min_filter_texels + 1 (see the header). Finite for every input.
float pcss_local_search_radius_texels(float receiver_distance, PcssLocalParams p) {
  float z = local_nonneg(receiver_distance);
  float near = local_nonneg(p.near);
  float numerator = local_nonneg(p.light_radius) * max(z - near, 0.0);
  // A zero numerator (light of radius 0, receiver at the near plane) is radius 0 even over a zero
  // denominator; a positive one over zero is +infinity, which the bound clamps.
  float radius = numerator > 0.0 ? numerator / (z * near * local_nonneg(p.texel_at_unit)) : 0.0;
  return pcss_search_radius_bounded(radius, p.min_filter_texels, p.max_search_texels);
}

// Returns the PCF disk radius in texels for a receiver at receiver_distance behind a blocker at
// blocker_distance: R (z_r - z_b) / (z_r z_b texel_at_unit), clamped to
// [min_filter_texels, max(max_filter_texels, min_filter_texels)]: the minimum when the blocker is
// not in front of the receiver or R is 0, the maximum when the blocker is at the light.
float pcss_local_filter_radius_texels(float receiver_distance, float blocker_distance,
                                      PcssLocalParams p) {
  float lo = local_nonneg(p.min_filter_texels);
  float hi = max(local_nonneg(p.max_filter_texels), lo);
  float zr = local_nonneg(receiver_distance);
  float zb = local_nonneg(blocker_distance);
  float numerator = local_nonneg(p.light_radius) * max(zr - zb, 0.0);
  float radius = numerator > 0.0 ? numerator / (zr * zb * local_nonneg(p.texel_at_unit)) : 0.0;
  return penumbra_is_nan(radius) ? lo : clamp(radius, lo, hi);
}

// Returns the PCSS shadow factor of a spot light in layer `layer` of array maps: coord the
// receiver's (biased) shadow coordinate, receiver_distance its distance along the spot's axis,
// plane_gradient the receiver plane's depth gradient in the map (receiver_plane_depth_gradient;
// vec2(0) for none). Search and filter as in the header, blockers from
// pcss_blocker_search_plane_array, their mean depth linearized with the projection's planes; the
// filter is pcf_vogel_array, faded by pcss_confidence. Invalid coords are lit.
float pcss_spot_shadow_array(sampler2DArrayShadow compare_map, sampler2DArray depth_map,
                             vec3 coord, int layer, vec2 texel_size, float receiver_distance,
                             PcssLocalParams params, int tier, float rotation, bool reverse_z,
                             vec2 plane_gradient) {
  if (!pcf_coord_in_map(coord)) return 1.0;
  vec3 c = vec3(coord.xy, clamp(coord.z, 0.0, 1.0));
  int search_taps = pcss_search_tap_count(tier);
  float search_radius = pcss_local_search_radius_texels(receiver_distance, params);
  float blocker_depth;
  int blockers;
  pcss_blocker_search_plane_array(depth_map, c, layer, search_radius, search_taps, rotation,
                                  texel_size, reverse_z, plane_gradient, blocker_depth, blockers);
  if (blockers == 0) return 1.0;
  float blocker_distance = linearize_depth(blocker_depth, params.near, params.far, reverse_z);
  float filter_radius = min(
      pcss_local_filter_radius_texels(receiver_distance, blocker_distance, params), search_radius);
  if (!pcss_needs_filter(blockers, search_taps, search_radius, filter_radius)) return 0.0;
  float filtered = pcf_vogel_array(compare_map, c, layer, pcss_filter_tap_count(tier),
                                   filter_radius, rotation, texel_size);
  float confidence = pcss_confidence(blockers, search_taps, params.confidence_fraction);
  return pcf_saturate_or_lit(mix(1.0, filtered, confidence));
}

// ---- cube maps -------------------------------------------------------------------------------

// Returns the compare reference of a receiver at `distance` from a point light:
// t = clamp((distance - near) * inv_range, 0, 1), 1 - t under reverse-Z (what the cube stores).
// A NaN (a NaN input, inf * 0, inf - inf) is the far plane: tested before the clamp, whose
// result for a NaN is undefined (lavapipe gives 0, the near plane).
float cube_compare_depth(float distance, float near, float inv_range, bool reverse_z) {
  float q = (distance - near) * inv_range;
  float t = penumbra_is_nan(q) ? 1.0 : clamp(q, 0.0, 1.0);
  return reverse_z ? 1.0 - t : t;
}

// Returns the distance from the light of a stored cube depth (the inverse of cube_compare_depth).
float cube_stored_distance(float stored, float near, float far, bool reverse_z) {
  float t = clamp(stored, 0.0, 1.0);
  t = reverse_z ? 1.0 - t : t;
  return near + t * (far - near);
}

// Returns two unit vectors that with normalize(dir) form a right-handed orthonormal basis
// (Duff et al. 2017, branchless); dir need not be unit length. A zero or non-finite dir gives the
// basis of +Z.
void cube_tangent_basis(vec3 dir, out vec3 t, out vec3 b) {
  float ll = dot(dir, dir);
  vec3 n = (ll >= kLocalMinNormal && penumbra_is_finite(ll)) ? dir * inversesqrt(ll)
                                                                   : vec3(0.0, 0.0, 1.0);
  float s = n.z >= 0.0 ? 1.0 : -1.0;
  float a = -1.0 / (s + n.z);
  float c = n.x * n.y * a;
  t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
  b = vec3(c, s + n.y * n.y * a, -n.y);
}

// Returns the world length, in the plane perpendicular to dir, of one texel of the cube face dir
// selects, scaled by the direction's length: 2 m / resolution with m the largest component of
// |dir|; t and b receive cube_tangent_basis(dir). A tap one texel aside is dir + step * t.
float cube_texel_step(vec3 dir, float resolution, out vec3 t, out vec3 b) {
  cube_tangent_basis(dir, t, b);
  vec3 a = abs(dir);
  return 2.0 * max(max(a.x, a.y), a.z) / resolution;
}

// Returns true when dir can address a cube map: finite and not zero (or denormal).
bool cube_dir_valid(vec3 dir) {
  float ll = dot(dir, dir);
  return penumbra_is_finite(ll) && ll >= kLocalMinNormal;
}

// Returns the box-grid PCF shadow factor of a cube map: the mean of (2r+1)^2 bilinear compare
// taps (r = radius clamped to 0..5) one texel apart in the plane perpendicular to dir, around the
// light-to-receiver direction dir (need not be unit length). A texel there spans 2 m / resolution
// at the face's major-axis length m. Hardware cube filtering handles taps that cross a face edge
// (seamless cube maps). ref from cube_compare_depth. Lit (1) for an invalid dir or reference.
float pcf_cube_array(samplerCubeArrayShadow map, vec3 dir, int layer, float ref, int radius,
                     float resolution) {
  if (!cube_dir_valid(dir) || !penumbra_is_finite(ref) || !(resolution > 0.0)) return 1.0;
  int r = pcf_clamp_radius(radius);
  vec3 t, b;
  float step = cube_texel_step(dir, resolution, t, b);
  float depth = clamp(ref, 0.0, 1.0);
  float sum = 0.0;
  for (int j = -r; j <= r; ++j) {
    for (int i = -r; i <= r; ++i) {
      vec3 d = dir + (float(i) * t + float(j) * b) * step;
      sum += texture(map, vec4(d, float(layer)), depth);
    }
  }
  float n = float(2 * r + 1);
  return pcf_saturate_or_lit(sum / (n * n));
}

// Returns the Vogel-disk PCF shadow factor of a cube map: tap_count (clamped to 1..64) bilinear
// compare taps on a disk of radius_texels texels perpendicular to dir, rotated by `rotation`.
float pcf_cube_vogel_array(samplerCubeArrayShadow map, vec3 dir, int layer, float ref,
                           int tap_count, float radius_texels, float rotation, float resolution) {
  if (!cube_dir_valid(dir) || !penumbra_is_finite(ref) || !(resolution > 0.0)) return 1.0;
  int n = clamp(tap_count, 1, kPcfMaxVogelTaps);
  vec3 t, b;
  float step = cube_texel_step(dir, resolution, t, b) * pcf_safe_radius(radius_texels);
  float angle = penumbra_is_finite(rotation) ? rotation : 0.0;
  float depth = clamp(ref, 0.0, 1.0);
  float sum = 0.0;
  for (int i = 0; i < n; ++i) {
    vec2 o = vogel_disk_sample(i, n, angle) * step;
    sum += texture(map, vec4(dir + o.x * t + o.y * b, float(layer)), depth);
  }
  return pcf_saturate_or_lit(sum / float(n));
}

// The blocker search of pcss_cube_blocker_search against the receiver's plane: a tap is a
// blocker only when it is closer to the light than the plane through the receiver (at dir from
// the light) with normal plane_normal, where the tap's ray meets that plane (a ray that does not
// meet it: the far end). inv_range is 1 / (far - near) of cube_compare_depth, whose units ref
// is in. A receiver tilted away from the light then does not find its own surface across a
// wide disk. plane_normal vec3(0) (or not finite), or inv_range <= 0: the flat search.
void pcss_cube_blocker_search_plane(samplerCubeArray depth_map, vec3 dir, int layer, float ref,
                                    float radius_texels, int tap_count, float rotation,
                                    float resolution, bool reverse_z, vec3 plane_normal,
                                    float inv_range, out float average_depth,
                                    out int blocker_count) {
  float receiver = clamp(ref, 0.0, 1.0);
  average_depth = penumbra_is_finite(receiver) ? receiver : 0.0;
  blocker_count = 0;
  if (!cube_dir_valid(dir) || !penumbra_is_finite(ref) || !(resolution > 0.0)) return;
  int n = clamp(tap_count, 1, kPcssMaxSearchTaps);
  vec3 t, b;
  float step = cube_texel_step(dir, resolution, t, b) * pcf_safe_radius(radius_texels);
  float angle = penumbra_is_finite(rotation) ? rotation : 0.0;
  bool plane = penumbra_is_finite(plane_normal.x) && penumbra_is_finite(plane_normal.y) &&
               penumbra_is_finite(plane_normal.z) && dot(plane_normal, plane_normal) > 0.0 &&
               inv_range > 0.0 && penumbra_is_finite(inv_range);
  float along = dot(dir, plane_normal);  // the receiver's plane: dot(x, n) = along
  float dir_length = length(dir);
  float sum = 0.0;
  for (int i = 0; i < n; ++i) {
    vec2 o = vogel_disk_sample(i, n, angle) * step;
    vec3 w = dir + o.x * t + o.y * b;
    float stored = textureLod(depth_map, vec4(w, float(layer)), 0.0).r;
    float limit = receiver;
    if (plane) {
      // Where the tap's ray from the light meets the plane: lambda w, lambda = along / (w.n).
      float wn = dot(w, plane_normal);
      float lambda = wn != 0.0 ? along / wn : -1.0;
      float meet = lambda > 0.0 ? lambda * length(w) : 1e30;
      float shift = clamp((meet - dir_length) * inv_range, -2.0, 2.0);
      limit = receiver + (reverse_z ? -shift : shift);
    }
    if (pcss_is_blocker(stored, limit, reverse_z)) {
      sum += stored;
      ++blocker_count;
    }
  }
  if (blocker_count > 0) average_depth = sum / float(blocker_count);
}

// Blocker search of a cube (layer `layer`): tap_count (clamped to 1..64) raw depths, nearest, on
// a Vogel disk of radius_texels texels perpendicular to dir, rotated by `rotation`. Returns in
// blocker_count how many are strictly closer to the light than ref (clamped to [0, 1]) and in
// average_depth their mean stored depth (ref when there is none). An invalid dir finds none.
void pcss_cube_blocker_search(samplerCubeArray depth_map, vec3 dir, int layer, float ref,
                              float radius_texels, int tap_count, float rotation,
                              float resolution, bool reverse_z, out float average_depth,
                              out int blocker_count) {
  pcss_cube_blocker_search_plane(depth_map, dir, layer, ref, radius_texels, tap_count, rotation,
                                 resolution, reverse_z, vec3(0.0), 0.0, average_depth,
                                 blocker_count);
}

// Returns the PCSS shadow factor of a point light's cube (layer `layer`): dir from the light to
// the (biased) receiver, receiver_distance = length(dir), ref = cube_compare_depth of it. The
// blocker search reads tap_count raw depths (nearest) on a Vogel disk of the search radius;
// blocker distances are linear, so their mean is a mean distance; plane_normal is the receiver's
// normal for pcss_cube_blocker_search_plane (vec3(0): the flat search). Then as
// pcss_spot_shadow_array.
float pcss_cube_shadow_array(samplerCubeArrayShadow compare_map, samplerCubeArray depth_map,
                             vec3 dir, int layer, float ref, float receiver_distance,
                             float resolution, PcssLocalParams params, int tier, float rotation,
                             bool reverse_z, vec3 plane_normal) {
  if (!cube_dir_valid(dir) || !penumbra_is_finite(ref) || !(resolution > 0.0)) return 1.0;
  int search_taps = pcss_search_tap_count(tier);
  float search_radius = pcss_local_search_radius_texels(receiver_distance, params);
  float angle = penumbra_is_finite(rotation) ? rotation : 0.0;
  float receiver = clamp(ref, 0.0, 1.0);
  float blocker_depth;
  int blockers;
  float inv_range = 1.0 / max(params.far - params.near, 1e-30);
  pcss_cube_blocker_search_plane(depth_map, dir, layer, receiver, search_radius, search_taps,
                                 angle, resolution, reverse_z, plane_normal, inv_range,
                                 blocker_depth, blockers);
  if (blockers == 0) return 1.0;
  float blocker_distance = cube_stored_distance(blocker_depth, params.near, params.far, reverse_z);
  float filter_radius = min(
      pcss_local_filter_radius_texels(receiver_distance, blocker_distance, params), search_radius);
  if (!pcss_needs_filter(blockers, search_taps, search_radius, filter_radius)) return 0.0;
  float filtered = pcf_cube_vogel_array(compare_map, dir, layer, receiver,
                                        pcss_filter_tap_count(tier), filter_radius, angle,
                                        resolution);
  float confidence = pcss_confidence(blockers, search_taps, params.confidence_fraction);
  return pcf_saturate_or_lit(mix(1.0, filtered, confidence));
}

#endif  // PENUMBRA_LOCAL_SHADOW_GLSL
