#version 460
layout(location = 0) in vec3 uvw;
layout(location = 0) out vec4 color;

layout(set = 1, binding = 0) uniform sampler2DShadow shadow_map;
layout(set = 1, binding = 1) uniform sampler2DArrayShadow cascades;
layout(set = 1, binding = 2) uniform samplerCube environment;
layout(set = 1, binding = 3) uniform samplerCubeShadow point_shadow;
layout(set = 1, binding = 4) uniform texture2D albedo;
layout(set = 1, binding = 5) uniform sampler linear_sampler;
layout(set = 1, binding = 6) uniform sampler2D textures[4];
layout(set = 1, binding = 7) uniform sampler3D volume;
layout(set = 2, binding = 0, r32f) uniform image2D mask;

void main() {
  float s = texture(shadow_map, vec3(uvw.xy, 0.5));
  s += texture(cascades, vec4(uvw.xy, 1.0, 0.5));
  s += texture(point_shadow, vec4(uvw, 0.5));
  vec4 c = texture(environment, uvw);
  c += texture(sampler2D(albedo, linear_sampler), uvw.xy);
  c += texture(textures[2], uvw.xy);
  c += texture(volume, uvw);
  c.x += imageLoad(mask, ivec2(0)).x;
  color = c * s;
}
