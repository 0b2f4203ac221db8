#version 460
// Forward lighting: sun (visibility from the resolve), spot and point lights (visibility from the
// local-light resolve), the contact mask on the primary light's, hemispheric ambient. HDR output.
#include "penumbra/common.glsl"
#include "penumbra/frame_types.glsl"
#include "penumbra/shadow_types.glsl"
#include "render/alpha_mask.glsl"

#ifndef PENUMBRA_SUN_SHADOWS
#define PENUMBRA_SUN_SHADOWS 0
#endif
#ifndef PENUMBRA_CONTACT
#define PENUMBRA_CONTACT 0
#endif
#ifndef PENUMBRA_SPOT_SHADOWS
#define PENUMBRA_SPOT_SHADOWS 0
#endif
#ifndef PENUMBRA_POINT_SHADOWS
#define PENUMBRA_POINT_SHADOWS 0
#endif
#ifndef PENUMBRA_VISIBILITY_OUTPUT
#define PENUMBRA_VISIBILITY_OUTPUT 0
#endif

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(set = 0, binding = 0) uniform FrameBlock { FrameGpu frame; };
#if PENUMBRA_SUN_SHADOWS
layout(set = 0, binding = 1) uniform sampler2D shadow_info;
#endif
#if PENUMBRA_CONTACT
layout(set = 0, binding = 2) uniform sampler2D contact_mask;
#endif
#if PENUMBRA_SPOT_SHADOWS > 0 || PENUMBRA_POINT_SHADOWS > 0
// The local lights' filtered visibility (local_shadow_resolve.comp): spot 0, spot 1, point 0,
// point 1.
layout(set = 0, binding = 3) uniform sampler2D local_shadow;
#define PENUMBRA_LOCAL_SHADOWS 1
#else
#define PENUMBRA_LOCAL_SHADOWS 0
#endif

layout(push_constant) uniform Push { DrawPush draw; };
layout(location = 0) out vec4 out_color;
#if PENUMBRA_VISIBILITY_OUTPUT
// Each light's visibility exactly as the lighting below uses it, for the ray-traced reference:
// slot 0 the sun, 1 + i spot i, 1 + kMaxSpotLights + i point i; slots 0-3 in out_visibility0,
// 4-7 in out_visibility1 (RendererOptions::visibility_output).
layout(location = 1) out vec4 out_visibility0;
layout(location = 2) out vec4 out_visibility1;
#endif

float spot_cone(LightGpu l, vec3 to_light_unit) {
  float c = dot(-to_light_unit, l.direction_cos.xyz);
  return smoothstep(l.direction_cos.w, max(l.params.x, l.direction_cos.w + 1e-4), c);
}

float range_falloff(float dist, float range) {
  float x = clamp(1.0 - pow(dist / range, 4.0), 0.0, 1.0);
  return x * x / (dist * dist + 1.0);
}


void main() {
  if (draw_alpha_discards(draw, in_uv)) discard;
  vec3 n = normalize(in_normal);
  if (!gl_FrontFacing) n = -n;
  vec3 albedo = draw.albedo.rgb;
  vec3 brdf = albedo * kInvPi;  // Lambert; light intensities are irradiance
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec3 color = albedo * frame.ambient.rgb * (0.6 + 0.4 * n.y);
  float slot_visibility[8] = float[8](1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0);
  // The contact mask darkens the primary light (frame.counts.w: its slot).
  float contact = 1.0;
#if PENUMBRA_CONTACT
  contact = texelFetch(contact_mask, pixel, 0).r;
#endif
  uint primary = frame.counts.z != 0u ? frame.counts.w : 0xffffffffu;

  if (frame.sun_direction.w > 0.0) {
    vec3 l = frame.sun_direction.xyz;
    float visibility = 1.0;
#if PENUMBRA_SUN_SHADOWS
    visibility = texelFetch(shadow_info, pixel, 0).r;
#endif
    if (primary == 0u) visibility *= contact;
    slot_visibility[0] = visibility;
    color += brdf * frame.sun_color.rgb * frame.sun_direction.w * max(dot(n, l), 0.0) * visibility;
  }

  for (int i = 0; i < int(frame.counts.x); ++i) {
    LightGpu light = frame.spots[i];
    vec3 d = light.position_range.xyz - in_position;
    float dist = length(d);
    vec3 l = d / max(dist, 1e-6);
    float visibility = 1.0;
#if PENUMBRA_LOCAL_SHADOWS
    if (light.params.y >= 0.0) visibility = texelFetch(local_shadow, pixel, 0)[i];
#endif
    if (primary == uint(1 + i)) visibility *= contact;
    slot_visibility[1 + i] = visibility;
    color += brdf * light.color_intensity.rgb * light.color_intensity.w * max(dot(n, l), 0.0) *
             spot_cone(light, l) * range_falloff(dist, light.position_range.w) * visibility;
  }

  for (int i = 0; i < int(frame.counts.y); ++i) {
    LightGpu light = frame.points[i];
    vec3 d = light.position_range.xyz - in_position;
    float dist = length(d);
    vec3 l = d / max(dist, 1e-6);
    float visibility = 1.0;
#if PENUMBRA_LOCAL_SHADOWS
    if (light.params.y >= 0.0) visibility = texelFetch(local_shadow, pixel, 0)[kMaxSpotLights + i];
#endif
    if (primary == uint(1 + kMaxSpotLights + i)) visibility *= contact;
    slot_visibility[1 + kMaxSpotLights + i] = visibility;
    color += brdf * light.color_intensity.rgb * light.color_intensity.w * max(dot(n, l), 0.0) *
             range_falloff(dist, light.position_range.w) * visibility;
  }
  out_color = vec4(color, 1.0);
#if PENUMBRA_VISIBILITY_OUTPUT
  out_visibility0 = vec4(slot_visibility[0], slot_visibility[1], slot_visibility[2],
                         slot_visibility[3]);
  out_visibility1 = vec4(slot_visibility[4], slot_visibility[5], slot_visibility[6],
                         slot_visibility[7]);
#endif
}
