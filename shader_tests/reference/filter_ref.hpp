#pragma once

// Independent C++ references for the shadow filters of shaders/penumbra/pcf.glsl, pcss.glsl and
// vsm.glsl, in double precision. They are written from the definitions, not from the GLSL:
// - a hardware compare tap is "compare each texel of the 2x2 footprint, then filter
//   bilinearly" (Vulkan spec, "Depth Compare Operation" and "Texel Filtering"), clamp to edge;
// - the box grid PCF is the lit area fraction of the (2r+1)^2-texel square centred at the point,
//   integrated texel by texel (no taps at all);
// - disk kernels average compare taps at offsets the caller provides (the tests read the sample
//   positions back from noise.glsl, which has its own tests, so this checks only the filtering);
// - PCSS follows the geometry stated in pcss.glsl's header;
// - VSM / EVSM evaluate the Chebyshev (Cantelli) bound on the moments.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <glm/glm.hpp>
#include <span>
#include <vector>

namespace penumbra::filter_ref {

// A depth map: width x height floats, row-major, row 0 at v = 0; texel (x, y) covers
// [x, x + 1] x [y, y + 1] in texel space (uv * size).
struct DepthMap {
  int width = 0;
  int height = 0;
  std::vector<float> depth;

  // The stored depth with clamp-to-edge addressing.
  float at(int x, int y) const {
    x = std::clamp(x, 0, width - 1);
    y = std::clamp(y, 0, height - 1);
    return depth[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                 static_cast<std::size_t>(x)];
  }
  // The map as a toroidal image of its size holds it at offset (ox, oy) (pcf.glsl's windowed
  // lookups): texel (x, y) at ((x + ox) mod width, (y + oy) mod height).
  DepthMap rolled(int ox, int oy) const {
    DepthMap m = *this;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        m.depth[static_cast<std::size_t>(((y + oy) % height) * width + (x + ox) % width)] = at(x, y);
    return m;
  }
  // The same map mirrored left-right.
  DepthMap mirrored_x() const {
    DepthMap m = *this;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        m.depth[static_cast<std::size_t>(y * width + x)] = at(width - 1 - x, y);
    return m;
  }
  // The same map transposed (x <-> y).
  DepthMap transposed() const {
    DepthMap m{height, width, depth};
    for (int y = 0; y < width; ++y)
      for (int x = 0; x < height; ++x) m.depth[static_cast<std::size_t>(y * height + x)] = at(y, x);
    return m;
  }
};

inline bool finite(double v) {
  return std::isfinite(v);
}

// The functions' validity rule: finite (u, v, depth) with uv in [0, 1]^2; else lit.
inline bool in_map(glm::dvec2 uv, double depth) {
  return finite(uv.x) && finite(uv.y) && finite(depth) && uv.x >= 0.0 && uv.x <= 1.0 &&
         uv.y >= 0.0 && uv.y <= 1.0;
}

// The receiver depth as the functions compare it: clamped to [0, 1].
inline float clamp_depth(float d) {
  return std::clamp(d, 0.0f, 1.0f);
}

// The compare of one stored depth, as the compare sampler performs it: reverse-Z uses
// GREATER_OR_EQUAL (lit when the receiver is at least as close: receiver >= stored), standard
// LESS_OR_EQUAL. 1 = lit.
inline double texel_lit(float stored, float receiver, bool reverse_z) {
  return (reverse_z ? receiver >= stored : receiver <= stored) ? 1.0 : 0.0;
}

// One bilinear compare tap at uv: the four texels around uv * size - 0.5 compared, then
// weighted bilinearly (clamp to edge).
inline double compare_tap(const DepthMap& m, glm::dvec2 uv, float receiver, bool reverse_z) {
  const double fx = uv.x * m.width - 0.5;
  const double fy = uv.y * m.height - 0.5;
  const double x0 = std::floor(fx), y0 = std::floor(fy);
  const double a = fx - x0, b = fy - y0;
  const int ix = static_cast<int>(std::clamp(x0, -2.0, double(m.width) + 1.0));
  const int iy = static_cast<int>(std::clamp(y0, -2.0, double(m.height) + 1.0));
  auto lit = [&](int x, int y) { return texel_lit(m.at(x, y), receiver, reverse_z); };
  return (1 - a) * (1 - b) * lit(ix, iy) + a * (1 - b) * lit(ix + 1, iy) +
         (1 - a) * b * lit(ix, iy + 1) + a * b * lit(ix + 1, iy + 1);
}

// Length of the overlap of [lo0, hi0] and [lo1, hi1].
inline double overlap(double lo0, double hi0, double lo1, double hi1) {
  return std::max(0.0, std::min(hi0, hi1) - std::max(lo0, lo1));
}

// Box-grid PCF: the lit fraction of the (2r+1) x (2r+1)-texel square centred at uv (r = radius
// clamped to 0..5), each texel a constant square (clamp to edge outside the map), integrated
// exactly. Invalid coords are lit.
inline double box_pcf(const DepthMap& m, glm::dvec2 uv, float receiver, int radius,
                      bool reverse_z) {
  if (!in_map(uv, receiver)) return 1.0;
  const int r = std::clamp(radius, 0, 5);
  const float d = clamp_depth(receiver);
  const double half = r + 0.5;
  const double cx = uv.x * m.width, cy = uv.y * m.height;
  const double x_lo = cx - half, x_hi = cx + half, y_lo = cy - half, y_hi = cy + half;
  double sum = 0.0;
  for (int y = static_cast<int>(std::floor(y_lo)); y < static_cast<int>(std::ceil(y_hi)); ++y) {
    const double wy = overlap(y_lo, y_hi, y, y + 1.0);
    for (int x = static_cast<int>(std::floor(x_lo)); x < static_cast<int>(std::ceil(x_hi)); ++x) {
      const double wx = overlap(x_lo, x_hi, x, x + 1.0);
      sum += wx * wy * texel_lit(m.at(x, y), d, reverse_z);
    }
  }
  const double n = 2.0 * r + 1.0;
  return sum / (n * n);
}

// Disk PCF: the mean of compare taps at uv + offsets[i] * radius_texels texels (offsets in the
// unit disk, as the GLSL reads them from noise.glsl). Invalid coords are lit; a negative or
// non-finite radius counts as 0.
inline double disk_pcf(const DepthMap& m, glm::dvec2 uv, float receiver,
                       std::span<const glm::dvec2> offsets, double radius_texels, bool reverse_z) {
  if (!in_map(uv, receiver)) return 1.0;
  if (!finite(radius_texels) || radius_texels < 0.0) radius_texels = 0.0;
  const float d = clamp_depth(receiver);
  const glm::dvec2 texel(1.0 / m.width, 1.0 / m.height);
  double sum = 0.0;
  for (const glm::dvec2& o : offsets)
    sum += compare_tap(m, uv + o * radius_texels * texel, d, reverse_z);
  return sum / static_cast<double>(offsets.size());
}

// ---- PCSS -----------------------------------------------------------------------------------

// Mirrors the GLSL struct PcssParams field for field (all floats; see pcss.glsl).
struct PcssParams {
  float tan_half_angle = 0.0f;
  float texel_world_size = 1.0f;
  float depth_near = 0.0f;
  float depth_far = 1.0f;
  float max_search_texels = 0.0f;
  float min_filter_texels = 0.0f;
  float max_filter_texels = 0.0f;
  float confidence_fraction = 0.0f;
};

inline int pcss_search_taps(int tier) {
  return std::array{8, 16, 32}[std::clamp(tier, 0, 2)];
}
inline int pcss_filter_taps(int tier) {
  return std::array{16, 32, 64}[std::clamp(tier, 0, 2)];
}

// World distance of a depth difference of 1 (orthographic light: depth is linear).
inline double depth_range(const PcssParams& p) {
  return std::abs(double(p.depth_far) - double(p.depth_near));
}

// Blockers can sit anywhere between the receiver and the near plane (d_max above it) and still
// hide part of a sun of half-angle theta/2 when within d_max tan(theta/2) of the point.
inline double search_radius_texels(float receiver, const PcssParams& p, bool reverse_z) {
  const double d = clamp_depth(receiver);
  const double to_near_world = (reverse_z ? 1.0 - d : d) * depth_range(p);
  const double r = to_near_world * p.tan_half_angle / p.texel_world_size;
  return std::clamp(r, 0.0, std::max<double>(p.max_search_texels, 0.0));
}

// Full penumbra width 2 d tan(theta/2) for a blocker at distance d above the receiver.
inline double penumbra_width(double blocker_distance, double tan_half_angle) {
  return 2.0 * std::max(blocker_distance, 0.0) * tan_half_angle;
}

inline double blocker_distance(double receiver, double blocker, const PcssParams& p,
                               bool reverse_z) {
  const double closer = reverse_z ? blocker - receiver : receiver - blocker;
  return std::max(closer, 0.0) * depth_range(p);
}

inline double penumbra_width_texels(double receiver, double blocker, const PcssParams& p,
                                    bool reverse_z) {
  return penumbra_width(blocker_distance(receiver, blocker, p, reverse_z), p.tan_half_angle) /
         p.texel_world_size;
}

inline double filter_radius_texels(double receiver, double blocker, const PcssParams& p,
                                   bool reverse_z) {
  const double lo = std::max<double>(p.min_filter_texels, 0.0);
  const double hi = std::max<double>(p.max_filter_texels, lo);
  return std::clamp(0.5 * penumbra_width_texels(receiver, blocker, p, reverse_z), lo, hi);
}

inline double confidence(int blockers, int search_taps, double fraction) {
  const double needed = std::max(std::clamp(fraction, 0.0, 1.0) * search_taps, 1.0);
  return std::clamp(blockers / needed, 0.0, 1.0);
}

inline bool is_blocker(float stored, float receiver, bool reverse_z) {
  return reverse_z ? stored > receiver : stored < receiver;
}

struct BlockerSearch {
  double sum = 0.0;
  int count = 0;
  double average = 0.0;  // the receiver depth when count == 0
  // A tap fell within `eps` texels of a texel edge and the texels on either side disagree (in
  // blocker-ness or depth): the GPU, rounding the tap position in float, may pick either.
  bool ambiguous = false;
};

// Blocker search with nearest reads (floor(uv * size), clamped to the edge) at
// uv + offsets[i] * radius_texels texels.
inline BlockerSearch blocker_search(const DepthMap& m, glm::dvec2 uv, float receiver,
                                    std::span<const glm::dvec2> offsets, double radius_texels,
                                    bool reverse_z, double eps = 1e-3) {
  BlockerSearch s;
  const float d = clamp_depth(receiver);
  s.average = d;
  if (!in_map(uv, receiver)) return s;
  if (!finite(radius_texels) || radius_texels < 0.0) radius_texels = 0.0;
  for (const glm::dvec2& o : offsets) {
    const glm::dvec2 p = uv * glm::dvec2(m.width, m.height) + o * radius_texels;
    auto candidates = [&](double v, int size) {
      std::array<int, 2> c{};
      const double f = std::floor(v);
      c[0] = c[1] = std::clamp(static_cast<int>(std::clamp(f, -1.0, double(size))), 0, size - 1);
      if (v - f < eps) c[1] = std::clamp(static_cast<int>(f) - 1, 0, size - 1);
      if (f + 1.0 - v < eps) c[1] = std::clamp(static_cast<int>(f) + 1, 0, size - 1);
      return c;
    };
    const auto cx = candidates(p.x, m.width);
    const auto cy = candidates(p.y, m.height);
    const float stored = m.at(cx[0], cy[0]);
    const bool blocker = is_blocker(stored, d, reverse_z);
    for (int x : cx)
      for (int y : cy) {
        const float other = m.at(x, y);
        const bool other_blocker = is_blocker(other, d, reverse_z);
        if (other_blocker != blocker || (blocker && other != stored)) s.ambiguous = true;
      }
    if (blocker) {
      s.sum += stored;
      ++s.count;
    }
  }
  if (s.count > 0) s.average = s.sum / s.count;
  return s;
}

struct PcssResult {
  double shadow = 1.0;
  bool ambiguous = false;  // blocker search ambiguous, or the early-out test too close to call
  int blockers = 0;
  double search_radius = 0.0;
  double filter_radius = 0.0;
};

// PCSS: search over search_offsets (the tier's Vogel disk), early-outs, disk PCF over
// filter_offsets with the penumbra's radius, confidence fade.
inline PcssResult pcss(const DepthMap& m, glm::dvec2 uv, float receiver, const PcssParams& p,
                       std::span<const glm::dvec2> search_offsets,
                       std::span<const glm::dvec2> filter_offsets, bool reverse_z) {
  PcssResult r;
  if (!in_map(uv, receiver)) return r;
  const float d = clamp_depth(receiver);
  // The filters search at least min_filter + 1 texels and at most max(max_search, that), so
  // that PCSS stays continuous at its degenerate ends (pcss.glsl, pcss_search_radius_bounded).
  const double lo = std::max<double>(p.min_filter_texels, 0.0) + 1.0;
  r.search_radius = std::clamp(search_radius_texels(d, p, reverse_z), lo,
                               std::max<double>(p.max_search_texels, lo));
  const BlockerSearch s = blocker_search(m, uv, d, search_offsets, r.search_radius, reverse_z);
  r.ambiguous = s.ambiguous;
  r.blockers = s.count;
  if (s.count == 0) return r;
  // The filter never reaches further than the search looked.
  const double unclamped = filter_radius_texels(d, s.average, p, reverse_z);
  r.filter_radius = std::min(unclamped, r.search_radius);
  const int n = static_cast<int>(search_offsets.size());
  if (std::abs(unclamped - r.search_radius) <= 1e-4 * (1.0 + r.search_radius)) r.ambiguous = true;
  if (s.count == n) {
    if (r.filter_radius <= r.search_radius) {
      r.shadow = 0.0;
      return r;
    }
  }
  const double filtered = disk_pcf(m, uv, d, filter_offsets, r.filter_radius, reverse_z);
  const double c = confidence(s.count, n, p.confidence_fraction);
  r.shadow = 1.0 - c * (1.0 - filtered);
  return r;
}

// ---- VSM / EVSM -----------------------------------------------------------------------------

// One-sided Chebyshev (Cantelli) bound: 1 when t <= mean, else var / (var + (t - mean)^2) with
// var = max(m2 - m1^2, min_variance).
inline double chebyshev(double m1, double m2, double t, double min_variance) {
  const double d = t - m1;
  if (d <= 0.0) return 1.0;
  const double var = std::max(m2 - m1 * m1, std::max(min_variance, 0.0));
  if (var + d * d <= 0.0) return 0.0;
  return var / (var + d * d);
}

// linstep(amount, 1, p).
inline double reduce_light_bleeding(double p, double amount) {
  const double a = std::clamp(amount, 0.0, 1.0);
  if (a >= 1.0) return p >= 1.0 ? 1.0 : 0.0;
  return std::clamp((p - a) / (1.0 - a), 0.0, 1.0);
}

// VSM: the distribution of the raw depth; under reverse-Z the receiver is behind when its depth
// is smaller, so the bound is taken on -depth.
inline double vsm_shadow(double m1, double m2, double receiver, double min_variance, double bleed,
                         bool reverse_z) {
  const double t = std::clamp(receiver, 0.0, 1.0);
  const double p =
      reverse_z ? chebyshev(-m1, m2, -t, min_variance) : chebyshev(m1, m2, t, min_variance);
  return reduce_light_bleeding(p, bleed);
}

inline double evsm_max_exponent(bool fp16) {
  return fp16 ? 5.54 : 42.0;
}

// The EVSM warp argument: x = 2 f - 1, f the distance from the light in [0, 1].
inline double evsm_x(double depth, bool reverse_z) {
  const double d = std::clamp(depth, 0.0, 1.0);
  return 2.0 * (reverse_z ? 1.0 - d : d) - 1.0;
}
inline double evsm_positive(double depth, double c, bool reverse_z) {
  return std::exp(c * evsm_x(depth, reverse_z));
}
inline double evsm_negative(double depth, double c, bool reverse_z) {
  return -std::exp(-c * evsm_x(depth, reverse_z));
}

}  // namespace penumbra::filter_ref
