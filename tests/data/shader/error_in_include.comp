#version 460
// The error is on line 4 of inc/bad.glsl, not here.
#include "inc/good.glsl"
#include "inc/bad.glsl"
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer Out { float result; };
void main() {
  result = good() + bad();
}
