// examples/shader-tests/glsl/my_shading.glsl — the GLSL library of the tutorial in docs/testing-shaders.md.
#ifndef MY_SHADING_GLSL
#define MY_SHADING_GLSL

// Lambert term with a wrap factor: max((N·L + wrap) / (1 + wrap), 0).
float wrapped_lambert(vec3 n, vec3 l, float wrap) {
  return max((dot(n, l) + wrap) / (1.0 + wrap), 0.0);
}

struct SpotLight {
  vec3 position;
  float cos_outer;
  vec3 direction;
  float cos_inner;
};

// Smooth spot cone attenuation in [0, 1]; the distance vector comes back through `to_light`.
float spot_cone(SpotLight light, vec3 p, out vec3 to_light) {
  to_light = light.position - p;
  float c = dot(normalize(-to_light), light.direction);
  return clamp((c - light.cos_outer) / max(light.cos_inner - light.cos_outer, 1e-6), 0.0, 1.0);
}

// 2×2 PCF from one bilinear hardware compare tap.
float shadow_tap(sampler2DShadow map, vec2 uv, float receiver_depth) {
  return texture(map, vec3(uv, receiver_depth));
}

#endif
