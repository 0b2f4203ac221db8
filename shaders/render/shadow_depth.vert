#version 460
// Shadow depth pass of the directional light: one draw per caster per cascade layer. Positions
// go to texels of a grid fixed in light space, in steps of 1/256 texel, less the whole-texel
// offset of the draw (index.y: x in the low 16 bits, y in the high): every step exact, so a grid
// texel drawn at the same window position is drawn the same every time (CascadeDrawGpu,
// include/penumbra/shadow/gpu_types.hpp).
#include "penumbra/shadow_types.glsl"
#include "penumbra/frame_types.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(set = 0, binding = 0) uniform ShadowDrawBlock { ShadowDrawGpu shadow; };
layout(push_constant) uniform Push { DrawPush draw; };

layout(location = 0) out vec2 out_uv;

void main() {
  out_uv = in_uv;
  CascadeDrawGpu c = shadow.cascades[draw.index.x];
  vec4 t = c.to_texels * (draw.model * vec4(in_position, 1.0));
  vec2 offset = vec2(float(draw.index.y & 0xffffu), float(draw.index.y >> 16));
  vec2 window = round(t.xy * 256.0) / 256.0 - offset;
  gl_Position = vec4(window * c.scale.x - 1.0, t.z, 1.0);
}
