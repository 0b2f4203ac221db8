// Extremes: kilometres from the origin, lights at the poles, tiny near planes, huge ranges.
// Measured maxima are printed (and recorded as test properties) for docs/cascades.md.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <penumbra/shadow/shadow.hpp>
#include <random>
#include <string>
#include <vector>

#include "shadow_test_util.hpp"

namespace penumbra::shadow {
namespace {

using test::default_camera;
using test::default_light;
using test::default_scene;
using test::fractional_distance;
using test::frustum_point;
using test::texel_coord;

void report(const std::string& key, double value) {
  std::printf("[ measured ] %s = %.3g\n", key.c_str(), value);
  testing::Test::RecordProperty(key, std::to_string(value));
}

const char* fit_name(CascadeFit fit) {
  switch (fit) {
    case CascadeFit::box:
      return "box";
    case CascadeFit::camera_sphere:
      return "camera_sphere";
    case CascadeFit::slice_sphere:
      return "slice_sphere";
  }
  return "?";
}

// 10k random camera translations (within +-25 m) around `origin`; 16 fixed world points near
// it. The double matrices are checked for every point and cascade; the float GPU matrices
// (pack_shadow with the render origin at the camera, positions made camera-relative in double
// and then rounded to float, as a camera-relative renderer does) for the points inside the
// cascade.
struct Drift {
  double cpu = 0.0;
  double gpu = 0.0;
  long gpu_samples = 0;
};

Drift snapping_drift(CascadeFit fit, const glm::dvec3& origin, int trials, std::uint64_t seed) {
  ShadowConfig config;
  config.fit = fit;
  const DirectionalLight light = default_light();
  const Aabb scene = default_scene(origin);
  std::mt19937_64 rng(seed);
  std::vector<glm::dvec3> points;
  for (int i = 0; i < 16; ++i) points.push_back(origin + test::uniform3(rng, -25.0, 25.0));
  const Camera base = default_camera(origin + glm::dvec3(0.0, 2.0, 0.0));
  const CascadeSet reference = compute_cascades(config, base, light, scene);
  const ShadowGpu reference_gpu = pack_shadow(reference, base.position);
  const std::size_t n = reference.cascades.size();
  std::vector<glm::dvec2> ref_cpu(n * points.size());
  std::vector<glm::dvec2> ref_gpu(n * points.size());
  for (std::size_t c = 0; c < n; ++c) {
    for (std::size_t k = 0; k < points.size(); ++k) {
      ref_cpu[c * points.size() + k] =
          texel_coord(reference.cascades[c].view_proj, points[k], reference.resolution);
      ref_gpu[c * points.size() + k] = test::texel_coord_gpu(
          reference_gpu.cascades[c].view_proj, points[k], base.position, reference.resolution);
    }
  }
  Drift drift;
  const double res = static_cast<double>(reference.resolution);
  for (int t = 0; t < trials; ++t) {
    Camera camera = base;
    camera.position += test::uniform3(rng, -25.0, 25.0);
    const CascadeSet set = compute_cascades(config, camera, light, scene);
    const ShadowGpu gpu = pack_shadow(set, camera.position);
    for (std::size_t c = 0; c < n; ++c) {
      for (std::size_t k = 0; k < points.size(); ++k) {
        const glm::dvec2 a = texel_coord(set.cascades[c].view_proj, points[k], set.resolution);
        const glm::dvec2 b = ref_cpu[c * points.size() + k];
        drift.cpu =
            std::max({drift.cpu, fractional_distance(a.x, b.x), fractional_distance(a.y, b.y)});
        const glm::dvec2 g = test::texel_coord_gpu(gpu.cascades[c].view_proj, points[k],
                                                   camera.position, set.resolution);
        const glm::dvec2 h = ref_gpu[c * points.size() + k];
        const bool inside = g.x >= 0 && g.y >= 0 && g.x <= res && g.y <= res && h.x >= 0 &&
                            h.y >= 0 && h.x <= res && h.y <= res;
        if (inside) {
          ++drift.gpu_samples;
          drift.gpu =
              std::max({drift.gpu, fractional_distance(g.x, h.x), fractional_distance(g.y, h.y)});
        }
      }
    }
  }
  return drift;
}

TEST(Extremes, SnappingInvariantFarFromOrigin) {
  for (const double distance : {0.0, 1e3, 1e4}) {
    for (const CascadeFit fit :
         {CascadeFit::box, CascadeFit::camera_sphere, CascadeFit::slice_sphere}) {
      SCOPED_TRACE(testing::Message() << fit_name(fit) << " at " << distance << " m");
      // Off the axes, so that every coordinate is large.
      const glm::dvec3 origin = distance * glm::normalize(glm::dvec3(1.0, 0.05, -0.8));
      const Drift d =
          snapping_drift(fit, origin, 10000, 1000 + static_cast<std::uint64_t>(distance));
      const std::string key = std::string("drift_") + fit_name(fit) + "_" +
                              std::to_string(static_cast<int>(distance)) + "m";
      report(key + "_cpu_texels", d.cpu);
      report(key + "_gpu_texels", d.gpu);
      EXPECT_LT(d.cpu, 1e-3);
      EXPECT_GT(d.gpu_samples, 10000);
      EXPECT_LT(d.gpu, 1e-3);
    }
  }
}

TEST(Extremes, RenderOriginKeepsFloatMatricesAccurateAt10km) {
  // Why pack_shadow takes a render origin. With absolute world coordinates at 10 km the float
  // path is still stable (snapping moves the float translation by exactly representable steps,
  // so the drift stays below 1e-3 texel), but it is inaccurate: the texel coordinate is off the
  // double-precision value by a large fraction of a texel. Camera-relative data fixes that.
  ShadowConfig config;
  const glm::dvec3 origin = 1e4 * glm::normalize(glm::dvec3(1.0, 0.05, -0.8));
  const Camera base = default_camera(origin + glm::dvec3(0, 2, 0));
  const Aabb scene = default_scene(origin);
  const CascadeSet reference = compute_cascades(config, base, default_light(), scene);
  const ShadowGpu ref_abs = pack_shadow(reference, glm::dvec3(0.0));
  std::mt19937_64 rng(3);
  double drift_abs = 0.0;
  double error_abs = 0.0;
  double error_rel = 0.0;
  for (int t = 0; t < 2000; ++t) {
    Camera camera = base;
    camera.position += test::uniform3(rng, -2.0, 2.0);
    const CascadeSet set = compute_cascades(config, camera, default_light(), scene);
    const ShadowGpu abs_gpu = pack_shadow(set, glm::dvec3(0.0));
    const ShadowGpu rel_gpu = pack_shadow(set, camera.position);
    const glm::dvec3 p = frustum_point(camera, test::uniform(rng, 1.0, 8.0),
                                       test::uniform(rng, -1, 1), test::uniform(rng, -1, 1));
    const glm::dvec2 exact = texel_coord(set.cascades[0].view_proj, p, 2048);
    const glm::dvec2 a =
        test::texel_coord_gpu(abs_gpu.cascades[0].view_proj, p, glm::dvec3(0.0), 2048);
    const glm::dvec2 b =
        test::texel_coord_gpu(ref_abs.cascades[0].view_proj, p, glm::dvec3(0.0), 2048);
    const glm::dvec2 r =
        test::texel_coord_gpu(rel_gpu.cascades[0].view_proj, p, camera.position, 2048);
    drift_abs = std::max({drift_abs, fractional_distance(a.x, b.x), fractional_distance(a.y, b.y)});
    error_abs = std::max({error_abs, std::abs(a.x - exact.x), std::abs(a.y - exact.y)});
    error_rel = std::max({error_rel, std::abs(r.x - exact.x), std::abs(r.y - exact.y)});
  }
  report("drift_absolute_float_10km_texels", drift_abs);
  report("error_absolute_float_10km_texels", error_abs);
  report("error_render_origin_float_10km_texels", error_rel);
  EXPECT_LT(drift_abs, 1e-3);
  EXPECT_GT(error_abs, 1e-2);
  EXPECT_LT(error_rel, 2e-3);
}

void check_basis(const glm::dvec3& d, double* worst) {
  const Basis b = orthonormal_basis(d);
  const glm::dvec3 n = d / glm::length(d);
  const double e = std::max({std::abs(glm::length(b.x) - 1.0), std::abs(glm::length(b.y) - 1.0),
                             std::abs(glm::length(b.z) - 1.0), std::abs(glm::dot(b.x, b.y)),
                             std::abs(glm::dot(b.x, b.z)), std::abs(glm::dot(b.y, b.z)),
                             glm::length(glm::cross(b.x, b.y) - b.z), glm::length(b.z - n)});
  *worst = std::max(*worst, e);
  ASSERT_LT(e, 1e-12) << d.x << " " << d.y << " " << d.z;
}

TEST(Extremes, BasisOrthonormalEverywhere) {
  std::mt19937_64 rng(101);
  double worst = 0.0;
  for (int i = 0; i < 100000; ++i) check_basis(test::random_direction(rng), &worst);
  report("basis_error_random", worst);
  double worst_pole = 0.0;
  check_basis(glm::dvec3(0, 1, 0), &worst_pole);
  check_basis(glm::dvec3(0, -1, 0), &worst_pole);
  // Within 1e-6 rad (and much less) of +-up, all around.
  for (const double eps : {1e-6, 3e-7, 1e-9, 1e-12, 1e-15, 1e-300}) {
    for (int k = 0; k < 64; ++k) {
      const double phi = 2.0 * std::numbers::pi * k / 64.0;
      for (const double sign : {1.0, -1.0}) {
        check_basis(glm::dvec3(std::sin(eps) * std::cos(phi), sign * std::cos(eps),
                               std::sin(eps) * std::sin(phi)),
                    &worst_pole);
      }
    }
  }
  report("basis_error_near_poles", worst_pole);
}

TEST(Extremes, TinyNearHugeFar) {
  Camera camera = default_camera();
  camera.near = 1e-4;
  camera.far = 1e6;
  Aabb scene{glm::dvec3(-1e6, -100.0, -1e6), glm::dvec3(1e6, 9000.0, 1e6)};
  for (const CascadeFit fit :
       {CascadeFit::box, CascadeFit::camera_sphere, CascadeFit::slice_sphere}) {
    for (const double lambda : {0.0, 0.5, 1.0}) {
      for (const std::uint32_t count : {1u, 4u, 8u}) {
        SCOPED_TRACE(testing::Message()
                     << fit_name(fit) << " lambda " << lambda << " count " << count);
        ShadowConfig config;
        config.fit = fit;
        config.cascade_count = count;
        config.split_lambda = lambda;
        config.max_distance = 1e6;
        const CascadeSet set = compute_cascades(config, camera, default_light(), scene);
        ASSERT_EQ(set.splits.size(), count + 1);
        EXPECT_EQ(set.splits.front(), 1e-4);
        EXPECT_EQ(set.splits.back(), 1e6);
        for (std::size_t i = 1; i < set.splits.size(); ++i) {
          EXPECT_LT(set.splits[i - 1], set.splits[i]);
        }
        for (const Cascade& c : set.cascades) {
          ASSERT_TRUE(is_finite(c.view_proj));
          EXPECT_GT(c.texel_world_size, 0.0);
          for (const double d : {c.fit_near, 0.5 * (c.fit_near + c.fit_far), c.fit_far}) {
            for (const double s : {-1.0, 1.0}) {
              const glm::dvec3 ndc = project_point(c.view_proj, frustum_point(camera, d, s, -s));
              EXPECT_LE(std::abs(ndc.x), 1.0);
              EXPECT_LE(std::abs(ndc.y), 1.0);
              EXPECT_GE(ndc.z, 0.0);
              EXPECT_LE(ndc.z, 1.0);
            }
          }
        }
        const ShadowGpu gpu = pack_shadow(set, camera.position);
        for (std::uint32_t c = 0; c < count; ++c) {
          for (int i = 0; i < 4; ++i) {
            for (int j = 0; j < 4; ++j) {
              EXPECT_TRUE(std::isfinite(gpu.cascades[c].view_proj[i][j]));
            }
          }
        }
      }
    }
  }
}

TEST(Extremes, DegenerateButValidCameras) {
  // Very narrow and very wide fields of view, extreme aspect ratios, light along the view
  // axis, a flat scene edge-on to the light: every matrix finite, every slice contained.
  struct Variant {
    double fov;
    double aspect;
    glm::dvec3 light;
  };
  const Variant variants[] = {
      {1e-4, 1.0, {0.35, -1, 0.25}}, {3.1, 1.0, {0.35, -1, 0.25}},   {1.0, 1e-3, {0, -1, 0}},
      {1.0, 1e3, {0, 1, 0}},         {1.0, 1.0, {0.6, -0.2, -0.77}}, {1.0, 1.0, {1, 0, 0}},
  };
  Aabb flat = default_scene();
  flat.max.y = flat.min.y;
  for (const Variant& v : variants) {
    for (const CascadeFit fit :
         {CascadeFit::box, CascadeFit::camera_sphere, CascadeFit::slice_sphere}) {
      Camera camera = default_camera();
      camera.fov_y = v.fov;
      camera.aspect = v.aspect;
      DirectionalLight light;
      light.direction = v.light;
      ShadowConfig config;
      config.fit = fit;
      const CascadeSet set = compute_cascades(config, camera, light, flat);
      for (const Cascade& c : set.cascades) {
        ASSERT_TRUE(is_finite(c.view_proj));
        for (const double d : {c.fit_near, c.fit_far}) {
          const glm::dvec3 ndc = project_point(c.view_proj, frustum_point(camera, d, 1.0, 1.0));
          EXPECT_LE(std::abs(ndc.x), 1.0);
          EXPECT_LE(std::abs(ndc.y), 1.0);
          EXPECT_GE(ndc.z, 0.0);
          EXPECT_LE(ndc.z, 1.0);
        }
      }
    }
  }
  // The clipmap of a flat scene with the light in its plane still has a depth range.
  DirectionalLight sideways;
  sideways.direction = glm::dvec3(1, 0, 0);
  Aabb wall = default_scene();
  wall.max.x = wall.min.x;
  const CascadeSet clip = compute_clipmap(ClipmapConfig{}, glm::dvec3(0.0), sideways, wall);
  for (const Cascade& c : clip.cascades) EXPECT_TRUE(is_finite(c.view_proj));
}

TEST(Extremes, ClipmapSnappingAt10km) {
  ClipmapConfig config;
  config.level_count = 8;
  const glm::dvec3 origin(7071.0, 120.0, -7071.0);
  std::mt19937_64 rng(5);
  const CascadeSet reference =
      compute_clipmap(config, origin, default_light(), default_scene(origin));
  std::vector<glm::dvec3> points;
  for (int i = 0; i < 16; ++i) points.push_back(origin + test::uniform3(rng, -10.0, 10.0));
  double drift = 0.0;
  for (int t = 0; t < 2000; ++t) {
    const CascadeSet set = compute_clipmap(config, origin + test::uniform3(rng, -40.0, 40.0),
                                           default_light(), default_scene(origin));
    for (std::size_t c = 0; c < set.cascades.size(); ++c) {
      for (const glm::dvec3& p : points) {
        const glm::dvec2 a = texel_coord(set.cascades[c].view_proj, p, set.resolution);
        const glm::dvec2 b = texel_coord(reference.cascades[c].view_proj, p, set.resolution);
        drift = std::max({drift, fractional_distance(a.x, b.x), fractional_distance(a.y, b.y)});
      }
    }
  }
  report("drift_clipmap_10km_texels", drift);
  EXPECT_LT(drift, 1e-3);
}

TEST(Extremes, DistantStarOverAsteroids) {
  // A star 1.5e8 km away (1 AU) lighting a field 3 km across: still finite, the range spans the
  // field.
  Camera camera;
  camera.position = glm::dvec3(0.0);
  camera.forward = glm::dvec3(0.0, 0.0, 1.0);
  camera.far = 1e4;
  std::vector<Aabb> field;
  std::mt19937_64 rng(7);
  for (int i = 0; i < 200; ++i) {
    const glm::dvec3 c(test::uniform(rng, -1500, 1500), test::uniform(rng, -1500, 1500),
                       test::uniform(rng, 100, 3000));
    field.push_back(Aabb{c - 5.0, c + 5.0});
  }
  const glm::dvec3 star(1.5e11, 2e10, 0.0);
  const PointShadow s = fit_point_shadow(star, camera, 5000.0, field, {});
  for (const glm::dmat4& m : s.face_view_proj) EXPECT_TRUE(is_finite(m));
  EXPECT_NE(s.face_mask, 0u);
  EXPECT_LT(s.depth_far - s.depth_near, 6000.0);
  const PointShadowGpu gpu = pack_point_shadow(s, camera.position);
  EXPECT_TRUE(std::isfinite(gpu.depth_range.z));
  report("star_depth_range_m", s.depth_far - s.depth_near);
}

}  // namespace
}  // namespace penumbra::shadow
