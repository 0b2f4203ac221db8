// Region masks from the reference and the depth buffer, and the region-aware comparison.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <glm/glm.hpp>
#include <penumbra/golden/golden.hpp>
#include <sstream>

namespace penumbra::golden {

const char* to_string(Region r) {
  switch (r) {
    case Region::umbra:
      return "umbra";
    case Region::penumbra:
      return "penumbra";
    case Region::silhouette:
      return "silhouette";
    case Region::lit:
      return "lit";
    case Region::none:
      break;
  }
  return "none";
}

namespace {

// Marks every pixel within `radius` (Chebyshev) of a marked one: a separable max filter.
std::vector<uint8_t> dilate(const std::vector<uint8_t>& in, uint32_t w, uint32_t h,
                            uint32_t radius) {
  if (radius == 0) return in;
  std::vector<uint8_t> rows(in.size(), 0), out(in.size(), 0);
  const int r = int(radius);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      if (!in[size_t(y) * w + x]) continue;
      for (int dx = -r; dx <= r; ++dx) {
        const int xx = int(x) + dx;
        if (xx >= 0 && xx < int(w)) rows[size_t(y) * w + size_t(xx)] = 1;
      }
    }
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      if (!rows[size_t(y) * w + x]) continue;
      for (int dy = -r; dy <= r; ++dy) {
        const int yy = int(y) + dy;
        if (yy >= 0 && yy < int(h)) out[size_t(yy) * w + x] = 1;
      }
    }
  return out;
}

}  // namespace

std::vector<Region> classify_regions(const reference::Receivers& receivers,
                                     const reference::LightMeasurement& light,
                                     const RegionOptions& o) {
  const uint32_t w = receivers.width, h = receivers.height;
  const size_t n = size_t(w) * h;
  std::vector<Region> out(n, Region::none);
  if (light.classes.size() != n || light.reference.value.size() != n) return out;
  for (size_t i = 0; i < n; ++i) {
    if (light.classes[i] != reference::ReceiverClass::lit) continue;
    const float r = light.reference.value[i];
    if (!std::isfinite(r)) continue;
    out[i] = r <= o.umbra_max ? Region::umbra : r >= o.lit_min ? Region::lit : Region::penumbra;
  }
  // Shadow edges: partly visible pixels, and umbra next to lit (a hard light's edge).
  std::vector<uint8_t> edge(n, 0);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const size_t i = size_t(y) * w + x;
      if (out[i] == Region::penumbra) {
        edge[i] = 1;
        continue;
      }
      if (out[i] != Region::umbra && out[i] != Region::lit) continue;
      const Region other = out[i] == Region::umbra ? Region::lit : Region::umbra;
      if ((x > 0 && out[i - 1] == other) || (x + 1 < w && out[i + 1] == other) ||
          (y > 0 && out[i - w] == other) || (y + 1 < h && out[i + w] == other))
        edge[i] = 1;
    }
  const std::vector<uint8_t> band = dilate(edge, w, h, o.band);
  for (size_t i = 0; i < n; ++i)
    if (band[i] && (out[i] == Region::umbra || out[i] == Region::lit)) out[i] = Region::penumbra;

  // Silhouettes: where the inverse distance to the eye (affine across a plane in screen space)
  // jumps against the trend of its neighbours, and where geometry meets the sky.
  if (receivers.eye && receivers.position.size() == n && receivers.valid.size() == n) {
    std::vector<double> inv(n, 0.0);
    for (size_t i = 0; i < n; ++i) {
      if (!receivers.valid[i]) continue;
      const double d = glm::length(receivers.position[i] - *receivers.eye);
      inv[i] = d > 0.0 ? 1.0 / d : 0.0;
    }
    std::vector<uint8_t> jump(n, 0);
    auto check = [&](size_t a, size_t i, size_t b) {
      const bool va = receivers.valid[a], vi = receivers.valid[i], vb = receivers.valid[b];
      if (vi != va || vi != vb) {
        jump[i] = 1;
        return;
      }
      if (!vi) return;
      const double second = std::abs(inv[a] - 2.0 * inv[i] + inv[b]);
      if (second > o.depth_jump * inv[i]) jump[i] = 1;
    };
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        const size_t i = size_t(y) * w + x;
        if (x > 0 && x + 1 < w) check(i - 1, i, i + 1);
        if (y > 0 && y + 1 < h) check(i - w, i, i + w);
      }
    const std::vector<uint8_t> near = dilate(jump, w, h, 1);
    for (size_t i = 0; i < n; ++i)
      if (near[i] && out[i] != Region::none) out[i] = Region::silhouette;
  }
  return out;
}

uint64_t Tolerance::allowed(uint64_t pixels) const {
  return std::max(min_allowed, uint64_t(std::floor(allowed_fraction * double(pixels))));
}

const Tolerance& Tolerances::of(Region r) const {
  switch (r) {
    case Region::umbra:
      return umbra;
    case Region::penumbra:
      return penumbra;
    case Region::silhouette:
      return silhouette;
    default:
      return lit;
  }
}

