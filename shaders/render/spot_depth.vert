#version 460
// Spot-light shadow depth: perspective from the cone.
#include "penumbra/shadow_types.glsl"
#include "penumbra/frame_types.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(set = 0, binding = 0) uniform SpotBlock { SpotShadowGpu spots[kMaxSpotLights]; };
layout(push_constant) uniform Push { DrawPush draw; };

layout(location = 0) out vec2 out_uv;

void main() {
  out_uv = in_uv;
  gl_Position = spots[draw.index.x].view_proj * (draw.model * vec4(in_position, 1.0));
}
