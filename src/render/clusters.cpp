#include "clusters.hpp"

#include <meshoptimizer.h>

#include <algorithm>
#include <penumbra/core/error.hpp>

namespace penumbra::render {

ClusteredMesh cluster_triangles(std::span<const scene::Vertex> vertices,
                                std::span<const uint32_t> indices, uint32_t per_cluster) {
  if (per_cluster == 0 || indices.size() % 3 != 0)
    throw Error("cluster_triangles: " + std::to_string(indices.size()) +
                " indices (not whole triangles) or 0 triangles per cluster");
  for (uint32_t i : indices)
    if (i >= vertices.size())
      throw Error("cluster_triangles: index " + std::to_string(i) + " beyond the " +
                  std::to_string(vertices.size()) + " vertices");
  ClusteredMesh out;
  out.indices.assign(indices.begin(), indices.end());
  const size_t triangles = indices.size() / 3;
  if (triangles > 2 * size_t(per_cluster))
    meshopt_spatialSortTriangles(out.indices.data(), indices.data(), indices.size(),
                                 &vertices[0].position.x, vertices.size(), sizeof(scene::Vertex));
  const size_t step = triangles > 2 * size_t(per_cluster) ? size_t(per_cluster) * 3
                                                          : std::max<size_t>(indices.size(), 1);
  for (size_t first = 0; first < out.indices.size(); first += step) {
    Cluster c;
    c.first_index = uint32_t(first);
    c.index_count = uint32_t(std::min(step, out.indices.size() - first));
    for (uint32_t k = 0; k < c.index_count; ++k)
      c.bounds.extend(vertices[out.indices[first + k]].position);
    out.clusters.push_back(c);
  }
  return out;
}

}  // namespace penumbra::render
