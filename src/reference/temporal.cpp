// Temporal stability: flicker between consecutive frames along a camera or sun path
// (temporal.hpp has the definitions).
#include <algorithm>
#include <array>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <memory>
#include <penumbra/core/error.hpp>
#include <penumbra/reference/metrics.hpp>
#include <penumbra/reference/temporal.hpp>
#include <penumbra/render/frame_types.hpp>
#include <thread>
#include <utility>
#include <vector>

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
      s.camera.target = s.camera.position +
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

namespace {

// The range of `visibility` over the 3x3 neighbourhood of (x, y) in a w x h image, over the
// pixels `use` accepts (the centre always counts).
template <class Use>
std::pair<float, float> neighbourhood_range(const std::vector<float>& visibility, uint32_t w,
                                            uint32_t h, uint32_t x, uint32_t y, Use use) {
  const float v = visibility[size_t{y} * w + x];
  float lo = v, hi = v;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int nx = int(x) + dx, ny = int(y) + dy;
      if (nx < 0 || ny < 0 || nx >= int(w) || ny >= int(h)) continue;
      const size_t j = size_t(ny) * w + size_t(nx);
      if (!use(j)) continue;
      lo = std::min(lo, visibility[j]);
      hi = std::max(hi, visibility[j]);
    }
  return {lo, hi};
}

// One pixel of `current` against `previous`: whether it is a shadow edge, whether it
// reprojects onto the same surface (measured), and whether it changed beyond the threshold.
struct PixelFlicker {
  bool measured = false, edge = false, changed = false;
};

class Reprojection {
 public:
  Reprojection(const FrameSample& previous, const FrameSample& current)
      : p_(previous), c_(current) {
    const Receivers& pr = previous.receivers;
    const Receivers& cr = current.receivers;
    if (pr.width != cr.width || pr.height != cr.height || previous.visibility.size() != pr.size() ||
        current.visibility.size() != cr.size() || previous.reached.size() != pr.size() ||
        current.reached.size() != cr.size())
      throw Error("count_flicker: the two frames differ in size");
    prev_view_proj_ = previous.camera.proj * previous.camera.view;
    eye_ = cr.origin + cr.eye.value_or(glm::dvec3(0.0));
  }

  PixelFlicker at(uint32_t x, uint32_t y, float threshold) const {
    const Receivers& pr = p_.receivers;
    const Receivers& cr = c_.receivers;
    const uint32_t w = cr.width, h = cr.height;
    const size_t i = size_t{y} * w + x;
    PixelFlicker out;
    if (!usable(cr, c_.reached, i)) return out;
    // A shadow edge in the current frame.
    const float v = c_.visibility[i];
    const auto [lo, hi] = neighbourhood_range(c_.visibility, w, h, x, y,
                                              [&](size_t j) { return usable(cr, c_.reached, j); });
    out.edge = hi - lo >= kEdgeSpan || (v > kPenumbraLow && v < kPenumbraHigh);
    // Its world position in the previous frame's pixels (centre coordinates).
    const glm::dvec3 world = cr.origin + cr.position[i];
    const glm::dvec4 c = prev_view_proj_ * glm::dvec4(world - p_.camera.origin, 1.0);
    if (!(c.w > 0.0)) return out;
    const double px = (c.x / c.w + 1.0) * 0.5 * w - 0.5;
    const double py = (c.y / c.w + 1.0) * 0.5 * h - 0.5;
    const double fx = std::floor(px), fy = std::floor(py);
    if (!(fx >= 0.0 && fy >= 0.0 && fx + 1.0 < double(w) && fy + 1.0 < double(h))) return out;
    const double ax = px - fx, ay = py - fy;
    const double tolerance = kSurfaceFraction * glm::length(world - eye_) + kSurfaceConstant;
    // The range of the previous frame's values around the point: the neighbours that carry
    // weight in the bilinear footprint (a TAA resolve's neighbourhood clamp). A value inside
    // it is the same shadow seen from elsewhere (a point-sampled edge, moved a fraction of a
    // pixel); outside it by more than the threshold, the shadow itself changed.
    double prev_lo = 2.0, prev_hi = -1.0;
    for (int k = 0; k < 4; ++k) {
      const size_t j = size_t(fy + (k >> 1)) * w + size_t(fx + (k & 1));
      const double weight = ((k & 1) ? ax : 1.0 - ax) * ((k >> 1) ? ay : 1.0 - ay);
      if (weight <= kNeighbourWeight) continue;
      if (!(usable(pr, p_.reached, j) &&
            glm::length(pr.origin + pr.position[j] - world) <= tolerance &&
            glm::dot(pr.normal[j], cr.normal[i]) >= kSameNormal))
        return out;  // another surface
      prev_lo = std::min(prev_lo, double(p_.visibility[j]));
      prev_hi = std::max(prev_hi, double(p_.visibility[j]));
    }
    if (prev_hi < prev_lo) return out;
    out.measured = true;
    out.changed =
        double(v) < prev_lo - double(threshold) || double(v) > prev_hi + double(threshold);
    return out;
  }

