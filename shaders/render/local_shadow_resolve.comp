#version 460
#extension GL_EXT_control_flow_attributes : require
// Spot and point light shadow resolve: per pixel and per shadowed local light, the world-unit
// biases and the configured filter (hard, PCF, Poisson, PCSS), through the library in
// penumbra/bias.glsl and penumbra/local_shadow.glsl, like the sun's resolve. Output rgba16f:
// the visibility of spot 0, spot 1, point 0, point 1 (1: lit, or a light without a shadow map;
// 0 where the surface faces away from the light). A second rgba16f image carries the debug
// views' data of the primary shadowed local light (the first shadowed spot, else the first
// shadowed point light): x the map (0 spot, 1-6 cube face +X..-Z, -1 none), y shadow-map texels
// per screen pixel, z the PCSS penumbra width in texels (penumbra view only; -1 facing away).
#include "penumbra/frame_types.glsl"
#include "penumbra/shadow_types.glsl"
#include "penumbra/bias.glsl"
#include "penumbra/cascade.glsl"
#include "penumbra/local_shadow.glsl"
#include "penumbra/noise.glsl"
#include "penumbra/vsm.glsl"
#include "penumbra/shadow_filter.glsl"

#ifndef PENUMBRA_SPOT_SHADOWS
#define PENUMBRA_SPOT_SHADOWS 0
#endif
#ifndef PENUMBRA_POINT_SHADOWS
#define PENUMBRA_POINT_SHADOWS 0
#endif
#ifndef PENUMBRA_POINT_MOMENTS
#define PENUMBRA_POINT_MOMENTS 0
#endif
#ifndef PENUMBRA_SPOT_MOMENTS
#define PENUMBRA_SPOT_MOMENTS 0
#endif
// The renderer's variant (src/render/passes/shadow_resolve.cpp): PENUMBRA_PENUMBRA_VIEW 0 leaves
// the penumbra view's PCSS estimate out of the SPIR-V (indoor: 93 -> 66 KB), as kPenumbraView 0
// switches it off. Undefined: compiled, and chosen per frame.
#ifndef PENUMBRA_PENUMBRA_VIEW
#define PENUMBRA_PENUMBRA_VIEW 1
#endif

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform FrameBlock { FrameGpu frame; };
layout(set = 0, binding = 1) uniform sampler2D scene_depth;   // nearest
layout(set = 0, binding = 2) uniform sampler2D scene_normal;  // nearest, view space
#if PENUMBRA_SPOT_SHADOWS > 0
layout(set = 0, binding = 3) uniform SpotBlock { SpotShadowGpu spot_shadows[kMaxSpotLights]; };
layout(set = 0, binding = 4) uniform sampler2DArrayShadow spot_compare;  // linear compare
layout(set = 0, binding = 5) uniform sampler2DArray spot_depth;          // nearest raw
#endif
#if PENUMBRA_POINT_SHADOWS > 0
layout(set = 0, binding = 6) uniform PointBlock { PointShadowGpu point_shadows[kMaxPointLights]; };
layout(set = 0, binding = 7) uniform samplerCubeArrayShadow point_compare;  // linear compare
layout(set = 0, binding = 8) uniform samplerCubeArray point_depth;          // nearest raw
#endif
layout(set = 0, binding = 9, rgba16f) uniform writeonly image2D local_shadow;
layout(set = 0, binding = 10, rgba16f) uniform writeonly image2D local_debug;
#if PENUMBRA_POINT_MOMENTS
// A point light's own filter = evsm2: the cubes' blurred EVSM2 moments (evsm_moments.comp over
// every face), linear, sampled across faces.
layout(set = 0, binding = 11) uniform samplerCubeArray point_moments;
#define POINT_MOMENTS point_moments
#else
#define POINT_MOMENTS point_depth  // never read: evsm2 is not among point_filters()
#endif
#if PENUMBRA_SPOT_MOMENTS
// A spot light's own filter = evsm2: its map's blurred EVSM2 moments of linear depth
// ((view depth - near) / (far - near); evsm2_moments_box_x_linear), linear, clamped.
layout(set = 0, binding = 12) uniform sampler2DArray spot_moments;
#define SPOT_MOMENTS spot_moments
#else
#define SPOT_MOMENTS spot_depth  // never read: evsm2 is not among spot_filters()
#endif

