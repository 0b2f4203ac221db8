#version 460
// Screen-space contact shadows: one invocation per pixel marches the depth buffer towards the
// directional light (penumbra/contact_shadows.glsl) and writes the mask, 1 = lit. Recorded by
// penumbra::render::ContactShadowPass after shaders/depth_resolve.comp has copied the depth
// into an R32F image that a linear sampler can filter.

#include "penumbra/contact_shadows.glsl"

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

// Which depth reads the march makes. Both on in the product; the tests switch one off to show
// that the mask then goes wrong (see contact_dual_test).
layout(constant_id = 0) const bool kBilinearRead = true;
layout(constant_id = 1) const bool kNearestRead = true;

// The R32F copy of the depth buffer, through a linear clamp-to-edge sampler.
layout(set = 0, binding = 0) uniform sampler2D filtered_depth;
// The depth buffer itself (any depth format), read with texelFetch.
layout(set = 0, binding = 1) uniform sampler2D scene_depth;
// View-space normals in xyz (x right, y down, z forward), read with texelFetch; with
// params.caster_mask, alpha >= 0.75 marks the surfaces that cast shadows.
layout(set = 0, binding = 2) uniform sampler2D scene_normals;
layout(set = 0, binding = 3, r8) uniform writeonly image2D contact_mask;

layout(push_constant) uniform ContactShadowPush { ContactShadowGpu params; } pc;

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(pixel, imageSize(contact_mask)))) return;
  vec3 normal = texelFetch(scene_normals, pixel, 0).xyz;
  float mask = contact_shadow_surfaces(filtered_depth, scene_depth, scene_normals, pixel, normal,
                                       pc.params, kBilinearRead, kNearestRead);
  imageStore(contact_mask, pixel, vec4(mask));
}
