#pragma once

// A mesh's triangles in clusters for the shadow maps' partial draws: sorted along a space-filling
// curve (meshoptimizer's spatial sort) and cut into runs of at most `per_cluster` triangles, each
// with its bounds. A shadow map drawn only in a rectangle then draws the clusters that can reach
// it, not the whole mesh. A depth-only draw's result does not depend on the order of its
// triangles (each texel keeps the nearest fragment), so a map drawn from the sorted indices is
// the map drawn from the mesh's own.

#include <cstdint>
#include <penumbra/scene/mesh.hpp>
#include <span>
#include <vector>

namespace penumbra::render {

struct Cluster {
  uint32_t first_index = 0, index_count = 0;  // a range of ClusteredMesh::indices
  scene::Bounds bounds;                       // of its triangles' vertices, in the mesh's space
};

struct ClusteredMesh {
  std::vector<uint32_t> indices;  // every triangle of the mesh once, cluster after cluster
  std::vector<Cluster> clusters;  // in index order, covering `indices`
};

// Triangles per cluster for the renderer's casters: small enough that a moving caster's rectangle
// takes a few hundred triangles of a large mesh, large enough that a whole draw stays a handful of
// draw calls (the 69,666-triangle bunny: 137 clusters).
inline constexpr uint32_t kClusterTriangles = 512;

// The clusters of a triangle list (3 indices per triangle, each < vertices.size()); a mesh of
// at most 2 * per_cluster triangles is one cluster in its own order. per_cluster >= 1.
ClusteredMesh cluster_triangles(std::span<const scene::Vertex> vertices,
                                std::span<const uint32_t> indices,
                                uint32_t per_cluster = kClusterTriangles);

}  // namespace penumbra::render
