#version 460
layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) buffer Values {
  float values[];
};

void main() {
  uint i = gl_GlobalInvocationID.x;
  values[i] = values[i] * 2.0;
}
