// Measuring a rendered frame against the reference, and writing what people look at.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <limits>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <penumbra/reference/frame.hpp>
#include <penumbra/render/frame_pack.hpp>
#include <sstream>
#include <system_error>

namespace penumbra::reference {
namespace fs = std::filesystem;

uint32_t visibility_slot(const LightRef& l) {
  return l.kind == LightKind::sun    ? render::kSunVisibilitySlot
         : l.kind == LightKind::spot ? render::spot_visibility_slot(l.index)
                                     : render::point_visibility_slot(l.index);
}

double umbra_kept(const LightMeasurement& l, size_t* umbra_count, bool weighted) {
  size_t umbra = 0;
  double all = 0.0, kept = 0.0;
  for (size_t i = 0; i < l.classes.size(); ++i) {
    if (l.classes[i] != ReceiverClass::lit || !(l.reference.value[i] < 0.5f)) continue;
    ++umbra;
    const double w = weighted && i < l.n_dot_l.size() ? double(l.n_dot_l[i]) : 1.0;
    all += w;
    kept += l.gpu[i] < 0.5f ? w : 0.0;
  }
  if (umbra_count) *umbra_count = umbra;
  return all > 0.0 ? kept / all : 1.0;
}

std::vector<std::string> budget_violations(const LightMeasurement& l, const AccuracyBudget& b) {
  std::vector<std::string> out;
  auto check = [&](const char* what, double value, double bound, bool percent) {
    if (value <= bound) return;  // NaN fails too
    char line[160];
    if (percent)
      std::snprintf(line, sizeof line, "%s %.2f%% > %.2f%%", what, 100.0 * value, 100.0 * bound);
    else
      std::snprintf(line, sizeof line, "%s %.4f > %.4f", what, value, bound);
    out.push_back(line);
  };
  check("false light", l.metrics.false_light, b.false_light, true);
  check("false shadow", l.metrics.false_shadow, b.false_shadow, true);
  if (l.area.hard())
    check("misclassified", l.metrics.misclassified, b.misclassified, true);
  else
    check("mean |dV|", l.metrics.mean_abs, b.mean_abs, false);
  const double kept = umbra_kept(l);
  if (!(kept >= b.umbra_kept)) {
    char line[160];
    std::snprintf(line, sizeof line, "umbra kept %.1f%% < %.1f%% (lost shadows)", 100.0 * kept,
                  100.0 * b.umbra_kept);
    out.push_back(line);
  }
  return out;
}

std::vector<float> light_texel_sizes(const scene::Scene& scene, const LightRef& light,
                                     const Receivers& receivers, uint32_t width, uint32_t height,
                                     std::span<const float> shadow_info) {
  const size_t n = receivers.size();
  std::vector<float> out(n, std::numeric_limits<float>::quiet_NaN());
  render::FrameCaps caps;
  caps.sun_shadows = bool(scene.sun);
  caps.spot_shadow_maps = render::kMaxSpotLights;
  caps.point_shadow_cubes = render::kMaxPointLights;
  const render::PackedFrame pf = render::pack_frame(scene, width, height, caps, 0);
  if (light.kind == LightKind::sun) {
    if (!scene.sun || shadow_info.size() < 4 * n) return out;
    const auto& cascades = pf.cascades.cascades;
    for (size_t i = 0; i < n; ++i) {
      const float c = shadow_info[4 * i + 1];
      if (c >= 0.0f && size_t(c) < cascades.size())
        out[i] = float(cascades[size_t(c)].texel_world_size);
    }
    return out;
  }
  // The light's map among the shadowed lights of its kind (lights without shadows have none).
  auto map_index = [&](const auto& lights) -> int {
    if (light.index >= lights.size() || !lights[light.index].shadows) return -1;
    int k = 0;
    for (uint32_t j = 0; j < light.index; ++j) k += lights[j].shadows ? 1 : 0;
    return k;
  };
  auto perspective = [&](const glm::dvec3& position, double p00, uint32_t resolution,
                         auto&& depth_of) {
    for (size_t i = 0; i < n; ++i) {
      if (!receivers.valid[i]) continue;
      const double z = depth_of(receivers.origin + receivers.position[i] - position);
      if (z > 0.0) out[i] = float(2.0 * z / (double(resolution) * p00));
    }
  };
  if (light.kind == LightKind::spot) {
    const int k = map_index(scene.spots);
    if (k < 0 || size_t(k) >= pf.spot_shadows.size()) return out;
    const shadow::SpotShadow& s = pf.spot_shadows[size_t(k)];
    perspective(s.position, s.projection[0][0], s.resolution,
                [&](const glm::dvec3& d) { return glm::dot(d, s.basis.z); });
  } else {
    const int k = map_index(scene.points);
    if (k < 0 || size_t(k) >= pf.point_shadows.size()) return out;
    const shadow::PointShadow& p = pf.point_shadows[size_t(k)];
    perspective(p.position, p.projection[0][0], p.resolution, [](const glm::dvec3& d) {
      return std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)});
    });
  }
  return out;
}

