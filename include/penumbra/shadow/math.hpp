#pragma once

// Light-space building blocks, all in double: an orthonormal basis for any direction, view
// matrices and Vulkan projections (clip z in [0, 1]) written by hand.
//
// Shadow view space (the space these projections take as input) is right-handed with +z
// pointing *away from the light* along its direction and x, y mapping to NDC x, y without any
// flip: ndc.x grows with view x, ndc.y grows with view y. Shadow maps are sampled with
//     uv = ndc.xy * 0.5 + 0.5
// which matches what the rasterizer wrote with a standard viewport (x, y, w, h) = (0, 0, W, H):
// Vulkan's NDC y = -1 is framebuffer row 0, and uv.y = 0 is texel row 0. Viewed as a picture,
// a shadow map therefore shows light-space +y downwards; nothing reads it that way.

#include <glm/glm.hpp>
#include <penumbra/shadow/types.hpp>

namespace penumbra::shadow {

// Right-handed orthonormal basis: cross(x, y) == z.
struct Basis {
  glm::dvec3 x{1.0, 0.0, 0.0};
  glm::dvec3 y{0.0, 1.0, 0.0};
  glm::dvec3 z{0.0, 0.0, 1.0};
};

// Normalizes a direction robustly (scales by the largest component first, so 1e-300 and 1e300
// both work). Throws penumbra::Error naming `what` when the direction is zero or not finite.
glm::dvec3 normalize_direction(const glm::dvec3& direction, const char* what);

// Orthonormal basis with z = normalize(direction), from Duff et al., "Building an Orthonormal
// Basis, Revisited" (JCGT 2017), evaluated in double with the pole axis moved to world +Y: the
// formula is exact at and around +-Y (a sun straight overhead or a light pointing straight up),
// and its one discontinuity (the copysign) is where the direction's y changes sign, i.e. when
// a directional light crosses the horizon. A sun moving across the sky never flips its basis.
// Orthonormal to ~1e-16 for every finite non-zero direction. Throws on zero / non-finite input.
Basis orthonormal_basis(const glm::dvec3& direction);

// World -> view matrix whose rows are the basis vectors: view = (dot(x, p - eye),
// dot(y, p - eye), dot(z, p - eye)).
glm::dmat4 view_matrix(const Basis& basis, const glm::dvec3& eye = glm::dvec3(0.0));

// Orthographic projection of the view-space box [lo, hi] to clip space: x, y to [-1, 1]
// (lo -> -1), z (distance along the light) to depth by the convention (reverse_z: lo.z -> 1,
// hi.z -> 0). Requires lo < hi on every axis.
glm::dmat4 orthographic_projection(const glm::dvec3& lo, const glm::dvec3& hi,
                                   DepthConvention depth);

// Perspective projection looking along view +z: clip = (x / tan_half_x, y / tan_half_y,
// A z + B, z), so ndc.x = +-1 at x / z = +-tan_half_x. Depth is hyperbolic, near -> 1 and
// far -> 0 under reverse_z (near -> 0, far -> 1 under standard). Requires 0 < near < far.
glm::dmat4 perspective_projection(double tan_half_x, double tan_half_y, double near, double far,
                                  DepthConvention depth);

// clip = m * (p, 1); returns (ndc.x, ndc.y, depth) after the perspective divide.
glm::dvec3 project_point(const glm::dmat4& m, const glm::dvec3& p);

// uv = ndc.xy * 0.5 + 0.5 (see the convention above).
inline glm::dvec2 ndc_to_uv(const glm::dvec2& ndc) {
  return ndc * 0.5 + 0.5;
}

// True when every entry is finite.
bool is_finite(const glm::dmat4& m);

}  // namespace penumbra::shadow
