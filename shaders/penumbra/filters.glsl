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

#endif
