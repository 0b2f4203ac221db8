#ifndef LEFT_GLSL
#define LEFT_GLSL
#include "common.glsl"
float left() { return common_value() + 1.0; }
#endif
