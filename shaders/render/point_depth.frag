#version 460
// Point-light cube face depth: linear distance from the light mapped to [0, 1] over the map's
// depth range (1 - t under reverse-Z), as PointShadowGpu documents.
#include "penumbra/shadow_types.glsl"
#include "penumbra/frame_types.glsl"
#include "render/alpha_mask.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec2 in_uv;

layout(set = 0, binding = 0) uniform PointBlock { PointShadowGpu points[kMaxPointLights]; };
layout(push_constant) uniform Push { DrawPush draw; };

void main() {
  if (draw_alpha_discards(draw, in_uv)) discard;
  PointShadowGpu p = points[draw.index.y];
  float t = clamp((length(in_position - p.position.xyz) - p.depth_range.x) * p.depth_range.z, 0.0, 1.0);
  gl_FragDepth = p.info.y == 1u ? 1.0 - t : t;
}
