// The shadow filters' constants: FrameGpu.mode.z (the sun's and the scene's filter) and
// LightGpu.params.w (a light's own). Generated from the filter table
// (src/scene/filters.cpp) by `penumbra-filters --glsl`; do not edit.
// PenumbraFilters.GlslConstantsMatchTheTable fails when this file is out of date.
#ifndef PENUMBRA_FILTERS_GLSL
#define PENUMBRA_FILTERS_GLSL

const uint kFilterHard = 0u;  // hard
const uint kFilterPcf = 1u;  // pcf
const uint kFilterPcss = 2u;  // pcss
const uint kFilterPoisson = 3u;  // poisson
const uint kFilterEvsm2 = 4u;  // evsm2
const uint kFilterVogel = 5u;  // vogel
const uint kFilterCount = 6u;

// The same numbers for #if: PENUMBRA_FILTERS_2D and PENUMBRA_FILTERS_CUBE (shadow_filter.glsl)
// are bit sets of them.
#define PENUMBRA_FILTER_HARD 0
#define PENUMBRA_FILTER_PCF 1
#define PENUMBRA_FILTER_PCSS 2
#define PENUMBRA_FILTER_POISSON 3
#define PENUMBRA_FILTER_EVSM2 4
#define PENUMBRA_FILTER_VOGEL 5

#endif
