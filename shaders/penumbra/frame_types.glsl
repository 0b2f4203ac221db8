// Renderer GPU structs, mirrored member for member from include/penumbra/render/frame_types.hpp
// (checked against SPIR-V reflection in tests/render). Positions are relative to the render
// origin (the camera).
#ifndef PENUMBRA_FRAME_TYPES_GLSL
#define PENUMBRA_FRAME_TYPES_GLSL

const int kMaxSpotLights = 2;
const int kMaxPointLights = 2;

struct LightGpu {
  vec4 position_range;
  vec4 direction_cos;
  vec4 color_intensity;
  vec4 params;
};

struct FrameGpu {
  mat4 view;
  mat4 proj;
  mat4 view_proj;
  mat4 inv_view_proj;
  vec4 camera_position;
  vec4 camera_forward;
  vec4 sun_direction;
  vec4 sun_color;
  vec4 ambient;
  vec4 viewport;
  vec4 projection;
  vec4 bias;
  vec4 filter_params;
  uvec4 mode;
  uvec4 counts;
  LightGpu spots[kMaxSpotLights];
  LightGpu points[kMaxPointLights];
  vec4 pcss;  // x: PCSS confidence fraction; y, z, w: local lights' PCSS search, min, max filter texels
  vec4 filter_world;  // x: 1 keeps PCF / Poisson widths constant in world units across cascades
  vec4 evsm;  // x: exponent (clamped for the format), y: min variance, z: bleed reduction, w: 1 fp16
};

struct TemporalGpu {
  mat4 to_previous_view;
  mat4 previous_proj;
  vec4 params;
};

struct DrawPush {
  mat4 model;
  vec4 albedo;
  vec4 mask;
  uvec4 index;
};

#include "penumbra/filters.glsl"  // kFilterHard ...: generated from the filter table

const uint kViewLit = 0u;
const uint kViewShadowFactor = 1u;
const uint kViewCascades = 2u;
const uint kViewContactMask = 3u;
const uint kViewTexelDensity = 4u;
const uint kViewPenumbra = 5u;
const uint kViewRedrawn = 6u;

#endif
