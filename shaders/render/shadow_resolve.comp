#version 460
// Sun shadow resolve: per pixel, cascade select + blend + distance fade + normal-offset and
// world-unit depth bias + the configured filter, all through the library in penumbra/shadow.glsl.
// Output rgba16f: r visibility (1 lit), g cascade index (-1 none), b PCSS penumbra width in
// texels (-1: the surface faces away from the sun; in the debug view `redrawn`, redrawn_code),
// a shadow-map texels per screen pixel (texel density).
#include "penumbra/frame_types.glsl"
#include "penumbra/shadow_types.glsl"
#include "penumbra/shadow.glsl"
#include "penumbra/shadow_filter.glsl"
#include "penumbra/noise.glsl"
#include "penumbra/vsm.glsl"

#ifndef PENUMBRA_SUN_MOMENTS
#define PENUMBRA_SUN_MOMENTS 0
#endif
// What the renderer's variant of this program compiles (src/render/passes/shadow_resolve.cpp),
// besides the filters (PENUMBRA_FILTERS_2D): PENUMBRA_PENUMBRA_VIEW 1 compiles the penumbra
// view's PCSS estimate, 0 leaves it out; PENUMBRA_REDRAWN_VIEW the same for the redrawn view;
// PENUMBRA_SUN_CONTAINMENT 0 leaves out the selection by containment (and so the clipmap).
// Undefined, each is compiled and chosen per frame. The specialization constants below pick
// the same choices; these remove the code from the SPIR-V as well, so that glslang, reflection
// and the driver's front end do not go through it at every edit (the default scene's resolve:
// 75 -> 49 KB), and an edit of code the frame does not run changes no SPIR-V.
#ifndef PENUMBRA_PENUMBRA_VIEW
#define PENUMBRA_PENUMBRA_VIEW 1
#endif
#ifndef PENUMBRA_REDRAWN_VIEW
#define PENUMBRA_REDRAWN_VIEW 1
#endif
#ifndef PENUMBRA_SUN_CONTAINMENT
#define PENUMBRA_SUN_CONTAINMENT 1
#endif
#define PENUMBRA_SUN_EVSM2 ((((PENUMBRA_FILTERS_2D) >> PENUMBRA_FILTER_EVSM2) & 1) != 0)

layout(local_size_x = 8, local_size_y = 8) in;

// The renderer specializes these per frame (src/render/passes/shadow_resolve.cpp), so the
// driver compiles only the filter in use. Unspecialized, the shader reads both from the frame.
const uint kFromFrame = 0xffffffffu;
layout(constant_id = 0) const uint kSunFilter = kFromFrame;     // kFilterHard ... kFilterEvsm2
layout(constant_id = 1) const uint kPenumbraView = kFromFrame;  // 1: the penumbra view, 0: not
// How the cascade is chosen: kByDepth, kByContainment, or kClipmap (containment, no fade).
// Selection by containment is half of llvmpipe's compile of a resolve that does not use it.
layout(constant_id = 2) const uint kSelection = kFromFrame;
layout(constant_id = 3) const uint kRedrawnView = kFromFrame;   // 1: the redrawn view, 0: not
const uint kByDepth = 0u;
const uint kByContainment = 1u;
const uint kClipmap = 2u;

layout(set = 0, binding = 0) uniform FrameBlock { FrameGpu frame; };
layout(set = 0, binding = 1) uniform ShadowBlock { ShadowGpu shadow; };
layout(set = 0, binding = 2) uniform sampler2D scene_depth;     // nearest
layout(set = 0, binding = 3) uniform sampler2D scene_normal;    // nearest, view space
layout(set = 0, binding = 4) uniform sampler2DArrayShadow shadow_compare;  // linear compare
layout(set = 0, binding = 5) uniform sampler2DArray shadow_depth;          // nearest raw
layout(set = 0, binding = 6, rgba16f) uniform writeonly image2D shadow_info;
#if PENUMBRA_SUN_MOMENTS
// filter = evsm2: the cascades' blurred EVSM2 moments (evsm_moments.comp), linear, clamped.
layout(set = 0, binding = 7) uniform sampler2DArray sun_moments;
#define SUN_MOMENTS sun_moments
#else
#define SUN_MOMENTS shadow_depth  // never read: evsm2 is not among sun_filters()
#endif

