#version 460
// Temporal accumulation of every light's visibility (shadows.temporal): per pixel, the last
// frame's accumulated visibility at the same surface point (reprojected through this frame's
// depth, checked against the last frame's distance and normal there) is clamped to the range of
// this frame's 3x3 neighbourhood and blended with this frame's resolve (penumbra/temporal.glsl).
// Inputs: the sun's resolve (shadow-info .r) and the local lights' (local-shadow, spot 0,
// spot 1, point 0, point 1), whichever the scene has. Outputs: temporal-local (rgba16f, the local
// lights' accumulated visibility) and temporal-aux (rgba32f: x the sun's accumulated visibility,
// y the distance to the eye (0: sky), zw the view-space normal, octahedral). The forward pass
// reads them in place of the resolves' images; the renderer copies them into the history for
// the next frame.
#include "penumbra/frame_types.glsl"
#include "penumbra/temporal.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform FrameBlock { FrameGpu frame; };
layout(set = 0, binding = 1) uniform TemporalBlock { TemporalGpu temporal; };
layout(set = 0, binding = 2) uniform sampler2D scene_depth;   // nearest
layout(set = 0, binding = 3) uniform sampler2D scene_normal;  // nearest, view space
#if PENUMBRA_SUN_SHADOWS > 0
layout(set = 0, binding = 4) uniform sampler2D shadow_info;  // the sun's resolve, .r
#endif
#if PENUMBRA_LOCAL_SHADOWS > 0
layout(set = 0, binding = 5) uniform sampler2D local_shadow;  // the local lights' resolve
#endif
layout(set = 0, binding = 6) uniform sampler2D history_local;  // the last frame's outputs
layout(set = 0, binding = 7) uniform sampler2D history_aux;
layout(set = 0, binding = 8, rgba16f) uniform writeonly image2D out_local;
layout(set = 0, binding = 9, rgba32f) uniform writeonly image2D out_aux;

// A reprojected point is on the last frame's surface when the normals agree within this cosine
// (26 degrees): across a crease the distance may agree while the surface does not.
const float kSameNormalCos = 0.9;
// Bilinear taps lighter than this are not read; the history is used when the taps on the same
// surface carry at least kMinHistoryWeight of the bilinear weight.
const float kTapWeight = 1e-3;
const float kMinHistoryWeight = 0.5;

// This frame's visibility at a pixel: the sun in x, the local lights in yzw of local.
void current_at(ivec2 p, out float sun, out vec4 local) {
  sun = 1.0;
  local = vec4(1.0);
#if PENUMBRA_SUN_SHADOWS > 0
  sun = texelFetch(shadow_info, p, 0).r;
#endif
#if PENUMBRA_LOCAL_SHADOWS > 0
  local = texelFetch(local_shadow, p, 0);
#endif
}

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  ivec2 size = ivec2(frame.viewport.xy);
  if (any(greaterThanEqual(pixel, size))) return;
  float sun;
  vec4 local;
  current_at(pixel, sun, local);
  vec4 nrm = texelFetch(scene_normal, pixel, 0);
  if (nrm.a == 0.0) {  // sky: nothing to accumulate
    imageStore(out_local, pixel, local);
    imageStore(out_aux, pixel, vec4(sun, 0.0, 0.0, 0.0));
    return;
  }
  float depth = texelFetch(scene_depth, pixel, 0).r;
  vec2 uv = (vec2(pixel) + 0.5) * frame.viewport.zw;
  vec4 h = frame.inv_view_proj * vec4(uv * 2.0 - 1.0, depth, 1.0);
  vec3 p = h.xyz / h.w;                         // world - origin
  vec3 view_pos = (frame.view * vec4(p, 1.0)).xyz;
  float distance = length(view_pos);

  // This frame's neighbourhood range (geometry pixels only).
  float sun_lo = sun, sun_hi = sun;
  vec4 local_lo = local, local_hi = local;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      ivec2 q = pixel + ivec2(dx, dy);
      if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
      if (texelFetch(scene_normal, q, 0).a == 0.0) continue;
      float s;
      vec4 l;
      current_at(q, s, l);
      sun_lo = min(sun_lo, s);
      sun_hi = max(sun_hi, s);
      local_lo = min(local_lo, l);
      local_hi = max(local_hi, l);
    }
  }

  float out_sun = sun;
  vec4 out_l = local;
  if (temporal.params.y > 0.0) {
    // The point in the last frame: its view-space position, normal and pixel.
    vec3 prev_pos = (temporal.to_previous_view * vec4(p, 1.0)).xyz;
    vec3 world_n = transpose(mat3(frame.view)) * nrm.xyz;
    vec3 prev_n = normalize(mat3(temporal.to_previous_view) * world_n);
    float prev_distance = length(prev_pos);
    vec3 at = temporal_reproject(temporal.previous_proj, prev_pos, vec2(size));
    if (at.z > 0.0) {
      vec2 f = floor(at.xy);
      vec2 a = at.xy - f;
      float weight_sum = 0.0;
      float sun_sum = 0.0;
      vec4 local_sum = vec4(0.0);
      for (int k = 0; k < 4; ++k) {
        ivec2 o = ivec2(k & 1, k >> 1);
        ivec2 q = ivec2(f) + o;
        float w = (o.x == 1 ? a.x : 1.0 - a.x) * (o.y == 1 ? a.y : 1.0 - a.y);
        if (w <= kTapWeight || any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size)))
          continue;
        vec4 aux = texelFetch(history_aux, q, 0);
        if (!temporal_same_surface(aux.y, oct_decode(aux.zw), prev_distance, prev_n,
                                   temporal.params.z, temporal.params.w, kSameNormalCos))
          continue;
        weight_sum += w;
        sun_sum += w * aux.x;
        local_sum += w * texelFetch(history_local, q, 0);
      }
      if (weight_sum >= kMinHistoryWeight) {
        float weight = temporal.params.x;
        out_sun = temporal_blend(vec4(sun_sum / weight_sum), vec4(sun), vec4(sun_lo),
                                 vec4(sun_hi), weight).x;
        out_l = temporal_blend(local_sum / weight_sum, local, local_lo, local_hi, weight);
      }
    }
  }
  imageStore(out_local, pixel, out_l);
  imageStore(out_aux, pixel, vec4(out_sun, distance, oct_encode(nrm.xyz)));
}
