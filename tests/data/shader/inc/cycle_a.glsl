// a includes b
#include "cycle_b.glsl"
float cycle_a() { return 1.0; }
