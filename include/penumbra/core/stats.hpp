#pragma once

// Statistics the tools and benchmarks share: the median of repeated timings, and a least-squares
// line with the standard error of its slope, so that a rate fitted from noisy timings can say
// whether the noise hides it instead of reporting a meaningless (even negative) number.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace penumbra::stats {

// The median of `v` (the mean of the two middle values for an even count); NaN when empty.
inline double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// The q-quantile of `v` (q in [0, 1]) by linear interpolation between order statistics (the
// "type 7" rule: q = 0 the minimum, q = 1 the maximum, 0.5 the median); NaN when empty.
inline double quantile(std::vector<double> v, double q) {
  if (v.empty() || !(q >= 0.0 && q <= 1.0)) return std::nan("");
  std::sort(v.begin(), v.end());
  const double h = q * double(v.size() - 1);
  const size_t lo = size_t(std::floor(h));
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (h - double(lo)) * (v[hi] - v[lo]);
}

// y = intercept + slope * x by ordinary least squares over n points.
struct LineFit {
  double intercept = std::nan("");
  double slope = std::nan("");
  // The standard error of the slope, sqrt(residual variance / sum (x - mean x)^2): NaN with
  // fewer than three points or when every x is the same.
  double slope_stderr = std::nan("");
  size_t n = 0;

  // The slope over its standard error (Student's t with n - 2 degrees of freedom).
  double t() const { return slope / slope_stderr; }
  // Whether the slope is positive and stands out of the noise: at least `min_t` standard errors
  // above zero. With 8 points (6 degrees of freedom) t = 4 is beyond the 99.5% quantile (3.71).
  // An exact fit (zero residuals) with a positive slope qualifies.
  bool significantly_positive(double min_t = 4.0) const {
    if (!(slope > 0.0) || !std::isfinite(slope)) return false;
    if (slope_stderr == 0.0) return true;
    return std::isfinite(slope_stderr) && slope >= min_t * slope_stderr;
  }
};

inline LineFit fit_line(const std::vector<double>& x, const std::vector<double>& y) {
  LineFit f;
  f.n = std::min(x.size(), y.size());
  if (f.n < 2) return f;
  double mx = 0, my = 0;
  for (size_t i = 0; i < f.n; ++i) {
    mx += x[i];
    my += y[i];
  }
  mx /= double(f.n);
  my /= double(f.n);
  double sxx = 0, sxy = 0;
  for (size_t i = 0; i < f.n; ++i) {
    sxx += (x[i] - mx) * (x[i] - mx);
    sxy += (x[i] - mx) * (y[i] - my);
  }
  if (!(sxx > 0.0)) return f;
  f.slope = sxy / sxx;
  f.intercept = my - f.slope * mx;
  if (f.n >= 3) {
    double ssr = 0;
    for (size_t i = 0; i < f.n; ++i) {
      const double r = y[i] - (f.intercept + f.slope * x[i]);
      ssr += r * r;
    }
    f.slope_stderr = std::sqrt(ssr / double(f.n - 2) / sxx);
  }
  return f;
}

}  // namespace penumbra::stats
