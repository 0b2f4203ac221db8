#pragma once

// Internal helpers shared by the mesh sources of penumbra::scene.

#include <glm/glm.hpp>
#include <penumbra/scene/mesh.hpp>

namespace penumbra::scene::detail {

// Appends src to dst with its positions transformed by `transform` (normals by its inverse
// transpose, renormalised). The transform must not mirror.
void append(Mesh& dst, const Mesh& src, const glm::mat4& transform);

}  // namespace penumbra::scene::detail
