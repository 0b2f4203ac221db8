// Shadow GPU structs, mirrored member for member from include/penumbra/shadow/gpu_types.hpp
// (the C++ header is the source of truth and documents every field). Only mat4 / vec4 / uvec4
// members and arrays of them or of 16-byte-multiple structs: the std140 and std430 layouts are
// identical and equal to the C++ layout (tests/shadow/gpu_layout_tests.cpp checks both against
// SPIR-V reflection). No #version here: include it from a file that has one.
//
// Conventions (docs/cascades.md): matrices take positions relative to the render origin;
// shadow-map uv = ndc.xy * 0.5 + 0.5 (no flip); counts.y / info.y is the depth convention
// (0 standard, 1 reverse-Z: near -> 1, far -> 0); point lights store linear distance
// t = clamp((length(p - position.xyz) - depth_range.x) * depth_range.z, 0, 1), 1 - t under
// reverse-Z, in Vulkan cube face order +X, -X, +Y, -Y, +Z, -Z.

#ifndef PENUMBRA_SHADOW_TYPES_GLSL
#define PENUMBRA_SHADOW_TYPES_GLSL

#define PENUMBRA_MAX_CASCADES 8
#define PENUMBRA_SHADOW_LAYOUT_CASCADES 0u
#define PENUMBRA_SHADOW_LAYOUT_CLIPMAP 1u
#define PENUMBRA_DEPTH_STANDARD 0u
#define PENUMBRA_DEPTH_REVERSE_Z 1u

struct CascadeGpu {
  mat4 view_proj;  // (world - render_origin) -> clip
  vec4 params;     // x texel world size, y depth near, z depth far (along the light), w width
};

struct ShadowGpu {
  CascadeGpu cascades[PENUMBRA_MAX_CASCADES];
  vec4 splits[PENUMBRA_MAX_CASCADES / 4];  // far view distance of cascade i at [i / 4][i % 4]
  vec4 light_dir_angular;                  // xyz towards the light, w angular diameter (rad)
  vec4 pcss;       // x tan(angular / 2), y blocker search texels, z min filter, w max filter
  vec4 selection;  // x camera near, y blend fraction, z max distance, w fade fraction
  vec4 camera_position;  // xyz relative to the render origin
  vec4 camera_forward;   // xyz unit
  uvec4 counts;    // x count, y depth convention, z resolution, w layout
  uvec4 modes;     // x cascade selection (0 view distance, 1 containment)
  uvec4 redrawn[PENUMBRA_MAX_CASCADES];  // x kRedrawn* bits, yz move in texels (debug view)
  uvec4 redrawn_rect[PENUMBRA_MAX_CASCADES];  // map texels moving casters were drawn into
  vec4 window[PENUMBRA_MAX_CASCADES];    // the windowed lookups' window (pcf.glsl), z 0: none
};

// ShadowGpu.redrawn.x, SpotShadowGpu.info.z, PointShadowGpu.info.w (4 bits a face).
#define PENUMBRA_REDRAWN_WHOLE 1u
#define PENUMBRA_REDRAWN_STRIPS 2u
#define PENUMBRA_REDRAWN_MOVING 4u

// The sun's depth pass (shadow_depth.vert; gpu_types.hpp says how): anchor-relative positions to
// texels of a grid fixed in light space.
struct CascadeDrawGpu {
  mat4 to_texels;  // (world - anchor) -> xy grid texels, z depth
  vec4 scale;      // x 2 / P (the viewport's side P)
};

struct ShadowDrawGpu {
  CascadeDrawGpu cascades[PENUMBRA_MAX_CASCADES];
};

struct SpotShadowGpu {
  mat4 view_proj;
  vec4 position_near;  // xyz relative to the render origin, w near
  vec4 direction_far;  // xyz unit axis, w far
  vec4 params;         // x cos(outer), y tan(outer), z texel world size at distance 1
  uvec4 info;          // x resolution, y depth convention, z redrawn bits (debug view)
};

struct PointShadowGpu {
  mat4 face_view_proj[6];  // +X, -X, +Y, -Y, +Z, -Z
  vec4 position;           // xyz relative to the render origin
  vec4 depth_range;        // x near, y far, z 1 / (far - near), w clip near
  uvec4 info;              // x face mask, y depth convention, z resolution, w redrawn bits
};

#endif  // PENUMBRA_SHADOW_TYPES_GLSL
