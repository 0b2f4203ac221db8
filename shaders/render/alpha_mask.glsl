// The alpha test of a draw in the renderer's fragment stages (prepass, forward, the shadow
// casters): a procedural pattern, or one of the scene's mask textures (set 1, binding 0; the
// draw's index.w picks it). PENUMBRA_MASK_TEXTURES is the number of textures the scene samples.
#ifndef PENUMBRA_RENDER_ALPHA_MASK_GLSL
#define PENUMBRA_RENDER_ALPHA_MASK_GLSL
#include "penumbra/frame_types.glsl"
#include "penumbra/material.glsl"

#ifndef PENUMBRA_MASK_TEXTURES
#define PENUMBRA_MASK_TEXTURES 0
#endif
// 0 in the opaque pipelines, whose draws have no mask: no alpha test and no discard (a stage
// with a discard may lose the early depth test), and an edit of the masks reaches only the
// masked pipelines.
#ifndef PENUMBRA_ALPHA_TEST
#define PENUMBRA_ALPHA_TEST 1
#endif

#if PENUMBRA_MASK_TEXTURES > 0
layout(set = 1, binding = 0) uniform sampler2D mask_textures[PENUMBRA_MASK_TEXTURES];
#endif

// True when the draw's material cuts the fragment at uv out.
bool draw_alpha_discards(DrawPush d, vec2 uv) {
#if !PENUMBRA_ALPHA_TEST
  return false;
#else
  int pattern = int(d.mask.x);
#if PENUMBRA_MASK_TEXTURES > 0
  if (pattern == kMaskTexture) {
    uint t = min(d.index.w, uint(PENUMBRA_MASK_TEXTURES - 1));
    return texture_mask(mask_textures[t], uv, d.mask.zw) < d.mask.y;
  }
#endif
  return alpha_test_discards(uv, pattern, d.mask.zw, d.mask.y);
#endif
}

#endif