std::string RegionResult::to_line() const {
  char buf[400];
  const double pct = pixels ? 100.0 * double(over) / double(pixels) : 0.0;
  int k = std::snprintf(buf, sizeof buf,
                        "%s %s: %llu of %llu pixels (%.2f%%) differ by more than %.3f (allowed "
                        "%llu)",
                        image.c_str(), region.c_str(), (unsigned long long)over,
                        (unsigned long long)pixels, pct, double(tolerance.max_diff),
                        (unsigned long long)allowed);
  if (worst > 0.0f && k > 0 && size_t(k) < sizeof buf)
    k += std::snprintf(buf + k, sizeof buf - size_t(k),
                       "; worst at (%u, %u): expected %.3f, actual %.3f", worst_x, worst_y,
                       double(expected), double(actual));
  if (non_finite && k > 0 && size_t(k) < sizeof buf)
    std::snprintf(buf + k, sizeof buf - size_t(k), "; %llu non-finite values",
                  (unsigned long long)non_finite);
  return buf;
}

bool Comparison::passed() const {
  return structural.empty() &&
         std::all_of(results.begin(), results.end(), [](const RegionResult& r) {
           return r.passed();
         });
}

std::vector<std::string> Comparison::failures() const {
  std::vector<std::string> out = structural;
  for (const auto& r : results)
    if (!r.passed()) out.push_back("FAIL " + r.to_line());
  return out;
}

std::string Comparison::summary() const {
  std::ostringstream s;
  for (const auto& line : structural) s << "FAIL " << line << "\n";
  for (const auto& r : results) s << (r.passed() ? "ok   " : "FAIL ") << r.to_line() << "\n";
  return s.str();
}

namespace {

struct Accumulator {
  RegionResult r;
  void add(float e, float a, uint32_t x, uint32_t y) {
    ++r.pixels;
    if (!std::isfinite(a)) {
      ++r.non_finite;
      return;
    }
    const float d = std::abs(a - e);
    if (d > r.tolerance.max_diff) ++r.over;
    for (size_t k = 0; k < std::size(kHistogramThresholds); ++k)
      r.histogram[k] += d > kHistogramThresholds[k];
    if (d > r.worst) {
      r.worst = d;
      r.worst_x = x;
      r.worst_y = y;
      r.expected = e;
      r.actual = a;
    }
  }
  RegionResult done() {
    r.allowed = r.tolerance.allowed(r.pixels);
    return r;
  }
};

}  // namespace

Comparison compare(const Frame& g, const Frame& a, const Tolerances& t) {
  Comparison c;
  if (g.width != a.width || g.height != a.height) {
    c.structural.push_back("size: golden " + std::to_string(g.width) + "x" +
                           std::to_string(g.height) + ", frame " + std::to_string(a.width) + "x" +
                           std::to_string(a.height));
    return c;
  }
  const uint32_t w = g.width;
  const size_t n = size_t(g.width) * g.height;
  if (g.lit.size() != n * 4 || a.lit.size() != n * 4) {
    c.structural.push_back("lit image: not width x height RGBA8 pixels");
    return c;
  }
  for (const auto& al : a.lights)
    if (std::none_of(g.lights.begin(), g.lights.end(),
                     [&](const LightImage& gl) { return gl.light == al.light; }))
      c.structural.push_back("light " + al.light + ": in the frame but not in the golden");
  // Per pixel, the loosest region any light gives it: the frame's tolerance there.
  std::vector<uint8_t> loose(n, 0);
  for (const auto& gl : g.lights) {
    const auto it = std::find_if(a.lights.begin(), a.lights.end(),
                                 [&](const LightImage& al) { return al.light == gl.light; });
    if (it == a.lights.end()) {
      c.structural.push_back("light " + gl.light + ": in the golden but not in the frame");
      continue;
    }
    if (gl.visibility.size() != n || gl.regions.size() != n || it->visibility.size() != n) {
      c.structural.push_back("light " + gl.light + ": visibility or regions of the wrong size");
      continue;
    }
    for (Region region : kRegions) {
      if (region == Region::none) continue;
      Accumulator acc;
      acc.r.image = gl.light;
      acc.r.region = to_string(region);
      acc.r.tolerance = t.of(region);
      for (size_t i = 0; i < n; ++i)
        if (gl.regions[i] == region)
          acc.add(gl.visibility[i], it->visibility[i], uint32_t(i % w), uint32_t(i / w));
      if (acc.r.pixels) c.results.push_back(acc.done());
    }
    for (size_t i = 0; i < n; ++i)
      loose[i] |= gl.regions[i] == Region::penumbra || gl.regions[i] == Region::silhouette;
  }
  // The lit frame: the largest RGB channel difference per pixel.
  Accumulator tight, edges;
  tight.r.image = edges.r.image = "frame";
  tight.r.region = "away from shadow edges";
  edges.r.region = "shadow edges and silhouettes";
  tight.r.tolerance = t.frame_tight;
  edges.r.tolerance = t.frame_loose;
  for (size_t i = 0; i < n; ++i) {
    int worst = -1;
    float e = 0.0f, v = 0.0f;
    for (int ch = 0; ch < 3; ++ch) {
      const int d = std::abs(int(g.lit[i * 4 + size_t(ch)]) - int(a.lit[i * 4 + size_t(ch)]));
      if (d > worst) {
        worst = d;
        e = float(g.lit[i * 4 + size_t(ch)]) / 255.0f;
        v = float(a.lit[i * 4 + size_t(ch)]) / 255.0f;
      }
    }
    (loose[i] ? edges : tight).add(e, v, uint32_t(i % w), uint32_t(i / w));
  }
  for (Accumulator* acc : {&tight, &edges})
    if (acc->r.pixels) c.results.push_back(acc->done());
  return c;
}

}  // namespace penumbra::golden
