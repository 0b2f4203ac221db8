// The ray tracer of the reference: the scene's casters in an Embree 3 BVH, area-light sampling
// per receiver with an adaptive early stop, on a pool of threads.
#include <embree3/rtcore.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <penumbra/core/error.hpp>
#include <penumbra/reference/reference.hpp>
#include <thread>

#include "hash.hpp"

namespace penumbra::reference {
namespace {

bool finite(const glm::dvec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// An orthonormal basis around unit w (Duff et al. 2017, branchless).
void basis(const glm::dvec3& w, glm::dvec3& e1, glm::dvec3& e2) {
  const double sign = std::copysign(1.0, w.z);
  const double a = -1.0 / (sign + w.z);
  const double b = w.x * w.y * a;
  e1 = {1.0 + sign * w.x * w.x * a, sign * b, -sign * w.x};
  e2 = {b, sign + w.y * w.y * a, -w.y};
}

// What the tracer keeps of each geometry: the triangles as Embree has them (relative to the
// origin, float), the world vertex normals (for the terminator offset) and, for masked
// materials, the uvs and the mask.
struct Surface {
  std::vector<glm::vec3> position;
  std::vector<glm::vec3> normal;  // unit, world orientation
  std::vector<uint32_t> indices;
  bool masked = false;
  std::vector<glm::vec2> uv;
  scene::Material material;  // its mask: the pattern or the texture, the scale and the cutoff
};

// A shadow ray's context: the triangle it starts on, which it ignores (terminator = smooth).
struct ShadowContext {
  RTCIntersectContext context;  // first: Embree passes a pointer to it to the filters
  unsigned self_geometry = RTC_INVALID_GEOMETRY_ID;
  unsigned self_primitive = RTC_INVALID_GEOMETRY_ID;
};

// Embree's occlusion filter: a hit on the ray's own triangle, or where a mask cuts the surface
// out, is rejected and the ray goes on.
void occlusion_filter(const RTCFilterFunctionNArguments* args) {
  const auto* g = static_cast<const Surface*>(args->geometryUserPtr);
  const auto* c = reinterpret_cast<const ShadowContext*>(args->context);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    if (RTCHitN_geomID(args->hit, args->N, i) == c->self_geometry && prim == c->self_primitive) {
      args->valid[i] = 0;
      continue;
    }
    if (!g->masked) continue;
    const float u = RTCHitN_u(args->hit, args->N, i), v = RTCHitN_v(args->hit, args->N, i);
    const glm::vec2 uv = (1.0f - u - v) * g->uv[g->indices[3 * prim]] +
                         u * g->uv[g->indices[3 * prim + 1]] + v * g->uv[g->indices[3 * prim + 2]];
    if (scene::alpha_test_discards(g->material, uv)) args->valid[i] = 0;
  }
}

std::string embree_error(RTCDevice device) {
  switch (rtcGetDeviceError(device)) {
    case RTC_ERROR_NONE:
      return "";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "out of memory";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
      return "invalid operation";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "unsupported CPU";
    default:
      return "unknown error";
  }
}

}  // namespace

struct Tracer::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  glm::dvec3 origin{0.0};
  size_t triangles = 0;
  uint64_t hash = 0;
  std::vector<std::unique_ptr<Surface>> surfaces;  // by Embree geometry id

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

Tracer::Tracer(const scene::Scene& s, glm::dvec3 origin) : impl_(std::make_unique<Impl>()) {
  auto& m = *impl_;
  m.origin = origin;
  m.device = rtcNewDevice(nullptr);
  if (!m.device) throw Error("reference: Embree could not create a device");
  m.scene = rtcNewScene(m.device);
  rtcSetSceneBuildQuality(m.scene, RTC_BUILD_QUALITY_HIGH);
  detail::Hasher hash;
  for (const auto& inst : s.instances) {
    if (!inst.casts_shadows) continue;
    const scene::Mesh& mesh = s.meshes.at(inst.mesh);
    const scene::Material& mat = s.materials.at(inst.material);
    if (mesh.vertices.empty() || mesh.indices.size() < 3) continue;
    // The GPU's model matrix: the transform relative to the origin, in double, then float.
    glm::dmat4 model = glm::dmat4(inst.transform);
    model[3] -= glm::dvec4(origin, 0.0);
    const glm::mat4 model_f = glm::mat4(model);
    // Triangles with a non-finite corner are left out (the rasterizer draws nothing there).
    std::vector<glm::vec3> positions(mesh.vertices.size());
    for (size_t v = 0; v < positions.size(); ++v)
      positions[v] = glm::vec3(model_f * glm::vec4(mesh.vertices[v].position, 1.0f));
    std::vector<uint32_t> indices;
    indices.reserve(mesh.indices.size());
    for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      bool ok = true;
      for (int k = 0; k < 3; ++k) {
        const uint32_t idx = mesh.indices[t + k];
        if (idx >= positions.size()) {
          ok = false;
          break;
        }
        const glm::vec3 p = positions[idx];
        ok = ok && std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
      }
      if (ok)
        indices.insert(indices.end(), mesh.indices.begin() + long(t),
                       mesh.indices.begin() + long(t) + 3);
    }
    if (indices.empty()) continue;
    auto surface = std::make_unique<Surface>();
    // Normals transform with the inverse transpose; a degenerate one is left zero (no offset).
    const glm::dmat3 normal_matrix = glm::transpose(glm::inverse(glm::dmat3(model)));
    surface->normal.resize(mesh.vertices.size());
    for (size_t v = 0; v < mesh.vertices.size(); ++v) {
      const glm::dvec3 n = normal_matrix * glm::dvec3(mesh.vertices[v].normal);
      const double len = glm::length(n);
      surface->normal[v] = len > 0.0 && std::isfinite(len) ? glm::vec3(n / len) : glm::vec3(0.0f);
    }
    RTCGeometry g = rtcNewGeometry(m.device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, sizeof(float) * 3, positions.size()));
    auto* ib = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, sizeof(uint32_t) * 3, indices.size() / 3));
    if (!vb || !ib) {
      rtcReleaseGeometry(g);
      throw Error("reference: Embree could not allocate the buffers of mesh '" + mesh.name +
                  "': " + embree_error(m.device));
    }
    std::memcpy(vb, positions.data(), positions.size() * sizeof(glm::vec3));
    std::memcpy(ib, indices.data(), indices.size() * sizeof(uint32_t));
    hash.bytes(positions.data(), positions.size() * sizeof(glm::vec3));
    hash.bytes(indices.data(), indices.size() * sizeof(uint32_t));
    hash.bytes(surface->normal.data(), surface->normal.size() * sizeof(glm::vec3));
    if (mat.alpha == scene::AlphaMode::masked) {
      surface->masked = true;
      surface->uv.reserve(mesh.vertices.size());
      for (const auto& v : mesh.vertices) surface->uv.push_back(v.uv);
      surface->material = mat;
      hash.bytes(surface->uv.data(), surface->uv.size() * sizeof(glm::vec2));
      hash.pod(int(mat.mask));
      hash.pod(mat.mask_scale);
      hash.pod(mat.alpha_cutoff);
      if (mat.mask_image) {
        hash.pod(mat.mask_image->width);
        hash.pod(mat.mask_image->height);
        hash.bytes(mat.mask_image->texels.data(), mat.mask_image->texels.size());
      }
    }
    surface->position = std::move(positions);
    surface->indices = std::move(indices);
    rtcSetGeometryUserData(g, surface.get());
    rtcSetGeometryOccludedFilterFunction(g, occlusion_filter);
    rtcCommitGeometry(g);
    const unsigned id = rtcAttachGeometry(m.scene, g);
    rtcReleaseGeometry(g);
    m.triangles += surface->indices.size() / 3;
    if (m.surfaces.size() <= id) m.surfaces.resize(id + 1);
    m.surfaces[id] = std::move(surface);
  }
  rtcCommitScene(m.scene);
  if (const auto e = embree_error(m.device); !e.empty())
    throw Error("reference: building the BVH of scene '" + s.name + "' failed: " + e);
  hash.pod(origin);
  m.hash = hash.h;
}

