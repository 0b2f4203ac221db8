// Screen-space contact shadows: a short ray march through the depth buffer from each pixel
// towards the primary directional light. The march is split into pure functions so that each
// one is unit-tested on its own (shader_tests/contact_shadows_tests.cpp); contact_shadow() puts
// them together and shaders/contact_shadows.comp calls it once per pixel. No #version here:
// include this from a stage file.
//
// Conventions (docs/contact-shadows.md has the whole algorithm):
// - View space is penumbra/depth.glsl's: right-handed, x right, y up, the camera looks down -z
//   (GLM's lookAt); a point in front of the camera has view distance -view.z > 0. Normals and
//   the light direction are in this space.
// - uv = ndc.xy * 0.5 + 0.5 with no Y flip (Vulkan NDC y = -1 is row 0, and v = 0 addresses
//   row 0), so view +y maps to ndc -y (the projection carries the flip, as in depth.glsl's
//   view_position_from_view_distance); pixel (x, y) has its centre at uv = (vec2(x, y) + 0.5) /
//   extent.
// - Depth-buffer values are Vulkan clip depth in [0, 1] of a symmetric perspective projection
//   (tan_half_fov_y, aspect, near, far; far_plane = 0 stands for an infinite far plane).
//   Reverse-Z (default): near -> 1, far -> 0, sky = 0. Standard: near -> 0, far -> 1, sky = 1.
// - The depth buffer is read twice per tap: nearest (texelFetch of the depth image) and bilinear
//   (a linear sampler on an R32F copy of the same values, shaders/depth_resolve.comp). The copy
//   holds the hyperbolic depth itself, not view distance: on a plane the hyperbolic depth is an
//   affine function of screen position, so the bilinear read is exact there.
// - The mask is 1 where lit and 1 - intensity where a tap is occluded (faded at screen edges).

#ifndef PENUMBRA_CONTACT_SHADOWS_GLSL
#define PENUMBRA_CONTACT_SHADOWS_GLSL

#include "penumbra/finite.glsl"

#include "penumbra/common.glsl"
#include "penumbra/depth.glsl"
#include "penumbra/noise.glsl"

// The most march steps per pixel (ContactShadowSettings::step_count is validated against it on
// the host and clamped here).
const uint kContactMaxSteps = 64u;

// The largest step exponent (ContactShadowSettings::step_exponent is validated against it).
const float kContactMaxStepExponent = 8.0;

// The floor of N.L in the slope-scaled bias: tolerance = depth_bias * z / max(N.L, 0.25), so
// the tolerance grows by at most 4x at grazing light.
const float kContactMinNdotL = 0.25;

// What contact_surface_depth returns for "no surface here" (sky, or a non-finite value).
const float kContactNoSurface = -1.0;

// The largest float below 1 (1 - 2^-24).
const float kContactOneMinusEpsilon = 0.99999994039535522461;

// Smallest normal float: a squared length below it (zero, or a denormal that a GPU may flush)
// makes a vector degenerate.
const float kContactMinNormal = 1.175494351e-38;

// The parameters of one dispatch; mirrored by penumbra::render::ContactShadowGpu
// (include/penumbra/render/contact_shadows.hpp), checked against SPIR-V reflection. 80 bytes,
// the same under std140, std430 and C++.
struct ContactShadowGpu {
  vec4 light_dir;        // w 0: xyz the unit direction towards a directional light (view space);
                         // w 1: xyz the position of a spot or point light (view space)
  vec2 extent;           // width, height of the depth buffer in pixels
  float tan_half_fov_y;  // tan of half the vertical field of view
  float aspect;          // width / height of the projection (tan_half_fov_x / tan_half_fov_y)
  float near_plane;      // view distance of the near plane, > 0
  float far_plane;       // view distance of the far plane, > near; 0: an infinite far plane
  float max_distance;    // ray length in view-space units (world units)
  float thickness;       // how far behind a visible surface an occluder is assumed to extend
  float depth_bias;      // slope-scaled tolerance, as a fraction of the receiver's view distance
  float intensity;       // mask = 1 - intensity * occlusion
  float step_exponent;   // t_i = ((i + noise) / N)^step_exponent
  float edge_fade;       // occlusion fades to 0 over this fraction of the screen at its borders
  uint step_count;       // the most steps per pixel, <= kContactMaxSteps; 0: no pass at all
  uint frame;            // frame index for the golden-ratio noise offset
  uint reverse_z;        // 1: reverse-Z (near -> 1), 0: standard depth (near -> 0)
  uint caster_mask;      // 1: surfaces_alpha < 0.75 never occludes (see contact_shadow)
};

