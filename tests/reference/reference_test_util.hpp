#pragma once
// Scenes built in code for the reference's tests: quads, boxes and spheres at known places.
#include <glm/gtc/matrix_transform.hpp>
#include <penumbra/reference/reference.hpp>
#include <penumbra/scene/mesh.hpp>
#include <penumbra/scene/scene.hpp>

namespace penumbra::reference::test {

// A horizontal quad at height y over [x0, x1] × [z0, z1], u along x and v along z in [0, 1].
inline scene::Mesh quad(double x0, double x1, double z0, double z1, double y) {
  scene::Mesh m;
  m.name = "quad";
  const auto v = [&](double x, double z, float u, float w) {
    scene::Vertex vert;
    vert.position = glm::vec3(float(x), float(y), float(z));
    vert.normal = glm::vec3(0, 1, 0);
    vert.uv = glm::vec2(u, w);
    return vert;
  };
  m.vertices = {v(x0, z0, 0, 0), v(x1, z0, 1, 0), v(x1, z1, 1, 1), v(x0, z1, 0, 1)};
  m.indices = {0, 2, 1, 0, 3, 2};
  scene::update_bounds(m);
  return m;
}

// Adds a mesh with its own material at a world transform; returns the instance index.
inline size_t add(scene::Scene& s, scene::Mesh mesh, glm::mat4 transform = glm::mat4(1.0f),
                  scene::Material material = {}, bool casts = true) {
  s.meshes.push_back(std::move(mesh));
  s.materials.push_back(std::move(material));
  scene::Instance inst;
  inst.mesh = uint32_t(s.meshes.size() - 1);
  inst.material = uint32_t(s.materials.size() - 1);
  inst.transform = transform;
  inst.casts_shadows = casts;
  s.instances.push_back(inst);
  return s.instances.size() - 1;
}

inline glm::mat4 translate(glm::dvec3 t) {
  return glm::mat4(glm::translate(glm::dmat4(1.0), t));
}

inline AreaLight sun_light(glm::dvec3 to_light, double angular_diameter_degrees) {
  AreaLight a;
  a.kind = LightKind::sun;
  a.direction_to_light = glm::normalize(to_light);
  a.angular_radius = 0.5 * glm::radians(angular_diameter_degrees);
  return a;
}

inline AreaLight sphere_light(glm::dvec3 position, double radius) {
  AreaLight a;
  a.kind = LightKind::point;
  a.position = position;
  a.radius = radius;
  return a;
}

}  // namespace penumbra::reference::test
