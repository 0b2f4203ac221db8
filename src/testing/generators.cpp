#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numbers>
#include <penumbra/testing/generators.hpp>

namespace penumbra::testing {

std::uint64_t Rng::below(std::uint64_t n) {
  if (n == 0) throw Error("Rng::below: the range is empty (n = 0)");
  // Rejection of the top partial block keeps the result unbiased.
  const std::uint64_t threshold = (0 - n) % n;
  for (;;) {
    const std::uint64_t r = engine_();
    if (r >= threshold) return r % n;
  }
}

namespace detail {

float uniform_scalar(Rng& rng, float lo, float hi) {
  const double u = rng.next_unit();
  const double v =
      static_cast<double>(lo) + (static_cast<double>(hi) - static_cast<double>(lo)) * u;
  return std::clamp(static_cast<float>(v), lo, hi);
}

double uniform_scalar(Rng& rng, double lo, double hi) {
  const double u = rng.next_unit();
  // lo * (1 - u) + hi * u cannot overflow, unlike hi - lo for +-DBL_MAX.
  return std::clamp(lo * (1.0 - u) + hi * u, lo, hi);
}

std::int32_t uniform_scalar(Rng& rng, std::int32_t lo, std::int32_t hi) {
  const auto span = static_cast<std::uint64_t>(static_cast<std::int64_t>(hi) - lo) + 1;
  return static_cast<std::int32_t>(static_cast<std::int64_t>(lo) +
                                   static_cast<std::int64_t>(rng.below(span)));
}

std::uint32_t uniform_scalar(Rng& rng, std::uint32_t lo, std::uint32_t hi) {
  const std::uint64_t span = static_cast<std::uint64_t>(hi) - lo + 1;
  return static_cast<std::uint32_t>(lo + rng.below(span));
}

bool uniform_scalar(Rng& rng, bool lo, bool hi) {
  if (lo == hi) return lo;
  return (rng.next_u64() >> 63) != 0;
}

void throw_bad_range(const std::string& lo, const std::string& hi) {
  throw Error("uniform: bad range [" + lo + ", " + hi +
              "]: bounds must be finite with lo <= hi in every component");
}

}  // namespace detail

glm::vec3 UnitVector3::operator()(Rng& rng) const {
  // z uniform in [-1, 1] and a uniform azimuth give a uniform point on the sphere
  // (Archimedes' hat-box theorem); always two draws, so sequences stay aligned.
  const double z = 2.0 * rng.next_unit() - 1.0;
  const double phi = 2.0 * std::numbers::pi * rng.next_unit();
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return glm::normalize(glm::vec3(static_cast<float>(r * std::cos(phi)),
                                  static_cast<float>(r * std::sin(phi)), static_cast<float>(z)));
}

namespace {

void add_unique(std::vector<float>& values, float v) {
  // Compare bit patterns so that -0 and +0 are distinct and NaN is found.
  const auto same = [v](float x) {
    return std::bit_cast<std::uint32_t>(x) == std::bit_cast<std::uint32_t>(v);
  };
  if (std::find_if(values.begin(), values.end(), same) == values.end()) values.push_back(v);
}

}  // namespace

std::vector<float> extreme_float_values(const ExtremeOptions& options) {
  using L = std::numeric_limits<float>;
  std::vector<float> positive = {
      0.0f, L::min(), 1e-30f, 0.5f, std::nextafter(1.0f, 0.0f), 1.0f, std::nextafter(1.0f, 2.0f),
      1e30f};
  if (options.denormals) {
    positive.push_back(L::denorm_min());                 // nextafter(0, 1)
    positive.push_back(std::nextafter(L::min(), 0.0f));  // the largest denormal
  }
  if (options.max_values) positive.push_back(L::max());
  std::vector<float> values;
  for (float v : positive) add_unique(values, v);
  if (options.negative) {
    for (float v : positive) add_unique(values, -v);
  }
  if (options.nan_inf) {
    add_unique(values, L::quiet_NaN());
    add_unique(values, L::infinity());
    if (options.negative) add_unique(values, -L::infinity());
  }
  return values;
}

ExtremeFloat extremes_float(const ExtremeOptions& options) {
  ExtremeOptions o = options;
  if (!o.negative) o.lo = std::max(o.lo, 0.0f);
  if (!(o.special_fraction >= 0.0 && o.special_fraction <= 1.0)) {
    throw Error("extremes_float: special_fraction " + std::to_string(o.special_fraction) +
                " is outside [0, 1]");
  }
  if (!(o.lo <= o.hi) || !std::isfinite(o.lo) || !std::isfinite(o.hi)) {
    throw Error("extremes_float: bad ordinary range [" + format_value(o.lo) + ", " +
                format_value(o.hi) + "]");
  }
  return ExtremeFloat{extreme_float_values(o), o};
}

float ExtremeFloat::operator()(Rng& rng) const {
  if (rng.next_unit() < options.special_fraction) {
    return specials[static_cast<std::size_t>(rng.below(specials.size()))];
  }
  return detail::uniform_scalar(rng, options.lo, options.hi);
}

std::vector<float> depth_special_values(DepthConvention convention,
                                        const DepthExtremeOptions& options) {
  (void)convention;  // the special depths are the same; the ordinary draws differ
  std::vector<float> values;
  for (float v : {0.0f, -0.0f, 1.0f, std::nextafter(1.0f, 0.0f), std::nextafter(0.0f, 1.0f), 1e-7f,
                  1.0f - 1e-7f, 0.5f, std::numeric_limits<float>::min()}) {
    add_unique(values, v);
  }
  if (options.out_of_range) {
    for (float v :
         {std::nextafter(0.0f, -1.0f), -1e-7f, std::nextafter(1.0f, 2.0f), 1.0f + 1e-7f}) {
      add_unique(values, v);
    }
  }
  return values;
}

DepthExtremes depth_extremes(DepthConvention convention, const DepthExtremeOptions& options) {
  if (!(options.special_fraction >= 0.0 && options.special_fraction <= 1.0)) {
    throw Error("depth_extremes: special_fraction " + std::to_string(options.special_fraction) +
                " is outside [0, 1]");
  }
  if (!(options.near > 0.0 && options.near < options.far && std::isfinite(options.far))) {
    throw Error("depth_extremes: need 0 < near < far < inf, got near " +
                std::to_string(options.near) + ", far " + std::to_string(options.far));
  }
  return DepthExtremes{convention, depth_special_values(convention, options), options};
}

float DepthExtremes::operator()(Rng& rng) const {
  if (rng.next_unit() < options.special_fraction) {
    return specials[static_cast<std::size_t>(rng.below(specials.size()))];
  }
  const double u = rng.next_unit();
  const double t = rng.next_unit();
  if (u < 0.5) return static_cast<float>(t);
  // A view distance log-uniform in [near, far], projected by the convention.
  const double n = options.near;
  const double f = options.far;
  const double z = n * std::pow(f / n, t);
  const double d = convention == DepthConvention::reverse_z ? n * (f - z) / (z * (f - n))
                                                            : f * (z - n) / (z * (f - n));
  return std::clamp(static_cast<float>(d), 0.0f, 1.0f);
}

}  // namespace penumbra::testing
