// NaN and infinity tests on the bits, for every file of the library. On the bits because
// isnan()/isinf() may be folded away by drivers that assume no NaNs (fast-math); these are
// exact everywhere. No #version here: include it from a file that has one.

#ifndef PENUMBRA_FINITE_GLSL
#define PENUMBRA_FINITE_GLSL

// True when x is neither NaN nor an infinity.
bool penumbra_is_finite(float x) {
  return (floatBitsToUint(x) & 0x7fffffffu) < 0x7f800000u;
}

// True when every component is finite.
bool penumbra_is_finite(vec3 v) {
  return penumbra_is_finite(v.x) && penumbra_is_finite(v.y) && penumbra_is_finite(v.z);
}

// True when x is NaN.
bool penumbra_is_nan(float x) {
  return (floatBitsToUint(x) & 0x7fffffffu) > 0x7f800000u;
}

#endif  // PENUMBRA_FINITE_GLSL
