// Scene queries (bounds, requirements), the alpha masks, and finding shipped scenes by name.

#include <algorithm>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <penumbra/scene/filters.hpp>
#include <penumbra/scene/scene.hpp>
#include <string>
#include <system_error>

#ifndef PENUMBRA_SCENE_DIR
#define PENUMBRA_SCENE_DIR "scenes"
#endif

namespace penumbra::scene {
namespace {

namespace fs = std::filesystem;

Bounds instance_bounds(const Scene& scene, bool casters_only) {
  Bounds bounds;
  for (const Instance& instance : scene.instances) {
    if (casters_only && !instance.casts_shadows) continue;
    bounds.extend(scene.motion_bounds(instance));
  }
  return bounds;
}

glm::dmat4 rotation_xyz_d(glm::dvec3 degrees) {
  glm::dmat4 m(1.0);
  m = glm::rotate(m, glm::radians(degrees.z), glm::dvec3(0, 0, 1));
  m = glm::rotate(m, glm::radians(degrees.y), glm::dvec3(0, 1, 0));
  m = glm::rotate(m, glm::radians(degrees.x), glm::dvec3(1, 0, 0));
  return m;
}

std::vector<fs::path> scene_dirs() {
  // An installed tool's scenes first (share/penumbra/scenes beside it), then the source tree's.
  std::vector<fs::path> dirs;
  if (const auto share = installed_share_dir(); !share.empty()) dirs.push_back(share / "scenes");
  dirs.emplace_back(PENUMBRA_SCENE_DIR);
  if (fs::path("scenes") != fs::path(PENUMBRA_SCENE_DIR)) dirs.emplace_back("scenes");
  return dirs;
}

}  // namespace

float procedural_mask(glm::vec2 uv, MaskPattern pattern, glm::vec2 scale) {
  const glm::vec2 p = uv * scale;
  const auto fract = [](float x) { return x - std::floor(x); };
  switch (pattern) {
    case MaskPattern::stripes:
      return fract(p.x) < 0.5f ? 1.0f : 0.0f;
    case MaskPattern::checker:
      return ((int(std::floor(p.x)) + int(std::floor(p.y))) & 1) == 0 ? 1.0f : 0.0f;
    case MaskPattern::circles: {
      const glm::vec2 c(fract(p.x) - 0.5f, fract(p.y) - 0.5f);
      return std::sqrt(c.x * c.x + c.y * c.y) > 0.3f ? 1.0f : 0.0f;
    }
    case MaskPattern::none:
    case MaskPattern::texture:
      break;
  }
  return 1.0f;
}

bool alpha_test_discards(glm::vec2 uv, MaskPattern pattern, glm::vec2 scale, float cutoff) {
  return procedural_mask(uv, pattern, scale) < cutoff;
}

double walk_fraction(std::uint32_t frame, std::uint32_t frames) {
  if (frames == 0) return 0.0;
  const std::uint64_t period = 2ull * frames;
  const std::uint64_t p = frame % period;
  return double(p <= frames ? p : period - p) / double(frames);
}

bool Motion::moves() const {
  return (move_frames > 0 && move != glm::vec3(0.0f)) || spin != glm::vec3(0.0f);
}

glm::mat4 Motion::transform_at(std::uint32_t frame) const {
  const glm::dmat4 b(base);
  const glm::dvec3 pivot(b[3]);
  // The spin's angle modulo a turn, so that frame 10^6 turns as exactly as frame 1.
  glm::dvec3 angle(0.0);
  for (int i = 0; i < 3; ++i) angle[i] = std::fmod(double(frame) * double(spin[i]), 360.0);
  const glm::dvec3 at = pivot + glm::dvec3(move) * walk_fraction(frame, move_frames);
  glm::dmat4 m = rotation_xyz_d(angle) * glm::translate(glm::dmat4(1.0), -pivot) * b;
  m = glm::translate(glm::dmat4(1.0), at) * m;
  return glm::mat4(m);
}

glm::vec3 Camera::position_at(std::uint32_t frame) const {
  return glm::vec3(glm::dvec3(position) + glm::dvec3(move) * walk_fraction(frame, move_frames));
}

glm::vec3 Camera::target_at(std::uint32_t frame) const {
  return glm::vec3(glm::dvec3(target) + glm::dvec3(move) * walk_fraction(frame, move_frames));
}

Camera Camera::at(std::uint32_t frame) const {
  Camera c = *this;
  c.position = position_at(frame);
  c.target = target_at(frame);
  return c;
}

void Scene::pose(std::uint32_t k) {
  for (Instance& instance : instances)
    if (instance.motion) instance.transform = instance.motion->transform_at(k);
}

void Scene::hold_still() {
  pose(0);
  for (Instance& instance : instances) instance.motion.reset();
  camera.move = glm::vec3(0.0f);
  camera.move_frames = 0;
}

bool Scene::has_motion() const {
  if (camera.move_frames > 0 && camera.move != glm::vec3(0.0f)) return true;
  return std::any_of(instances.begin(), instances.end(),
                     [](const Instance& i) { return i.motion && i.motion->moves(); });
}

Bounds Scene::motion_bounds(const Instance& instance) const {
  if (instance.mesh >= meshes.size()) return {};
  const Bounds& local = meshes[instance.mesh].bounds;
  if (!instance.motion) return transform_bounds(local, instance.transform);
  const Motion& m = *instance.motion;
  Bounds at_rest = transform_bounds(local, m.base);
  if (m.spin != glm::vec3(0.0f) && !at_rest.empty()) {
    // Turning about its origin, the object stays within the sphere about the origin through
    // its farthest corner.
    const glm::vec3 pivot(m.base[3]);
    float r = 0.0f;
    for (int i = 0; i < 8; ++i) {
      const glm::vec3 corner((i & 1) ? at_rest.max.x : at_rest.min.x,
                             (i & 2) ? at_rest.max.y : at_rest.min.y,
                             (i & 4) ? at_rest.max.z : at_rest.min.z);
      r = std::max(r, glm::length(corner - pivot));
    }
    r *= 1.0f + 1e-6f;  // the rounding of the turned corners
    at_rest = Bounds{pivot - glm::vec3(r), pivot + glm::vec3(r)};
  }
  // The walk is a straight line: its two ends bound every place between.
  Bounds all = at_rest;
  if (m.move_frames > 0) {
    Bounds end = at_rest;
    end.min += m.move;
    end.max += m.move;
    all.extend(end);
  }
  return all;
}

void translate_scene(Scene& scene, const glm::dvec3& offset) {
  auto moved = [&](const glm::vec3& v) { return glm::vec3(glm::dvec3(v) + offset); };
  scene.camera.position = moved(scene.camera.position);
  scene.camera.target = moved(scene.camera.target);
  for (auto& s : scene.spots) s.position = moved(s.position);
  for (auto& p : scene.points) p.position = moved(p.position);
  for (auto& i : scene.instances) {
    const glm::vec3 t = moved(glm::vec3(i.transform[3]));
    i.transform[3] = glm::vec4(t, i.transform[3].w);
    if (i.motion) {
      const glm::vec3 b = moved(glm::vec3(i.motion->base[3]));
      i.motion->base[3] = glm::vec4(b, i.motion->base[3].w);
    }
  }
}

Bounds Scene::world_bounds() const {
  return instance_bounds(*this, false);
}

std::vector<Bounds> Scene::instance_world_bounds() const {
  std::vector<Bounds> out;
  out.reserve(instances.size());
  for (const Instance& instance : instances)
    out.push_back(instance.mesh < meshes.size()
                      ? transform_bounds(meshes[instance.mesh].bounds, instance.transform)
                      : Bounds{});
  return out;
}

Bounds Scene::caster_bounds() const {
  return instance_bounds(*this, true);
}

Scene::Requirements Scene::requirements() const {
  Requirements r;
  r.sun_shadows = sun.has_value() && sun->shadows;
  r.cascades = !r.sun_shadows                            ? 0
               : shadows.layout == ShadowLayout::clipmap ? shadows.clipmap_levels
                                                         : shadows.cascades;
  // Only the lights the renderer shades get maps (a scene built in code may hold more).
  for (std::size_t i = 0; i < spots.size() && i < kMaxSpotLights; ++i) {
    const SpotLight& spot = spots[i];
    r.spot_shadow_maps += spot.shadows ? 1 : 0;
    r.spot_moments = r.spot_moments || (spot.shadows && spot.filter && filter_spec(*spot.filter).moments);
  }
  for (std::size_t i = 0; i < points.size() && i < kMaxPointLights; ++i) {
    const PointLight& point = points[i];
    r.point_shadow_cubes += point.shadows ? 1 : 0;
    r.point_moments = r.point_moments || (point.shadows && point.filter && filter_spec(*point.filter).moments);
  }
  const bool has_light = sun.has_value() || !spots.empty() || !points.empty();
  r.contact_pass = contact.step_count > 0 && has_light;
  r.temporal =
      shadows.temporal && (r.sun_shadows || r.spot_shadow_maps > 0 || r.point_shadow_cubes > 0);
  for (const Instance& instance : instances) {
    if (instance.material < materials.size() &&
        materials[instance.material].alpha == AlphaMode::masked) {
      r.masked_materials = true;
    }
  }
  r.mask_textures = std::uint32_t(mask_images().size());
  r.sun_moments = r.sun_shadows && filter_spec(shadows.filter).moments;
  if (r.sun_shadows || r.spot_shadow_maps > 0 || r.point_shadow_cubes > 0) {
    r.analytic_spheres = std::uint32_t(analytic_spheres().size());
  }
  return r;
}

std::vector<glm::vec4> Scene::analytic_spheres() const {
  std::vector<glm::vec4> spheres;
  for (const Instance& instance : instances) {
    if (!(instance.analytic_sphere_radius > 0.0f)) continue;
    // A uniform scale: any column's length is the scale.
    const float scale = glm::length(glm::vec3(instance.transform[0]));
    spheres.emplace_back(glm::vec3(instance.transform[3]), instance.analytic_sphere_radius * scale);
  }
  return spheres;
}

namespace {
// One texture whichever material loaded it: the same object, or the same file.
bool same_mask_image(const std::shared_ptr<const MaskImage>& a,
                     const std::shared_ptr<const MaskImage>& b) {
  return a && b && (a == b || a->source == b->source);
}
}  // namespace

std::vector<std::shared_ptr<const MaskImage>> Scene::mask_images() const {
  std::vector<std::shared_ptr<const MaskImage>> images;
  for (std::uint32_t m = 0; m < materials.size(); ++m) {
    const Material& mat = materials[m];
    if (mat.alpha != AlphaMode::masked || mat.mask != MaskPattern::texture || !mat.mask_image)
      continue;
    const bool used = std::any_of(instances.begin(), instances.end(),
                                  [m](const Instance& i) { return i.material == m; });
    const bool listed = std::any_of(images.begin(), images.end(), [&](const auto& image) {
      return same_mask_image(image, mat.mask_image);
    });
    if (used && !listed) images.push_back(mat.mask_image);
  }
  return images;
}

int Scene::mask_image_index(std::uint32_t material) const {
  return mask_image_index(material, mask_images());
}

int Scene::mask_image_index(std::uint32_t material,
                            const std::vector<std::shared_ptr<const MaskImage>>& images) const {
  if (material >= materials.size() || materials[material].mask != MaskPattern::texture) return -1;
  for (size_t i = 0; i < images.size(); ++i)
    if (same_mask_image(images[i], materials[material].mask_image)) return int(i);
  return -1;
}

std::vector<std::string> shipped_scenes() {
  std::vector<std::string> names;
  std::error_code ec;
  for (const fs::path& dir : scene_dirs()) {
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
      if (entry.path().extension() == ".toml") names.push_back(entry.path().stem().string());
    }
    if (!names.empty()) break;
  }
  std::sort(names.begin(), names.end());
  return names;
}

std::filesystem::path find_scene(std::string_view name_or_path) {
  const std::string given(name_or_path);
  if (given.empty()) throw Error("find_scene: empty scene name");
  std::error_code ec;
  const bool looks_like_path = given.find('/') != std::string::npos ||
                               given.find('\\') != std::string::npos ||
                               fs::path(given).extension() == ".toml";
  if (looks_like_path || fs::is_regular_file(given, ec)) return fs::path(given);
  std::string looked;
  for (const fs::path& dir : scene_dirs()) {
    const fs::path candidate = dir / (given + ".toml");
    if (fs::is_regular_file(candidate, ec)) return candidate;
    looked += (looked.empty() ? "" : ", ") + candidate.string();
  }
  std::string available;
  for (const std::string& name : shipped_scenes()) {
    available += (available.empty() ? "" : ", ") + name;
  }
  throw Error("scene '" + given + "' not found (looked for " + looked +
              "); shipped scenes: " + (available.empty() ? "none found" : available));
}

}  // namespace penumbra::scene
