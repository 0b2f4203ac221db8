// The scenes in scenes/: each loads, is plausible (camera frames the content, lights inside
// their rooms) and requires exactly the passes its description promises.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>
#include <map>
#include <penumbra/scene/scene.hpp>
#include <string>
#include <vector>

#include "scene_test_util.hpp"

namespace penumbra::scene {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;

const Scene& shipped(const std::string& name) {
  static std::map<std::string, Scene> cache;
  auto it = cache.find(name);
  if (it == cache.end()) it = cache.emplace(name, load_scene(find_scene(name))).first;
  return it->second;
}

bool finite(const Bounds& b) {
  return std::isfinite(b.min.x) && std::isfinite(b.min.y) && std::isfinite(b.min.z) &&
         std::isfinite(b.max.x) && std::isfinite(b.max.y) && std::isfinite(b.max.z);
}

// The fraction of instances (other than those larger than `ignore_larger_than`) whose bounds
// centre lies inside the camera's view frustum.
double fraction_in_view(const Scene& scene, float ignore_larger_than) {
  const Camera& c = scene.camera;
  const float aspect =
      static_cast<float>(scene.render.width) / static_cast<float>(scene.render.height);
  const glm::mat4 view_proj =
      glm::perspective(glm::radians(c.fov_y_degrees), aspect, c.near, c.far) *
      glm::lookAt(c.position, c.target, c.up);
  std::size_t counted = 0;
  std::size_t visible = 0;
  for (const Instance& instance : scene.instances) {
    const Bounds b = transform_bounds(scene.meshes[instance.mesh].bounds, instance.transform);
    if (glm::length(b.size()) > ignore_larger_than) continue;
    ++counted;
    const glm::vec4 clip = view_proj * glm::vec4(b.center(), 1.0f);
    if (clip.w > 0.0f && std::abs(clip.x) <= clip.w && std::abs(clip.y) <= clip.w) ++visible;
  }
  return counted == 0 ? 0.0 : static_cast<double>(visible) / static_cast<double>(counted);
}

TEST(ShippedScenes, AreTheFourPromised) {
  EXPECT_THAT(shipped_scenes(), ElementsAre("default", "grazing", "indoor", "space"));
}

class EveryShippedScene : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryShippedScene, LoadsAndIsConsistent) {
  const Scene& scene = shipped(GetParam());
  EXPECT_EQ(scene.name, GetParam());
  ASSERT_FALSE(scene.instances.empty());
  for (const Mesh& mesh : scene.meshes) testing::expect_valid_mesh(mesh);
  for (const Instance& instance : scene.instances) {
    ASSERT_LT(instance.mesh, scene.meshes.size());
    ASSERT_LT(instance.material, scene.materials.size());
  }
  // Every mesh is used (only what is required is loaded).
  std::vector<bool> used(scene.meshes.size(), false);
  for (const Instance& instance : scene.instances) used[instance.mesh] = true;
  for (std::size_t i = 0; i < used.size(); ++i) EXPECT_TRUE(used[i]) << scene.meshes[i].name;
  const Bounds world = scene.world_bounds();
  ASSERT_FALSE(world.empty());
  EXPECT_TRUE(finite(world));
  EXPECT_FALSE(scene.caster_bounds().empty());
  // The camera looks at the content: most objects (not the ground or walls) are in view.
  EXPECT_GE(fraction_in_view(scene, 6.0f), 0.6) << scene.name;
  EXPECT_LT(scene.shadows.max_distance, scene.camera.far);
  EXPECT_EQ(scene.render.width, 1280u);
  EXPECT_EQ(scene.render.height, 720u);
}

INSTANTIATE_TEST_SUITE_P(ShippedScenes, EveryShippedScene,
                         ::testing::Values("default", "grazing", "space", "indoor"),
                         [](const auto& param_info) { return param_info.param; });

TEST(ShippedScenes, DefaultRequiresSunCascadesAndContact) {
  const Scene& scene = shipped("default");
  const Scene::Requirements r = scene.requirements();
  EXPECT_TRUE(r.sun_shadows);
  EXPECT_EQ(r.cascades, scene.shadows.cascades);
  EXPECT_EQ(r.cascades, 3u);  // from penumbra-bench (scenes/default.toml)
  EXPECT_EQ(r.spot_shadow_maps, 0u);
  EXPECT_EQ(r.point_shadow_cubes, 0u);
  EXPECT_TRUE(r.contact_pass);
  EXPECT_TRUE(r.masked_materials);  // the fence
  ASSERT_TRUE(scene.sun.has_value());
  EXPECT_NEAR(glm::length(scene.sun->direction), 1.0f, 1e-6f);
  EXPECT_LT(scene.sun->direction.y, -0.5f);
  // The promised content.
  std::vector<std::string> names;
  for (const Mesh& mesh : scene.meshes) names.push_back(mesh.name);
  auto count_prefix = [&](const std::string& prefix) {
    std::size_t n = 0;
    for (const Instance& instance : scene.instances) {
      n += scene.meshes[instance.mesh].name.rfind(prefix, 0) == 0 ? 1 : 0;
    }
    return n;
  };
  EXPECT_EQ(count_prefix("bunny"), 1u);
  EXPECT_GE(count_prefix("post"), 3u);
  EXPECT_EQ(count_prefix("chair"), 1u);
  EXPECT_EQ(count_prefix("sphere"), 1u);
  EXPECT_EQ(count_prefix("plane"), 1u);
  EXPECT_GE(count_prefix("box"), 2u);  // a box and the fence
  // Objects stand on the ground plane (y = 0), none floats or sinks.
  for (const Instance& instance : scene.instances) {
    const Bounds b = transform_bounds(scene.meshes[instance.mesh].bounds, instance.transform);
    EXPECT_GE(b.min.y, -1e-4f) << scene.meshes[instance.mesh].name;
    EXPECT_LE(b.min.y, 0.06f) << scene.meshes[instance.mesh].name;
  }
}

