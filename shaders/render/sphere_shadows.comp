#version 460
#extension GL_EXT_control_flow_attributes : require
// Analytic sphere shadows: per pixel, every shadowed light's visibility (the sun's in the
// shadow-info image, the spots' and point lights' in the local-shadow image) times what the
// scene's analytic spheres leave of the light, in closed form (penumbra/sphere_shadow.glsl).
// Those spheres are not drawn into the shadow maps. Runs after the resolves, in place.
#include "penumbra/frame_types.glsl"
#include "penumbra/shadow_types.glsl"
#include "penumbra/sphere_shadow.glsl"

#ifndef PENUMBRA_SUN_SHADOWS
#define PENUMBRA_SUN_SHADOWS 0
#endif
#ifndef PENUMBRA_LOCAL_SHADOWS
#define PENUMBRA_LOCAL_SHADOWS 0
#endif
#ifndef PENUMBRA_ANALYTIC_SPHERES
#define PENUMBRA_ANALYTIC_SPHERES 1
#endif

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform FrameBlock { FrameGpu frame; };
layout(set = 0, binding = 1) uniform sampler2D scene_depth;  // nearest
// The spheres: xyz centre relative to the origin, w radius.
layout(set = 0, binding = 2) uniform SphereBlock {
  vec4 analytic_spheres[PENUMBRA_ANALYTIC_SPHERES];
};
#if PENUMBRA_SUN_SHADOWS
layout(set = 0, binding = 3) uniform ShadowBlock { ShadowGpu shadow; };
layout(set = 0, binding = 4, rgba16f) uniform image2D shadow_info;  // r: the sun's visibility
#endif
#if PENUMBRA_LOCAL_SHADOWS
layout(set = 0, binding = 5, rgba16f) uniform image2D local_shadow;  // spot 0, 1, point 0, 1
#endif

#if PENUMBRA_LOCAL_SHADOWS
// A shadowed spot or point light's visibility past every sphere (a product: sphere_shadow.glsl).
float local_sphere_visibility(LightGpu light, vec3 p) {
  float v = 1.0;
  for (int i = 0; i < PENUMBRA_ANALYTIC_SPHERES; ++i)
    v *= 1.0 - sphere_light_occlusion(p, light.position_range.xyz, light.params.z,
                                      analytic_spheres[i]);
  return v;
}
#endif

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(pixel, ivec2(frame.viewport.xy)))) return;
  float depth = texelFetch(scene_depth, pixel, 0).r;
  // The sky (the far plane) has no receiver.
  if (depth == (frame.mode.y == 1u ? 0.0 : 1.0)) return;
  vec2 uv = (vec2(pixel) + 0.5) * frame.viewport.zw;
  vec4 h = frame.inv_view_proj * vec4(uv * 2.0 - 1.0, depth, 1.0);
  vec3 p = h.xyz / h.w;
#if PENUMBRA_SUN_SHADOWS
  vec4 sun = imageLoad(shadow_info, pixel);
  if (sun.r > 0.0) {  // 0: in shadow already, or facing away
    float v = 1.0;
    for (int i = 0; i < PENUMBRA_ANALYTIC_SPHERES; ++i)
      v *= 1.0 - sun_sphere_occlusion(p, shadow.light_dir_angular.xyz,
                                      0.5 * shadow.light_dir_angular.w, analytic_spheres[i]);
    sun.r *= v;
    imageStore(shadow_info, pixel, sun);
  }
#endif
#if PENUMBRA_LOCAL_SHADOWS
  vec4 local = imageLoad(local_shadow, pixel);
  // One loop over the lights present, the spots then the point lights, so the spheres'
  // occlusion is compiled once, not once for each kind: llvmpipe compiled a new version of this
  // shader for the orrery (one point light, three spheres) in 98-101 ms instead of 152-170, and
  // the pass ran in 21.9 ms instead of 25.6 at 640x360 (docs/hot-reload.md). Not unrolled: the
  // copies would undo it. (A loop over all four slots, skipping the absent ones, cost a third
  // more per frame: llvmpipe runs a skipped iteration's body with no lane on.)
  int spots = int(frame.counts.x);
  [[dont_unroll]] for (int k = 0; k < spots + int(frame.counts.y); ++k) {
    bool spot = k < spots;
    int i = spot ? k : k - spots;
    int slot = spot ? i : kMaxSpotLights + i;
    LightGpu light;  // assigned, not chosen by ?: (glslang's SPIR-V for that is invalid)
    if (spot)
      light = frame.spots[i];
    else
      light = frame.points[i];
    if (light.params.y >= 0.0 && local[slot] > 0.0) local[slot] *= local_sphere_visibility(light, p);
  }
  imageStore(local_shadow, pixel, local);
#endif
}
