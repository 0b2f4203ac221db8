// cluster_triangles (src/render/clusters.cpp): the shadow maps' partial draws take a mesh's
// clusters, so every triangle must be in exactly one, as it was wound, and inside its cluster's
// bounds; the clusters must be compact enough to be worth culling.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <clusters.hpp>
#include <penumbra/core/error.hpp>
#include <penumbra/scene/mesh.hpp>
#include <vector>

namespace penumbra::render {
namespace {

using Triangle = std::array<uint32_t, 3>;

std::vector<Triangle> triangles(const std::vector<uint32_t>& indices) {
  std::vector<Triangle> out;
  for (size_t i = 0; i + 2 < indices.size(); i += 3)
    out.push_back({indices[i], indices[i + 1], indices[i + 2]});
  std::sort(out.begin(), out.end());
  return out;
}

float volume(const scene::Bounds& b) {
  const glm::vec3 s = glm::max(b.size(), glm::vec3(1e-4f));
  return s.x * s.y * s.z;
}

// Every triangle once, wound as given; the clusters cover the indices in order, none larger
// than asked, each holding its triangles' vertices.
void expect_partition(const scene::Mesh& m, const ClusteredMesh& c, uint32_t per_cluster) {
  EXPECT_EQ(triangles(c.indices), triangles(m.indices));
  uint32_t next = 0;
  for (const Cluster& k : c.clusters) {
    EXPECT_EQ(k.first_index, next);
    EXPECT_GT(k.index_count, 0u);
    EXPECT_EQ(k.index_count % 3, 0u);
    EXPECT_LE(k.index_count, 3 * std::max(per_cluster, uint32_t(m.indices.size() / 3)));
    for (uint32_t i = k.first_index; i < k.first_index + k.index_count; ++i) {
      const glm::vec3 p = m.vertices[c.indices[i]].position;
      ASSERT_TRUE(glm::all(glm::greaterThanEqual(p, k.bounds.min)) &&
                  glm::all(glm::lessThanEqual(p, k.bounds.max)))
          << "index " << i << " outside its cluster's bounds";
    }
    next += k.index_count;
  }
  EXPECT_EQ(next, c.indices.size());
}

TEST(ClusterTriangles, TheBunnyInCompactClustersOfAtMostTheSizeAsked) {
  const scene::Mesh bunny = scene::load_mesh(PENUMBRA_MODEL_DIR "/bunny.obj");
  const ClusteredMesh c = cluster_triangles(bunny.vertices, bunny.indices, kClusterTriangles);
  expect_partition(bunny, c, kClusterTriangles);
  ASSERT_EQ(c.clusters.size(), (69666u + kClusterTriangles - 1) / kClusterTriangles);
  for (size_t k = 0; k + 1 < c.clusters.size(); ++k)
    EXPECT_EQ(c.clusters[k].index_count, 3 * kClusterTriangles);
  // Compact: a cluster's box is a small part of the mesh's (the median 0.46%; the file's own
  // triangle order cut into the same runs gives a median of 86%, and fails this).
  std::vector<float> parts;
  for (const Cluster& k : c.clusters) parts.push_back(volume(k.bounds) / volume(bunny.bounds));
  std::nth_element(parts.begin(), parts.begin() + parts.size() / 2, parts.end());
  EXPECT_LT(parts[parts.size() / 2], 0.01f);
}

TEST(ClusterTriangles, ASmallMeshIsOneClusterInItsOwnOrder) {
  const scene::Mesh box = scene::make_box({1.0f, 2.0f, 3.0f});
  const ClusteredMesh c = cluster_triangles(box.vertices, box.indices, 6);
  ASSERT_EQ(c.clusters.size(), 1u);
  EXPECT_EQ(c.indices, box.indices);
  EXPECT_EQ(c.clusters[0].bounds.min, box.bounds.min);
  EXPECT_EQ(c.clusters[0].bounds.max, box.bounds.max);
  // 12 triangles in clusters of 5: sorted, three clusters (5, 5, 2).
  const ClusteredMesh five = cluster_triangles(box.vertices, box.indices, 5);
  expect_partition(box, five, 5);
  EXPECT_EQ(five.clusters.size(), 3u);
}

TEST(ClusterTriangles, BadInputIsAClearError) {
  const scene::Mesh box = scene::make_box({1.0f, 1.0f, 1.0f});
  std::vector<uint32_t> beyond = box.indices;
  beyond[7] = uint32_t(box.vertices.size());
  EXPECT_THAT([&] { cluster_triangles(box.vertices, beyond); },
              testing::ThrowsMessage<Error>(testing::HasSubstr("index 24 beyond the 24 vertices")));
  std::vector<uint32_t> partial(box.indices.begin(), box.indices.end() - 1);
  EXPECT_THAT([&] { cluster_triangles(box.vertices, partial); },
              testing::ThrowsMessage<Error>(testing::HasSubstr("35 indices (not whole triangles)")));
  EXPECT_THROW(cluster_triangles(box.vertices, box.indices, 0), Error);
}

}  // namespace
}  // namespace penumbra::render