TEST(ShippedScenes, GrazingSunIsThreeDegreesUp) {
  const Scene& scene = shipped("grazing");
  ASSERT_TRUE(scene.sun.has_value());
  const float elevation = glm::degrees(std::asin(-scene.sun->direction.y));
  EXPECT_NEAR(elevation, 3.0f, 1e-3f);
  const Scene::Requirements r = scene.requirements();
  EXPECT_TRUE(r.sun_shadows);
  EXPECT_GE(r.cascades, 1u);
  EXPECT_EQ(r.point_shadow_cubes, 0u);
  // The ground reaches past the shadows of the 2 m posts (about 38 m long).
  const Bounds world = scene.world_bounds();
  EXPECT_GE(world.size().x, 80.0f);
  EXPECT_GE(world.size().z, 80.0f);
}

TEST(ShippedScenes, SpaceHasOneStarAndAnAsteroidField) {
  const Scene& scene = shipped("space");
  const Scene::Requirements r = scene.requirements();
  EXPECT_FALSE(r.sun_shadows);
  EXPECT_EQ(r.cascades, 0u);
  EXPECT_EQ(r.spot_shadow_maps, 0u);
  EXPECT_EQ(r.point_shadow_cubes, 1u);
  EXPECT_FALSE(r.contact_pass);
  EXPECT_FALSE(scene.sun.has_value());
  ASSERT_EQ(scene.points.size(), 1u);
  EXPECT_GE(scene.instances.size(), 200u);
  for (const Mesh& mesh : scene.meshes) EXPECT_EQ(mesh.name, "asteroid-low");  // no ground
  // Every asteroid is within the star's range and outside its core.
  for (const Instance& instance : scene.instances) {
    const Bounds b = transform_bounds(scene.meshes[instance.mesh].bounds, instance.transform);
    const float distance = glm::length(b.center() - scene.points[0].position);
    EXPECT_LT(distance, scene.points[0].range);
    EXPECT_GT(distance, 5.0f);
  }
}

TEST(ShippedScenes, IndoorHasASpotAndAPointInAClosedRoom) {
  const Scene& scene = shipped("indoor");
  const Scene::Requirements r = scene.requirements();
  EXPECT_FALSE(r.sun_shadows);
  EXPECT_EQ(r.cascades, 0u);
  EXPECT_EQ(r.spot_shadow_maps, 1u);
  EXPECT_EQ(r.point_shadow_cubes, 1u);
  EXPECT_TRUE(r.contact_pass);
  EXPECT_FALSE(scene.sun.has_value());
  // The room: the camera and both lights are inside the walls.
  const Bounds room = scene.world_bounds();
  auto inside = [&](glm::vec3 p) {
    return p.x > room.min.x + 0.2f && p.x < room.max.x - 0.2f && p.y > 0.0f && p.y < 3.0f &&
           p.z > room.min.z + 0.2f && p.z < room.max.z - 0.2f;
  };
  EXPECT_TRUE(inside(scene.camera.position));
  ASSERT_EQ(scene.spots.size(), 1u);
  ASSERT_EQ(scene.points.size(), 1u);
  EXPECT_TRUE(inside(scene.spots[0].position));
  EXPECT_TRUE(inside(scene.points[0].position));
  std::size_t chairs = 0;
  std::size_t tables = 0;
  for (const Instance& instance : scene.instances) {
    const std::string& name = scene.meshes[instance.mesh].name;
    chairs += name == "chair" ? 1 : 0;
    tables += name.rfind("table", 0) == 0 ? 1 : 0;
  }
  EXPECT_GE(chairs, 2u);
  EXPECT_EQ(tables, 1u);
}

// translate_scene moves everything with a position, each value rounded to float once, and
// nothing else (orientation, scale, the sun).
TEST(ShippedScenes, TranslateSceneMovesEveryPositionOnce) {
  const Scene original = load_scene(find_scene("indoor"));
  Scene moved = original;
  const glm::dvec3 offset(1e5, 0.25, -1e5);
  translate_scene(moved, offset);
  auto expect_moved = [&](const glm::vec3& a, const glm::vec3& b) {
    EXPECT_EQ(b, glm::vec3(glm::dvec3(a) + offset));
  };
  expect_moved(original.camera.position, moved.camera.position);
  expect_moved(original.camera.target, moved.camera.target);
  ASSERT_FALSE(original.spots.empty());
  ASSERT_FALSE(original.points.empty());
  for (size_t i = 0; i < original.spots.size(); ++i) {
    expect_moved(original.spots[i].position, moved.spots[i].position);
    EXPECT_EQ(original.spots[i].direction, moved.spots[i].direction);
  }
  for (size_t i = 0; i < original.points.size(); ++i)
    expect_moved(original.points[i].position, moved.points[i].position);
  ASSERT_EQ(original.instances.size(), moved.instances.size());
  for (size_t i = 0; i < original.instances.size(); ++i) {
    expect_moved(glm::vec3(original.instances[i].transform[3]),
                 glm::vec3(moved.instances[i].transform[3]));
    for (int c = 0; c < 3; ++c)
      EXPECT_EQ(original.instances[i].transform[c], moved.instances[i].transform[c]);
  }
  // The bounds move with it (to float precision at 1e5: 8 mm).
  const Bounds a = original.world_bounds(), b = moved.world_bounds();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(double(b.min[k]) - double(a.min[k]), offset[k], 0.02);
}

}  // namespace
}  // namespace penumbra::scene
