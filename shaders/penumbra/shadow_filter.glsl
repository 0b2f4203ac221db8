// One dispatch per map kind: the shadow filter a light uses (kFilterHard ..., filters.glsl,
// generated from the filter table in src/scene/filters.cpp), evaluated over a 2D array of
// shadow maps (the sun's cascades, the spot lights' maps) or a cube array (the point lights').
// The sun's and the local lights' resolves call these and nothing else to filter; a new filter
// is its function in the library and its case here.
//
// `allowed` is a bit set of the filters the caller may ask for (1u << kFilterX): a resolve
// specialized for its filters passes a constant, so the driver compiles only those cases.
// Unknown or unallowed filters return 1 (lit).
//
// PENUMBRA_FILTERS_2D and PENUMBRA_FILTERS_CUBE, when a stage defines them, are the same kind of
// bit set for the preprocessor (1 << PENUMBRA_FILTER_X, filters.glsl): a case outside them is
// not compiled at all, so the SPIR-V holds only the filters named there (and an edit of another
// filter's file does not change it). A filter outside them returns 1 (lit), as one outside
// `allowed` does. Undefined: every filter. Pure: every map comes in as an argument. A
// caller without moments passes any map of the same type as `moments` and never asks for
// evsm2.
#ifndef PENUMBRA_SHADOW_FILTER_GLSL
#define PENUMBRA_SHADOW_FILTER_GLSL

#include "penumbra/filters.glsl"
#include "penumbra/local_shadow.glsl"
#include "penumbra/pcf.glsl"
#include "penumbra/pcss.glsl"
#include "penumbra/vsm.glsl"

const uint kAllFilters = 0xffffffffu;

#ifndef PENUMBRA_FILTERS_2D
#define PENUMBRA_FILTERS_2D 0x7fffffff
#endif
#ifndef PENUMBRA_FILTERS_CUBE
#define PENUMBRA_FILTERS_CUBE 0x7fffffff
#endif

bool filter_allowed(uint allowed, uint mode) {
  return mode < 32u && (allowed & (1u << mode)) != 0u;
}

// The filter keys' values as the frame carries them (FrameGpu.filter_params: x the PCF radius,
// y the PCSS tier, z the Poisson taps, w the Poisson disk's radius), and the PCSS and EVSM2
// numbers a reach needs.
struct FilterExtent {
  vec4 params;
  float pcss_search_texels;      // PCSS: the blocker search's largest radius
  float pcss_min_filter_texels;  // PCSS: its smallest filter radius
  float evsm_blur;               // EVSM2: the moments' blur radius in texels
};

// Texels the filter reaches beyond the receiver's own: the border a cascade chosen by
// containment must hold around it (the filter table's reach, filters.cpp). hard 1 (one bilinear
// compare tap), PCF r + 1, the disks their radius rounded up + 1, PCSS the blocker search + 1,
// EVSM2 its blur + 1 (then bilinear).
float shadow_filter_reach_texels(uint mode, FilterExtent e) {
  if (mode == kFilterPcf) return e.params.x + 1.0;
  if (mode == kFilterPoisson || mode == kFilterVogel) return ceil(e.params.w) + 1.0;
  if (mode == kFilterPcss) return ceil(e.pcss_search_texels) + 1.0;
  if (mode == kFilterEvsm2) return e.evsm_blur + 1.0;
  return 1.0;
}

// The reach beyond one texel that widens the receiver's normal offset
// (filter_normal_offset_texels, bias.glsl). PCF's outer taps are bilinear compares centred
// `radius` texels out, which read up to one texel beyond: a spot or point light counts that
// texel (`local`); without it PCF radius 1 put a moire of acne over the indoor ceiling, which
// the point light grazes (false shadow 2.67%, mean |dV| 0.0085; with it 0.59% and 0.0036,
// docs/accuracy.md). The sun's cascades measured no better with it and keep theirs. hard and
// EVSM2: none (its bound needs no wider offset).
float shadow_filter_offset_reach(uint mode, FilterExtent e, bool local) {
  if (mode == kFilterPcf) return e.params.x + (local ? 1.0 : 0.0);
  if (mode == kFilterPoisson || mode == kFilterVogel) return e.params.w;
  if (mode == kFilterPcss) return e.pcss_min_filter_texels;
  return 0.0;
}

