// Acne, leaks and the contact gap, told apart (failure_modes.hpp).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <penumbra/core/error.hpp>
#include <penumbra/core/json.hpp>
#include <penumbra/core/stats.hpp>
#include <penumbra/reference/failure_modes.hpp>
#include <thread>

namespace penumbra::reference {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

void check_size(size_t got, size_t want, const char* what) {
  if (got != want)
    throw Error(std::string("failure modes: ") + what + " has " + std::to_string(got) +
                " values, expected " + std::to_string(want));
}

// Any unit vector across unit w.
glm::dvec3 across(const glm::dvec3& w) {
  const glm::dvec3 a = std::abs(w.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  return glm::normalize(glm::cross(w, a));
}

// The distance to the first caster on the ray, by bisection on its length with Tracer::blocked
// (the occlusion query has no hit distance): 40 halvings of the bracket.
double first_hit(const Tracer& tracer, const glm::dvec3& org, const glm::dvec3& dir, double dist) {
  double hi = dist;
  if (!std::isfinite(hi)) {  // the sun: grow a finite bracket first
    hi = 1.0;
    while (!tracer.blocked(org, dir, hi) && hi < 1e12) hi *= 4.0;
  }
  double lo = 0.0;
  for (int k = 0; k < 40 && hi - lo > 1e-7 * hi; ++k) {
    const double mid = 0.5 * (lo + hi);
    if (tracer.blocked(org, dir, mid))
      hi = mid;
    else
      lo = mid;
  }
  return hi;
}

}  // namespace

CasterProbe probe_casters(const Tracer& tracer, const Receivers& receivers, const AreaLight& light,
                          std::span<const float> reach, uint32_t ring, uint32_t threads) {
  const size_t n = receivers.size();
  check_size(reach.size(), n, "the reach");
  ring = std::max(ring, 3u);
  CasterProbe out;
  out.blocker_distance.assign(n, kNaN);
  out.caster_in_reach.assign(n, 0);
  out.light_in_reach.assign(n, 0);
  out.contact_distance.assign(n, kNaN);
  out.light_cosine.assign(n, kNaN);
  const glm::dvec3 centre = light.position - tracer.origin();
  const glm::dvec3 sun_dir = glm::normalize(light.direction_to_light);
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (;;) {
      const size_t begin = next.fetch_add(256);
      if (begin >= n) break;
      for (size_t i = begin; i < std::min(n, begin + 256); ++i) {
        if (!receivers.valid[i]) continue;
        const glm::dvec3 p = receivers.position[i];
        glm::dvec3 l = sun_dir;
        double dist = std::numeric_limits<double>::infinity();
        if (light.kind != LightKind::sun) {
          dist = glm::length(centre - p);
          if (!(dist > light.radius) || !(dist > 0.0)) continue;
          l = (centre - p) / dist;
        }
        glm::dvec3 nrm = receivers.normal[i];
        if (glm::dot(nrm, l) < 0.0) nrm = -nrm;
        const glm::dvec3 org = p + nrm * ray_offset(p);
        const bool blocked = tracer.blocked(org, l, dist);
        const double d = blocked ? first_hit(tracer, org, l, dist) : double(kInf);
        out.blocker_distance[i] = float(d);
        // Along the surface: the ray's component in the tangent plane, over the blocker distance.
        const glm::dvec3 l_tangent = l - glm::dot(l, nrm) * nrm;
        out.contact_distance[i] = blocked ? float(d * glm::length(l_tangent)) : kInf;
        const double ln = glm::dot(l, nrm);
        out.light_cosine[i] = float(ln);
        bool caster = blocked, light_seen = !blocked;
        const double r = std::isfinite(reach[i]) ? std::max(0.0, double(reach[i])) : 0.0;
        if (r > 0.0 && ln > 1e-6) {
          const glm::dvec3 e1 = across(l), e2 = glm::cross(l, e1);
          for (uint32_t k = 0; k < ring && !(caster && light_seen); ++k) {
            const double a = 6.283185307179586 * (double(k) + 0.5) / double(ring);
            const glm::dvec3 u = r * (std::cos(a) * e1 + std::sin(a) * e2);
            // Carried along the light onto the tangent plane: q = p + u + s l, (q - p).n = 0.
            const glm::dvec3 q = p + u - (glm::dot(u, nrm) / ln) * l;
            const glm::dvec3 lq = light.kind == LightKind::sun ? l : glm::normalize(centre - q);
            const double dq = light.kind == LightKind::sun ? dist : glm::length(centre - q);
            if (tracer.blocked(q + nrm * ray_offset(q), lq, dq))
              caster = true;
            else
              light_seen = true;
          }
        }
        out.caster_in_reach[i] = caster ? 1 : 0;
        out.light_in_reach[i] = light_seen ? 1 : 0;
      }
    }
  };
  const uint32_t t = threads ? threads : std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::thread> pool;
  for (uint32_t k = 0; k < t; ++k) pool.emplace_back(work);
  for (auto& th : pool) th.join();
  return out;
}

