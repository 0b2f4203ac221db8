#include "truth.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <penumbra/core/stats.hpp>
#include <penumbra/reference/metrics.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/scene/params.hpp>

namespace penumbra::runtime {
namespace {

std::string format(const char* fmt, double a, double b = 0.0, double c = 0.0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, fmt, a, b, c);
  return buf;
}

// Frames along a --truth-flicker path (penumbra-tune's path length).
constexpr std::uint32_t kFlickerFrames = 8;

std::string flicker_text(const TruthLight& l) {
  return std::isfinite(l.flicker) ? format(", flicker %.2f%%, path error %.5f",
                                           100.0 * l.flicker, l.path_error)
                                  : std::string();
}

std::string flicker_delta(const TruthLight& b, const TruthLight& a) {
  if (!std::isfinite(a.flicker) || !std::isfinite(b.flicker)) return "";
  return format(", flicker %.2f -> %.2f%%", 100.0 * b.flicker, 100.0 * a.flicker) +
         format(", path error %.5f -> %.5f", b.path_error, a.path_error);
}

std::string gap_text(double texels) {
  return std::isfinite(texels) ? format("%.2f", texels) : std::string("none");
}

}  // namespace

TruthSnapshot measure_truth(Session& session, std::uint32_t frames,
                            const reference::MeasureOptions& options,
                            const std::optional<reference::CameraPath>& path) {
  render::Renderer& renderer = session.renderer();
  TruthSnapshot s;
  std::vector<double> totals;
  std::map<std::string, std::vector<double>> passes;
  // No warm-up frame: the session has rendered the reload's first frame already.
  for (std::uint32_t f = 0; f < frames; ++f) {
    renderer.render(0);
    double total = 0.0;
    for (const auto& t : renderer.timings()) {
      passes[t.name].push_back(t.gpu_ms);
      total += t.gpu_ms;
    }
    totals.push_back(total);
  }
  s.frame_ms = stats::median(totals);
  s.spread_ms = 0.5 * (stats::quantile(totals, 0.75) - stats::quantile(totals, 0.25));
  for (auto& [name, v] : passes) s.pass_ms[name] = stats::median(v);
  // The measured frame: fresh history, frame 0, as penumbra-reference measures a still frame.
  renderer.reset_history();
  renderer.render(0);
  const reference::FrameMeasurement m = reference::measure_frame(renderer, options);
  s.pixels = m.lit;
  s.width = m.width;
  s.height = m.height;
  for (const std::string& key : scene::scene_keys(renderer.scene(), false))
    s.settings.push_back(key + "=" + scene::get_param(renderer.scene(), key));
  std::sort(s.settings.begin(), s.settings.end());
  for (const auto& l : m.lights) {
    s.heat.push_back(reference::error_image(l.gpu, l.reference.value, l.classes, m.lit));
    TruthLight t;
    t.name = l.light.name();
    t.mean_abs = l.metrics.mean_abs;
    t.false_light = l.metrics.false_light;
    t.false_shadow = l.metrics.false_shadow;
    t.acne = l.has_failure_modes ? l.failure.acne : 0.0;
    t.gap_texels = l.has_failure_modes ? l.failure.contact_gap_texels : std::nan("");
    s.lights.push_back(t);
  }
  if (path) {
    reference::FlickerOptions fo;
    fo.frames = kFlickerFrames;
    fo.truth = options.trace;
    fo.cache_dir = options.cache_dir;
    for (const auto& f : reference::measure_flicker(renderer, *path, fo))
      for (auto& t : s.lights)
        if (t.name == f.light) {
          t.flicker = f.excess_fraction();
          t.path_error = f.path_mean_abs_error;
        }
    renderer.reset_history();
  }
  return s;
}

std::vector<std::string> truth_lines(const TruthSnapshot& now) {
  std::vector<std::string> out;
  out.push_back(format("[truth] GPU %.3f ms per frame (spread %.3f)", now.frame_ms,
                       now.spread_ms));
  for (const auto& l : now.lights)
    out.push_back("[truth] " + l.name +
                  format(": mean |dV| %.5f, false light %.3f%%, false shadow %.3f%%",
                         l.mean_abs, 100.0 * l.false_light, 100.0 * l.false_shadow) +
                  format(", acne %.3f%%, gap ", 100.0 * l.acne) + gap_text(l.gap_texels) +
                  " texels" + flicker_text(l));
  return out;
}

