#version 460
// Point-light cube face: face view-projection for rasterization, world position for the
// linear-distance depth the fragment stage writes.
#include "penumbra/shadow_types.glsl"
#include "penumbra/frame_types.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(set = 0, binding = 0) uniform PointBlock { PointShadowGpu points[kMaxPointLights]; };
layout(push_constant) uniform Push { DrawPush draw; };

layout(location = 0) out vec3 out_position;
layout(location = 1) out vec2 out_uv;

void main() {
  vec4 world = draw.model * vec4(in_position, 1.0);
  out_position = world.xyz;
  out_uv = in_uv;
  gl_Position = points[draw.index.y].face_view_proj[draw.index.x] * world;
}