// What a lookup in a 2D array of maps needs besides the maps.
struct ShadowLookup2D {
  vec3 coord;         // map uv and the receiver's compare depth
  int layer;          // the cascade or the spot light's map
  vec2 texel;         // 1 / map resolution
  float rotation;     // the disks' per-pixel rotation (radians)
  bool reverse_z;
  int pcf_radius;     // pcf: the box's radius in texels
  int taps;           // poisson: its taps
  float disk_radius;  // poisson: its radius in texels
  int pcss_tier;      // pcss: pcss_search_tap_count / pcss_filter_tap_count's tier
  // pcss: the sun's directional form (pcss), or a spot light's perspective form (pcss_local,
  // with the receiver's distance along the axis and the receiver plane's depth gradient).
  bool perspective;
  PcssParams pcss;
  PcssLocalParams pcss_local;
  float receiver_distance;
  vec2 plane_gradient;
  // evsm2: exponent, min variance, bleed reduction, fp16 (w != 0); the receiver's depth as the
  // moments store it; with mips, the receiver's footprint in the map.
  vec4 evsm;
  float moments_depth;
  bool footprint;
  vec2 duv_dx, duv_dy;
};

// The filter `mode` of a lookup in the maps, read through `window` (pcf.glsl's windowed
// lookups) by the compare filters and the directional PCSS; EVSM2's moments and the perspective
// PCSS read the maps themselves (window.z must be 0 with them).
float shadow_filter_2d_array(uint mode, uint allowed, sampler2DArrayShadow compare_map,
                             sampler2DArray depth_map, sampler2DArray moments, ShadowLookup2D q,
                             vec4 window) {
#if (((PENUMBRA_FILTERS_2D) >> PENUMBRA_FILTER_HARD) & 1) != 0
  if (filter_allowed(allowed, kFilterHard) && mode == kFilterHard)
    return pcf_grid_array(compare_map, q.coord, q.layer, 0, q.texel, window);
#endif
#if (((PENUMBRA_FILTERS_2D) >> PENUMBRA_FILTER_PCF) & 1) != 0
  if (filter_allowed(allowed, kFilterPcf) && mode == kFilterPcf)
    return pcf_grid_array(compare_map, q.coord, q.layer, q.pcf_radius, q.texel, window);
#endif
#if (((PENUMBRA_FILTERS_2D) >> PENUMBRA_FILTER_POISSON) & 1) != 0
  if (filter_allowed(allowed, kFilterPoisson) && mode == kFilterPoisson)
    return pcf_poisson_array(compare_map, q.coord, q.layer, q.taps, q.disk_radius, q.rotation,
                             q.texel, window);
#endif
#if (((PENUMBRA_FILTERS_2D) >> PENUMBRA_FILTER_VOGEL) & 1) != 0
  if (filter_allowed(allowed, kFilterVogel) && mode == kFilterVogel)
    return pcf_vogel_array(compare_map, q.coord, q.layer, q.taps, q.disk_radius, q.rotation,
                           q.texel, window);
#endif
#if (((PENUMBRA_FILTERS_2D) >> PENUMBRA_FILTER_EVSM2) & 1) != 0
  if (filter_allowed(allowed, kFilterEvsm2) && mode == kFilterEvsm2) {
    vec3 c = vec3(q.coord.xy, q.moments_depth);
    if (q.footprint)
      return evsm2_sample_shadow_array_footprint(moments, c, q.layer, q.duv_dx, q.duv_dy,
                                                 q.evsm.x, q.evsm.y, q.evsm.z, q.reverse_z,
                                                 q.evsm.w != 0.0);
    return evsm2_sample_shadow_array(moments, c, q.layer, q.evsm.x, q.evsm.y, q.evsm.z,
                                     q.reverse_z, q.evsm.w != 0.0);
  }
#endif
#if (((PENUMBRA_FILTERS_2D) >> PENUMBRA_FILTER_PCSS) & 1) != 0
  if (filter_allowed(allowed, kFilterPcss) && mode == kFilterPcss) {
    if (q.perspective)
      return pcss_spot_shadow_array(compare_map, depth_map, q.coord, q.layer, q.texel,
                                    q.receiver_distance, q.pcss_local, q.pcss_tier, q.rotation,
                                    q.reverse_z, q.plane_gradient);
    return pcss_shadow_array(compare_map, depth_map, q.coord, q.layer, q.texel, q.pcss,
                             q.pcss_tier, q.rotation, q.reverse_z, window);
  }
#endif
  return 1.0;
}