// True when a depth-buffer value holds no surface: the far plane or beyond (reverse-Z: depth
// <= 0; standard: depth >= 1), or NaN / infinite.
bool contact_is_sky(float depth, bool reverse_z) {
  if (!penumbra_is_finite(depth)) return true;
  return reverse_z ? depth <= 0.0 : depth >= 1.0;
}

// Returns the view distance (-view.z > 0) of a depth-buffer value through depth.glsl's
// linearize_depth (far_plane > 0) or linearize_depth_infinite (far_plane == 0), or
// kContactNoSurface for sky (contact_is_sky), for a non-finite value and for any value whose
// view distance is not positive and finite.
float contact_surface_depth(float depth, float near_plane, float far_plane, bool reverse_z) {
  if (contact_is_sky(depth, reverse_z)) return kContactNoSurface;
  float z = far_plane > 0.0 ? linearize_depth(depth, near_plane, far_plane, reverse_z)
                            : linearize_depth_infinite(depth, near_plane, reverse_z);
  return (penumbra_is_finite(z) && z > 0.0) ? z : kContactNoSurface;
}

// uv of the centre of pixel `pixel` on a screen of `extent` pixels.
vec2 contact_pixel_uv(ivec2 pixel, vec2 extent) { return (vec2(pixel) + 0.5) / extent; }

// The view-space position of pixel `pixel`'s surface at view distance z: its NDC times the
// projection's scale terms times z (depth.glsl's view_position_from_view_distance), with no
// inverse-matrix round trip, which loses precision far from the camera.
vec3 contact_ray_origin(ivec2 pixel, float z, ContactShadowGpu p) {
  return view_position_from_view_distance(contact_pixel_uv(pixel, p.extent), z, p.tan_half_fov_y,
                                          p.aspect);
}

// The uv a view-space position in front of the camera (view.z < 0) projects to: the inverse of
// depth.glsl's view_position_from_view_distance, ndc = (x / (aspect t d), -y / (t d)) with
// t = tan_half_fov_y and d = -view.z, the projection's scale terms (no matrix).
vec2 contact_project_uv(vec3 view_position, float tan_half_fov_y, float aspect) {
  float d = -view_position.z;
  vec2 ndc = vec2(view_position.x / (aspect * tan_half_fov_y * d),
                  -view_position.y / (tan_half_fov_y * d));
  return ndc_to_uv(ndc);
}

// Returns the length of the ray from `origin` along the unit direction `to_light`: max_distance
// (clamped to >= 0), or less when the light points behind the camera (to_light.z > 0: towards
// the viewer) and the full ray would come nearer than the near plane: then the ray ends on the
// near plane (view distance near_plane), the last depth a pixel can hold, just before the camera
// plane where the projection breaks down. 0 when the origin itself is at or before the near
// plane and the ray points backwards.
//
// "Towards the viewer" is read from the bits (sign clear, not +0, finite), not from a float
// comparison: a GPU may flush a denormal to.z to 0 in any arithmetic or comparison (Vulkan lets
// it), which would make the ray parallel to the near plane and skip the clamp, while the ray
// really does approach the plane (by 0.034 over a length of FLT_MAX for to.z = 1e-40). A z
// below FLT_MIN is clamped up to FLT_MIN: the length to the plane with the larger z is no longer
// than the true one, so the ray still ends behind the plane, and every device computes the same
// length whether it flushes or not.
float contact_ray_length(vec3 origin, vec3 to_light, float max_distance, float near_plane) {
  float len = max(max_distance, 0.0);
  uint z_bits = floatBitsToUint(to_light.z);
  if (z_bits != 0u && z_bits < 0x7f800000u) {
    float dz = max(to_light.z, kContactMinNormal);
    if (-(origin.z + dz * len) < near_plane) len = max((-origin.z - near_plane) / dz, 0.0);
  }
  return min(len, max(max_distance, 0.0));
}

