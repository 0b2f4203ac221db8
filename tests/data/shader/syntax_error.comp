#version 460
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer Out { float result; };
void main() {
  float x = ;
  result = x;
}