// The renderer specializes these per frame (src/render/passes/shadow_resolve.cpp): bit f of
// kSpotFilters (kPointFilters) is set when a spot (point) light may be filtered with f, so the
// driver compiles only those filters; kPenumbraView is 1 with the penumbra view. Unspecialized,
// every filter is compiled and the view is read from the frame.
const uint kFromFrame = 0xffffffffu;
layout(constant_id = 0) const uint kSpotFilters = kFromFrame;
layout(constant_id = 1) const uint kPointFilters = kFromFrame;
layout(constant_id = 2) const uint kPenumbraView = kFromFrame;
bool penumbra_view() {
  return kPenumbraView == kFromFrame ? frame.mode.w == kViewPenumbra : kPenumbraView == 1u;
}
bool in_set(uint filters, uint f) { return (filters & (1u << f)) != 0u; }
// The filters each kind of light compiles (shadow_filter.glsl; kFromFrame: every one), evsm2
// only with its moments.
uint spot_filters() {
  return PENUMBRA_SPOT_MOMENTS != 0 ? kSpotFilters : kSpotFilters & ~(1u << kFilterEvsm2);
}
uint point_filters() {
  return PENUMBRA_POINT_MOMENTS != 0 ? kPointFilters : kPointFilters & ~(1u << kFilterEvsm2);
}

// The light's own filter (LightGpu.params.w), else the scene's.
uint light_filter(LightGpu light) {
  return light.params.w >= 0.0 ? uint(light.params.w) : frame.mode.z;
}

// The normal offset for the light's filter: wider than one texel, it grows with the reach
// (shadow_filter_offset_reach: a spot or point light counts PCF's bilinear texel).
float normal_offset_texels(LightGpu light) {
  FilterExtent e;
  e.params = frame.filter_params;
  e.pcss_search_texels = frame.pcss.y;
  e.pcss_min_filter_texels = frame.pcss.z;
  e.evsm_blur = frame.filter_world.y;
  return filter_normal_offset_texels(frame.bias.x,
                                     shadow_filter_offset_reach(light_filter(light), e, true));
}

PcssLocalParams local_params(float radius, float texel_at_unit, float near, float far) {
  PcssLocalParams p;
  p.light_radius = radius;
  p.texel_at_unit = texel_at_unit;
  p.near = near;
  p.far = far;
  p.max_search_texels = frame.pcss.y;
  p.min_filter_texels = frame.pcss.z;
  p.max_filter_texels = frame.pcss.w;
  p.confidence_fraction = frame.pcss.x;
  return p;
}

// The debug view `redrawn`: what the shadow-map cache drew this frame of a map (or cube face)
// with bits b (shadow_types.glsl): 3 drawn whole, 1 drawn again where moving casters were or are
// (somewhere in it: the whole map or face is marked), 0 kept (the sun's codes,
// shadow_resolve.comp; a spot or point map is never scrolled).
float redrawn_code(uint b) {
  return (b & PENUMBRA_REDRAWN_WHOLE) != 0u ? 3.0 : (b & PENUMBRA_REDRAWN_MOVING) != 0u ? 1.0 : 0.0;
}

