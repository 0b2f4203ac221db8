#version 460
#include "inc/left.glsl"
#include "inc/right.glsl"
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer Out { float result; };
void main() {
  result = left() + right() + common_value();
}
