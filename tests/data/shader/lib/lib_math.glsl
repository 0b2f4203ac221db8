#ifndef LIB_MATH_GLSL
#define LIB_MATH_GLSL
float lib_square(float x) { return x * x; }
#endif
