// Alpha masks of masked materials (fences, leaves): procedural patterns (pure functions of the
// surface uv) and mask textures (the texture comes in as an argument).
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

// Coverage in [0, 1] of a mask texture (its first channel) at uv scaled by `scale`: level 0
// through the sampler given (the renderer's: linear, repeat), so no derivatives are needed and
// the test may run in non-uniform control flow. scene::texture_mask is its C++ twin.
float texture_mask(sampler2D mask, vec2 uv, vec2 scale) {
  return textureLod(mask, uv * scale, 0.0).r;
}

#endif