// The ray's end point: origin + to_light * contact_ray_length(...).
vec3 contact_ray_end(vec3 origin, vec3 to_light, float max_distance, float near_plane) {
  return origin + to_light * contact_ray_length(origin, to_light, max_distance, near_plane);
}

// Returns the largest t in [0, 1] for which mix(uv_start, uv_end, t) stays on the screen
// ([0, 1]^2), uv_start being on it: where a ray that leaves the screen has to stop.
float contact_screen_exit(vec2 uv_start, vec2 uv_end) {
  vec2 d = uv_end - uv_start;
  float t = 1.0;
  if (d.x > 0.0) t = min(t, (1.0 - uv_start.x) / d.x);
  if (d.x < 0.0) t = min(t, -uv_start.x / d.x);
  if (d.y > 0.0) t = min(t, (1.0 - uv_start.y) / d.y);
  if (d.y < 0.0) t = min(t, -uv_start.y / d.y);
  return clamp(t, 0.0, 1.0);
}

// Returns the number of steps for a ray that covers length_px pixels on the screen: never more
// than one per pixel crossed (floor(length_px)), never more than max_steps (itself clamped to
// kContactMaxSteps); 0 for a ray shorter than one pixel (it cannot leave its own pixel) and for
// NaN.
uint contact_step_count(float length_px, uint max_steps) {
  uint cap = min(max_steps, kContactMaxSteps);
  if (!(length_px >= 1.0)) return 0u;
  if (!(length_px < float(cap))) return cap;  // also +Inf
  return min(uint(floor(length_px)), cap);
}

// The noise of a pixel in frame `frame`: interleaved gradient noise at the pixel centre plus
// the frame's golden-ratio offset, wrapped to [0, 1). A different low-discrepancy jitter of the
// step positions each frame (temporal accumulation turns it into a smooth result).
float contact_noise(ivec2 pixel, uint frame) {
  float n = interleaved_gradient_noise(vec2(pixel) + 0.5) + golden_ratio_offset(frame);
  return min(fract(n), kContactOneMinusEpsilon);
}

// Parameter t in [0, 1] of step i of n (n >= 1; 0 counts as 1): ((i + noise) / n)^exponent.
// Exponent 2 (the default) packs steps near the receiver, where contact shadows come from; 1 is
// uniform. An exponent below 1 (or NaN) counts as 1, one above kContactMaxStepExponent as that.
float contact_step_t(uint i, uint n, float noise, float exponent) {
  float x = clamp((float(i) + noise) / float(max(n, 1u)), 0.0, 1.0);
  if (exponent == 2.0) return x * x;
  if (!(exponent > 1.0)) return x;
  if (!(x > 0.0)) return 0.0;  // pow(0, y) is exp2(y * -inf): keep it away from the GPU
  return pow(x, min(exponent, kContactMaxStepExponent));
}

// Returns N.L for the receiver's normal (any length: it is scaled by its largest component
// first, so neither 1e-20 nor 1e30 over- or underflows) and the unit direction to the light;
// kContactMinNdotL for a degenerate normal (largest component zero, denormal or non-finite), so
// the march goes on with the largest tolerance.
float contact_n_dot_l(vec3 normal, vec3 to_light) {
  vec3 a = abs(normal);
  float m = max(max(a.x, a.y), a.z);
  if (!(m >= kContactMinNormal) || !penumbra_is_finite(m)) return kContactMinNdotL;
  vec3 n = normal / m;
  return dot(n, to_light) * inversesqrt(dot(n, n));
}

