// The geometry of a scene file: materials, meshes (shapes, model files, glmark2 models),
// [[object]] instances and [[scatter]] fields. docs/scenes.md is the format's reference.

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <map>
#include <penumbra/core/file.hpp>

#include "param_access.hpp"
#include "toml_reader.hpp"

#ifndef PENUMBRA_MODEL_DIR
#define PENUMBRA_MODEL_DIR "/usr/share/glmark2/models"
#endif

namespace penumbra::scene::file {
namespace {

fs::path resolve(const Context& ctx, const std::string& path) {
  fs::path p(path);
  if (p.is_relative()) p = ctx.base_dir / p;
  std::error_code ec;
  fs::path absolute = fs::absolute(p, ec);
  return (ec ? p : absolute).lexically_normal();
}

// A file-valued key's file, resolved against the scene's folder: an error at the key's line when
// the path holds a NUL byte (the OS would cut it there and open another file) or names no
// regular file (missing, a directory, a device), saying which.
fs::path input_file(const Reader& r, std::string_view key, const std::string& what,
                    const std::string& given) {
  if (const size_t nul = given.find('\0'); nul != std::string::npos)
    r.fail_key(key, what + " '" + printable(given) + "' contains a NUL byte (at " +
                        std::to_string(nul) + "); a path cannot");
  const fs::path file = resolve(r.context(), given);
  if (const std::string problem = file_problem(file); !problem.empty())
    r.fail_key(key, what + " '" + printable(given) + "' " + problem + " (resolved to " +
                        printable(file.string()) + ")");
  return file;
}

Material read_material(const Reader& r) {
  r.check_keys({"name", "albedo", "alpha", "mask", "mask_texture", "mask_scale", "alpha_cutoff"});
  Material m;
  m.name = r.required_string("name");
  m.albedo = r.vec3("albedo", m.albedo, kUnit);
  const std::optional<AlphaMode> alpha = r.opt_enum("alpha", kAlphaModes);
  std::optional<MaskPattern> mask = r.opt_enum("mask", kMasks);
  if (r.has("mask_texture")) {
    if (mask && *mask != MaskPattern::texture) {
      r.fail_key("mask_texture", "only applies with mask = 'texture' (this material has mask = '" +
                                     std::string(name_of(kMasks, *mask)) + "')");
    }
    mask = MaskPattern::texture;
    const std::string given = *r.opt_string("mask_texture");
    m.mask_texture = input_file(r, "mask_texture", "texture file", given);
    try {
      m.mask_image = std::make_shared<const MaskImage>(load_mask_image(m.mask_texture));
    } catch (const Error& e) {
      r.fail_key("mask_texture", "'" + given + "': " + e.what());
    }
  } else if (mask == MaskPattern::texture) {
    r.fail_key("mask", "mask = 'texture' needs a mask_texture file");
  }
  m.mask = mask.value_or(MaskPattern::none);
  m.alpha = alpha.value_or(m.mask == MaskPattern::none ? AlphaMode::opaque : AlphaMode::masked);
  if (m.alpha == AlphaMode::masked && m.mask == MaskPattern::none) {
    r.fail_key("alpha",
               "alpha = 'masked' needs a mask (mask = 'stripes', 'checker', 'circles' or "
               "'texture')");
  }
  if (m.alpha == AlphaMode::opaque && m.mask != MaskPattern::none) {
    r.fail_key(r.has("mask") ? "mask" : "mask_texture",
               "a mask has no effect on an opaque material (set alpha = 'masked' or leave alpha "
               "out)");
  }
  if (const auto scale = r.opt_vec<2>("mask_scale", kPositive)) m.mask_scale = glm::vec2(*scale);
  m.alpha_cutoff = r.numberf("alpha_cutoff", m.alpha_cutoff, open(0.0, 1.0));
  return m;
}

// ---- meshes and instances --------------------------------------------------------------------

const std::vector<std::string_view> kShapes{"plane", "box", "sphere", "post", "chair", "table"};
const std::vector<std::string_view> kShapeKeys{"size",     "subdivisions", "radius",
                                               "segments", "rings",        "height"};

std::vector<std::string_view> shape_keys(std::string_view kind, bool scatter) {
  if (kind == "plane") return {"size", "subdivisions"};
  if (kind == "box" || kind == "table") return {"size"};
  // A scatter's `radius` is where it places instances: its spheres and posts keep their default
  // radius and take their size from `scale`.
  if (kind == "sphere")
    return scatter ? std::vector<std::string_view>{"segments", "rings"}
                   : std::vector<std::string_view>{"radius", "segments", "rings"};
  if (kind == "post")
    return scatter ? std::vector<std::string_view>{"height", "segments"}
                   : std::vector<std::string_view>{"radius", "height", "segments"};
  if (kind == "chair") return {};
  // model: and file:
  if (scatter) return {"size"};
  return {"size", "height"};
}

std::vector<std::string> model_names(const fs::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string ext = entry.path().extension().string();
    if (ext == ".obj" || ext == ".3ds") names.push_back(entry.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

fs::path model_dir() {
  if (const char* env = std::getenv("PENUMBRA_MODEL_DIR"); env != nullptr && *env != '\0') {
    return env;
  }
  return PENUMBRA_MODEL_DIR;
}

std::string hex_float(float v) {
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%a", static_cast<double>(v));
  return buffer;
}

struct MeshUse {
  std::uint32_t mesh = 0;
  glm::mat4 normalize{1.0f};   // applied before the object's own transform
  float sphere_radius = 0.0f;  // mesh = "sphere": its radius (about the object's origin)
};

// `analytic_shadow = true`: the instance's shadow is computed in closed form as a sphere's
// (penumbra/sphere_shadow.glsl) instead of being drawn into the shadow maps. Only a sphere under a
// uniform scale is a sphere; returns its object-space radius, 0 when the key is absent or false.
float analytic_sphere_radius(const Reader& r, const MeshUse& use, bool uniform_scale,
                             bool casts_shadows) {
  if (!r.boolean("analytic_shadow", false)) return 0.0f;
  if (!(use.sphere_radius > 0.0f)) {
    r.fail_key("analytic_shadow",
               "analytic_shadow = true needs mesh = \"sphere\" (the closed form "
               "is a sphere's), not mesh = \"" +
                   r.opt_string("mesh").value_or("") + "\"");
  }
  if (!uniform_scale) {
    r.fail_key("analytic_shadow",
               "analytic_shadow = true needs a uniform scale (a single number): a sphere scaled "
               "unevenly is an ellipsoid");
  }
  if (!casts_shadows) {
    r.fail_key("analytic_shadow",
               "analytic_shadow = true with casts_shadows = false: an object "
               "that casts no shadow has no shadow to compute");
  }
  return use.sphere_radius;
}

// Fails at `analytic_shadow` when the scene's analytic spheres exceed kMaxAnalyticSpheres.
void check_analytic_count(const Reader& r, const Scene& scene) {
  const auto count =
      std::count_if(scene.instances.begin(), scene.instances.end(),
                    [](const Instance& i) { return i.analytic_sphere_radius > 0.0f; });
  if (std::uint32_t(count) > kMaxAnalyticSpheres) {
    r.fail_key("analytic_shadow", "the scene has " + std::to_string(count) +
                                      " analytic spheres; at most " +
                                      std::to_string(kMaxAnalyticSpheres) + " are supported");
  }
}

class Builder {
 public:
  Builder(const Context& ctx, Scene& scene) : ctx_(ctx), scene_(scene) {}

  void add_material(const Reader& r, Material material) {
    const std::uint32_t line = r.line_of(r.get("name"));
    if (const auto it = material_lines_.find(material.name); it != material_lines_.end()) {
      r.fail_key("name", "material '" + material.name + "' is already defined at line " +
                             std::to_string(it->second));
    }
    material_lines_[material.name] = line;
    scene_.materials.push_back(std::move(material));
  }

  std::uint32_t material(const Reader& r) {
    const std::string name = r.opt_string("material").value_or("default");
    for (std::size_t i = 0; i < scene_.materials.size(); ++i) {
      if (scene_.materials[i].name == name) return static_cast<std::uint32_t>(i);
    }
    if (name == "default") {  // the implicit default material
      scene_.materials.push_back(Material{.name = "default"});
      return static_cast<std::uint32_t>(scene_.materials.size() - 1);
    }
    std::vector<std::string_view> names;
    for (const Material& m : scene_.materials) names.push_back(m.name);
    r.fail_key("material",
               "unknown material '" + name + "'" + did_you_mean(name, names) +
                   (names.empty() ? "; no [[material]] is defined" : "; defined: " + join(names)));
  }

  // Reads `mesh` and its shape keys, checks the table's keys, and returns the (shared) mesh.
  MeshUse mesh(const Reader& r, const std::vector<std::string_view>& common, bool scatter) {
    const std::string spec = r.required_string("mesh");
    std::string kind = spec;
    if (spec.starts_with("model:")) kind = "model:";
    if (spec.starts_with("file:")) kind = "file:";
    const bool is_file = kind == "model:" || kind == "file:";
    if (!is_file && std::find(kShapes.begin(), kShapes.end(), kind) == kShapes.end()) {
      std::vector<std::string_view> valid = kShapes;
      r.fail_key("mesh", "unknown mesh '" + spec + "'; valid: " + join(valid) +
                             ", model:<name>, file:<path>" + did_you_mean(spec, valid));
    }
    std::vector<std::string_view> allowed = common;
    const std::vector<std::string_view> own = shape_keys(kind, scatter);
    allowed.insert(allowed.end(), own.begin(), own.end());
    r.check_keys(allowed, [&](std::string_view key) -> std::string {
      if (std::find(kShapeKeys.begin(), kShapeKeys.end(), key) == kShapeKeys.end()) return "";
      const std::string what = is_file ? "a mesh file" : "mesh '" + kind + "'";
      return "key '" + std::string(key) + "' does not apply to " + what + " in " + r.label() +
             " (" + what + " takes: " + (own.empty() ? "no shape keys" : join(own)) + ")";
    });

    MeshUse use;
    if (kind == "plane") {
      const auto size = r.opt_vec<2>("size", kPositive).value_or(glm::dvec2(10.0));
      const std::uint32_t sub = r.uint("subdivisions", 1, 1, 1024);
      const auto sx = static_cast<float>(size.x);
      const auto sz = static_cast<float>(size.y);
      use.mesh = shared("plane " + hex_float(sx) + " " + hex_float(sz) + " " + std::to_string(sub),
                        [&] { return make_plane(sx, sz, sub); });
    } else if (kind == "box" || kind == "table") {
      const glm::vec3 fallback = kind == "box" ? glm::vec3(1.0f) : glm::vec3(1.4f, 0.75f, 0.8f);
      const glm::vec3 size =
          r.vec3("size", fallback, kind == "box" ? kPositive : Range{0.1, kInf, true, false});
      const std::string key =
          kind + " " + hex_float(size.x) + " " + hex_float(size.y) + " " + hex_float(size.z);
      use.mesh = shared(key, [&] { return kind == "box" ? make_box(size) : make_table(size); });
    } else if (kind == "sphere") {
      const float radius = scatter ? 0.5f : r.numberf("radius", 0.5f, kPositive);
      const std::uint32_t segments = r.uint("segments", 32, 3, 1024);
      const std::uint32_t rings = r.uint("rings", 16, 2, 1024);
      use.mesh = shared("sphere " + hex_float(radius) + " " + std::to_string(segments) + " " +
                            std::to_string(rings),
                        [&] { return make_sphere(radius, segments, rings); });
      use.sphere_radius = radius;
    } else if (kind == "post") {
      const float radius = scatter ? 0.05f : r.numberf("radius", 0.05f, kPositive);
      const float height = r.numberf("height", 2.0f, kPositive);
      const std::uint32_t segments = r.uint("segments", 12, 3, 1024);
      use.mesh = shared(
          "post " + hex_float(radius) + " " + hex_float(height) + " " + std::to_string(segments),
          [&] { return make_post(radius, height, segments); });
    } else if (kind == "chair") {
      use.mesh = shared("chair", [] { return make_chair(); });
    } else {
      const fs::path file = mesh_file(r, spec, kind);
      use.mesh = shared("file " + file.string(), [&] {
        try {
          return load_mesh(file);
        } catch (const Error& e) {
          r.fail_key("mesh", e.what());
        }
      });
      const Bounds b = scene_.meshes[use.mesh].bounds;
      const glm::vec3 extent = b.size();
      if (r.has("size") && r.has("height")) {
        r.fail_key("height", "give either 'size' or 'height', not both");
      }
      if (const auto size = r.opt_number("size", kPositive)) {
        const float largest = std::max({extent.x, extent.y, extent.z});
        if (!(largest > 0.0f)) r.fail_key("size", "the mesh has no extent to scale");
        use.normalize =
            glm::scale(glm::mat4(1.0f), glm::vec3(static_cast<float>(*size) / largest)) *
            glm::translate(glm::mat4(1.0f), -b.center());
      } else if (const auto height = r.opt_number("height", kPositive)) {
        if (!(extent.y > 0.0f)) r.fail_key("height", "the mesh is flat in y");
        use.normalize =
            glm::scale(glm::mat4(1.0f), glm::vec3(static_cast<float>(*height) / extent.y)) *
            glm::translate(glm::mat4(1.0f), -glm::vec3(b.center().x, b.min.y, b.center().z));
      } else if (scatter) {
        use.normalize = glm::translate(glm::mat4(1.0f), -b.center());
      }
    }
    return use;
  }

  const Mesh& mesh_at(std::uint32_t index) const { return scene_.meshes[index]; }

 private:
  fs::path mesh_file(const Reader& r, const std::string& spec, const std::string& kind) const {
    if (kind == "file:") {
      const std::string given = spec.substr(5);
      if (given.empty()) r.fail_key("mesh", "'file:' needs a path, e.g. file:meshes/rock.obj");
      return input_file(r, "mesh", "mesh file", given);
    }
    const std::string model = spec.substr(6);
    const fs::path dir = model_dir();
    std::error_code ec;
    if (!model.empty() && model.find('/') == std::string::npos) {
      if (fs::path(model).has_extension() && fs::exists(dir / model, ec)) return dir / model;
      for (const char* ext : {".obj", ".3ds"}) {
        if (fs::exists(dir / (model + ext), ec)) return dir / (model + ext);
      }
    }
    const std::vector<std::string> names = model_names(dir);
    std::vector<std::string_view> views(names.begin(), names.end());
    r.fail_key("mesh", "model '" + model + "' not found in " + dir.string() +
                           (names.empty() ? " (is glmark2-data installed?)"
                                          : "; available: " + join(views)) +
                           did_you_mean(model, views));
  }

  template <class Make>
  std::uint32_t shared(const std::string& key, Make make) {
    if (const auto it = mesh_ids_.find(key); it != mesh_ids_.end()) return it->second;
    scene_.meshes.push_back(make());
    const auto id = static_cast<std::uint32_t>(scene_.meshes.size() - 1);
    mesh_ids_[key] = id;
    return id;
  }

  const Context& ctx_;
  Scene& scene_;
  std::map<std::string, std::uint32_t> mesh_ids_;
  std::map<std::string, std::uint32_t> material_lines_;
};

glm::mat4 rotation_xyz(glm::vec3 degrees) {
  // Applied about x, then y, then z (world axes).
  glm::mat4 m(1.0f);
  m = glm::rotate(m, glm::radians(degrees.z), glm::vec3(0, 0, 1));
  m = glm::rotate(m, glm::radians(degrees.y), glm::vec3(0, 1, 0));
  m = glm::rotate(m, glm::radians(degrees.x), glm::vec3(1, 0, 0));
  return m;
}

// `move` (metres), `move_frames` and `spin` (degrees per frame): the object's Motion.
void read_motion(const Reader& r, Instance& instance) {
  if (!r.has("move") && !r.has("move_frames") && !r.has("spin")) return;
  Motion m;
  m.base = instance.transform;
  m.move = r.vec3("move", glm::vec3(0.0f), ranges::closed(-1e5, 1e5));
  m.move_frames = r.uint("move_frames", 0, 0, 1000000);
  m.spin = r.vec3("spin", glm::vec3(0.0f), ranges::closed(-360.0, 360.0));
  if (r.has("move") && !r.has("move_frames"))
    r.fail_key("move", "needs move_frames, the frames from one end of the move to the other");
  if (r.has("move_frames") && !r.has("move"))
    r.fail_key("move_frames", "applies to a move; give move = [x, y, z] (metres)");
  Scene one;
  one.instances.push_back(instance);
  one.instances.back().motion = m;
  if (const std::string v = detail::motion_spin_violation(one, 0); !v.empty()) r.fail_key("spin", v);
  instance.motion = m;
}

void check_motion_bounds(const std::vector<const toml::table*>& objects, const Context& ctx,
                         const Scene& scene, std::size_t first_object) {
  for (std::size_t k = 0; k < objects.size(); ++k) {
    const std::string violation = detail::motion_bounds_violation(scene, first_object + k);
    if (violation.empty()) continue;
    const Reader r(ctx, *objects[k], indexed_label("object", k));
    r.fail_key("move", violation);
  }
}

void read_object(const Reader& r, Builder& builder, Scene& scene) {
  const MeshUse use = builder.mesh(
      r,
      {"mesh", "material", "position", "rotation", "scale", "casts_shadows", "analytic_shadow",
       "move", "move_frames", "spin"},
      false);
  Instance instance;
  instance.mesh = use.mesh;
  instance.material = builder.material(r);
  glm::vec3 scale(1.0f);
  bool uniform_scale = true;
  if (const toml::node* node = r.get("scale"); node != nullptr && node->is_array()) {
    scale = glm::vec3(*r.opt_vec<3>("scale", kPositive));
    uniform_scale = scale.x == scale.y && scale.y == scale.z;
  } else {
    scale = glm::vec3(r.numberf("scale", 1.0f, kPositive));
  }
  const glm::vec3 position = r.vec3("position", glm::vec3(0.0f));
  const glm::vec3 rotation = r.vec3("rotation", glm::vec3(0.0f));
  instance.transform = glm::translate(glm::mat4(1.0f), position) * rotation_xyz(rotation) *
                       glm::scale(glm::mat4(1.0f), scale) * use.normalize;
  instance.casts_shadows = r.boolean("casts_shadows", true);
  instance.analytic_sphere_radius =
      analytic_sphere_radius(r, use, uniform_scale, instance.casts_shadows);
  read_motion(r, instance);
  scene.instances.push_back(instance);
  check_analytic_count(r, scene);
}

// A deterministic generator (splitmix64), identical on every platform.
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

 private:
  std::uint64_t state_;
};

void read_scatter(const Reader& r, Builder& builder, Scene& scene) {
  const MeshUse use =
      builder.mesh(r,
                   {"mesh", "material", "count", "seed", "center", "radius", "inner_radius",
                    "flatten", "scale", "casts_shadows", "analytic_shadow"},
                   true);
  const std::uint32_t material = builder.material(r);
  if (!r.has("count")) r.missing("count");
  if (!r.has("radius")) r.missing("radius");
  const auto count = static_cast<std::uint32_t>(*r.opt_integer("count", 1, kMaxInstances));
  if (scene.instances.size() + count > kMaxInstances) {
    r.fail_key("count", std::to_string(count) + " more instances would make " +
                            std::to_string(scene.instances.size() + count) +
                            "; a scene has at most " + std::to_string(kMaxInstances) +
                            " (each is a draw in every pass)");
  }
  const auto seed = static_cast<std::uint64_t>(
      r.opt_integer("seed", 0, std::numeric_limits<std::int64_t>::max()).value_or(1));
  const glm::dvec3 center = r.opt_vec<3>("center").value_or(glm::dvec3(0.0));
  const double radius = *r.opt_number("radius", kPositive);
  const double inner = r.number("inner_radius", 0.0, kNonNegative);
  if (!(inner < radius)) {
    r.fail_at(r.get("inner_radius"), r.name("inner_radius") + " = " + format_number(inner) +
                                         " must be less than radius = " + format_number(radius));
  }
  const double flatten = r.number("flatten", 1.0, Range{0.0, 1.0, true, false});
  glm::dvec2 scale_range(1.0);
  if (const toml::node* node = r.get("scale"); node != nullptr && node->is_array()) {
    scale_range = *r.opt_vec<2>("scale", kPositive);
    if (scale_range.x > scale_range.y) {
      r.fail_at(node,
                r.name("scale") + " = " + describe(*node) + " must be [min, max] with min <= max");
    }
  } else {
    scale_range = glm::dvec2(r.number("scale", 1.0, kPositive));
  }
  const bool casts = r.boolean("casts_shadows", true);
  const float analytic_radius = analytic_sphere_radius(r, use, true, casts);

  const Bounds local = transform_bounds(builder.mesh_at(use.mesh).bounds, use.normalize);
  const double unit_radius = 0.5 * glm::length(glm::dvec3(local.size()));
  Random random(seed);
  struct Placed {
    glm::dvec3 position;
    double radius;
  };
  // Avoid earlier instances too, except those whose bounding sphere holds the centre (a ground
  // plane, the room around the field).
  std::vector<Placed> placed;
  for (const Instance& other : scene.instances) {
    const Bounds b = transform_bounds(scene.meshes[other.mesh].bounds, other.transform);
    const Placed sphere{glm::dvec3(b.center()), 0.5 * glm::length(glm::dvec3(b.size()))};
    if (glm::length(sphere.position - center) > sphere.radius) placed.push_back(sphere);
  }
  // Bounded work: overlap is avoided for fields of up to 4000 instances, until an instance finds
  // no free spot in 64 tries (the field is full) or 2·10^7 distance tests have been made; the
  // rest are placed where they fall. The same seed still gives the same field.
  bool avoid_overlap = count + placed.size() <= 4000;
  std::uint64_t tests = 0;
  constexpr std::uint64_t kMaxTests = 20'000'000;
  for (std::uint32_t i = 0; i < count; ++i) {
    const double scale = scale_range.x + (scale_range.y - scale_range.x) * random.uniform();
    const double bounding = unit_radius * scale;
    glm::dvec3 position = center;
    for (int attempt = 0; attempt < 64; ++attempt) {
      const double z = 2.0 * random.uniform() - 1.0;
      const double phi = 2.0 * glm::pi<double>() * random.uniform();
      const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
      const double r3 = inner * inner * inner +
                        (radius * radius * radius - inner * inner * inner) * random.uniform();
      glm::dvec3 offset = std::cbrt(r3) * glm::dvec3(s * std::cos(phi), z, s * std::sin(phi));
      offset.y *= flatten;
      position = center + offset;
      bool ok = glm::length(offset) >= inner;
      if (ok && avoid_overlap) {
        for (const Placed& p : placed) {
          ++tests;
          if (glm::length(p.position - position) < p.radius + bounding) {
            ok = false;
            break;
          }
        }
      }
      if (ok) break;
      if (attempt == 63 || tests > kMaxTests) avoid_overlap = false;
      if (!avoid_overlap && glm::length(offset) >= inner) break;
    }
    placed.push_back({position, bounding});
    // A uniformly random rotation (Shoemake).
    const double u1 = random.uniform();
    const double u2 = 2.0 * glm::pi<double>() * random.uniform();
    const double u3 = 2.0 * glm::pi<double>() * random.uniform();
    const glm::dquat q(std::sqrt(u1) * std::cos(u3), std::sqrt(1.0 - u1) * std::sin(u2),
                       std::sqrt(1.0 - u1) * std::cos(u2), std::sqrt(u1) * std::sin(u3));
    const glm::dmat4 transform = glm::translate(glm::dmat4(1.0), position) *
                                 glm::mat4_cast(glm::normalize(q)) *
                                 glm::scale(glm::dmat4(1.0), glm::dvec3(scale));
    scene.instances.push_back(
        Instance{use.mesh, material, glm::mat4(transform) * use.normalize, casts, analytic_radius});
  }
  check_analytic_count(r, scene);
}

}  // namespace

void read_geometry(const Context& ctx, const toml::table& root, Scene& scene) {
  Builder builder(ctx, scene);
  const auto materials = table_array(ctx, root, "material");
  for (std::size_t i = 0; i < materials.size(); ++i) {
    const Reader r(ctx, *materials[i], indexed_label("material", i));
    builder.add_material(r, read_material(r));
  }
  const auto objects = table_array(ctx, root, "object");
  const std::size_t first_object = scene.instances.size();
  for (std::size_t i = 0; i < objects.size(); ++i) {
    read_object(Reader(ctx, *objects[i], indexed_label("object", i)), builder, scene);
  }
  const auto scatters = table_array(ctx, root, "scatter");
  for (std::size_t i = 0; i < scatters.size(); ++i) {
    read_scatter(Reader(ctx, *scatters[i], indexed_label("scatter", i)), builder, scene);
  }
  check_motion_bounds(objects, ctx, scene, first_object);
}

}  // namespace penumbra::scene::file

namespace penumbra::scene::detail {

// A moving object's origin must stay within the still ones' bounds, grown by the object's own
// size on every side: an object that walks out of the scene is a typo in its move, and the sun's
// cascades take their depth range from everything the objects pass through.
std::string motion_bounds_violation(const Scene& scene, std::size_t i) {
  if (i >= scene.instances.size()) return "";
  const Instance& inst = scene.instances[i];
  if (!inst.motion || inst.motion->move_frames == 0 || inst.mesh >= scene.meshes.size())
    return "";
  Bounds still;
  for (const Instance& other : scene.instances)
    if (!other.motion) still.extend(scene.motion_bounds(other));
  const Bounds rest = transform_bounds(scene.meshes[inst.mesh].bounds, inst.motion->base);
  if (still.empty() || rest.empty()) return "";
  const glm::vec3 s = rest.size();
  const float grow = std::max({s.x, s.y, s.z});
  const glm::vec3 lo = still.min - grow, hi = still.max + grow;
  const glm::vec3 from(inst.motion->base[3]);
  const glm::vec3 to = from + inst.motion->move;
  const auto inside = [&](glm::vec3 p) {
    return glm::all(glm::greaterThanEqual(p, lo)) && glm::all(glm::lessThanEqual(p, hi));
  };
  if (inside(from) && inside(to)) return "";
  const auto fmt = [](glm::vec3 v) {
    return "[" + file::format_number(v.x) + ", " + file::format_number(v.y) + ", " + file::format_number(v.z) + "]";
  };
  return "the object's move takes it to " + fmt(to) + ", outside the still objects' bounds " +
         fmt(still.min) + " .. " + fmt(still.max) + " grown by its own size (" +
         file::format_number(grow) + " m)";
}

std::string motion_spin_violation(const Scene& scene, std::size_t i) {
  if (i >= scene.instances.size()) return "";
  const Instance& inst = scene.instances[i];
  if (inst.analytic_sphere_radius > 0.0f && inst.motion && inst.motion->spin != glm::vec3(0.0f))
    return "an analytic sphere's shadow does not turn; spin it without analytic_shadow, or move "
           "it instead";
  return "";
}

}  // namespace penumbra::scene::detail
