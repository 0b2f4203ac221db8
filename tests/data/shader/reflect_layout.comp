#version 460
// Layout reference for the reflection tests: the expected offsets are worked out by hand in
// tests/shader/reflection_test.cpp.
layout(local_size_x = 8, local_size_y = 4, local_size_z = 2) in;

layout(constant_id = 0) const uint kTaps = 16;
layout(constant_id = 3) const float kRadius = 1.5;
layout(constant_id = 5) const bool kReverseZ = true;

struct Inner {
  vec3 dir;
  float weight;
};

struct Light {
  vec3 color;
  float intensity;
  Inner inner[2];
  mat3 basis;
};

layout(std140, set = 0, binding = 0) uniform Params {
  vec3 a;
  float b;
  mat3 m;
  float f[3];
  vec3 v[2];
  Inner s;
  Light lights[2];
  float tail;
  vec2 uv;
} params;

layout(std430, set = 0, binding = 1) buffer Data {
  vec3 a;
  float b;
  mat3 m;
  float f[3];
  vec3 v[2];
  Inner s;
  Light lights[2];
  float tail;
  vec2 uv;
  float rt[];
} data;

layout(push_constant) uniform Push {
  mat4 view_proj;
  vec4 tint;
  uint count;
  float bias;
} pc;

void main() {
  float sum = params.a.x + params.b + params.m[0].x + params.f[1] + params.v[1].y + params.s.weight +
              params.lights[1].inner[1].weight + params.lights[0].basis[2].z + params.tail +
              params.uv.y;
  sum += data.a.x + data.b + data.m[1].y + data.f[2] + data.v[0].z + data.s.dir.x +
         data.lights[1].intensity + data.tail + data.uv.x;
  sum += pc.view_proj[0].x + pc.tint.w + float(pc.count) + pc.bias;
  sum += float(kTaps) * kRadius * (kReverseZ ? 1.0 : -1.0);
  data.rt[gl_GlobalInvocationID.x] = sum;
}
