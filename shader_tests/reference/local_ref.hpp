#pragma once
// PcssLocalParams of shaders/penumbra/local_shadow.glsl, member for member, for the tests of the
// spot and point light filters (local_shadow_tests.cpp, cube_shadow_tests.cpp).
#include <penumbra/testing/values.hpp>

namespace penumbra::local_ref {
struct PcssLocalParams {
  float light_radius = 0, texel_at_unit = 0, near = 0, far = 0, max_search_texels = 0,
        min_filter_texels = 0, max_filter_texels = 0, confidence_fraction = 0;
};
}  // namespace penumbra::local_ref

PENUMBRA_GLSL_STRUCT(penumbra::local_ref::PcssLocalParams, "PcssLocalParams", light_radius,
                     texel_at_unit, near, far, max_search_texels, min_filter_texels,
                     max_filter_texels, confidence_fraction);