FailureModes compute_failure_modes(std::span<const float> v, const Visibility& reference,
                                   std::span<const ReceiverClass> classes, const CasterProbe& probe,
                                   std::span<const float> texel_world, uint32_t image_width,
                                   const FailureModeOptions& options,
                                   std::vector<FailureMode>* modes) {
  const size_t n = classes.size();
  check_size(v.size(), n, "the GPU visibility");
  check_size(reference.value.size(), n, "the reference");
  check_size(probe.blocker_distance.size(), n, "the caster probe");
  check_size(probe.contact_distance.size(), n, "the caster probe's contacts");
  check_size(probe.light_cosine.size(), n, "the caster probe's cosines");
  check_size(texel_world.size(), n, "the texel sizes");
  if (!(options.max_contact_texels > 0.0) || !(options.seed_texels > 0.0))
    throw Error("failure modes: max_contact_texels and seed_texels must be > 0");
  const size_t width = image_width ? image_width : n;
  if (n % width != 0)
    throw Error("failure modes: " + std::to_string(n) + " receivers are not rows of " +
                std::to_string(width));
  const double t = options.threshold;
  FailureModes f;
  if (modes) modes->assign(n, FailureMode::none);
  auto measured = [&](size_t i) {
    return classes[i] == ReceiverClass::lit && std::isfinite(reference.value[i]) &&
           std::isfinite(v[i]);
  };
  // Umbra receivers near a contact, their distance from it in texels; those the GPU lights are
  // the gap's candidates.
  std::vector<double> x_texels(n, -1.0);
  std::vector<uint8_t> candidate(n, 0), in_gap(n, 0);
  std::vector<size_t> queue;
  uint64_t lit_receivers = 0;
  for (size_t i = 0; i < n; ++i) {
    if (!measured(i)) continue;
    ++lit_receivers;
    const double r = reference.value[i], g = v[i];
    if (r >= 1.0 && !probe.caster_in_reach[i]) {
      ++f.clear_receivers;
      if (g < 1.0 - t) {
        ++f.acne_receivers;
        if (modes) (*modes)[i] = FailureMode::acne;
      }
    }
    const double x = probe.contact_distance[i], tw = texel_world[i];
    if (r < 0.5 && std::isfinite(x) && std::isfinite(tw) && tw > 0.0 &&
        x / tw < options.max_contact_texels) {
      x_texels[i] = x / tw;
      ++f.contact_receivers;
      if (g >= 0.5) {
        candidate[i] = 1;
        if (x_texels[i] < options.seed_texels) {
          in_gap[i] = 1;
          queue.push_back(i);
        }
      }
    }
  }
  // The gap: lit candidates connected (4-neighbours in the image) to one touching a contact.
  for (size_t q = 0; q < queue.size(); ++q) {
    const size_t i = queue[q], x = i % width;
    const size_t next[4] = {x > 0 ? i - 1 : n, x + 1 < width ? i + 1 : n,
                            i >= width ? i - width : n, i + width < n ? i + width : n};
    for (size_t j : next)
      if (j < n && candidate[j] && !in_gap[j]) {
        in_gap[j] = 1;
        queue.push_back(j);
      }
  }
  std::vector<double> gap_texels, gap_world, gap_map;
  for (size_t i = 0; i < n; ++i) {
    if (!measured(i)) continue;
    const double r = reference.value[i], g = v[i];
    if (in_gap[i]) {
      ++f.gap_receivers;
      gap_texels.push_back(x_texels[i]);
      gap_world.push_back(double(probe.contact_distance[i]));
      gap_map.push_back(x_texels[i] * double(probe.light_cosine[i]));
      if (modes) (*modes)[i] = FailureMode::gap;
      continue;
    }
    // Leaks: false light where the truth is umbra across the filter's whole reach. False light
    // near a shadow's edge is the filter's blur; next to a contact, the gap.
    if (g > r + t && r <= 0.0 && !probe.light_in_reach[i]) {
      ++f.leak_receivers;
      if (modes) (*modes)[i] = FailureMode::leak;
    }
  }
  if (f.contact_receivers > 0) {
    // The gap's width: how far from the contact its receivers reach (the 95th percentile, so
    // that a few far pixels a thin lit sliver connects do not make it; the maximum apart).
    f.contact_gap_texels = f.contact_gap_world = f.contact_gap_max_texels = 0.0;
    f.contact_gap_map_texels = 0.0;
    if (!gap_texels.empty()) {
      f.contact_gap_texels = stats::quantile(gap_texels, 0.95);
      f.contact_gap_map_texels = stats::quantile(gap_map, 0.95);
      f.contact_gap_world = stats::quantile(gap_world, 0.95);
      f.contact_gap_max_texels = *std::max_element(gap_texels.begin(), gap_texels.end());
    }
  }
  f.acne = f.clear_receivers ? double(f.acne_receivers) / double(f.clear_receivers) : 0.0;
  f.leak = lit_receivers ? double(f.leak_receivers) / double(lit_receivers) : 0.0;
  return f;
}

