#ifndef COMMON_GLSL
#define COMMON_GLSL
float common_value() { return 0.5; }
#endif
