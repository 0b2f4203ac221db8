// b includes a: a cycle
#include "cycle_a.glsl"
float cycle_b() { return 2.0; }