Tracer::~Tracer() = default;

size_t Tracer::triangle_count() const {
  return impl_->triangles;
}
glm::dvec3 Tracer::origin() const {
  return impl_->origin;
}
uint64_t Tracer::geometry_hash() const {
  return impl_->hash;
}

namespace {

struct LightSampler {
  AreaLight light;
  glm::dvec3 centre_rel{0.0};  // spot / point: relative to the origin
  glm::dvec3 e1{0.0}, e2{0.0};
  double tan_radius = 0.0;

  // Direction from p toward the centre of the light (unit) and the distance to the light (inf
  // for the sun); false when p is inside a sphere light.
  bool centre(const glm::dvec3& p, glm::dvec3& dir, double& dist) const {
    if (light.kind == LightKind::sun) {
      dir = light.direction_to_light;
      dist = std::numeric_limits<double>::infinity();
      return true;
    }
    const glm::dvec3 c = centre_rel - p;
    dist = glm::length(c);
    if (!(dist > light.radius) || !(dist > 0.0)) return false;
    dir = c / dist;
    return true;
  }

  // Sample u in [0, 1)² → direction and ray length; (b1, b2) span the plane normal to
  // to_centre (sphere lights; from basis(), once per receiver).
  void sample(glm::dvec2 u, const glm::dvec3& to_centre, double dist, const glm::dvec3& b1,
              const glm::dvec3& b2, glm::dvec3& dir, double& tfar) const {
    const glm::dvec2 d = concentric_disk(u);
    if (light.kind == LightKind::sun) {
      dir = glm::normalize(to_centre + tan_radius * (d.x * e1 + d.y * e2));
      tfar = std::numeric_limits<double>::infinity();
      return;
    }
    // Uniform in the solid angle of the sphere: the disk's radius² maps to 1 - cos θ.
    const double sin_max = light.radius / dist;
    const double one_minus_cos_max = sin_max * sin_max / (1.0 + std::sqrt(1.0 - sin_max * sin_max));
    const double rho2 = d.x * d.x + d.y * d.y;
    const double one_minus_cos = rho2 * one_minus_cos_max;
    const double cos_t = 1.0 - one_minus_cos;
    const double sin_t = std::sqrt(std::max(0.0, one_minus_cos * (2.0 - one_minus_cos)));
    const double rho = std::sqrt(rho2);
    const double cx = rho > 0.0 ? d.x / rho : 1.0, cy = rho > 0.0 ? d.y / rho : 0.0;
    dir = cos_t * to_centre + sin_t * (cx * b1 + cy * b2);
    // The near intersection with the sphere.
    const double b = dist * cos_t;
    const double disc = light.radius * light.radius - dist * dist * sin_t * sin_t;
    tfar = b - std::sqrt(std::max(0.0, disc));
  }
};

bool occluded(RTCScene scene, ShadowContext& context, const glm::dvec3& org, const glm::dvec3& dir,
              double tfar) {
  RTCRay ray{};
  ray.org_x = float(org.x);
  ray.org_y = float(org.y);
  ray.org_z = float(org.z);
  ray.dir_x = float(dir.x);
  ray.dir_y = float(dir.y);
  ray.dir_z = float(dir.z);
  ray.tnear = 0.0f;
  ray.tfar = std::isfinite(tfar) ? float(tfar) : std::numeric_limits<float>::infinity();
  ray.mask = 0xffffffffu;
  ray.flags = 0;
  rtcOccluded1(scene, &context.context, &ray);
  return ray.tfar < 0.0f;  // Embree sets tfar to -inf on a hit
}

// The caster surface at receiver p: the first hit of a short ray through p along unit `along`
// (the view ray for G-buffer receivers, minus the normal for explicit points), from `window`
// metres before p to `window` past it. False when p is on no caster (a receiver that casts no
// shadow, or one off by more than the window).
bool surface_at(RTCScene scene, const glm::dvec3& p, const glm::dvec3& along, double window,
                RTCRayHit& rh) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  rh = RTCRayHit{};
  const glm::dvec3 org = p - along * window;
  rh.ray.org_x = float(org.x);
  rh.ray.org_y = float(org.y);
  rh.ray.org_z = float(org.z);
  rh.ray.dir_x = float(along.x);
  rh.ray.dir_y = float(along.y);
  rh.ray.dir_z = float(along.z);
  rh.ray.tnear = 0.0f;
  rh.ray.tfar = float(2.0 * window);
  rh.ray.mask = 0xffffffffu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene, &context, &rh);
  return rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
}

}  // namespace

