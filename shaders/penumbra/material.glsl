// Procedural alpha masks of masked materials (fences, leaves): pure functions of the surface uv.
#ifndef PENUMBRA_MATERIAL_GLSL
#define PENUMBRA_MATERIAL_GLSL

const int kMaskNone = 0;
const int kMaskTexture = 1;  // not procedural: callers sample their texture instead
const int kMaskStripes = 2;
const int kMaskChecker = 3;
const int kMaskCircles = 4;

// Coverage in [0, 1] of a procedural mask at uv scaled by `scale` (1 = opaque).
float procedural_mask(vec2 uv, int pattern, vec2 scale) {
  vec2 p = uv * scale;
  if (pattern == kMaskStripes) return fract(p.x) < 0.5 ? 1.0 : 0.0;
  if (pattern == kMaskChecker) return ((int(floor(p.x)) + int(floor(p.y))) & 1) == 0 ? 1.0 : 0.0;
  if (pattern == kMaskCircles) return length(fract(p) - 0.5) > 0.3 ? 1.0 : 0.0;
  return 1.0;
}

// True when the fragment is cut out by the alpha test.
bool alpha_test_discards(vec2 uv, int pattern, vec2 scale, float cutoff) {
  return procedural_mask(uv, pattern, scale) < cutoff;
}

#endif
