#version 460
#extension GL_GOOGLE_include_directive : require
#include "inc/good.glsl"
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer Out { float result; };
void main() {
  result = good();
}