  double weight(size_t i) const {
    return c_.weight.size() == c_.receivers.size() ? double(c_.weight[i]) : 1.0;
  }

 private:
  static bool usable(const Receivers& r, const std::vector<uint8_t>& reached, size_t i) {
    return r.valid[i] && reached[i];
  }
  const FrameSample& p_;
  const FrameSample& c_;
  glm::dmat4 prev_view_proj_{1.0};
  glm::dvec3 eye_{0.0};
};

// Runs body(y0, y1, block) over the frame's rows in blocks of kRowBlock, on the machine's
// threads. What a block sums goes in its own slot and the slots are added in block order, so
// the numbers are the same on any machine, whatever the thread count.
constexpr uint32_t kRowBlock = 16;

template <class Partial, class Body>
Partial for_row_blocks(uint32_t h, Body&& body) {
  const uint32_t blocks = (h + kRowBlock - 1) / kRowBlock;
  std::vector<Partial> partial(blocks);
  const uint32_t threads =
      std::clamp(std::thread::hardware_concurrency(), 1u, blocks ? blocks : 1u);
  auto work = [&](uint32_t t) {
    for (uint32_t b = t; b < blocks; b += threads)
      body(b * kRowBlock, std::min(h, (b + 1) * kRowBlock), partial[b]);
  };
  std::vector<std::thread> pool;
  for (uint32_t t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (auto& t : pool) t.join();
  Partial total{};
  for (const Partial& p : partial) total += p;
  return total;
}

struct Counts {
  size_t edge = 0, changed = 0;
  double edge_weight = 0.0, changed_weight = 0.0;
  Counts& operator+=(const Counts& o) {
    edge += o.edge;
    changed += o.changed;
    edge_weight += o.edge_weight;
    changed_weight += o.changed_weight;
    return *this;
  }
};

}  // namespace

void count_flicker(const FrameSample& previous, const FrameSample& current, float threshold,
                   size_t& edge_pixels, size_t& changed, std::vector<uint32_t>* per_pixel,
                   double* edge_weight, double* changed_weight) {
  const Reprojection r(previous, current);
  const uint32_t w = current.receivers.width, h = current.receivers.height;
  const bool count_pixels = per_pixel && per_pixel->size() == current.receivers.size();
  const Counts c = for_row_blocks<Counts>(h, [&](uint32_t y0, uint32_t y1, Counts& out) {
    for (uint32_t y = y0; y < y1; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        const PixelFlicker f = r.at(x, y, threshold);
        if (!f.measured || !f.edge) continue;
        const size_t i = size_t{y} * w + x;
        ++out.edge;
        const double weight = r.weight(i);
        out.edge_weight += weight;
        if (!f.changed) continue;
        ++out.changed;
        out.changed_weight += weight;
        if (count_pixels) ++(*per_pixel)[i];  // each pixel in one block only
      }
  });
  edge_pixels += c.edge;
  changed += c.changed;
  if (edge_weight) *edge_weight += c.edge_weight;
  if (changed_weight) *changed_weight += c.changed_weight;
}

std::vector<uint8_t> changed_pixels(const FrameSample& previous, const FrameSample& current,
                                    float threshold) {
  const Reprojection r(previous, current);
  const uint32_t w = current.receivers.width, h = current.receivers.height;
  std::vector<uint8_t> out(size_t{w} * h, 0);
  for_row_blocks<Counts>(h, [&](uint32_t y0, uint32_t y1, Counts&) {
    for (uint32_t y = y0; y < y1; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        const PixelFlicker f = r.at(x, y, threshold);
        out[size_t{y} * w + x] = f.measured && f.changed ? 1 : 0;
      }
  });
  return out;
}

