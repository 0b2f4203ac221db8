#version 460
// Tonemap (exposure + ACES fit + sRGB) and the debug views, into an rgba8 image for PNG or the
// swapchain.
#include "penumbra/frame_types.glsl"

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

layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0) uniform FrameBlock { FrameGpu frame; };
layout(set = 0, binding = 1) uniform sampler2D hdr;
#if PENUMBRA_SUN_SHADOWS
layout(set = 0, binding = 2) uniform sampler2D shadow_info;
#endif
#if PENUMBRA_CONTACT
layout(set = 0, binding = 3) uniform sampler2D contact_mask;
#endif
layout(set = 0, binding = 4, rgba8) uniform writeonly image2D ldr;
#if PENUMBRA_SPOT_SHADOWS > 0 || PENUMBRA_POINT_SHADOWS > 0
// The local lights' visibility (local_shadow_resolve.comp): spot 0, spot 1, point 0, point 1.
layout(set = 0, binding = 5) uniform sampler2D local_shadow;
// The primary shadowed local light's debug data: x map (0 spot, 1-6 cube face, -1 none),
// y texels per pixel, z PCSS penumbra width (texels; -1 facing away).
layout(set = 0, binding = 6) uniform sampler2D local_debug;
#define PENUMBRA_LOCAL_SHADOWS 1
#else
#define PENUMBRA_LOCAL_SHADOWS 0
#endif

vec3 aces(vec3 x) {
  return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}
vec3 to_srgb(vec3 c) {
  return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}
vec3 heat(float t) {  // 0 blue → 1 red
  t = clamp(t, 0.0, 1.0);
  return clamp(vec3(1.5 - abs(4.0 * t - 3.0), 1.5 - abs(4.0 * t - 2.0), 1.5 - abs(4.0 * t - 1.0)), 0.0, 1.0);
}

// The cascades view's tint of cascade i (0-7). Selects, not a constant array indexed at run time:
// llvmpipe compiles such an index into a gather on every lane, and this shader's two arrays cost
// about 50 ms of LLVM on each new version of it (docs/hot-reload.md).
vec3 cascade_color(int i) {
  return i == 0 ? vec3(1, 0.3, 0.3)
       : i == 1 ? vec3(0.3, 1, 0.3)
       : i == 2 ? vec3(0.3, 0.5, 1)
       : i == 3 ? vec3(1, 1, 0.3)
       : i == 4 ? vec3(1, 0.3, 1)
       : i == 5 ? vec3(0.3, 1, 1)
       : i == 6 ? vec3(1, 0.6, 0.2)
                : vec3(0.7, 0.7, 0.7);
}

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(pixel, ivec2(frame.viewport.xy)))) return;
  vec3 color = texelFetch(hdr, pixel, 0).rgb * frame.ambient.w;
  vec3 out_rgb = to_srgb(aces(color));
  uint view = frame.mode.w;
  vec4 info = vec4(1.0, -1.0, 0.0, 0.0);
#if PENUMBRA_SUN_SHADOWS
  info = texelFetch(shadow_info, pixel, 0);
#elif PENUMBRA_LOCAL_SHADOWS
  // No sun: the cascade, texel-density and penumbra views show the primary shadowed local light
  // (its map, or cube face, in place of the cascade).
  vec4 ld = texelFetch(local_debug, pixel, 0);
  info = vec4(1.0, ld.x, ld.z, ld.y);
#endif
  float contact = 1.0;
#if PENUMBRA_CONTACT
  contact = texelFetch(contact_mask, pixel, 0).r;
#endif
  // The shadow factor of every light together: the product of their visibilities (1 where a
  // light does not reach) and the contact mask.
  float local = 1.0;
#if PENUMBRA_LOCAL_SHADOWS
  vec4 v = texelFetch(local_shadow, pixel, 0);
  local = v.x * v.y * v.z * v.w;
#endif
  if (view == kViewShadowFactor) out_rgb = vec3(info.r * local * contact);
  if (view == kViewCascades) {
    vec3 tint = info.g >= 0.0 ? cascade_color(int(info.g) & 7) : vec3(1.0);
    out_rgb = mix(out_rgb, tint * (0.3 + 0.7 * info.r * local), 0.6);
  }
  if (view == kViewContactMask) out_rgb = vec3(contact);
  if (view == kViewTexelDensity) {
    // Shadow-map texels per screen pixel on a log scale: 1 (green) is ideal, red undersampled
    // (one texel covers several pixels: blocky shadows), blue oversampled.
    out_rgb = info.g >= 0.0 ? heat(0.5 - log2(max(info.a, 1e-6)) / 6.0) : vec3(0.0);
  }
  if (view == kViewPenumbra) {
    // PCSS penumbra width in texels, 0 (blue) to 16+ (red), over a grey copy of the image where
    // no blocker was found.
    float grey = dot(out_rgb, vec3(0.2126, 0.7152, 0.0722)) * 0.6;
    out_rgb = info.b > 0.0 ? heat(info.b / 16.0) : vec3(grey);
  }
  if (view == kViewRedrawn) {
    // What the shadow-map cache drew this frame of the texel each pixel reads (the resolves'
    // redrawn_code): red drawn whole, yellow a strip a scrolled cascade newly reached, cyan
    // drawn again where moving casters were or are, the image in grey where the map was kept.
    float grey = dot(out_rgb, vec3(0.2126, 0.7152, 0.0722)) * 0.6;
    int code = info.g >= 0.0 ? clamp(int(info.b + 0.5), 0, 3) : 0;
    vec3 tint = code == 1   ? vec3(0.2, 0.9, 1.0)
                : code == 2 ? vec3(1.0, 0.9, 0.2)
                            : vec3(1.0, 0.25, 0.2);
    out_rgb = code == 0 ? vec3(grey) : mix(vec3(grey), tint, 0.7);
  }
  imageStore(ldr, pixel, vec4(out_rgb, 1.0));
}