std::vector<std::string> changed_settings(const TruthSnapshot& before, const TruthSnapshot& after) {
  std::vector<std::string> gone, changed;
  std::set_symmetric_difference(before.settings.begin(), before.settings.end(),
                                after.settings.begin(), after.settings.end(),
                                std::back_inserter(gone));
  for (const std::string& entry : gone) {
    const std::string key = entry.substr(0, entry.find('='));
    if (changed.empty() || changed.back() != key) changed.push_back(key);
  }
  changed.erase(std::unique(changed.begin(), changed.end()), changed.end());
  return changed;
}

bool gpu_change_is_noise(const TruthSnapshot& before, const TruthSnapshot& after) {
  // Within the two snapshots' spreads, or under 3% of the frame (lavapipe's frames vary by a
  // few percent between snapshots seconds apart, more than within one).
  return std::abs(after.frame_ms - before.frame_ms) <=
         std::max(before.spread_ms + after.spread_ms, 0.03 * before.frame_ms);
}

std::vector<std::string> truth_lines(const TruthSnapshot& before, const TruthSnapshot& after) {
  std::vector<std::string> out;
  const double dms = after.frame_ms - before.frame_ms;
  const bool noise = gpu_change_is_noise(before, after);
  if (const auto changed = changed_settings(before, after); !changed.empty()) {
    std::string keys;
    for (const auto& k : changed) keys += (keys.empty() ? "" : ", ") + k;
    out.push_back("[truth] the view changed since the last snapshot (" + keys +
                  "): these deltas compare two views, not only the edit");
  }
  out.push_back(format("[truth] GPU %.3f -> %.3f ms per frame", before.frame_ms, after.frame_ms) +
                format(" (%+.3f ms, spread %.3f / %.3f)", dms, before.spread_ms,
                       after.spread_ms) +
                (noise ? ": within the noise" : ""));
  for (const auto& [name, ms] : after.pass_ms) {
    const auto it = before.pass_ms.find(name);
    // Passes that moved by more than 2% (the frame's line above says whether it is noise).
    if (it == before.pass_ms.end() || std::abs(ms - it->second) <= 0.02 * it->second) continue;
    out.push_back("[truth]   " + name + format(" %.3f -> %.3f ms", it->second, ms));
  }
  for (const auto& a : after.lights) {
    const TruthLight* b = nullptr;
    for (const auto& x : before.lights)
      if (x.name == a.name) b = &x;
    if (b == nullptr) continue;
    out.push_back("[truth] " + a.name +
                  format(": mean |dV| %.5f -> %.5f (%+.5f)", b->mean_abs, a.mean_abs,
                         a.mean_abs - b->mean_abs) +
                  format(", false light %.3f -> %.3f%%", 100.0 * b->false_light,
                         100.0 * a.false_light) +
                  format(", false shadow %.3f -> %.3f%%", 100.0 * b->false_shadow,
                         100.0 * a.false_shadow) +
                  format(", acne %.3f -> %.3f%%", 100.0 * b->acne, 100.0 * a.acne) +
                  ", gap " + gap_text(b->gap_texels) + " -> " + gap_text(a.gap_texels) +
                  " texels" + flicker_delta(*b, a));
  }
  out.push_back(after.pixels == before.pixels ? "[truth] image: bit-identical to before"
                                              : "[truth] image: changed");
  return out;
}

std::vector<std::string> truth_since(const TruthSnapshot& start, const TruthSnapshot& now) {
  std::string line = format("[truth] since the start: GPU %+.3f ms", now.frame_ms - start.frame_ms);
  for (const auto& a : now.lights)
    for (const auto& b : start.lights)
      if (a.name == b.name)
        line += ", " + a.name + format(" mean |dV| %+.5f", a.mean_abs - b.mean_abs);
  line += now.pixels == start.pixels ? "; image bit-identical to the start"
                                     : "; image changed since the start";
  if (!changed_settings(start, now).empty()) line += " (the view changed since then)";
  return {line};
}

}  // namespace penumbra::runtime