void count_excess_flicker(const FrameSample& previous, const FrameSample& current, float threshold,
                          std::span<const uint8_t> excused, Flicker& flicker) {
  const Reprojection r(previous, current);
  const uint32_t w = current.receivers.width, h = current.receivers.height;
  if (excused.size() != size_t{w} * h)
    throw Error("count_excess_flicker: the truth's changes and the frame differ in size");
  if (flicker.excess_per_pixel.size() != excused.size())
    flicker.excess_per_pixel.assign(excused.size(), 0);
  flicker.has_truth = true;
  // Aliasing of detail finer than a pixel picks neighbouring pixels at random: the truth's
  // change at a pixel or any of its 8 neighbours excuses the renderer's.
  auto excused_near = [&](uint32_t x, uint32_t y) {
    for (uint32_t ny = y > 0 ? y - 1 : 0; ny <= std::min(y + 1, h - 1); ++ny)
      for (uint32_t nx = x > 0 ? x - 1 : 0; nx <= std::min(x + 1, w - 1); ++nx)
        if (excused[size_t{ny} * w + nx]) return true;
    return false;
  };
  const Counts c = for_row_blocks<Counts>(h, [&](uint32_t y0, uint32_t y1, Counts& out) {
    for (uint32_t y = y0; y < y1; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        const size_t i = size_t{y} * w + x;
        if (excused_near(x, y)) continue;
        const PixelFlicker f = r.at(x, y, threshold);
        if (!f.measured || !f.edge || !f.changed) continue;
        ++out.changed;
        out.changed_weight += r.weight(i);
        ++flicker.excess_per_pixel[i];
      }
  });
  flicker.excess_changed += c.changed;
  flicker.excess_changed_weight += c.changed_weight;
}

std::vector<float> accumulate_visibility(const FrameSample& previous, const FrameSample& current,
                                         float weight) {
  const Receivers& pr = previous.receivers;
  const Receivers& cr = current.receivers;
  if (pr.width != cr.width || pr.height != cr.height || previous.visibility.size() != pr.size() ||
      current.visibility.size() != cr.size())
    throw Error("accumulate_visibility: the two frames differ in size");
  const uint32_t w = cr.width, h = cr.height;
  const glm::dmat4 prev_view = previous.camera.view;
  const glm::dmat4 prev_proj = previous.camera.proj;
  // The last eye, relative to the last origin.
  const glm::dvec3 prev_eye = glm::dvec3(glm::inverse(prev_view) * glm::dvec4(0, 0, 0, 1));
  auto distance_to_prev_eye = [&](size_t j) { return glm::length(pr.position[j] - prev_eye); };
  std::vector<float> out = current.visibility;
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const size_t i = size_t{y} * w + x;
      if (!cr.valid[i]) continue;
      const float v = current.visibility[i];
      const auto [lo, hi] = neighbourhood_range(current.visibility, w, h, x, y,
                                                [&](size_t j) { return cr.valid[j] != 0; });
      // The point relative to the last origin, in the last view.
      const glm::dvec3 p = cr.origin + cr.position[i] - pr.origin;
      const glm::dvec3 prev_pos = glm::dvec3(prev_view * glm::dvec4(p, 1.0));
      const double expected = glm::length(prev_pos);
      const glm::dvec4 c = prev_proj * glm::dvec4(prev_pos, 1.0);
      if (!(c.w > 0.0)) continue;
      const double px = (c.x / c.w * 0.5 + 0.5) * w - 0.5, py = (c.y / c.w * 0.5 + 0.5) * h - 0.5;
      const double fx = std::floor(px), fy = std::floor(py), ax = px - fx, ay = py - fy;
      double weight_sum = 0.0, sum = 0.0;
      for (int k = 0; k < 4; ++k) {
        const double qx = fx + (k & 1), qy = fy + (k >> 1);
        const double tap = ((k & 1) ? ax : 1.0 - ax) * ((k >> 1) ? ay : 1.0 - ay);
        if (tap <= kNeighbourWeight || qx < 0.0 || qy < 0.0 || qx >= double(w) || qy >= double(h))
          continue;
        const size_t j = size_t(qy) * w + size_t(qx);
        if (!pr.valid[j]) continue;
        const double tolerance = double(render::kTemporalSurfaceFraction) * expected +
                                 double(render::kTemporalSurfaceConstant);
        if (std::abs(distance_to_prev_eye(j) - expected) > tolerance ||
            glm::dot(pr.normal[j], cr.normal[i]) < kSameNormal)
          continue;
        weight_sum += tap;
        sum += tap * double(previous.visibility[j]);
      }
      if (weight_sum < 0.5) continue;
      const double history = std::clamp(sum / weight_sum, double(lo), double(hi));
      out[i] = float(history + double(weight) * (double(v) - history));
    }
  return out;
}

