// The shadow library's umbrella: include this one file to get cascade selection and blending,
// world -> shadow-map coordinates, depth bias, and the filters (PCF, PCSS, VSM/EVSM). Each
// concern lives in its own file; see each file's header for its conventions (reverse-Z default,
// shadow factor 1 = lit, invalid coordinates lit). No #version here: include this from a stage
// file.

#ifndef PENUMBRA_SHADOW_GLSL
#define PENUMBRA_SHADOW_GLSL

#include "penumbra/bias.glsl"
#include "penumbra/cascade.glsl"
#include "penumbra/pcf.glsl"
#include "penumbra/pcss.glsl"
#include "penumbra/local_shadow.glsl"
#include "penumbra/vsm.glsl"

#endif  // PENUMBRA_SHADOW_GLSL