uint sun_filter() { return kSunFilter == kFromFrame ? frame.mode.z : kSunFilter; }
// The filters this pipeline may dispatch to (shadow_filter.glsl): the specialized one, with the
// Poisson disk that constant width turns PCF into; evsm2 only with its moments. The renderer's
// PENUMBRA_FILTERS_2D narrows what is compiled: the disk only while constant width is on.
uint sun_filters() {
  uint all = kSunFilter == kFromFrame ? kAllFilters
             : kSunFilter == kFilterPcf ? (1u << kFilterPcf) | (1u << kFilterPoisson)
                                        : 1u << kSunFilter;
  return PENUMBRA_SUN_MOMENTS != 0 ? all : all & ~(1u << kFilterEvsm2);
}
// The sun's filter keys (shadow_filter.glsl): PCSS's from its block.
FilterExtent sun_extent() {
  FilterExtent e;
  e.params = frame.filter_params;
  e.pcss_search_texels = shadow.pcss.y;
  e.pcss_min_filter_texels = shadow.pcss.z;
  e.evsm_blur = frame.filter_world.y;
  return e;
}
bool penumbra_view() {
  return kPenumbraView == kFromFrame ? frame.mode.w == kViewPenumbra : kPenumbraView == 1u;
}
uint selection() {
  if (kSelection != kFromFrame) return kSelection;
  if (shadow.counts.w == PENUMBRA_SHADOW_LAYOUT_CLIPMAP) return kClipmap;
  return shadow.modes.x == 1u ? kByContainment : kByDepth;
}
bool redrawn_view() {
  return kRedrawnView == kFromFrame ? frame.mode.w == kViewRedrawn : kRedrawnView == 1u;
}

// Visibility from one cascade, with its penumbra width (texels) for the debug view. dpdx, dpdy:
// how far the receiver's surface moves across one pixel (evsm2 with mips reads its footprint).
float cascade_visibility(int c, vec3 p, vec3 n, vec3 to_light, vec2 pixel, vec3 dpdx, vec3 dpdy,
                         out float penumbra) {
  penumbra = 0.0;
  CascadeGpu cascade = shadow.cascades[c];
  float texel_world = cascade.params.x;
  bool reverse_z = shadow.counts.y == 1u;
  // World-unit biases (bias.glsl): the normal offset in this cascade's texels, then the receiver
  // moves towards the sun by the depth bias in metres (the cascade's depth is linear, so this is
  // exactly bias / depth range in depth units).
  // The offset grows with the filter's reach beyond one texel (filter_normal_offset_texels).
  uint filter_mode = sun_filter();
  bool constant_width =
      frame.filter_world.x != 0.0 && (filter_mode == kFilterPcf || filter_mode == kFilterPoisson);
  float reach = shadow_filter_offset_reach(filter_mode, sun_extent(), false);
  // Constant width in world units: a Poisson disk whose radius is fixed in cascade 0's texels
  // and so shrinks, in texels, in the coarser cascades.
  float world_radius = filter_mode == kFilterPcf ? frame.filter_params.x + 0.5 : frame.filter_params.w;
  world_radius *= shadow.cascades[0].params.x / texel_world;
  if (constant_width) reach = world_radius;
  vec3 offset =
      normal_offset(n, to_light, texel_world, filter_normal_offset_texels(frame.bias.x, reach));
  float bias = world_depth_bias(dot(n, to_light), frame.bias.z, frame.bias.y, frame.bias.w,
                                texel_world);
  vec3 biased = bias_toward_light(p + offset, to_light, bias);
  vec3 coord = world_to_shadow_coord(cascade.view_proj, biased);
  vec2 texel = vec2(1.0 / float(shadow.counts.z));
  float rotation = 6.2831853 * interleaved_gradient_noise_temporal(pixel, frame.mode.x);
  PcssParams params;
  params.tan_half_angle = shadow.pcss.x;
  params.texel_world_size = texel_world;
  params.depth_near = cascade.params.y;
  params.depth_far = cascade.params.z;
  params.max_search_texels = shadow.pcss.y;
  params.min_filter_texels = shadow.pcss.z;
  params.max_filter_texels = shadow.pcss.w;
  params.confidence_fraction = frame.pcss.x;
  // The penumbra debug view shows the PCSS estimate whatever the filter: the width the sun's
  // angular size would give here.
#if PENUMBRA_PENUMBRA_VIEW
  if (penumbra_view()) {
    float average;
    int blockers;
    float radius = pcss_search_radius_texels(clamp(coord.z, 0.0, 1.0), params, reverse_z);
    pcss_blocker_search_array(shadow_depth, coord, c, radius,
                              pcss_search_tap_count(int(frame.filter_params.y)), rotation, texel,
                              reverse_z, shadow.window[c], average, blockers);
    if (blockers > 0) penumbra = pcss_penumbra_width_texels(coord.z, average, params, reverse_z);
  }
#endif
  // The filter (shadow_filter.glsl). Constant width in world units turns PCF into the Poisson
  // disk of world_radius.
  ShadowLookup2D q;
  q.coord = coord;
  q.layer = c;
  q.texel = texel;
  q.rotation = rotation;
  q.reverse_z = reverse_z;
  q.pcf_radius = int(frame.filter_params.x);
  q.taps = int(frame.filter_params.z);
  q.disk_radius = constant_width ? world_radius : frame.filter_params.w;
  q.pcss_tier = int(frame.filter_params.y);
  q.perspective = false;
  q.pcss = params;
  q.evsm = frame.evsm;
  q.moments_depth = coord.z;
  q.footprint = filter_mode == kFilterEvsm2 && frame.filter_world.z != 0.0;  // shadows.evsm_mips
#if PENUMBRA_SUN_EVSM2
  if (q.footprint) {
    q.duv_dx = world_to_shadow_coord(cascade.view_proj, biased + dpdx).xy - coord.xy;
    q.duv_dy = world_to_shadow_coord(cascade.view_proj, biased + dpdy).xy - coord.xy;
  }
#endif
  // The cascade's window on the image sampled: the renderer's toroidal grid read in place, or
  // the map itself (window.z 0).
  return shadow_filter_2d_array(constant_width ? kFilterPoisson : filter_mode, sun_filters(),
                                shadow_compare, shadow_depth, SUN_MOMENTS, q, shadow.window[c]);
}

