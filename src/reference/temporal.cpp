// Temporal stability: flicker between consecutive frames along a camera or sun path
// (temporal.hpp has the definitions).
#include <algorithm>
#include <array>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <penumbra/core/error.hpp>
#include <penumbra/reference/metrics.hpp>
#include <penumbra/reference/temporal.hpp>
#include <penumbra/render/frame_types.hpp>

namespace penumbra::reference {
namespace {

// The partial-visibility band and the neighbourhood span that make a pixel a shadow edge.
constexpr float kPenumbraLow = 0.02f, kPenumbraHigh = 0.98f, kEdgeSpan = 0.5f;
// Reprojected neighbours must lie on the receiver's surface: within this fraction of the
// distance to the camera, plus a constant (metres).
constexpr double kSurfaceFraction = 0.02, kSurfaceConstant = 0.002;
// ... and face the same way (cosine between the normals): the other side of a crease (a room's
// corner, a box's edge) is near in distance but another surface.
constexpr double kSameNormal = 0.9;
// Bilinear neighbours lighter than this do not widen the previous frame's range (a still camera
// puts all the weight on one pixel, up to rounding).
constexpr double kNeighbourWeight = 1e-3;

uint32_t visibility_slot(const LightRef& l) {
  return l.kind == LightKind::sun    ? render::kSunVisibilitySlot
         : l.kind == LightKind::spot ? render::spot_visibility_slot(l.index)
                                     : render::point_visibility_slot(l.index);
}

bool drawn(const LightRef& l) {
  return !((l.kind == LightKind::spot && l.index >= render::kMaxSpotLights) ||
           (l.kind == LightKind::point && l.index >= render::kMaxPointLights));
}

glm::vec3 rotate_about_up(glm::vec3 v, glm::vec3 up, double degrees) {
  const glm::dmat4 r = glm::rotate(glm::dmat4(1.0), glm::radians(degrees), glm::dvec3(up));
  return glm::vec3(glm::dmat3(r) * glm::dvec3(v));
}

void apply(scene::Scene& s, const CameraPath& path, uint32_t k) {
  const double amount = path.step * double(k);
  switch (path.motion) {
    case Motion::translate: {
      const glm::vec3 forward = s.camera.target - s.camera.position;
      const glm::vec3 right = glm::normalize(glm::cross(forward, s.camera.up));
      const glm::vec3 offset = right * float(amount);
      s.camera.position += offset;
      s.camera.target += offset;
      break;
    }
    case Motion::yaw:
      s.camera.target =
          s.camera.position +
          rotate_about_up(s.camera.target - s.camera.position, s.camera.up, amount);
      break;
    case Motion::sun_azimuth:
      if (s.sun) s.sun->direction = rotate_about_up(s.sun->direction, {0, 1, 0}, amount);
      break;
  }
}

}  // namespace

std::vector<CameraPath> standard_paths() {
  return {{"translate-1mm", Motion::translate, 0.001},
          {"translate-1cm", Motion::translate, 0.01},
          {"yaw-0.05deg", Motion::yaw, 0.05},
          {"sun-0.05deg", Motion::sun_azimuth, 0.05}};
}

CameraPath find_path(const std::string& name) {
  std::string have;
  for (const auto& p : standard_paths()) {
    if (p.name == name) return p;
    have += (have.empty() ? "" : ", ") + p.name;
  }
  throw Error("no camera path '" + name + "' (the paths: " + have + ")");
}

void count_flicker(const FrameSample& previous, const FrameSample& current, float threshold,
                   size_t& edge_pixels, size_t& changed, std::vector<uint32_t>* per_pixel,
                   double* edge_weight, double* changed_weight) {
  const Receivers& pr = previous.receivers;
  const Receivers& cr = current.receivers;
  const uint32_t w = cr.width, h = cr.height;
  if (pr.width != w || pr.height != h || previous.visibility.size() != pr.size() ||
      current.visibility.size() != cr.size() || previous.reached.size() != pr.size() ||
      current.reached.size() != cr.size())
    throw Error("count_flicker: the two frames differ in size");
  const glm::dmat4 prev_view_proj = previous.camera.proj * previous.camera.view;
  const glm::dvec3 eye = cr.origin + cr.eye.value_or(glm::dvec3(0.0));
  auto usable = [](const Receivers& r, const std::vector<uint8_t>& reached, size_t i) {
    return r.valid[i] && reached[i];
  };
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const size_t i = size_t{y} * w + x;
      if (!usable(cr, current.reached, i)) continue;
      // A shadow edge in the current frame.
      const float v = current.visibility[i];
      float lo = v, hi = v;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int nx = int(x) + dx, ny = int(y) + dy;
          if (nx < 0 || ny < 0 || nx >= int(w) || ny >= int(h)) continue;
          const size_t j = size_t(ny) * w + size_t(nx);
          if (!usable(cr, current.reached, j)) continue;
          lo = std::min(lo, current.visibility[j]);
          hi = std::max(hi, current.visibility[j]);
        }
      if (!(hi - lo >= kEdgeSpan || (v > kPenumbraLow && v < kPenumbraHigh))) continue;
      // Its world position in the previous frame's pixels (centre coordinates).
      const glm::dvec3 world = cr.origin + cr.position[i];
      const glm::dvec4 c = prev_view_proj * glm::dvec4(world - previous.camera.origin, 1.0);
      if (!(c.w > 0.0)) continue;
      const double px = (c.x / c.w + 1.0) * 0.5 * w - 0.5;
      const double py = (c.y / c.w + 1.0) * 0.5 * h - 0.5;
      const double fx = std::floor(px), fy = std::floor(py);
      if (!(fx >= 0.0 && fy >= 0.0 && fx + 1.0 < double(w) && fy + 1.0 < double(h))) continue;
      const double ax = px - fx, ay = py - fy;
      const double tolerance = kSurfaceFraction * glm::length(world - eye) + kSurfaceConstant;
      // The range of the previous frame's values around the point: the neighbours that carry
      // weight in the bilinear footprint (a TAA resolve's neighbourhood clamp). A value inside
      // it is the same shadow seen from elsewhere (a point-sampled edge, moved a fraction of a
      // pixel); outside it by more than the threshold, the shadow itself changed.
      double prev_lo = 2.0, prev_hi = -1.0;
      bool same_surface = true;
      for (int k = 0; k < 4 && same_surface; ++k) {
        const size_t j = size_t(fy + (k >> 1)) * w + size_t(fx + (k & 1));
        const double weight = ((k & 1) ? ax : 1.0 - ax) * ((k >> 1) ? ay : 1.0 - ay);
        if (weight <= kNeighbourWeight) continue;
        same_surface = usable(pr, previous.reached, j) &&
                       glm::length(pr.origin + pr.position[j] - world) <= tolerance &&
                       glm::dot(pr.normal[j], cr.normal[i]) >= kSameNormal;
        prev_lo = std::min(prev_lo, double(previous.visibility[j]));
        prev_hi = std::max(prev_hi, double(previous.visibility[j]));
      }
      if (!same_surface || prev_hi < prev_lo) continue;
      ++edge_pixels;
      const double weight = current.weight.size() == cr.size() ? double(current.weight[i]) : 1.0;
      if (edge_weight) *edge_weight += weight;
      if (double(v) < prev_lo - double(threshold) || double(v) > prev_hi + double(threshold)) {
        ++changed;
        if (changed_weight) *changed_weight += weight;
        if (per_pixel && per_pixel->size() == cr.size()) ++(*per_pixel)[i];
      }
    }
}

