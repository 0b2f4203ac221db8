// The reference's lights (the scene's sun, spot and point lights as area lights) and its
// receivers (points with normals, or a G-buffer unprojected), apart from the tracer.
#include <algorithm>
#include <cmath>
#include <penumbra/core/error.hpp>
#include <penumbra/reference/reference.hpp>

namespace penumbra::reference {
namespace {

bool finite(const glm::dvec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

}  // namespace

std::string LightRef::name() const {
  switch (kind) {
    case LightKind::sun:
      return "sun";
    case LightKind::spot:
      return "spot" + std::to_string(index);
    case LightKind::point:
      return "point" + std::to_string(index);
  }
  return "?";
}

std::vector<LightRef> scene_lights(const scene::Scene& scene) {
  std::vector<LightRef> out;
  if (scene.sun) out.push_back({LightKind::sun, 0});
  for (uint32_t i = 0; i < scene.spots.size(); ++i) out.push_back({LightKind::spot, i});
  for (uint32_t i = 0; i < scene.points.size(); ++i) out.push_back({LightKind::point, i});
  return out;
}

bool AreaLight::hard() const {
  return kind == LightKind::sun ? !(angular_radius > 0.0) : !(radius > 0.0);
}

AreaLight area_light(const scene::Scene& scene, const LightRef& light) {
  AreaLight a;
  a.kind = light.kind;
  switch (light.kind) {
    case LightKind::sun:
      if (!scene.sun) throw Error("reference: scene '" + scene.name + "' has no sun");
      a.direction_to_light = -glm::normalize(glm::dvec3(scene.sun->direction));
      a.angular_radius = 0.5 * glm::radians(double(scene.sun->angular_diameter_degrees));
      break;
    case LightKind::spot:
    case LightKind::point: {
      const bool spot = light.kind == LightKind::spot;
      if (light.index >= (spot ? scene.spots.size() : scene.points.size()))
        throw Error("reference: scene '" + scene.name + "' has no " + light.name());
      a.position =
          glm::dvec3(spot ? scene.spots[light.index].position : scene.points[light.index].position);
      a.radius = spot ? scene.spots[light.index].radius : scene.points[light.index].radius;
      break;
    }
  }
  return a;
}

double ray_offset(const glm::dvec3& p) {
  const double m = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  return std::max(kRayOffsetMin, kRayOffsetRelative * m);
}

Receivers receivers_from_points(std::span<const glm::dvec3> world_points,
                                std::span<const glm::dvec3> normals, glm::dvec3 origin) {
  if (world_points.size() != normals.size())
    throw Error("reference: " + std::to_string(world_points.size()) + " points but " +
                std::to_string(normals.size()) + " normals");
  Receivers r;
  r.width = static_cast<uint32_t>(world_points.size());
  r.height = 1;
  r.origin = origin;
  for (size_t i = 0; i < world_points.size(); ++i) {
    const glm::dvec3 n = normals[i];
    const double len = glm::length(n);
    const bool ok = finite(world_points[i]) && finite(n) && len > 0.0;
    r.position.push_back(world_points[i] - origin);
    r.normal.push_back(ok ? n / len : glm::dvec3(0.0));
    r.valid.push_back(ok ? 1 : 0);
    r.rejected += ok ? 0 : 1;
  }
  return r;
}

Receivers receivers_from_gbuffer(uint32_t width, uint32_t height, std::span<const float> depth,
                                 std::span<const glm::vec4> normal_view, const glm::dmat4& view,
                                 const glm::dmat4& proj, glm::dvec3 origin) {
  const size_t n = size_t{width} * height;
  if (depth.size() != n || normal_view.size() != n)
    throw Error("reference: a " + std::to_string(width) + "x" + std::to_string(height) +
                " G-buffer needs " + std::to_string(n) + " depth and normal texels (got " +
                std::to_string(depth.size()) + " and " + std::to_string(normal_view.size()) + ")");
  Receivers r;
  r.width = width;
  r.height = height;
  r.origin = origin;
  r.position.resize(n);
  r.normal.resize(n);
  r.valid.assign(n, 0);
  r.depth_tolerance.assign(n, 0.0f);
  r.eye = glm::dvec3(glm::inverse(view)[3]);
  const glm::dmat4 inv_view_proj = glm::inverse(proj * view);
  const glm::dmat3 view_to_world = glm::transpose(glm::dmat3(view));  // view is a rotation
  for (uint32_t y = 0; y < height; ++y)
    for (uint32_t x = 0; x < width; ++x) {
      const size_t i = size_t{y} * width + x;
      const glm::vec4 nv = normal_view[i];
      if (!(nv.w > 0.25f)) continue;  // sky (alpha 0; 0.5 and 1 are geometry)
      // Pixel centre in NDC: Vulkan x, y in [-1, 1] with +y down the image, z in [0, 1].
      const glm::dvec4 ndc((x + 0.5) / width * 2.0 - 1.0, (y + 0.5) / height * 2.0 - 1.0,
                           double(depth[i]), 1.0);
      const glm::dvec4 h = inv_view_proj * ndc;
      const glm::dvec3 p = glm::dvec3(h) / h.w;
      // The stored depth's rounding, as a distance along the view ray: 4 float steps either way.
      double tolerance = 0.0;
      for (const float toward : {-1.0f, 2.0f}) {
        float d = depth[i];
        for (int k = 0; k < 4; ++k) d = std::nextafter(d, toward);
        const glm::dvec4 hd = inv_view_proj * glm::dvec4(ndc.x, ndc.y, double(d), 1.0);
        const double e = glm::length(glm::dvec3(hd) / hd.w - p);
        if (std::isfinite(e)) tolerance = std::max(tolerance, e);
      }
      glm::dvec3 normal = view_to_world * glm::dvec3(nv);
      const double len = glm::length(normal);
      if (!finite(p) || !(len > 0.0) || !std::isfinite(len)) {
        ++r.rejected;
        continue;
      }
      r.position[i] = p;
      r.normal[i] = normal / len;
      r.valid[i] = 1;
      r.depth_tolerance[i] = float(tolerance);
    }
  return r;
}

}  // namespace penumbra::reference
