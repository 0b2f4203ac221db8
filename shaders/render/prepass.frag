#version 460
// Depth + normal prepass: view-space normal in rgb (unit; the contact pass reads view space),
// in alpha 1 for geometry that casts shadows, 0.5 for geometry that casts none (the contact pass
// then ignores it as an occluder), and sky stays 0.
#include "penumbra/frame_types.glsl"
#include "render/alpha_mask.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(set = 0, binding = 0) uniform FrameBlock { FrameGpu frame; };
layout(push_constant) uniform Push { DrawPush draw; };

layout(location = 0) out vec4 out_normal;

void main() {
  if (draw_alpha_discards(draw, in_uv)) discard;
  vec3 n = normalize(in_normal);
  out_normal = vec4(mat3(frame.view) * (gl_FrontFacing ? n : -n), draw.index.z != 0u ? 1.0 : 0.5);
}