std::string FailureModes::to_json() const {
  return "\"acne\": " + json::number(acne) +
         ", \"acne_receivers\": " + std::to_string(acne_receivers) +
         ", \"clear_receivers\": " + std::to_string(clear_receivers) +
         ", \"leak\": " + json::number(leak) +
         ", \"leak_receivers\": " + std::to_string(leak_receivers) +
         ", \"contact_gap_texels\": " + json::number(contact_gap_texels) +
         ", \"contact_gap_world\": " + json::number(contact_gap_world) +
         ", \"contact_gap_max_texels\": " + json::number(contact_gap_max_texels) +
         ", \"contact_gap_map_texels\": " + json::number(contact_gap_map_texels) +
         ", \"contact_receivers\": " + std::to_string(contact_receivers) +
         ", \"gap_receivers\": " + std::to_string(gap_receivers);
}

std::vector<uint8_t> failure_mode_image(std::span<const FailureMode> modes,
                                        std::span<const uint8_t> frame_rgba) {
  check_size(frame_rgba.size(), 4 * modes.size(), "the frame");
  std::vector<uint8_t> out(frame_rgba.size());
  static constexpr uint8_t kColour[4][3] = {{0, 0, 0}, {255, 0, 255}, {255, 40, 0}, {255, 230, 0}};
  for (size_t i = 0; i < modes.size(); ++i) {
    const double l = 0.2126 * frame_rgba[4 * i] + 0.7152 * frame_rgba[4 * i + 1] +
                     0.0722 * frame_rgba[4 * i + 2];
    const uint8_t grey = uint8_t(std::clamp(32.0 + 0.5 * l, 0.0, 255.0));
    const auto m = size_t(modes[i]);
    for (int k = 0; k < 3; ++k) out[4 * i + k] = m ? kColour[m][k] : grey;
    out[4 * i + 3] = 255;
  }
  return out;
}

}  // namespace penumbra::reference