bool Tracer::blocked(const glm::dvec3& origin_relative, const glm::dvec3& direction,
                     double tfar) const {
  ShadowContext context;
  rtcInitIntersectContext(&context.context);
  return occluded(impl_->scene, context, origin_relative, direction, tfar);
}

glm::dvec3 terminator_offset(const std::array<glm::dvec3, 3>& vertex,
                             const std::array<glm::dvec3, 3>& normal, const glm::dvec3& p,
                             const glm::dvec3& barycentric) {
  glm::dvec3 offset(0.0);
  for (int k = 0; k < 3; ++k) {
    // Below vertex k's tangent plane: move up onto it; above it: stay (outward only).
    const double below = std::min(0.0, glm::dot(p - vertex[k], normal[k]));
    offset -= barycentric[k] * below * normal[k];
  }
  return offset;
}

namespace {

void print_progress(const std::string& label, size_t done, size_t total, double elapsed) {
  const double f = total ? double(done) / double(total) : 1.0;
  const int width = 30;
  const int filled = static_cast<int>(f * width);
  const double eta = f > 0.0 ? elapsed * (1.0 - f) / f : 0.0;
  std::fprintf(stderr, "\r%s [%.*s%*s] %5.1f%%  ETA %4.0f s ", label.c_str(), filled,
               "##############################", width - filled, "", 100.0 * f, eta);
  std::fflush(stderr);
}

}  // namespace

