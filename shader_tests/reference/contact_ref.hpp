#pragma once

// An independent C++ reference of the screen-space contact-shadow march
// (shaders/penumbra/contact_shadows.glsl), in double precision, written from the algorithm's
// description in docs/contact-shadows.md rather than from the GLSL: the depth is linearized by
// inverting the projection's depth formula, the near-plane clamp intersects the ray with the
// plane, the screen clip is Liang-Barsky, the bilinear read is done by hand.
//
// Besides the mask, march_pixel() says whether the pixel is *marginal*: whether a float-sized
// perturbation of one of its decisions (a tap within 1e-4 pixel of a texel edge, where the
// nearest read and the own-texel skip may pick the other texel; a depth difference within a
// relative 2e-5 of the tolerance window's ends; a ray length within 1e-4 pixel of a whole number
// of pixels, which sets the step count; N.L within 1e-6 of 0) or the device's filtering
// precision (a bilinear read whose allowed range, below, reaches across an end of the window)
// could change the mask. The GPU computes in float, so it may take the other branch there and
// only there; tests accept a mismatch only on marginal pixels. In practice these are taps that
// land exactly on a depth discontinuity, where the two candidate texels hold different surfaces.
//
// The bilinear read is not exact on every device. Vulkan lets a device quantise the sample
// position's fraction within a texel (the bilinear weights) to 2^-subTexelPrecisionBits
// (Params::bilinear_weight_error; 8 bits on NVIDIA and on lavapipe, though lavapipe filters
// exactly). The device then returns the exact bilinear function at a position within that many
// texels of the true one along each axis, which differs from the exact read by up to
// 2^-bits * (x difference + y difference of the footprint's texels) <= 2 * 2^-bits * range. A
// difference of 2^-8 of a silhouette's depth jump is a large change of view distance, far
// beyond any float rounding, so the reference carries it as an interval: PixelResult::mask_lo
// and mask_hi are the smallest and largest masks a device may return when every bilinear read
// may lie anywhere in its allowed range (every other decision exact); mask is the exact-filter
// value between them. A result outside [mask_lo, mask_hi] is a mismatch, allowed on marginal
// pixels only.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <limits>
#include <vector>

