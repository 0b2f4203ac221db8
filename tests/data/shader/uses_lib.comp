#version 460
#include "lib_math.glsl"
#include <lib_math.glsl>
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer Out { float result; };
void main() {
  result = lib_square(3.0);
}
