#version 460
#ifndef FOO
#error FOO must be defined
#endif
layout(local_size_x = WIDTH) in;
layout(std430, binding = 0) buffer Out { float result[WIDTH]; };
void main() {
  result[gl_LocalInvocationIndex] = SCALE;
}
