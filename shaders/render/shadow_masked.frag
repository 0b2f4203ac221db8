#version 460
// Alpha-tested shadow casters (fences): the opaque pipeline has no fragment stage at all.
#include "penumbra/frame_types.glsl"
#include "penumbra/material.glsl"

layout(location = 0) in vec2 in_uv;
layout(push_constant) uniform Push { DrawPush draw; };

void main() {
  if (alpha_test_discards(in_uv, int(draw.mask.x), draw.mask.zw, draw.mask.y)) discard;
}
