#version 460
// The sun's EVSM2 moments (shadows.filter = evsm2), in two dispatches over every cascade layer:
// PENUMBRA_EVSM_PASS 0 reads the cascade's depths, warps each into the moments of the positive
// EVSM warp and averages them along x over 2 r + 1 texels (penumbra/vsm.glsl:
// evsm2_moments_box_x, the exponent clamped for the moment format); pass 1 averages the result
// along y (moments_box_y) into the moment map the shadow resolve samples. r = push.params.x
// (shadows.evsm_blur); reads clamp at the map's edges. Cascades read in place from their toroidal
// grid are read through each layer's window, so the moments are laid out as the cascades. PENUMBRA_EVSM_FORMAT is the storage format (rg16f or rg32f). The point lights'
// cubes are read and written face by face the same way; the spot lights' maps
// (PENUMBRA_EVSM_SPOTS) are perspective and are made linear first, each layer with its own
// planes (evsm2_moments_box_x_linear).
#include "penumbra/frame_types.glsl"
#include "penumbra/shadow_types.glsl"
#include "penumbra/vsm.glsl"

#ifndef PENUMBRA_EVSM_SPOTS
#define PENUMBRA_EVSM_SPOTS 0
#endif

#ifndef PENUMBRA_EVSM_PASS
#define PENUMBRA_EVSM_PASS 0
#endif
#ifndef PENUMBRA_EVSM_FORMAT
#define PENUMBRA_EVSM_FORMAT rg32f
#endif

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform FrameBlock { FrameGpu frame; };
#if PENUMBRA_EVSM_PASS == 0
layout(set = 0, binding = 1) uniform sampler2DArray shadow_depth;  // nearest, raw depths
layout(set = 0, binding = 2, PENUMBRA_EVSM_FORMAT) uniform writeonly image2DArray moments_x;
#else
layout(set = 0, binding = 1) uniform sampler2DArray moments_x;  // nearest
layout(set = 0, binding = 2, PENUMBRA_EVSM_FORMAT) uniform writeonly image2DArray moments;
#endif
// x blur radius, y resolution; windows: each sun layer's offset on the toroidal grid it is read
// from in place (ShadowMapPass::sun_offset; 0 for a map laid out as its cascade), two a vec4.
layout(push_constant) uniform Push {
  uvec4 params;
  ivec4 windows[4];
};
#if PENUMBRA_EVSM_SPOTS && PENUMBRA_EVSM_PASS == 0
layout(set = 0, binding = 3) uniform SpotBlock { SpotShadowGpu spot_shadows[kMaxSpotLights]; };
#endif

void main() {
  ivec3 t = ivec3(gl_GlobalInvocationID);
  int size = int(params.y);
  if (t.x >= size || t.y >= size) return;
  int r = int(params.x);
#if PENUMBRA_EVSM_PASS == 0
#if PENUMBRA_EVSM_SPOTS
  SpotShadowGpu s = spot_shadows[t.z];
  vec2 m = evsm2_moments_box_x_linear(shadow_depth, t, r, size, frame.evsm.x, s.position_near.w,
                                      s.direction_far.w, s.info.y == 1u, frame.evsm.w != 0.0);
#else
  ivec4 pair = windows[min(t.z, 7) / 2];
  ivec2 window = (t.z & 1) == 0 ? pair.xy : pair.zw;
  vec2 m = evsm2_moments_box_x(shadow_depth, t, r, size, frame.evsm.x, frame.mode.y == 1u,
                               frame.evsm.w != 0.0, window);
#endif
  imageStore(moments_x, t, vec4(m, 0.0, 0.0));
#else
  imageStore(moments, t, vec4(moments_box_y(moments_x, t, r, size), 0.0, 0.0));
#endif
}