FrameMeasurement measure_frame(render::Renderer& renderer, const MeasureOptions& options) {
  const scene::Scene& scene = renderer.scene();
  FrameMeasurement m;
  m.width = renderer.width();
  m.height = renderer.height();
  m.lit = renderer.read_rgba8();
  const render::GBuffer g = renderer.read_gbuffer();
  m.receivers = receivers_from_gbuffer(g.width, g.height, g.depth, g.normal_view, g.camera.view,
                                       g.camera.proj, g.camera.origin);
  // The lights asked for (all when none is named); an unknown name is an error listing them.
  const std::vector<LightRef> all = scene_lights(scene);
  std::vector<LightRef> lights = options.lights.empty() ? all : std::vector<LightRef>{};
  for (const auto& name : options.lights) {
    const auto it =
        std::find_if(all.begin(), all.end(), [&](const LightRef& l) { return l.name() == name; });
    if (it == all.end()) {
      std::string have;
      for (const auto& l : all) have += (have.empty() ? "" : ", ") + l.name();
      throw Error("reference: scene '" + scene.name + "' has no light '" + name +
                  "' (it has: " + (have.empty() ? "none" : have) + ")");
    }
    if (std::none_of(lights.begin(), lights.end(),
                     [&](const LightRef& l) { return l.name() == name; }))
      lights.push_back(*it);
  }
  const Tracer tracer(scene, g.camera.origin);
  m.triangles = tracer.triangle_count();
  std::vector<float> shadow_info;  // read once, for the sun's cascade per pixel
  for (const auto& l : lights) {
    if ((l.kind == LightKind::spot && l.index >= render::kMaxSpotLights) ||
        (l.kind == LightKind::point && l.index >= render::kMaxPointLights))
      continue;  // the renderer draws at most kMax… lights of a kind
    LightMeasurement lm;
    lm.light = l;
    lm.area = area_light(scene, l);
    TraceOptions t = options.trace;
    t.progress_label = "reference " + l.name();
    // Only the receivers this light reaches are traced (outside a spot's cone or a light's
    // range its visibility does not show in the frame).
    lm.classes = classify_receivers(m.receivers, scene, l, &lm.n_dot_l);
    Receivers reached = m.receivers;
    for (size_t i = 0; i < reached.size(); ++i)
      if (lm.classes[i] == ReceiverClass::none) reached.valid[i] = 0;
    lm.reference = options.cache_dir ? trace_cached(tracer, reached, lm.area, t, *options.cache_dir)
                                     : tracer.trace(reached, lm.area, t);
    lm.gpu = renderer.read_visibility(visibility_slot(l));
    lm.metrics = compute_metrics(lm.gpu, lm.reference, lm.classes, lm.area.hard(), options.metrics,
                                 lm.n_dot_l);
    lm.metrics.light = l.name();
    if (options.failure_modes) {
      if (shadow_info.empty()) shadow_info = renderer.read_shadow_info();
      lm.texel_world = light_texel_sizes(scene, l, m.receivers, m.width, m.height, shadow_info);
      // The filter's reach at each receiver: its texels times the texel's world size there.
      std::optional<scene::Filter> own;
      if (l.kind == LightKind::spot) own = scene.spots[l.index].filter;
      if (l.kind == LightKind::point) own = scene.points[l.index].filter;
      const double reach_texels =
          scene::filter_reach_texels(own.value_or(scene.shadows.filter), scene.shadows);
      std::vector<float> reach(lm.texel_world.size());
      for (size_t i = 0; i < reach.size(); ++i)
        reach[i] = float(reach_texels * double(lm.texel_world[i]));
      lm.probe = probe_casters(tracer, reached, lm.area, reach, 8, options.trace.threads);
      lm.failure = compute_failure_modes(lm.gpu, lm.reference, lm.classes, lm.probe, lm.texel_world,
                                         m.receivers.width, options.failure, &lm.modes);
      lm.has_failure_modes = true;
    }
    m.lights.push_back(std::move(lm));
  }
  return m;
}

