#version 460
// Alpha-tested shadow casters (fences): the opaque pipeline has no fragment stage at all.
#include "penumbra/frame_types.glsl"
#include "render/alpha_mask.glsl"

layout(location = 0) in vec2 in_uv;
layout(push_constant) uniform Push { DrawPush draw; };

void main() {
  if (draw_alpha_discards(draw, in_uv)) discard;
}