Visibility Tracer::trace(const Receivers& receivers, const AreaLight& light,
                         const TraceOptions& options) const {
  if (options.samples == 0) throw Error("reference: samples must be >= 1");
  const auto start = std::chrono::steady_clock::now();
  LightSampler ls;
  ls.light = light;
  if (light.kind == LightKind::sun) {
    ls.light.direction_to_light = glm::normalize(light.direction_to_light);
    if (!finite(ls.light.direction_to_light))
      throw Error("reference: the sun's direction is not a usable vector");
    basis(ls.light.direction_to_light, ls.e1, ls.e2);
    ls.tan_radius = std::tan(light.angular_radius);
  } else {
    ls.centre_rel = light.position - impl_->origin;
  }
  const bool hard = light.hard();
  const bool smooth = options.terminator == Terminator::smooth;
  const uint32_t max_samples = hard ? 1 : options.samples;
  const uint32_t initial = std::clamp(options.initial_samples, 1u, max_samples);

  const size_t n = receivers.size();
  Visibility out;
  out.value.assign(n, std::numeric_limits<float>::quiet_NaN());
  out.std_error.assign(n, std::numeric_limits<float>::quiet_NaN());
  out.samples.assign(n, 0);
  std::atomic<uint64_t> rays{0};
  std::atomic<size_t> next{0}, done{0};
  constexpr size_t kChunk = 256;
  RTCScene scene = impl_->scene;

  auto work = [&] {
    uint64_t local_rays = 0;
    for (;;) {
      const size_t begin = next.fetch_add(kChunk);
      if (begin >= n) break;
      const size_t end = std::min(n, begin + kChunk);
      for (size_t i = begin; i < end; ++i) {
        if (!receivers.valid[i]) continue;
        const glm::dvec3 p = receivers.position[i];
        glm::dvec3 to_centre;
        double dist;
        if (!ls.centre(p, to_centre, dist)) {  // inside the light: it is all visible
          out.value[i] = 1.0f;
          out.std_error[i] = 0.0f;
          out.samples[i] = 1;
          continue;
        }
        // Offset toward the light's side of the surface.
        glm::dvec3 nrm = receivers.normal[i];
        if (glm::dot(nrm, to_centre) < 0.0) nrm = -nrm;
        ShadowContext context;
        rtcInitIntersectContext(&context.context);
        glm::dvec3 surface_point = p;
        RTCRayHit rh;
        // G-buffer receivers are looked up along their view ray, within the stored depth's
        // rounding, and moved onto the surface found; explicit points along their normal.
        const bool from_view = receivers.eye.has_value() && i < receivers.depth_tolerance.size();
        const glm::dvec3 along =
            from_view ? glm::normalize(p - *receivers.eye) : -receivers.normal[i];
        const double window =
            std::max(16.0 * ray_offset(p), from_view ? double(receivers.depth_tolerance[i]) : 0.0);
        // (Explicit points under the flat-triangle model need no lookup.)
        const bool on_caster =
            (smooth || from_view) && finite(along) && surface_at(scene, p, along, window, rh);
        if (on_caster && from_view) {
          const double t = double(rh.ray.tfar);
          surface_point = p + along * (t - window);
        }
        if (smooth && on_caster) {
          const Surface& surface = *impl_->surfaces.at(rh.hit.geomID);
          const uint32_t* tri = &surface.indices[3 * size_t{rh.hit.primID}];
          const glm::dvec3 b(1.0 - double(rh.hit.u) - double(rh.hit.v), rh.hit.u, rh.hit.v);
          std::array<glm::dvec3, 3> v, nv;
          glm::dvec3 smooth_normal(0.0);
          for (int k = 0; k < 3; ++k) {
            v[k] = glm::dvec3(surface.position[tri[k]]);
            nv[k] = glm::dvec3(surface.normal[tri[k]]);
            smooth_normal += b[k] * nv[k];
          }
          // Only where the light is on the smooth surface's outer side; behind it the surface
          // shadows itself, and the flat triangle's answer stands.
          if (glm::dot(smooth_normal, to_centre) > 0.0) {
            const glm::dvec3 on_triangle = b[0] * v[0] + b[1] * v[1] + b[2] * v[2];
            surface_point += terminator_offset(v, nv, on_triangle, b);
            context.self_geometry = rh.hit.geomID;
            context.self_primitive = rh.hit.primID;
          }
        }
        const glm::dvec3 org = surface_point + nrm * ray_offset(surface_point);
        uint32_t visible = 0, count = 0;
        if (hard) {
          visible = occluded(scene, context, org, to_centre, dist) ? 0 : 1;
          count = 1;
        } else {
          const uint64_t seed = options.shared_pattern
                                    ? detail::mix64(options.seed)
                                    : detail::mix64(options.seed ^ detail::mix64(i));
          glm::dvec3 b1(0.0), b2(0.0);
          if (light.kind != LightKind::sun) basis(to_centre, b1, b2);
          for (; count < max_samples; ++count) {
            if (options.adaptive && count == initial && (visible == 0 || visible == count)) break;
            glm::dvec3 dir;
            double tfar;
            ls.sample(sobol_owen(count, seed), to_centre, dist, b1, b2, dir, tfar);
            if (!occluded(scene, context, org, dir, tfar)) ++visible;
          }
        }
        local_rays += count;
        const double pv = double(visible) / count;
        out.value[i] = float(pv);
        out.std_error[i] =
            hard ? 0.0f : float(std::sqrt(std::max(pv * (1.0 - pv), 1.0 / count) / count));
        out.samples[i] = count;
      }
      done.fetch_add(end - begin);
    }
    rays.fetch_add(local_rays);
  };

  const uint32_t threads =
      options.threads ? options.threads : std::max(1u, std::thread::hardware_concurrency());
  const bool show = options.progress && isatty(STDERR_FILENO);
  std::vector<std::thread> pool;
  for (uint32_t t = 0; t < threads; ++t) pool.emplace_back(work);
  if (show) {
    while (done.load() < n) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      print_progress(
          options.progress_label, std::min(done.load(), n), n,
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
  }
  for (auto& t : pool) t.join();
  out.rays = rays.load();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (show) {
    print_progress(options.progress_label, n, n, out.seconds);
    std::fprintf(stderr, "\n");
  }
  return out;
}

}  // namespace penumbra::reference
