// Error metrics of a visibility image against the reference, and the images people look at.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <penumbra/core/error.hpp>
#include <penumbra/core/json.hpp>
#include <penumbra/reference/metrics.hpp>
#include <sstream>

namespace penumbra::reference {
namespace {

void check_size(size_t got, size_t want, const char* what) {
  if (got != want)
    throw Error(std::string("reference metrics: ") + what + " has " + std::to_string(got) +
                " values, expected " + std::to_string(want));
}

std::string number(double v) {
  return json::number(v);
}

uint8_t grey_of(std::span<const uint8_t> rgba, size_t i) {
  const double l = 0.2126 * rgba[4 * i] + 0.7152 * rgba[4 * i + 1] + 0.0722 * rgba[4 * i + 2];
  return static_cast<uint8_t>(std::clamp(l, 0.0, 255.0));
}

}  // namespace

std::vector<ReceiverClass> classify_receivers(const Receivers& receivers, const scene::Scene& scene,
                                              const LightRef& light, std::vector<float>* n_dot_l) {
  const AreaLight a = area_light(scene, light);
  std::vector<ReceiverClass> out(receivers.size(), ReceiverClass::none);
  if (n_dot_l) n_dot_l->assign(receivers.size(), 0.0f);
  double range = std::numeric_limits<double>::infinity(), cos_outer = -2.0;
  glm::dvec3 axis(0.0);
  if (light.kind == LightKind::spot) {
    const auto& s = scene.spots[light.index];
    range = s.range;
    cos_outer = std::cos(glm::radians(double(s.outer_degrees)));
    axis = glm::normalize(glm::dvec3(s.direction));
  } else if (light.kind == LightKind::point) {
    range = scene.points[light.index].range;
  }
  const glm::dvec3 centre = a.position - receivers.origin;
  for (size_t i = 0; i < receivers.size(); ++i) {
    if (!receivers.valid[i]) continue;
    glm::dvec3 l = a.direction_to_light;
    if (light.kind != LightKind::sun) {
      const glm::dvec3 d = centre - receivers.position[i];
      const double dist = glm::length(d);
      if (!(dist < range) || !(dist > 0.0)) continue;
      l = d / dist;
      if (light.kind == LightKind::spot && !(glm::dot(-l, axis) > cos_outer)) continue;
    }
    const double c = glm::dot(receivers.normal[i], l);
    out[i] = c > 0.0 ? ReceiverClass::lit : ReceiverClass::facing_away;
    if (n_dot_l) (*n_dot_l)[i] = float(std::max(c, 0.0));
  }
  return out;
}

Metrics compute_metrics(std::span<const float> v, const Visibility& reference,
                        std::span<const ReceiverClass> classes, bool hard,
                        const MetricsOptions& options, std::span<const float> n_dot_l) {
  check_size(reference.value.size(), classes.size(), "the reference");
  check_size(v.size(), classes.size(), "the GPU visibility");
  if (!n_dot_l.empty()) check_size(n_dot_l.size(), classes.size(), "the n.l weights");
  double sum_weighted = 0.0, sum_weights = 0.0;
  Metrics m;
  m.hard = hard;
  std::vector<double> abs_errors;
  double sum_abs = 0.0, sum_sq = 0.0, sum_se = 0.0, sum_abs_away = 0.0;
  uint64_t false_light = 0, false_shadow = 0, wrong = 0, shadowed = 0, partial = 0;
  double false_light_w = 0.0, false_shadow_w = 0.0;
  const double t = options.threshold;
  for (size_t i = 0; i < classes.size(); ++i) {
    const double r = reference.value[i], g = v[i];
    if (classes[i] == ReceiverClass::lit && std::isfinite(r) && !std::isfinite(g)) ++m.non_finite;
    if (!std::isfinite(r) || !std::isfinite(g)) continue;
    if (classes[i] == ReceiverClass::facing_away) {
      ++m.facing_away;
      sum_abs_away += std::abs(g - r);
      continue;
    }
    if (classes[i] != ReceiverClass::lit) continue;
    ++m.receivers;
    const double e = g - r;
    sum_abs += std::abs(e);
    sum_sq += e * e;
    if (!n_dot_l.empty()) {
      sum_weighted += std::abs(e) * n_dot_l[i];
      sum_weights += n_dot_l[i];
    }
    abs_errors.push_back(std::abs(e));
    if (g > r + t) ++false_light;
    if (g < r - t) ++false_shadow;
    if (!n_dot_l.empty()) {
      if (g > r + t) false_light_w += n_dot_l[i];
      if (g < r - t) false_shadow_w += n_dot_l[i];
    }
    if ((g >= 0.5) != (r >= 0.5)) ++wrong;
    if (r < 0.5) ++shadowed;
    if (r > 0.0 && r < 1.0) {
      ++partial;
      sum_se += std::isfinite(reference.std_error[i]) ? reference.std_error[i] : 0.0;
    }
  }
  const double n = double(m.receivers);
  if (m.receivers > 0) {
    m.mean_abs = sum_abs / n;
    m.mean_abs_lit = sum_weights > 0.0 ? sum_weighted / sum_weights : 0.0;
    m.rmse = std::sqrt(sum_sq / n);
    const size_t k = std::min(abs_errors.size() - 1,
                              static_cast<size_t>(std::ceil(0.99 * double(abs_errors.size()))) - 1);
    std::nth_element(abs_errors.begin(), abs_errors.begin() + long(k), abs_errors.end());
    m.p99_abs = abs_errors[k];
    m.false_light = double(false_light) / n;
    m.false_shadow = double(false_shadow) / n;
    m.false_light_lit = sum_weights > 0.0 ? false_light_w / sum_weights : 0.0;
    m.false_shadow_lit = sum_weights > 0.0 ? false_shadow_w / sum_weights : 0.0;
    m.misclassified = hard ? double(wrong) / n : std::numeric_limits<double>::quiet_NaN();
    m.reference_partial_fraction = double(partial) / n;
    m.reference_std_error = partial ? sum_se / double(partial) : 0.0;
    m.shadowed_fraction = double(shadowed) / n;
  } else {
    m.misclassified = std::numeric_limits<double>::quiet_NaN();
  }
  if (m.facing_away > 0) m.mean_abs_facing_away = sum_abs_away / double(m.facing_away);
  return m;
}

std::string Metrics::to_json() const {
  std::ostringstream s;
  s << "{\"light\": \"" << light << "\", \"hard\": " << (hard ? "true" : "false")
    << ", \"receivers\": " << receivers << ", \"facing_away\": " << facing_away
    << ", \"non_finite\": " << non_finite << ", \"mean_abs\": " << number(mean_abs)
    << ", \"mean_abs_lit\": " << number(mean_abs_lit) << ", \"rmse\": " << number(rmse)
    << ", \"p99_abs\": " << number(p99_abs) << ", \"false_light\": " << number(false_light)
    << ", \"false_shadow\": " << number(false_shadow)
    << ", \"false_light_lit\": " << number(false_light_lit)
    << ", \"false_shadow_lit\": " << number(false_shadow_lit)
    << ", \"misclassified\": " << number(misclassified)
    << ", \"mean_abs_facing_away\": " << number(mean_abs_facing_away)
    << ", \"reference_partial_fraction\": " << number(reference_partial_fraction)
    << ", \"reference_std_error\": " << number(reference_std_error)
    << ", \"shadowed_fraction\": " << number(shadowed_fraction) << "}";
  return s.str();
}

std::string Metrics::to_line() const {
  char b[512];
  std::snprintf(b, sizeof b,
                "%s: receivers %llu  mean|dV| %.4f (n.l-weighted %.4f)  rmse %.4f  p99 %.3f  "
                "false-light %.2f%%  false-shadow %.2f%%%s",
                light.c_str(), static_cast<unsigned long long>(receivers), mean_abs, mean_abs_lit,
                rmse, p99_abs, 100.0 * false_light, 100.0 * false_shadow,
                hard ? ("  misclassified " + number(100.0 * misclassified) + "%").c_str() : "");
  return b;
}

std::vector<uint8_t> visibility_image(std::span<const float> visibility,
                                      std::span<const ReceiverClass> classes,
                                      std::span<const uint8_t> frame_rgba) {
  check_size(visibility.size(), classes.size(), "the visibility");
  check_size(frame_rgba.size(), 4 * classes.size(), "the frame");
  std::vector<uint8_t> out(frame_rgba.size());
  for (size_t i = 0; i < classes.size(); ++i) {
    uint8_t g;
    if (classes[i] == ReceiverClass::lit && std::isfinite(visibility[i]))
      g = static_cast<uint8_t>(std::lround(std::clamp(double(visibility[i]), 0.0, 1.0) * 255.0));
    else
      g = static_cast<uint8_t>(grey_of(frame_rgba, i) / 4);
    out[4 * i] = out[4 * i + 1] = out[4 * i + 2] = g;
    out[4 * i + 3] = 255;
  }
  return out;
}

std::vector<uint8_t> error_image(std::span<const float> v, std::span<const float> reference,
                                 std::span<const ReceiverClass> classes,
                                 std::span<const uint8_t> frame_rgba) {
  check_size(v.size(), classes.size(), "the GPU visibility");
  check_size(reference.size(), classes.size(), "the reference");
  check_size(frame_rgba.size(), 4 * classes.size(), "the frame");
  std::vector<uint8_t> out(frame_rgba.size());
  const double too_dark[3] = {40, 110, 255}, too_light[3] = {255, 60, 20};
  for (size_t i = 0; i < classes.size(); ++i) {
    const double grey = 64.0 + 0.5 * grey_of(frame_rgba, i);
    double c[3] = {grey, grey, grey};
    const double e = double(v[i]) - double(reference[i]);
    if (classes[i] == ReceiverClass::lit && std::isfinite(e) && std::abs(e) >= 0.02) {
      const double a = std::min(1.0, std::abs(e) / 0.5);
      const double* hot = e < 0.0 ? too_dark : too_light;
      for (int k = 0; k < 3; ++k) c[k] = (1.0 - a) * grey + a * hot[k];
    }
    for (int k = 0; k < 3; ++k)
      out[4 * i + k] = static_cast<uint8_t>(std::clamp(std::lround(c[k]), 0l, 255l));
    out[4 * i + 3] = 255;
  }
  return out;
}

}  // namespace penumbra::reference
