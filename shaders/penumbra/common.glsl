// Shared constants of the Penumbra GLSL library. Keep this file tiny: constants only, no
// functions, so that any library file can include it. No #version here: include it from a file
// that has one.

#ifndef PENUMBRA_COMMON_GLSL
#define PENUMBRA_COMMON_GLSL

const float kPi = 3.14159265358979323846;        // pi, rounded to float
const float kTwoPi = 6.28318530717958647692;     // 2 pi, rounded to float
const float kHalfPi = 1.57079632679489661923;    // pi / 2, rounded to float
const float kInvPi = 0.31830988618379067154;     // 1 / pi, rounded to float
const float kInvTwoPi = 0.15915494309189533577;  // 1 / (2 pi), rounded to float

// +infinity (glslang folds 1.0 / 0.0 to it), and the largest finite float (2 - 2^-23) * 2^127.
const float kInfinity = 1.0 / 0.0;
const float kFloatMax = 3.40282347e38;

#endif  // PENUMBRA_COMMON_GLSL