#if PENUMBRA_SPOT_SHADOWS > 0
float spot_visibility(LightGpu light, SpotShadowGpu s, int map, vec3 p, vec3 n, float rotation,
                      inout vec4 debug) {
  vec3 d = light.position_range.xyz - p;
  float dist = length(d);
  vec3 l = d / max(dist, 1e-6);
  float n_dot_l = dot(n, l);
  float axial = dot(p - s.position_near.xyz, s.direction_far.xyz);
  float texel_world = perspective_texel_world_size(s.params.z, axial);
  debug = vec4(0.0, texel_world, n_dot_l > 0.0 ? 0.0 : -1.0, 1.0);
  if (!(n_dot_l > 0.0)) return 0.0;
  vec3 q = p + normal_offset(n, l, texel_world, normal_offset_texels(light));
  float bias = world_depth_bias(n_dot_l, frame.bias.z, frame.bias.y, frame.bias.w, texel_world);
  q = bias_toward_light(q, l, min(bias, 0.5 * dist));
  vec3 coord = world_to_shadow_coord(s.view_proj, q);
  bool reverse_z = s.info.y == 1u;
  vec2 texel = vec2(1.0 / float(s.info.x));
  PcssLocalParams params =
      local_params(light.params.z, s.params.z, s.position_near.w, s.direction_far.w);
  float receiver_distance = dot(q - s.position_near.xyz, s.direction_far.xyz);
#if PENUMBRA_PENUMBRA_VIEW
  if (penumbra_view()) {  // the PCSS estimate whatever the filter
    float average;
    int blockers;
    pcss_blocker_search_array(spot_depth, coord, map,
                              pcss_local_search_radius_texels(receiver_distance, params),
                              pcss_search_tap_count(int(frame.filter_params.y)), rotation, texel,
                              reverse_z, average, blockers);
    PcssLocalParams wide = params;
    wide.min_filter_texels = 0.0;
    wide.max_filter_texels = 1e30;
    float zb = linearize_depth(average, params.near, params.far, reverse_z);
    if (blockers > 0) debug.z = 2.0 * pcss_local_filter_radius_texels(receiver_distance, zb, wide);
  }
#endif
  uint filter_mode = light_filter(light);
  ShadowLookup2D f;
  f.coord = coord;
  f.layer = map;
  f.texel = texel;
  f.rotation = rotation;
  f.reverse_z = reverse_z;
  f.pcf_radius = int(frame.filter_params.x);
  f.taps = int(frame.filter_params.z);
  f.disk_radius = frame.filter_params.w;
  f.pcss_tier = int(frame.filter_params.y);
  f.perspective = true;
  f.pcss_local = params;
  f.receiver_distance = receiver_distance;
  f.evsm = frame.evsm;
  // evsm2: the receiver's view depth mapped as the moments' depths were (1 - t under reverse-Z).
  float t = clamp((receiver_distance - params.near) / (params.far - params.near), 0.0, 1.0);
  f.moments_depth = reverse_z ? 1.0 - t : t;
  f.footprint = false;
  if (in_set(spot_filters(), kFilterPcss) && filter_mode == kFilterPcss) {
    // The receiver plane's depth gradient in the map, from two points on the plane a texel's
    // footprint away (receiver_plane_depth_gradient takes any two independent steps).
    vec3 t1, t2;
    cube_tangent_basis(n, t1, t2);
    vec3 step1 = world_to_shadow_coord(s.view_proj, q + t1 * texel_world) - coord;
    vec3 step2 = world_to_shadow_coord(s.view_proj, q + t2 * texel_world) - coord;
    f.plane_gradient = receiver_plane_depth_gradient(step1, step2);
  }
  return shadow_filter_2d_array(filter_mode, spot_filters(), spot_compare, spot_depth,
                                SPOT_MOMENTS, f);
}
#endif

#if PENUMBRA_POINT_SHADOWS > 0
// The cube face a light-to-receiver direction selects (+X, -X, +Y, -Y, +Z, -Z: 0..5).
float cube_face_of(vec3 v) {
  vec3 a = abs(v);
  if (a.z >= a.x && a.z >= a.y) return v.z < 0.0 ? 5.0 : 4.0;
  if (a.y >= a.x) return v.y < 0.0 ? 3.0 : 2.0;
  return v.x < 0.0 ? 1.0 : 0.0;
}