// The finest cascade whose map holds the receiver with the filter's reach; count when none.
// The library's select_cascade_by_position, reading each matrix from the block in place: handing
// it a local mat4[8] made llvmpipe lower every dynamic index into selects over 128 floats, about
// 2 s of LLVM compile on each new version of this shader (docs/hot-reload.md).
#if PENUMBRA_SUN_CONTAINMENT
int select_cascade_containing(vec3 p, int count) {
  int n = clamp(count, 0, kCascadeMaxCount);
  float border = shadow_filter_reach_texels(sun_filter(), sun_extent());
  float resolution = float(shadow.counts.z);
  for (int i = 0; i < n; ++i)
    if (shadow_coord_in_bounds(world_to_shadow_coord(shadow.cascades[i].view_proj, p), border,
                               resolution))
      return i;
  return n;
}
#endif

// The debug view `redrawn`: what the shadow-map cache drew this frame of the texel of cascade c
// that p falls in (ShadowGpu.redrawn): 3 the cascade was drawn whole, 2 the texel lies in a
// strip a scrolled cascade newly reached, 1 it lies where moving casters were or are and was
// drawn again (the cascade restored with the moving casters drawn over it, through a grid of its
// own), 0 kept as it was.
#if PENUMBRA_REDRAWN_VIEW
float redrawn_code(int c, vec3 p) {
  uvec4 r = shadow.redrawn[c];
  if ((r.x & PENUMBRA_REDRAWN_WHOLE) != 0u) return 3.0;
  if ((r.x & PENUMBRA_REDRAWN_STRIPS) != 0u) {
    float n = float(shadow.counts.z);
    vec2 t = floor(world_to_shadow_coord(shadow.cascades[c].view_proj, p).xy * n);
    vec2 m = vec2(ivec2(r.yz));  // the move across the map: the columns and rows it brought in
    if ((m.x > 0.0 && t.x >= n - m.x) || (m.x < 0.0 && t.x < -m.x) ||
        (m.y > 0.0 && t.y >= n - m.y) || (m.y < 0.0 && t.y < -m.y))
      return 2.0;
  }
  if ((r.x & PENUMBRA_REDRAWN_MOVING) == 0u) return 0.0;
  // Drawn again where moving casters were or are: that rectangle (the whole cascade without one).
  uvec4 d = shadow.redrawn_rect[c];
  if (d.z == 0u) return 1.0;
  vec2 t = floor(world_to_shadow_coord(shadow.cascades[c].view_proj, p).xy * float(shadow.counts.z));
  return all(greaterThanEqual(t, vec2(d.xy))) && all(lessThan(t, vec2(d.zw))) ? 1.0 : 0.0;
}
#endif

