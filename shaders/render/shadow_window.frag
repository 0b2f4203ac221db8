#version 460
// The sun's map from its grid (ShadowMapPass): map texel u of a cascade is grid texel w + u,
// stored at (w + u) mod N of the grid's layer; its depth is written as it is stored.
layout(set = 0, binding = 0) uniform sampler2DArray grid;
// x: the layer; y, z: the window's first texel modulo N; w: N.
layout(push_constant) uniform Push { ivec4 window; } push;

void main() {
  ivec2 u = (ivec2(gl_FragCoord.xy) + push.window.yz) % push.window.w;
  gl_FragDepth = texelFetch(grid, ivec3(u, push.window.x), 0).r;
}