float point_visibility(LightGpu light, PointShadowGpu s, int map, vec3 p, vec3 n, float rotation,
                       inout vec4 debug) {
  vec3 d = light.position_range.xyz - p;
  float dist = length(d);
  vec3 l = d / max(dist, 1e-6);
  float n_dot_l = dot(n, l);
  float resolution = float(s.info.z);
  float texel_world = cube_texel_world_size(p - s.position.xyz, resolution);
  debug = vec4(1.0 + cube_face_of(p - s.position.xyz), texel_world, n_dot_l > 0.0 ? 0.0 : -1.0,
               1.0);
  if (!(n_dot_l > 0.0)) return 0.0;
  vec3 q = p + normal_offset(n, l, texel_world, normal_offset_texels(light));
  float bias = world_depth_bias(n_dot_l, frame.bias.z, frame.bias.y, frame.bias.w, texel_world);
  q = bias_toward_light(q, l, min(bias, 0.5 * dist));
  vec3 v = q - s.position.xyz;
  float receiver_distance = length(v);
  bool reverse_z = s.info.y == 1u;
  float ref = cube_compare_depth(receiver_distance, s.depth_range.x, s.depth_range.z, reverse_z);
  PcssLocalParams params =
      local_params(light.params.z, 2.0 / resolution, s.depth_range.x, s.depth_range.y);
#if PENUMBRA_PENUMBRA_VIEW
  if (penumbra_view()) {  // the PCSS estimate whatever the filter
    float average;
    int blockers;
    pcss_cube_blocker_search(point_depth, v, map, ref,
                             pcss_local_search_radius_texels(receiver_distance, params),
                             pcss_search_tap_count(int(frame.filter_params.y)), rotation,
                             resolution, reverse_z, average, blockers);
    PcssLocalParams wide = params;
    wide.min_filter_texels = 0.0;
    wide.max_filter_texels = 1e30;
    float zb = cube_stored_distance(average, params.near, params.far, reverse_z);
    if (blockers > 0) debug.z = 2.0 * pcss_local_filter_radius_texels(receiver_distance, zb, wide);
  }
#endif
  ShadowLookupCube f;
  f.dir = v;
  f.layer = map;
  f.ref = ref;
  f.resolution = resolution;
  f.rotation = rotation;
  f.reverse_z = reverse_z;
  f.pcf_radius = int(frame.filter_params.x);
  f.taps = int(frame.filter_params.z);
  f.disk_radius = frame.filter_params.w;
  f.pcss_tier = int(frame.filter_params.y);
  f.pcss_local = params;
  f.receiver_distance = receiver_distance;
  f.plane_normal = n;
  f.evsm = frame.evsm;
  return shadow_filter_cube_array(light_filter(light), point_filters(), point_compare,
                                  point_depth, POINT_MOMENTS, f);
}
#endif

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  ivec2 size = ivec2(frame.viewport.xy);
  if (any(greaterThanEqual(pixel, size))) return;
  vec4 visibility = vec4(1.0);
  vec4 nrm = texelFetch(scene_normal, pixel, 0);
  if (nrm.a == 0.0) {  // sky
    imageStore(local_shadow, pixel, visibility);
    imageStore(local_debug, pixel, vec4(-1.0, 0.0, 0.0, 0.0));
    return;
  }
  float depth = texelFetch(scene_depth, pixel, 0).r;
  vec2 uv = (vec2(pixel) + 0.5) * frame.viewport.zw;
  vec4 h = frame.inv_view_proj * vec4(uv * 2.0 - 1.0, depth, 1.0);
  vec3 p = h.xyz / h.w;
  vec3 n = normalize(transpose(mat3(frame.view)) * nrm.xyz);
  float rotation = 6.2831853 * interleaved_gradient_noise_temporal(vec2(pixel), frame.mode.x);
  // The debug data of the first shadowed light (the spots come first); the rest's is dropped.
  vec4 debug = vec4(-1.0, 0.0, 0.0, 0.0);
  // Not unrolled: the drivers would unroll each loop to kMaxSpotLights (kMaxPointLights) copies
  // of the light's biases and filter, and compile them all. llvmpipe compiled a new version of
  // this shader in 500-650 ms unrolled, 200-260 ms not (docs/hot-reload.md).
#if PENUMBRA_SPOT_SHADOWS > 0
  [[dont_unroll]] for (int i = 0; i < int(frame.counts.x); ++i) {
    int map = int(frame.spots[i].params.y);
    if (map >= 0) {
      bool first = debug.w == 0.0;
      vec4 d = debug;
      visibility[i] = spot_visibility(frame.spots[i], spot_shadows[map], map, p, n, rotation, d);
      if (first && frame.mode.w == kViewRedrawn) d.z = redrawn_code(spot_shadows[map].info.z);
      if (first) debug = d;
    }
  }
#endif
#if PENUMBRA_POINT_SHADOWS > 0
  [[dont_unroll]] for (int i = 0; i < int(frame.counts.y); ++i) {
    int map = int(frame.points[i].params.y);
    if (map >= 0) {
      bool first = debug.w == 0.0;
      vec4 d = debug;
      visibility[kMaxSpotLights + i] =
          point_visibility(frame.points[i], point_shadows[map], map, p, n, rotation, d);
      if (first && frame.mode.w == kViewRedrawn)  // the face d.x - 1's bits
        d.z = redrawn_code(point_shadows[map].info.w >> (4u * uint(d.x - 1.0)) & 15u);
      if (first) debug = d;
    }
  }
#endif
  // Shadow-map texels per screen pixel: the pixel's world footprint over the texel's.
  float view_depth = dot(p - frame.camera_position.xyz, frame.camera_forward.xyz);
  float pixel_world = view_depth * 2.0 * frame.projection.z * frame.viewport.w;
  debug.y = debug.y > 0.0 ? pixel_world / debug.y : 0.0;
  imageStore(local_shadow, pixel, visibility);
  imageStore(local_debug, pixel, debug);
}