// The camera-relative world position seen at screen uv with depth buffer value depth.
vec3 unproject(vec2 uv, float depth) {
  vec4 h = frame.inv_view_proj * vec4(uv * 2.0 - 1.0, depth, 1.0);
  return h.xyz / h.w;
}

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  ivec2 size = ivec2(frame.viewport.xy);
  if (any(greaterThanEqual(pixel, size))) return;
  vec4 nrm = texelFetch(scene_normal, pixel, 0);
  if (nrm.a == 0.0) {  // sky
    imageStore(shadow_info, pixel, vec4(1.0, -1.0, 0.0, 0.0));
    return;
  }
  float depth = texelFetch(scene_depth, pixel, 0).r;
  vec2 uv = (vec2(pixel) + 0.5) * frame.viewport.zw;
  vec3 p = unproject(uv, depth);
  // The prepass stores view-space normals; the view matrix is a rotation (camera-relative).
  vec3 n = normalize(transpose(mat3(frame.view)) * nrm.xyz);
  vec3 to_light = shadow.light_dir_angular.xyz;
  float view_depth = dot(p - shadow.camera_position.xyz, shadow.camera_forward.xyz);
  int count = int(shadow.counts.x);
  // Containment, and always for a clipmap (its levels are nested squares around the camera).
  bool by_containment = selection() != kByDepth;
  // The splits go in as the block's two vec4, not as an array copied by value (cascade.glsl).
#if PENUMBRA_SUN_CONTAINMENT
  int c = by_containment
              ? select_cascade_containing(p, count)
              : select_cascade_by_depth(view_depth, shadow.splits[0], shadow.splits[1], count);
#else
  int c = select_cascade_by_depth(view_depth, shadow.splits[0], shadow.splits[1], count);
#endif
  // The surface's move across one pixel, on its tangent plane (the neighbours' rays through it,
  // capped at 64 pixels' worth where they graze it): evsm2 with mips reads that footprint.
  vec3 dpdx = vec3(0.0), dpdy = vec3(0.0);
#if PENUMBRA_SUN_EVSM2
  if (sun_filter() == kFilterEvsm2 && frame.filter_world.z != 0.0) {
    vec3 eye = shadow.camera_position.xyz;
    dpdx = ray_plane_point(eye, unproject(uv + vec2(frame.viewport.z, 0.0), depth), p, n, 64.0) - p;
    dpdy = ray_plane_point(eye, unproject(uv + vec2(0.0, frame.viewport.w), depth), p, n, 64.0) - p;
  }
#endif
  float visibility = 1.0;
  float penumbra = 0.0;
  float texel_world = 0.0;
  if (dot(n, to_light) <= 0.0) {
    visibility = 0.0;  // faces turned away from the sun are in their own shadow
    penumbra = -1.0;   // marks "self-shadowed" for the debug views and tests
    texel_world = c < count ? shadow.cascades[c].params.x : 0.0;
  } else if (c < count) {
    // Blending follows the view-distance slices; a cascade chosen by containment is used alone.
    float blend = by_containment ? 0.0
                                 : cascade_blend_to_next(view_depth, shadow.splits[0],
                                                         shadow.splits[1], c, count,
                                                         shadow.selection.x, shadow.selection.y);
    // This cascade, then the next one where the two blend: one call site in a loop, so the
    // driver compiles the filter once, not twice (llvmpipe: 1.8 -> 1.15 s of LLVM unspecialized).
    float first = 1.0, next = 1.0;
    for (int k = 0; k < (blend > 0.0 ? 2 : 1); ++k) {
      float level_penumbra;
      float v = cascade_visibility(c + k, p, n, to_light, vec2(pixel), dpdx, dpdy, level_penumbra);
      if (k == 0) {
        first = v;
        penumbra = level_penumbra;
      } else {
        next = v;
      }
    }
    visibility = blend > 0.0 ? mix(first, next, blend) : first;
    texel_world = shadow.cascades[c].params.x;
    // A clipmap ends where its coarsest level does (c == count: lit), not at a view distance.
    float fade = selection() == kClipmap
                     ? 0.0
                     : shadow_distance_fade(view_depth, shadow.selection.z, shadow.selection.w);
    visibility = mix(visibility, 1.0, fade);  // fade: how far shadows have faded to lit
  }
  // Shadow-map texels per screen pixel: the pixel's world footprint over the texel's.
  float pixel_world = view_depth * 2.0 * frame.projection.z * frame.viewport.w;
  float density = texel_world > 0.0 ? pixel_world / texel_world : 0.0;
#if PENUMBRA_REDRAWN_VIEW
  if (redrawn_view()) penumbra = c < count ? redrawn_code(c, p) : 0.0;
#endif
  imageStore(shadow_info, pixel, vec4(visibility, c < count ? float(c) : -1.0, penumbra, density));
}