std::vector<fs::path> write_measurement(const FrameMeasurement& m, const fs::path& dir,
                                        const std::string& json_header, bool images) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error("cannot create " + dir.string() + ": " + ec.message());
  std::vector<fs::path> written;
  // The images are made only when written (each is a pass over the frame).
  auto png = [&](const std::string& name, const auto& make) {
    if (!images) return;
    render::write_png(dir / name, m.width, m.height, make());
    written.push_back(dir / name);
  };
  png("lit.png", [&] { return m.lit; });
  const bool suffix = m.lights.size() > 1;
  std::string lights_json;
  for (const auto& l : m.lights) {
    const std::string s = suffix ? "-" + l.light.name() : "";
    png("reference" + s + ".png",
        [&] { return visibility_image(l.reference.value, l.classes, m.lit); });
    png("visibility" + s + ".png", [&] { return visibility_image(l.gpu, l.classes, m.lit); });
    png("error" + s + ".png",
        [&] { return error_image(l.gpu, l.reference.value, l.classes, m.lit); });
    if (l.has_failure_modes)
      png("modes" + s + ".png", [&] { return failure_mode_image(l.modes, m.lit); });
    std::string j = l.metrics.to_json();
    j.pop_back();  // add the tracer's numbers to the light's object
    if (l.has_failure_modes) j += ", " + l.failure.to_json();
    j += ", \"umbra_kept\": " + std::to_string(umbra_kept(l)) +
         ", \"umbra_kept_lit\": " + std::to_string(umbra_kept(l, nullptr, true)) +
         ", \"rays\": " + std::to_string(l.reference.rays) +
         ", \"trace_seconds\": " + std::to_string(l.reference.seconds) +
         ", \"from_cache\": " + (l.reference.from_cache ? "true" : "false") + "}";
    lights_json += (lights_json.empty() ? "\n    " : ",\n    ") + j;
  }
  // Geometry pixels the frame shows black (every channel <= 1/255): no light, not even the
  // ambient, reaches them: what a NaN in the lighting or a broken pass leaves.
  uint64_t geometry = 0, black = 0;
  for (size_t i = 0; i < m.receivers.valid.size() && i * 4 + 2 < m.lit.size(); ++i) {
    if (!m.receivers.valid[i]) continue;
    ++geometry;
    black += m.lit[i * 4] <= 1 && m.lit[i * 4 + 1] <= 1 && m.lit[i * 4 + 2] <= 1;
  }
  const fs::path json = dir / "metrics.json";
  std::ostringstream out;
  out << "{\n  " << json_header << (json_header.empty() ? "" : ",\n  ") << "\"width\": " << m.width
      << ", \"height\": " << m.height << ", \"triangles\": " << m.triangles
      << ", \"geometry_pixels\": " << geometry << ", \"black_pixels\": " << black
      << ", \"rejected_pixels\": " << m.receivers.rejected << ",\n  \"lights\": [" << lights_json
      << "\n  ]\n}\n";
  write_file_atomic(json, out.str());
  written.push_back(json);
  return written;
}

}  // namespace penumbra::reference
