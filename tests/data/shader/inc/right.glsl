#ifndef RIGHT_GLSL
#define RIGHT_GLSL
#include "common.glsl"
float right() { return common_value() + 2.0; }
#endif
