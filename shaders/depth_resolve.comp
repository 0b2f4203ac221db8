#version 460
// Copies a depth buffer into an R32F image, value for value. Lavapipe (and other devices) cannot
// filter depth formats linearly, but can filter R32F: the contact-shadow march reads this copy
// through a linear sampler for its bilinear depth read. The values stay hyperbolic (not view
// depth): on a plane they are affine in screen space, so bilinear filtering is exact there.

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(set = 0, binding = 0) uniform sampler2D scene_depth;
layout(set = 0, binding = 1, r32f) uniform writeonly image2D resolved_depth;

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(pixel, imageSize(resolved_depth)))) return;
  imageStore(resolved_depth, pixel, vec4(texelFetch(scene_depth, pixel, 0).r));
}
