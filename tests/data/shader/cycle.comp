#version 460
#include "inc/cycle_a.glsl"
layout(local_size_x = 1) in;
void main() {}