std::vector<uint8_t> flicker_image(const Flicker& flicker, std::span<const uint8_t> lit,
                                   uint32_t pairs) {
  const size_t n = size_t{flicker.width} * flicker.height;
  if (lit.size() != n * 4 || flicker.changed_per_pixel.size() != n)
    throw Error("flicker_image: the frame and the counts differ in size");
  std::vector<uint8_t> out(n * 4);
  for (size_t i = 0; i < n; ++i) {
    const float grey =
        0.5f * (0.299f * lit[4 * i] + 0.587f * lit[4 * i + 1] + 0.114f * lit[4 * i + 2]);
    const float f = pairs ? std::min(1.0f, float(flicker.changed_per_pixel[i]) / float(pairs)) : 0;
    const float k = f > 0.0f ? 0.35f + 0.65f * f : 0.0f;  // any flicker shows
    out[4 * i] = uint8_t(std::lround(grey * (1.0f - k) + 255.0f * k));
    out[4 * i + 1] = uint8_t(std::lround(grey * (1.0f - k)));
    out[4 * i + 2] = uint8_t(std::lround(grey * (1.0f - k)));
    out[4 * i + 3] = 255;
  }
  return out;
}

std::vector<Flicker> measure_flicker(render::Renderer& renderer, const CameraPath& path,
                                     const FlickerOptions& options) {
  if (options.frames < 2)
    throw Error("measure_flicker: " + std::to_string(options.frames) +
                " frames (at least 2: flicker is measured between consecutive frames)");
  if (!(path.step >= 0.0) || !std::isfinite(path.step))
    throw Error("measure_flicker: path '" + path.name + "' has step " + std::to_string(path.step));
  scene::Scene& s = renderer.scene();
  if (path.motion == Motion::sun_azimuth && !s.sun) return {};
  std::vector<LightRef> lights;
  for (const auto& l : scene_lights(s))
    if (drawn(l)) lights.push_back(l);
  std::vector<Flicker> out;
  for (const auto& l : lights) {
    Flicker f{path.name, l.name()};
    f.width = renderer.width();
    f.height = renderer.height();
    f.changed_per_pixel.assign(size_t{f.width} * f.height, 0);
    out.push_back(std::move(f));
  }

  const scene::Camera camera = s.camera;
  const std::optional<scene::Sun> sun = s.sun;
  std::vector<FrameSample> previous(lights.size()), current(lights.size());
  try {
    for (uint32_t k = 0; k < options.frames; ++k) {
      s.camera = camera;
      s.sun = sun;
      apply(s, path, k);
      renderer.render(k);
      const render::GBuffer g = renderer.read_gbuffer();
      const Receivers receivers = receivers_from_gbuffer(
          g.width, g.height, g.depth, g.normal_view, g.camera.view, g.camera.proj, g.camera.origin);
      for (size_t li = 0; li < lights.size(); ++li) {
        FrameSample& f = current[li];
        f.receivers = receivers;
        f.camera = g.camera;
        f.visibility = renderer.read_visibility(visibility_slot(lights[li]));
        const auto classes = classify_receivers(receivers, s, lights[li], &f.weight);
        f.reached.resize(classes.size());
        for (size_t i = 0; i < classes.size(); ++i) {
          f.reached[i] = classes[i] != ReceiverClass::none;
          if (classes[i] != ReceiverClass::lit) f.weight[i] = 0.0f;
        }
        if (k > 0)
          count_flicker(previous[li], f, options.threshold, out[li].edge_pixels, out[li].changed,
                        &out[li].changed_per_pixel, &out[li].edge_weight,
                        &out[li].changed_weight);
      }
      std::swap(previous, current);
    }
  } catch (...) {
    s.camera = camera;
    s.sun = sun;
    throw;
  }
  s.camera = camera;
  s.sun = sun;
  return out;
}

}  // namespace penumbra::reference