// The filter `mode` of a lookup in the maps themselves.
float shadow_filter_2d_array(uint mode, uint allowed, sampler2DArrayShadow compare_map,
                             sampler2DArray depth_map, sampler2DArray moments,
                             ShadowLookup2D q) {
  return shadow_filter_2d_array(mode, allowed, compare_map, depth_map, moments, q, vec4(0.0));
}

// What a lookup in a cube array needs besides the maps.
struct ShadowLookupCube {
  vec3 dir;           // light to receiver
  int layer;          // the point light's cube
  float ref;          // the receiver's compare depth (cube_compare_depth)
  float resolution;   // a face's texels per side
  float rotation;
  bool reverse_z;
  int pcf_radius;
  int taps;
  float disk_radius;
  int pcss_tier;
  PcssLocalParams pcss_local;
  float receiver_distance;
  vec3 plane_normal;  // pcss: the receiver's normal
  vec4 evsm;          // as ShadowLookup2D's
};

float shadow_filter_cube_array(uint mode, uint allowed, samplerCubeArrayShadow compare_map,
                               samplerCubeArray depth_map, samplerCubeArray moments,
                               ShadowLookupCube q) {
#if (((PENUMBRA_FILTERS_CUBE) >> PENUMBRA_FILTER_HARD) & 1) != 0
  if (filter_allowed(allowed, kFilterHard) && mode == kFilterHard)
    return pcf_cube_array(compare_map, q.dir, q.layer, q.ref, 0, q.resolution);
#endif
#if (((PENUMBRA_FILTERS_CUBE) >> PENUMBRA_FILTER_PCF) & 1) != 0
  if (filter_allowed(allowed, kFilterPcf) && mode == kFilterPcf)
    return pcf_cube_array(compare_map, q.dir, q.layer, q.ref, q.pcf_radius, q.resolution);
#endif
#if (((PENUMBRA_FILTERS_CUBE) >> PENUMBRA_FILTER_POISSON) & 1) != 0
  if (filter_allowed(allowed, kFilterPoisson) && mode == kFilterPoisson)
    return pcf_cube_vogel_array(compare_map, q.dir, q.layer, q.ref, q.taps, q.disk_radius,
                                q.rotation, q.resolution);
#endif
#if (((PENUMBRA_FILTERS_CUBE) >> PENUMBRA_FILTER_EVSM2) & 1) != 0
  if (filter_allowed(allowed, kFilterEvsm2) && mode == kFilterEvsm2)
    return evsm2_sample_shadow_cube_array(moments, q.dir, q.layer, q.ref, q.evsm.x, q.evsm.y,
                                          q.evsm.z, q.reverse_z, q.evsm.w != 0.0);
#endif
#if (((PENUMBRA_FILTERS_CUBE) >> PENUMBRA_FILTER_PCSS) & 1) != 0
  if (filter_allowed(allowed, kFilterPcss) && mode == kFilterPcss)
    return pcss_cube_shadow_array(compare_map, depth_map, q.dir, q.layer, q.ref,
                                  q.receiver_distance, q.resolution, q.pcss_local, q.pcss_tier,
                                  q.rotation, q.reverse_z, q.plane_normal);
#endif
  return 1.0;
}

#endif