std::vector<uint8_t> flicker_image(const Flicker& flicker, std::span<const uint8_t> lit,
                                   uint32_t pairs) {
  const size_t n = size_t{flicker.width} * flicker.height;
  if (lit.size() != n * 4 || flicker.changed_per_pixel.size() != n)
    throw Error("flicker_image: the frame and the counts differ in size");
  const bool split = flicker.has_truth && flicker.excess_per_pixel.size() == n;
  std::vector<uint8_t> out(n * 4);
  for (size_t i = 0; i < n; ++i) {
    const float grey =
        0.5f * (0.299f * lit[4 * i] + 0.587f * lit[4 * i + 1] + 0.114f * lit[4 * i + 2]);
    // Red: flicker (with the truth measured, only what the truth does not share); blue: what
    // the truth shares.
    const uint32_t red_count = split ? flicker.excess_per_pixel[i] : flicker.changed_per_pixel[i];
    const uint32_t blue_count = split ? flicker.changed_per_pixel[i] - red_count : 0;
    const bool red = red_count > 0;
    const uint32_t count = red ? red_count : blue_count;
    const float f = pairs ? std::min(1.0f, float(count) / float(pairs)) : 0;
    const float k = f > 0.0f ? 0.35f + 0.65f * f : 0.0f;  // any flicker shows
    const float base = grey * (1.0f - k);
    out[4 * i] = uint8_t(std::lround(base + (red ? 255.0f * k : 0.0f)));
    out[4 * i + 1] = uint8_t(std::lround(base + (red ? 0.0f : 96.0f * k)));
    out[4 * i + 2] = uint8_t(std::lround(base + (red ? 0.0f : 255.0f * k)));
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
  const bool moving = std::any_of(s.instances.begin(), s.instances.end(), [](const auto& i) {
    return i.motion && i.motion->moves();
  });
  std::vector<FrameSample> previous(lights.size()), current(lights.size());
  // The truth at the same receivers (FlickerOptions::truth): a BVH per relative origin.
  std::vector<FrameSample> previous_truth(options.truth ? lights.size() : 0),
      current_truth(options.truth ? lights.size() : 0);
  std::unique_ptr<Tracer> tracer;
  TraceOptions truth_options = options.truth.value_or(TraceOptions{});
  truth_options.shared_pattern = true;
  // A path starts from a still camera: no history from whatever the renderer drew before
  // (shadows.temporal).
  renderer.reset_history();
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
                        &out[li].changed_per_pixel, &out[li].edge_weight, &out[li].changed_weight);
        if (!options.truth) continue;
        // Moving objects (Instance::motion): the renderer posed them at frame k, and the truth
        // is traced among them where they are now.
        if (!tracer || tracer->origin() != receivers.origin || (li == 0 && moving))
          tracer = std::make_unique<Tracer>(s, receivers.origin);
        FrameSample& t = current_truth[li];
        t.receivers = receivers;
        t.camera = f.camera;
        t.reached = f.reached;
        t.weight = f.weight;
        Receivers reached = receivers;
        for (size_t i = 0; i < reached.size(); ++i)
          if (!f.reached[i]) reached.valid[i] = 0;
        truth_options.progress_label =
            "truth " + lights[li].name() + " " + path.name + " " + std::to_string(k);
        t.visibility = options.cache_dir
                           ? trace_cached(*tracer, reached, area_light(s, lights[li]),
                                          truth_options, *options.cache_dir)
                                 .value
                           : tracer->trace(reached, area_light(s, lights[li]), truth_options).value;
        if (k == 0) continue;
        Flicker& o = out[li];
        o.has_truth = true;
        double error_sum = 0.0, lit_sum = 0.0, lit_weight = 0.0;
        size_t error_count = 0;
        for (size_t i = 0; i < t.visibility.size(); ++i) {
          if (!receivers.valid[i] || !f.reached[i]) continue;
          const double e = std::abs(double(f.visibility[i]) - double(t.visibility[i]));
          error_sum += e;
          ++error_count;
          lit_sum += double(f.weight[i]) * e;
          lit_weight += double(f.weight[i]);
        }
        // The frames' errors averaged (frames 1 .. frames - 1, k of them so far).
        const double frame_error = error_count ? error_sum / double(error_count) : 0.0;
        const double frame_error_lit = lit_weight > 0.0 ? lit_sum / lit_weight : 0.0;
        o.path_mean_abs_error += (frame_error - o.path_mean_abs_error) / double(k);
        o.path_mean_abs_error_lit += (frame_error_lit - o.path_mean_abs_error_lit) / double(k);
        count_flicker(previous_truth[li], t, options.threshold, o.truth_edge_pixels,
                      o.truth_changed, nullptr, &o.truth_edge_weight, &o.truth_changed_weight);
        count_excess_flicker(previous[li], f, options.threshold,
                             changed_pixels(previous_truth[li], t, options.threshold), o);
      }
      std::swap(previous, current);
      std::swap(previous_truth, current_truth);
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