// The depth tolerance of the occlusion test at a receiver at view distance z:
// depth_bias * z / max(N.L, 0.25): relative to the distance (the depth buffer's error and a
// pixel's footprint grow with it) and slope-scaled (grazing light needs more).
float contact_bias_tolerance(float depth_bias, float z, float n_dot_l) {
  return depth_bias * z / max(n_dot_l, kContactMinNdotL);
}

// How many float steps of the stored depth the occlusion test tolerates at least
// (contact_depth_step): the receiver's depth and each tap's carry one rounding each.
const float kContactDepthSteps = 2.0;

// The view-space distance that one float step of the stored depth d spans at view distance z:
// ulp(d) * |dz/dd|, with |dz/dd| = z^2 (far - near) / (far near) in both conventions (z^2 / near
// for an infinite far plane, far_plane = 0). Depth differences below a few such steps are
// rounding, not geometry: standard depth with near 1e-4 and far 1e6 stores 10 m in steps of
// 6 cm, while reverse-Z keeps them near 1e-7 of z. 0 for a depth of 0, NaN or infinity; +Inf
// where the buffer cannot tell distances apart at all.
float contact_depth_step(float d, float z, float near_plane, float far_plane) {
  if (!(d > 0.0) || !penumbra_is_finite(d) || !(z > 0.0)) return 0.0;
  int e;
  frexp(d, e);
  float ulp = ldexp(1.0, e - 24);  // d = m 2^e with m in [0.5, 1): 24 significant bits
  float scale =
      far_plane > 0.0 ? (far_plane - near_plane) / (far_plane * near_plane) : 1.0 / near_plane;
  return z * (z * (scale * ulp));
}

// a * (1 - t) + b * t for a, b >= 0 and t in [0, 1], written out: both terms are >= 0, so
// nothing cancels and the result keeps the operands' relative precision (fused or not). mix()
// may be evaluated as a + t * (b - a) (the H100 evidently does): for a = 5e5, b = 1e-6, t = 1
// that is 5e5 - 5e5 = 0, not 1e-6, an inverse depth of 0 (a ray end at infinity).
float contact_mix_positive(float a, float b, float t) { return a * (1.0 - t) + b * t; }

// The ray's view distance at t: 1 / mix(1 / z_start, 1 / z_end, t) (contact_mix_positive). The
// ray is interpolated linearly in screen space, where 1 / z (not z) varies linearly, so this is
// exact.
float contact_ray_depth(float inv_z_start, float inv_z_end, float t) {
  return 1.0 / contact_mix_positive(inv_z_start, inv_z_end, t);
}

// True when the ray at view distance ray_z is inside the occluder whose visible surface is at
// surface_z: tolerance < ray_z - surface_z < tolerance + thickness (occluders are assumed
// `thickness` deep; the tolerance absorbs depth-buffer error). False for kContactNoSurface.
bool contact_ray_behind(float ray_z, float surface_z, float tolerance, float thickness) {
  if (!(surface_z > 0.0)) return false;
  float delta = ray_z - surface_z;
  return delta > tolerance && delta < tolerance + thickness;
}

// The dual depth test: the ray is occluded only when it is behind the bilinear-filtered surface
// AND behind the nearest-texel surface (contact_ray_behind). Bilinear alone invents surfaces
// between the two sides of a silhouette (false shadows beside every edge); nearest alone turns
// every slope into stairs whose risers shadow the treads under grazing light. use_bilinear /
// use_nearest switch a read off (for the tests that show why both are needed); with both off
// nothing is occluded.
bool contact_dual_test(float ray_z, float bilinear_z, float nearest_z, float tolerance,
                       float thickness, bool use_bilinear, bool use_nearest) {
  if (!use_bilinear && !use_nearest) return false;
  if (use_bilinear && !contact_ray_behind(ray_z, bilinear_z, tolerance, thickness)) return false;
  if (use_nearest && !contact_ray_behind(ray_z, nearest_z, tolerance, thickness)) return false;
  return true;
}

