#pragma once

// Mesh invariants shared by the scene tests.

#include <gtest/gtest.h>

#include <cmath>
#include <glm/glm.hpp>
#include <penumbra/scene/mesh.hpp>

namespace penumbra::scene::testing {

// 6 x the signed volume enclosed by the triangles (positive when they wind CCW seen from
// outside, i.e. their normals point out), about `origin`.
inline double signed_volume(const Mesh& mesh, glm::dvec3 origin = glm::dvec3(0.0)) {
  double sum = 0.0;
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const glm::dvec3 a = glm::dvec3(mesh.vertices[mesh.indices[t]].position) - origin;
    const glm::dvec3 b = glm::dvec3(mesh.vertices[mesh.indices[t + 1]].position) - origin;
    const glm::dvec3 c = glm::dvec3(mesh.vertices[mesh.indices[t + 2]].position) - origin;
    sum += glm::dot(a, glm::cross(b, c));
  }
  return sum / 6.0;
}

// Indices in range, finite positions, unit normals, uvs finite, bounds equal to the positions'
// bounds, and each (non-degenerate) triangle wound CCW with respect to its vertex normals.
inline void expect_valid_mesh(const Mesh& mesh, double min_winding_fraction = 1.0) {
  ASSERT_FALSE(mesh.vertices.empty()) << mesh.name;
  ASSERT_EQ(mesh.indices.size() % 3, 0u) << mesh.name;
  Bounds bounds;
  std::size_t bad_normals = 0;
  for (const Vertex& v : mesh.vertices) {
    ASSERT_TRUE(std::isfinite(v.position.x) && std::isfinite(v.position.y) &&
                std::isfinite(v.position.z))
        << mesh.name;
    ASSERT_TRUE(std::isfinite(v.uv.x) && std::isfinite(v.uv.y)) << mesh.name;
    const float len = glm::length(v.normal);
    if (!(std::abs(len - 1.0f) < 1e-4f)) ++bad_normals;
    bounds.extend(v.position);
  }
  EXPECT_EQ(bad_normals, 0u) << mesh.name << ": normals not unit length";
  EXPECT_EQ(bounds.min, mesh.bounds.min) << mesh.name;
  EXPECT_EQ(bounds.max, mesh.bounds.max) << mesh.name;
  std::size_t checked = 0;
  std::size_t agreeing = 0;
  for (std::size_t t = 0; t < mesh.indices.size(); t += 3) {
    for (std::size_t k = 0; k < 3; ++k) ASSERT_LT(mesh.indices[t + k], mesh.vertices.size());
    const Vertex& a = mesh.vertices[mesh.indices[t]];
    const Vertex& b = mesh.vertices[mesh.indices[t + 1]];
    const Vertex& c = mesh.vertices[mesh.indices[t + 2]];
    const glm::vec3 face = glm::cross(b.position - a.position, c.position - a.position);
    if (!(glm::length(face) > 1e-12f)) continue;  // degenerate
    ++checked;
    if (glm::dot(face, a.normal + b.normal + c.normal) > 0.0f) ++agreeing;
  }
  ASSERT_GT(checked, 0u) << mesh.name;
  EXPECT_GE(static_cast<double>(agreeing), min_winding_fraction * static_cast<double>(checked))
      << mesh.name << ": " << checked - agreeing << " of " << checked
      << " triangles wound against their normals";
}

}  // namespace penumbra::scene::testing
