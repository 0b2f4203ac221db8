#ifndef GOOD_GLSL
#define GOOD_GLSL
float good() { return 1.0; }
#endif