namespace penumbra::reference::contact {

inline constexpr std::uint32_t kMaxSteps = 64;
inline constexpr double kMinNdotL = 0.25;

// Margins of the marginal-pixel analysis (see above).
inline constexpr double kTexelEdgeMargin = 1e-4;  // pixels
inline constexpr double kDepthMarginRel = 2e-5;   // of the ray's view depth
inline constexpr double kLengthMargin = 1e-4;     // pixels
inline constexpr double kNdotLMargin = 1e-6;

enum class Reads { dual, bilinear_only, nearest_only };

// View space as in depth.glsl: x right, y up, the camera looks down -z; view distance = -z.
struct Params {
  glm::dvec3 to_light{0.0, 1.0, 0.0};  // view space; normalized by the march
  // A positional light: to_light is its view-space position, the ray goes towards it and no
  // further than it.
  bool positional = false;
  double tan_half_fov_y = 1.0;
  double aspect = 1.0;
  double near = 0.1;
  double far = std::numeric_limits<double>::infinity();
  double max_distance = 0.5;
  double thickness = 0.1;
  double depth_bias = 0.002;
  double intensity = 1.0;
  double step_exponent = 2.0;
  double edge_fade = 0.05;
  std::uint32_t step_count = 16;
  std::uint32_t frame = 0;
  bool reverse_z = true;
  // The device's bilinear weights are the sample position's fraction within a texel quantised to
  // this (2^-subTexelPrecisionBits of VkPhysicalDeviceLimits): the filtered depth may be the
  // exact filter's at any position within this many texels along each axis, up to
  // 2 * bilinear_weight_error * (the footprint's range) from the exact read (see the top). 0
  // for an exact filter.
  double bilinear_weight_error = 0.0;
};

struct Buffers {
  int width = 0, height = 0;
  std::vector<float> depth;        // row-major, row 0 first
  std::vector<glm::vec3> normals;  // view space, row-major
  float at(int x, int y) const { return depth[static_cast<std::size_t>(y) * width + x]; }
};

// ---- the pieces ----------------------------------------------------------------------------

inline bool is_sky(double d, bool reverse_z) {
  if (!std::isfinite(d)) return true;
  return reverse_z ? !(d > 0.0) : !(d < 1.0);
}

// Inverts reverse-Z d = n (f - z) / (z (f - n)) (d = n / z for f = inf) and standard
// d = f (z - n) / (z (f - n)) (d = 1 - n / z for f = inf), after clamping d to [0, 1].
inline double view_depth(double d, double near, double far, bool reverse_z) {
  d = std::clamp(d, 0.0, 1.0);
  if (std::isinf(far)) return reverse_z ? near / d : near / (1.0 - d);
  return reverse_z ? near * far / (d * (far - near) + near) : near * far / (far - d * (far - near));
}

// The forward projection (for building buffers): view distance -> depth-buffer value.
inline double device_depth(double z, double near, double far, bool reverse_z) {
  if (std::isinf(far)) return reverse_z ? near / z : 1.0 - near / z;
  return reverse_z ? near * (far - z) / (z * (far - near)) : far * (z - near) / (z * (far - near));
}

// View distance of a depth-buffer value, or -1 for no surface.
inline double surface_depth(double d, double near, double far, bool reverse_z) {
  if (is_sky(d, reverse_z)) return -1.0;
  const double z = view_depth(d, near, far, reverse_z);
  return std::isfinite(z) && z > 0.0 ? z : -1.0;
}

inline glm::dvec2 pixel_uv(int x, int y, int width, int height) {
  return {(x + 0.5) / width, (y + 0.5) / height};
}

// The point at view distance z seen at uv (Vulkan: uv.y = 0 is the top, view +y is up).
inline glm::dvec3 view_position(glm::dvec2 uv, double z, double tan_half_fov_y, double aspect) {
  const double tx = tan_half_fov_y * aspect;
  return {(2.0 * uv.x - 1.0) * tx * z, (1.0 - 2.0 * uv.y) * tan_half_fov_y * z, -z};
}

inline glm::dvec2 project_uv(glm::dvec3 p, double tan_half_fov_y, double aspect) {
  const double z = -p.z;
  return {0.5 + 0.5 * p.x / (z * tan_half_fov_y * aspect), 0.5 - 0.5 * p.y / (z * tan_half_fov_y)};
}

// Ray length: max_distance, cut where the ray meets the near plane (view distance near) when it
// heads towards the camera (+z).
inline double ray_length(glm::dvec3 origin, glm::dvec3 dir, double max_distance, double near) {
  const double len = std::max(max_distance, 0.0);
  if (dir.z <= 0.0) return len;
  const double to_near = (-origin.z - near) / dir.z;  // distance to the near plane
  return std::clamp(to_near, 0.0, len);
}

// Liang-Barsky: the largest t in [0, 1] for which uv0 + t (uv1 - uv0) is inside [0, 1]^2.
inline double screen_exit(glm::dvec2 uv0, glm::dvec2 uv1) {
  double t = 1.0;
  for (int a = 0; a < 2; ++a) {
    const double d = uv1[a] - uv0[a];
    if (d == 0.0) continue;
    const double bound = d > 0.0 ? 1.0 : 0.0;
    t = std::min(t, (bound - uv0[a]) / d);
  }
  return std::clamp(t, 0.0, 1.0);
}

inline std::uint32_t step_count(double length_px, std::uint32_t max_steps) {
  const std::uint32_t cap = std::min(max_steps, kMaxSteps);
  if (!(length_px >= 1.0)) return 0;
  if (length_px >= cap) return cap;
  return std::min(static_cast<std::uint32_t>(length_px), cap);
}

// Interleaved gradient noise (Jimenez 2014), evaluated in float in the order
// fract(c * fract(a x + b y)) with every operation rounded (the GLSL marks it `precise`).
inline float ign(float x, float y) {
  const float ax = 0.06711056f * x;
  const float by = 0.00583715f * y;
  const float inner = ax + by;
  const float f = inner - std::floor(inner);
  const float outer = 52.9829189f * f;
  return outer - std::floor(outer);
}

// fract(frame * (sqrt(5) - 1) / 2) truncated to 24 bits: bits 40..63 of frame times the golden
// ratio's fraction in 64-bit fixed point.
inline double golden_ratio_offset(std::uint32_t frame) {
  const std::uint64_t product = std::uint64_t{frame} * 0x9E3779B97F4A7C15ull;
  return static_cast<double>(product >> 40) / 16777216.0;
}

inline double noise(int x, int y, std::uint32_t frame) {
  const double n =
      static_cast<double>(ign(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f)) +
      golden_ratio_offset(frame);
  // The sum of two floats rounded to float, then wrapped (as on the GPU).
  const float sum = static_cast<float>(n);
  return static_cast<double>(sum) - std::floor(static_cast<double>(sum));
}

inline double step_t(std::uint32_t i, std::uint32_t n, double noise_value, double exponent) {
  const double x = std::clamp((i + noise_value) / std::max<std::uint32_t>(n, 1), 0.0, 1.0);
  const double k = exponent > 1.0 ? std::min(exponent, 8.0) : 1.0;  // NaN: 1
  return std::pow(x, k);
}

// A normal whose largest component is below FLT_MIN (or not finite) is degenerate.
inline double n_dot_l(glm::dvec3 normal, glm::dvec3 to_light) {
  const double m = std::max({std::fabs(normal.x), std::fabs(normal.y), std::fabs(normal.z)});
  if (!(m >= 1.1754943508222875e-38) || !std::isfinite(m)) return kMinNdotL;
  return glm::dot(normal, to_light) / glm::length(normal);
}

inline double tolerance(double depth_bias, double z, double ndl) {
  return depth_bias * z / std::max(ndl, kMinNdotL);
}

// One float step of the stored depth d, in view distance at z: ulp(d) |dz/dd| with
// |dz/dd| = z^2 (far - near) / (far near), z^2 / near for an infinite far plane.
inline double depth_step(double d, double z, double near, double far) {
  if (!(d > 0.0) || !std::isfinite(d) || !(z > 0.0)) return 0.0;
  int e = 0;
  std::frexp(d, &e);
  const double ulp = std::ldexp(1.0, e - 24);
  const double scale = std::isinf(far) || far <= 0.0 ? 1.0 / near : (far - near) / (far * near);
  return z * z * scale * ulp;
}

// 1/z is affine along a screen-space segment: z(t) = 1 / ((1 - t) / z0 + t / z1).
inline double ray_depth(double z0, double z1, double t) {
  return 1.0 / ((1.0 - t) / z0 + t / z1);
}

inline bool behind(double ray_z, double surface_z, double tol, double thickness) {
  if (!(surface_z > 0.0)) return false;
  const double d = ray_z - surface_z;
  return d > tol && d < tol + thickness;
}

inline double edge_fade(glm::dvec2 uv, double width) {
  if (!(width > 0.0)) return 1.0;
  const double border = std::min({uv.x, 1.0 - uv.x, uv.y, 1.0 - uv.y});
  return std::clamp(border / width, 0.0, 1.0);
}

// Bilinear read at uv (texel centres at (i + 0.5) / size, clamp to edge). range: the largest
// difference among the four texels.
inline double bilinear(const Buffers& b, glm::dvec2 uv, double* range = nullptr) {
  const double fx = uv.x * b.width - 0.5, fy = uv.y * b.height - 0.5;
  const double x0 = std::floor(fx), y0 = std::floor(fy);
  const double ax = fx - x0, ay = fy - y0;
  const auto clampi = [](double v, int n) { return std::clamp(static_cast<int>(v), 0, n - 1); };
  const int xa = clampi(x0, b.width), xb = clampi(x0 + 1, b.width);
  const int ya = clampi(y0, b.height), yb = clampi(y0 + 1, b.height);
  const double d00 = b.at(xa, ya), d10 = b.at(xb, ya), d01 = b.at(xa, yb), d11 = b.at(xb, yb);
  if (range) *range = std::max({d00, d10, d01, d11}) - std::min({d00, d10, d01, d11});
  return (1 - ay) * ((1 - ax) * d00 + ax * d10) + ay * ((1 - ax) * d01 + ax * d11);
}

// The smallest and largest bilinear read at a sample position within h texels of uv's along
// each axis (the weight quantisation above, h = 2^-subTexelPrecisionBits, plus any position
// slack). The filtered function is bilinear inside each cell between four texel centres and
// continuous across cells, so over the box its extremes lie at the box's corners and where the
// box's edges cross a row or column of texel centres (a footprint switch: the box may reach a
// texel outside the nominal footprint); those are the points evaluated.
inline void bilinear_range(const Buffers& b, glm::dvec2 uv, double h, double* lo, double* hi) {
  const auto candidates = [h](double f, std::vector<double>* out) {
    out->push_back(f - h);
    out->push_back(f + h);
    for (double k = std::ceil(f - h); k < f + h; k += 1.0) out->push_back(k);
  };
  std::vector<double> xs, ys;
  candidates(uv.x * b.width - 0.5, &xs);
  candidates(uv.y * b.height - 0.5, &ys);
  *lo = std::numeric_limits<double>::infinity();
  *hi = -*lo;
  for (double fx : xs) {
    for (double fy : ys) {
      const double v = bilinear(b, {(fx + 0.5) / b.width, (fy + 0.5) / b.height});
      *lo = std::min(*lo, v);
      *hi = std::max(*hi, v);
    }
  }
}

// The spread of view distances over the four texels of the bilinear footprint at uv (+inf when
// some but not all of them are sky): how big a depth discontinuity a tap straddles.
inline double footprint_spread(const Buffers& b, glm::dvec2 uv, double near, double far,
                               bool reverse_z) {
  const double fx = std::floor(uv.x * b.width - 0.5), fy = std::floor(uv.y * b.height - 0.5);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  int sky = 0;
  for (int dy = 0; dy <= 1; ++dy) {
    for (int dx = 0; dx <= 1; ++dx) {
      const int x = std::clamp(static_cast<int>(fx) + dx, 0, b.width - 1);
      const int y = std::clamp(static_cast<int>(fy) + dy, 0, b.height - 1);
      const double z = surface_depth(b.at(x, y), near, far, reverse_z);
      if (!(z > 0.0)) {
        ++sky;
        continue;
      }
      lo = std::min(lo, z);
      hi = std::max(hi, z);
    }
  }
  if (sky == 4) return 0.0;
  if (sky > 0) return std::numeric_limits<double>::infinity();
  return hi - lo;
}

// ---- the march -----------------------------------------------------------------------------

struct Ray {
  std::uint32_t steps = 0;  // 0: not marched
  glm::dvec2 uv0{0.0}, uv1{0.0};
  double z0 = 0.0, z1 = 0.0;  // view depth at both ends (after the clamp and the clip)
  double tolerance = 0.0;
  double length_px = 0.0;
  double n_dot_l = 0.0;
  bool clamped = false;  // the near-plane clamp shortened the ray
  bool clipped = false;  // the ray left the screen
};

inline Ray setup_ray(int x, int y, double depth, glm::dvec3 normal, const Params& p, int width,
                     int height) {
  Ray r;
  const double z0 = surface_depth(depth, p.near, p.far, p.reverse_z);
  if (!(z0 > 0.0)) return r;
  const glm::dvec2 uv0 = pixel_uv(x, y, width, height);
  const glm::dvec3 origin = view_position(uv0, z0, p.tan_half_fov_y, p.aspect);
  const glm::dvec3 to = p.positional ? p.to_light - origin : p.to_light;
  const double ll = glm::length(to);
  if (!(ll > 0.0) || !std::isfinite(ll)) return r;
  const glm::dvec3 l = to / ll;
  const double max_distance = p.positional ? std::min(p.max_distance, ll) : p.max_distance;
  r.n_dot_l = n_dot_l(normal, l);
  if (!(r.n_dot_l > 0.0)) return r;
  const double len = ray_length(origin, l, max_distance, p.near);
  r.clamped = len < std::max(max_distance, 0.0);
  const glm::dvec3 end = origin + l * len;
  const glm::dvec2 uv1 = project_uv(end, p.tan_half_fov_y, p.aspect);
  const double t = screen_exit(uv0, uv1);
  r.clipped = t < 1.0;
  r.uv0 = uv0;
  r.uv1 = uv0 + t * (uv1 - uv0);
  r.z0 = z0;
  r.z1 = ray_depth(z0, -end.z, t);
  r.length_px = glm::length((r.uv1 - uv0) * glm::dvec2(width, height));
  r.steps = step_count(r.length_px, p.step_count);
  r.tolerance =
      std::max(tolerance(p.depth_bias, z0, r.n_dot_l), 2.0 * depth_step(depth, z0, p.near, p.far));
  return r;
}

// Why a pixel is marginal (bits of PixelResult::reasons).
enum Reason : unsigned {
  kTexelEdge = 1,    // a tap within kTexelEdgeMargin of a texel edge whose texels decide apart
  kDepthWindow = 2,  // a depth difference within the margin of the tolerance window's ends
  kStepCount = 4,    // a ray length within kLengthMargin of a whole number of pixels
  kFacing = 8,       // N.L within kNdotLMargin of 0
  // With kTexelEdge, kDepthWindow or kBilinearWeight: the uncertain tap's bilinear footprint
  // straddles a depth discontinuity (its texels' view distances spread wider than the
  // occlusion window).
  kDiscontinuity = 16,
  // A bilinear read whose range under the device's weight quantisation
  // (Params::bilinear_weight_error) reaches across an end of the tolerance window.
  kBilinearWeight = 32,
};

struct PixelResult {
  double mask = 1.0;     // with the exact bilinear filter
  double mask_lo = 1.0;  // the smallest and largest mask a device may return when its bilinear
  double mask_hi = 1.0;  // reads may lie anywhere in their allowed range (see the top)
  bool marginal = false;
  unsigned reasons = 0;  // Reason bits, when marginal
  Ray ray;
};

namespace detail {

// Which outcomes of the occlusion test a read can have: can_hit, can_miss.
struct Outcomes {
  bool can_hit = true;
  bool can_miss = false;
};

// The outcomes of contact_ray_behind for a depth-buffer value anywhere in [lo, hi], each view
// distance also within `margin` either way (float rounding). The view distance is monotonic in
// the depth-buffer value, so the values in [lo, hi] map to a view-distance interval, plus "no
// surface" where the interval reaches the sky.
inline Outcomes behind_range(double lo, double hi, double ray_z, double tol, double thickness,
                             double margin, const Params& p) {
  if (!std::isfinite(lo) || !std::isfinite(hi)) return {true, true};
  const bool sky_lo = is_sky(lo, p.reverse_z), sky_hi = is_sky(hi, p.reverse_z);
  if (sky_lo && sky_hi) return {false, true};
  // The non-sky part: its ends' view distances (a sky end replaced by the far plane's value).
  const double sky_value = p.reverse_z ? 0.0 : 1.0;
  const double za = view_depth(sky_lo ? sky_value : lo, p.near, p.far, p.reverse_z);
  const double zb = view_depth(sky_hi ? sky_value : hi, p.near, p.far, p.reverse_z);
  const double zmin = std::min(za, zb) - margin, zmax = std::max(za, zb) + margin;
  // Behind when z is inside (ray_z - tol - thickness, ray_z - tol).
  const double front = ray_z - tol - thickness, back = ray_z - tol;
  Outcomes o;
  o.can_hit = zmin < back && zmax > front;
  o.can_miss = sky_lo || sky_hi || !(zmin > front) || !(zmax < back);
  return o;
}

// The march's occlusion weights with `steps` steps (the largest edge-fade weight of an occluding
// tap): exact with the reference's own decisions; sure / possible with every tap that float
// rounding or the filter precision could turn counted as missing / occluding; sure_w /
// possible_w the same for the filter precision alone (every other decision exact).
struct Occlusion {
  double exact = 0.0, sure = 0.0, possible = 0.0, sure_w = 0.0, possible_w = 0.0;
};

inline Occlusion occlusion(const Buffers& b, int x, int y, const Params& p, Reads reads,
                           const Ray& r, std::uint32_t steps, unsigned* reasons = nullptr) {
  const bool use_bilinear = reads != Reads::nearest_only;
  const bool use_nearest = reads != Reads::bilinear_only;
  const double nz = noise(x, y, p.frame);
  const double weight_h = std::max(p.bilinear_weight_error, 0.0);
  Occlusion o;
  for (std::uint32_t i = 0; i < steps; ++i) {
    const double t = step_t(i, steps, nz, p.step_exponent);
    const glm::dvec2 uv = r.uv0 + t * (r.uv1 - r.uv0);
    const double ray_z = ray_depth(r.z0, r.z1, t);
    const double margin = kDepthMarginRel * ray_z;
    const double w = edge_fade(uv, p.edge_fade);

    // The bilinear read: exact; over the weight quantisation alone; and over the quantisation,
    // a float-sized position error (kTexelEdgeMargin) and a few ULP of filter arithmetic, with
    // the float margin on the view distance.
    Outcomes bw, bf;
    bool b_exact = true;
    if (use_bilinear) {
      const double bd = bilinear(b, uv);
      b_exact =
          behind(ray_z, surface_depth(bd, p.near, p.far, p.reverse_z), r.tolerance, p.thickness);
      double lo = bd, hi = bd;
      if (weight_h > 0.0) bilinear_range(b, uv, weight_h, &lo, &hi);
      bw = behind_range(lo, hi, ray_z, r.tolerance, p.thickness, 0.0, p);
      bilinear_range(b, uv, weight_h + kTexelEdgeMargin, &lo, &hi);
      const double ulps = 4.0 * std::ldexp(std::max(std::fabs(lo), std::fabs(hi)), -24);
      bf = behind_range(lo - ulps, hi + ulps, ray_z, r.tolerance, p.thickness, margin, p);
    }

    // The texels a float evaluation might pick: both sides of an edge within the margin.
    const glm::dvec2 texel_f = uv * glm::dvec2(b.width, b.height);
    int xs[2], ys[2], nx = 0, ny = 0;
    for (double e : {-kTexelEdgeMargin, kTexelEdgeMargin}) {
      const int tx = std::clamp(static_cast<int>(std::floor(texel_f.x + e)), 0, b.width - 1);
      const int ty = std::clamp(static_cast<int>(std::floor(texel_f.y + e)), 0, b.height - 1);
      if (nx == 0 || xs[nx - 1] != tx) xs[nx++] = tx;
      if (ny == 0 || ys[ny - 1] != ty) ys[ny++] = ty;
    }
    const int nominal_x = std::clamp(static_cast<int>(std::floor(texel_f.x)), 0, b.width - 1);
    const int nominal_y = std::clamp(static_cast<int>(std::floor(texel_f.y)), 0, b.height - 1);

    bool tap_exact = false, tap_w_hit = false, tap_w_miss = false;
    bool tap_can_hit = false, tap_can_miss = false;
    bool any_exact = false, all_exact = true, nearest_close = false;
    for (int ix = 0; ix < nx; ++ix) {
      for (int iy = 0; iy < ny; ++iy) {
        const int tx = xs[ix], ty = ys[iy];
        // The receiver's own texel is skipped; with both reads off nothing is tested.
        const bool skip = (tx == x && ty == y) || (!use_bilinear && !use_nearest);
        bool n_exact = true, n_close = false;
        if (use_nearest) {
          const double nzd = surface_depth(b.at(tx, ty), p.near, p.far, p.reverse_z);
          n_exact = behind(ray_z, nzd, r.tolerance, p.thickness);
          n_close = nzd > 0.0 && (std::fabs(ray_z - nzd - r.tolerance) <= margin ||
                                  std::fabs(ray_z - nzd - r.tolerance - p.thickness) <= margin);
        }
        const bool hit = !skip && b_exact && n_exact;
        any_exact = any_exact || hit;
        all_exact = all_exact && hit;
        tap_can_hit = tap_can_hit || (!skip && bf.can_hit && (n_exact || n_close));
        tap_can_miss = tap_can_miss || skip || bf.can_miss || !n_exact || n_close;
        if (tx == nominal_x && ty == nominal_y) {
          tap_exact = hit;
          tap_w_hit = !skip && bw.can_hit && n_exact;
          tap_w_miss = skip || bw.can_miss || !n_exact;
          nearest_close = n_close && bf.can_hit;
        }
      }
    }
    if (tap_exact) o.exact = std::max(o.exact, w);
    if (tap_w_hit) o.possible_w = std::max(o.possible_w, w);
    if (!tap_w_miss) o.sure_w = std::max(o.sure_w, w);
    if (tap_can_hit) o.possible = std::max(o.possible, w);
    if (!tap_can_miss) o.sure = std::max(o.sure, w);
    if (reasons && w > o.sure && tap_can_hit && tap_can_miss) {
      const bool weight = tap_w_hit && tap_w_miss;
      if (any_exact != all_exact) *reasons |= kTexelEdge;
      if (weight) *reasons |= kBilinearWeight;
      if (nearest_close || (bf.can_hit && bf.can_miss && !weight)) *reasons |= kDepthWindow;
      if (footprint_spread(b, uv, p.near, p.far, p.reverse_z) > r.tolerance + p.thickness) {
        *reasons |= kDiscontinuity;
      }
    }
  }
  return o;
}

}  // namespace detail

inline PixelResult march_pixel(const Buffers& b, int x, int y, const Params& p,
                               Reads reads = Reads::dual) {
  PixelResult out;
  const glm::dvec3 n = b.normals.empty()
                           ? glm::dvec3(0.0)
                           : glm::dvec3(b.normals[static_cast<std::size_t>(y) * b.width + x]);
  out.ray = setup_ray(x, y, b.at(x, y), n, p, b.width, b.height);
  const Ray& r = out.ray;
  if (std::fabs(r.n_dot_l) <= kNdotLMargin && r.z0 > 0.0) {
    out.marginal = true;
    out.reasons |= kFacing;
  }
  if (r.steps == 0) {
    // Marginal when a float length might reach one whole pixel.
    if (r.z0 > 0.0 && r.n_dot_l > 0.0 && std::fabs(r.length_px - 1.0) <= kLengthMargin) {
      out.marginal = true;
      out.reasons |= kStepCount;
    }
    return out;
  }
  unsigned reasons = 0;
  const detail::Occlusion o = detail::occlusion(b, x, y, p, reads, r, r.steps, &reasons);
  const auto mask = [&](double occlusion) {
    return std::clamp(1.0 - p.intensity * occlusion, 0.0, 1.0);
  };
  out.mask = mask(o.exact);
  out.mask_lo = mask(o.possible_w);
  out.mask_hi = mask(o.sure_w);
  if (o.possible != o.sure) {
    out.marginal = true;
    out.reasons |= reasons;
  }
  // A length within the margin of a whole number of pixels (below the cap) may give one step
  // more or less in float.
  const double frac = r.length_px - std::floor(r.length_px);
  if (r.length_px < std::min(p.step_count, kMaxSteps) + 1.0 &&
      (frac <= kLengthMargin || frac >= 1.0 - kLengthMargin)) {
    for (std::uint32_t alt : {r.steps - 1, r.steps + 1}) {
      if (alt == 0 || alt > std::min(p.step_count, kMaxSteps)) continue;
      const detail::Occlusion a = detail::occlusion(b, x, y, p, reads, r, alt);
      if (a.sure != o.sure || a.possible != o.possible) {
        out.marginal = true;
        out.reasons |= kStepCount;
      }
    }
  }
  return out;
}

inline std::vector<PixelResult> march(const Buffers& b, const Params& p,
                                      Reads reads = Reads::dual) {
  std::vector<PixelResult> out(static_cast<std::size_t>(b.width) * b.height);
  for (int y = 0; y < b.height; ++y) {
    for (int x = 0; x < b.width; ++x) {
      out[static_cast<std::size_t>(y) * b.width + x] = march_pixel(b, x, y, p, reads);
    }
  }
  return out;
}

}  // namespace penumbra::reference::contact