// The weight in [0, 1] of an occluding tap at uv: 1 inside the screen, falling linearly to 0
// over the last `fade_width` (a fraction of the screen) at each border; 1 when fade_width <= 0.
float contact_edge_fade(vec2 uv, float fade_width) {
  if (!(fade_width > 0.0)) return 1.0;
  vec2 border = min(uv, 1.0 - uv);
  return clamp(min(border.x, border.y) / fade_width, 0.0, 1.0);
}

// Builds the screen-space segment that pixel `pixel` (depth-buffer value `depth`, view-space
// `normal`) marches along. Returns the number of steps, 0 when the pixel is not marched (mask
// 1): sky, back-facing (N.L <= 0: the lighting's N.L term already darkens it, and its ray would
// start inside its own surface), degenerate light direction or parameters, a ray shorter than a
// pixel. Otherwise uv_segment = (uv_start, uv_end) and inv_z = (1 / z_start, 1 / z_end) of the
// ray from the pixel's view position along light_dir (towards the light's position for a
// positional light, at most as far as the light), clamped before the camera plane and
// clipped to the screen (both > 0), and tolerance is the depth tolerance at the receiver: the
// larger of contact_bias_tolerance and kContactDepthSteps steps of the stored depth.
uint contact_ray_setup(ivec2 pixel, float depth, vec3 normal, ContactShadowGpu p,
                       out vec4 uv_segment, out vec2 inv_z, out float tolerance) {
  uv_segment = vec4(0.0);
  inv_z = vec2(0.0);
  tolerance = 0.0;
  bool reverse_z = p.reverse_z != 0u;
  float z0 = contact_surface_depth(depth, p.near_plane, p.far_plane, reverse_z);
  if (!(z0 > 0.0)) return 0u;
  vec3 origin = contact_ray_origin(pixel, z0, p);
  // A positional light: the ray goes towards its position, and no further than the light.
  bool positional = p.light_dir.w != 0.0;
  vec3 l = positional ? p.light_dir.xyz - origin : p.light_dir.xyz;
  float ll = dot(l, l);
  if (!(ll >= kContactMinNormal) || !penumbra_is_finite(ll)) return 0u;
  float max_distance = positional ? min(p.max_distance, sqrt(ll)) : p.max_distance;
  l *= inversesqrt(ll);
  float n_dot_l = contact_n_dot_l(normal, l);
  if (!(n_dot_l > 0.0)) return 0u;

  vec2 uv0 = contact_pixel_uv(pixel, p.extent);
  vec3 end = contact_ray_end(origin, l, max_distance, p.near_plane);
  float z1 = -end.z;
  if (!(z1 > 0.0) || !penumbra_is_finite(z1)) return 0u;
  vec2 uv1 = contact_project_uv(end, p.tan_half_fov_y, p.aspect);
  if (!penumbra_is_finite(uv1.x) || !penumbra_is_finite(uv1.y)) return 0u;
  // Both inverse depths stay >= FLT_MIN: 1 / z of a z beyond 1 / FLT_MIN (8.5e37) would be a
  // denormal that a GPU may flush to 0 (an end at infinity).
  float inv_z0 = max(1.0 / z0, kContactMinNormal);
  float inv_z1 = 1.0 / z1;
  float t_exit = contact_screen_exit(uv0, uv1);
  uv1 = mix(uv0, uv1, t_exit);
  inv_z1 = max(contact_mix_positive(inv_z0, inv_z1, t_exit), kContactMinNormal);

  uint steps = contact_step_count(length((uv1 - uv0) * p.extent), p.step_count);
  if (steps == 0u) return 0u;
  uv_segment = vec4(uv0, uv1);
  inv_z = vec2(inv_z0, inv_z1);
  tolerance = max(contact_bias_tolerance(p.depth_bias, z0, n_dot_l),
                  kContactDepthSteps * contact_depth_step(depth, z0, p.near_plane, p.far_plane));
  return steps;
}

// The contact-shadow mask of one pixel, in [0, 1] (1 = lit): the ray from the pixel towards the
// light (contact_ray_setup) is sampled at steps t_i (contact_step_t with contact_noise); at each
// tap outside the pixel's own texel the depth buffer is read nearest (texelFetch of
// nearest_depth) and bilinear (filtered_depth: the R32F copy through a linear sampler), and the
// tap occludes when contact_dual_test says so, weighted by contact_edge_fade at the tap. The
// mask is 1 - intensity * (the largest weight of an occluding tap), clamped to [0, 1]. With
// p.caster_mask set, a tap whose texel in `surfaces` has alpha below 0.75 (a surface that casts
// no shadow, or sky) does not occlude.
float contact_shadow_surfaces(sampler2D filtered_depth, sampler2D nearest_depth,
                              sampler2D surfaces, ivec2 pixel, vec3 normal, ContactShadowGpu p,
                              bool use_bilinear, bool use_nearest) {
  // Texel reads stay inside the depth image even when p.extent claims more than it holds.
  ivec2 size = min(ivec2(p.extent), textureSize(nearest_depth, 0));
  if (any(lessThan(pixel, ivec2(0))) || any(greaterThanEqual(pixel, size))) return 1.0;
  float depth = texelFetch(nearest_depth, pixel, 0).r;
  vec4 segment;
  vec2 inv_z;
  float tolerance;
  uint steps = contact_ray_setup(pixel, depth, normal, p, segment, inv_z, tolerance);
  if (steps == 0u) return 1.0;

  bool reverse_z = p.reverse_z != 0u;
  float noise = contact_noise(pixel, p.frame);
  float occlusion = 0.0;
  for (uint i = 0u; i < steps; ++i) {
    float t = contact_step_t(i, steps, noise, p.step_exponent);
    vec2 uv = mix(segment.xy, segment.zw, t);
    ivec2 texel = clamp(ivec2(floor(uv * p.extent)), ivec2(0), size - 1);
    if (texel == pixel) continue;  // the receiver's own texel: it would test the receiver itself
    // A surface that casts no shadow (the renderer's non-casting ground, say) never occludes.
    if (p.caster_mask != 0u && !(texelFetch(surfaces, texel, 0).a >= 0.75)) continue;
    float ray_z = contact_ray_depth(inv_z.x, inv_z.y, t);
    float nearest_z = kContactNoSurface;
    float bilinear_z = kContactNoSurface;
    if (use_nearest) {
      nearest_z = contact_surface_depth(texelFetch(nearest_depth, texel, 0).r, p.near_plane,
                                        p.far_plane, reverse_z);
    }
    if (use_bilinear) {
      bilinear_z = contact_surface_depth(textureLod(filtered_depth, uv, 0.0).r, p.near_plane,
                                         p.far_plane, reverse_z);
    }
    if (contact_dual_test(ray_z, bilinear_z, nearest_z, tolerance, p.thickness, use_bilinear,
                          use_nearest)) {
      occlusion = max(occlusion, contact_edge_fade(uv, p.edge_fade));
      if (occlusion >= 1.0) break;
    }
  }
  return clamp(1.0 - p.intensity * occlusion, 0.0, 1.0);
}

// contact_shadow_surfaces without a caster mask: every surface in the depth buffer occludes
// (p.caster_mask is ignored).
float contact_shadow(sampler2D filtered_depth, sampler2D nearest_depth, ivec2 pixel,
                     vec3 normal, ContactShadowGpu p, bool use_bilinear, bool use_nearest) {
  ContactShadowGpu q = p;
  q.caster_mask = 0u;
  return contact_shadow_surfaces(filtered_depth, nearest_depth, nearest_depth, pixel, normal, q,
                                 use_bilinear, use_nearest);
}

#endif  // PENUMBRA_CONTACT_SHADOWS_GLSL
