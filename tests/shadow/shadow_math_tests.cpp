// Shadow math: splits, basis, projections, cascade fitting, snapping, clipmaps, spot and point
// lights, GPU packing. Heavier sweeps live in shadow_extremes_tests.cpp.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
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

constexpr CascadeFit kFits[] = {CascadeFit::box, CascadeFit::camera_sphere,
                                CascadeFit::slice_sphere};
constexpr DepthConvention kDepths[] = {DepthConvention::reverse_z, DepthConvention::standard};

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

// ---------------------------------------------------------------------------------------------
// Splits

TEST(Splits, MonotoneFirstIsNearLastIsFarExactly) {
  for (const double lambda : {0.0, 0.25, 0.5, 0.75, 1.0}) {
    for (std::uint32_t count = 1; count <= kMaxCascades; ++count) {
      for (const auto& [near, far] : {std::pair{0.1, 150.0}, std::pair{0.5, 80.0},
                                      std::pair{0.01, 3333.3}, std::pair{1.0, 1.5}}) {
        SCOPED_TRACE(testing::Message() << "lambda " << lambda << " count " << count);
        const std::vector<double> s = pssm_splits(near, far, count, lambda);
        ASSERT_EQ(s.size(), count + 1);
        EXPECT_EQ(s.front(), near);
        EXPECT_EQ(s.back(), far);
        for (std::size_t i = 1; i < s.size(); ++i) EXPECT_LT(s[i - 1], s[i]);
      }
    }
  }
}

TEST(Splits, LambdaZeroIsUniformLambdaOneIsLogarithmic) {
  const std::vector<double> uniform = pssm_splits(1.0, 101.0, 4, 0.0);
  EXPECT_DOUBLE_EQ(uniform[1], 26.0);
  EXPECT_DOUBLE_EQ(uniform[2], 51.0);
  EXPECT_DOUBLE_EQ(uniform[3], 76.0);
  const std::vector<double> log = pssm_splits(1.0, 10000.0, 4, 1.0);
  EXPECT_NEAR(log[1], 10.0, 1e-12);
  EXPECT_NEAR(log[2], 100.0, 1e-11);
  EXPECT_NEAR(log[3], 1000.0, 1e-10);
  const std::vector<double> mixed = pssm_splits(1.0, 10000.0, 4, 0.5);
  EXPECT_NEAR(mixed[2], 0.5 * 100.0 + 0.5 * (1.0 + 9999.0 * 0.5), 1e-9);
}

TEST(Splits, FarEndClampedToMaxDistanceOrCameraFar) {
  ShadowConfig config;
  config.max_distance = 150.0;
  Camera camera = default_camera();
  camera.far = 1000.0;
  CascadeSet set = compute_cascades(config, camera, default_light(), default_scene());
  EXPECT_EQ(set.splits.back(), 150.0);
  EXPECT_EQ(set.cascades.back().fit_far, 150.0);
  camera.far = 60.0;
  set = compute_cascades(config, camera, default_light(), default_scene());
  EXPECT_EQ(set.splits.back(), 60.0);
  camera.far = std::numeric_limits<double>::infinity();
  set = compute_cascades(config, camera, default_light(), default_scene());
  EXPECT_EQ(set.splits.back(), 150.0);
  EXPECT_EQ(set.splits.front(), camera.near);
}

// ---------------------------------------------------------------------------------------------
// Basis and projections

void expect_orthonormal(const Basis& b, const glm::dvec3& direction, double tol) {
  const glm::dvec3 n = direction / glm::length(direction);
  EXPECT_NEAR(glm::length(b.x), 1.0, tol);
  EXPECT_NEAR(glm::length(b.y), 1.0, tol);
  EXPECT_NEAR(glm::length(b.z), 1.0, tol);
  EXPECT_NEAR(glm::dot(b.x, b.y), 0.0, tol);
  EXPECT_NEAR(glm::dot(b.x, b.z), 0.0, tol);
  EXPECT_NEAR(glm::dot(b.y, b.z), 0.0, tol);
  EXPECT_LT(glm::length(glm::cross(b.x, b.y) - b.z), tol);  // right-handed
  EXPECT_LT(glm::length(b.z - n), tol);
}

TEST(Basis, OrthonormalRightHandedAtPolesAndAxes) {
  const double h = std::sqrt(0.5);
  const std::pair<glm::dvec3, glm::dvec3> cases[] = {
      {{0, 1, 0}, {0, 1, 0}},         {{0, -1, 0}, {0, -1, 0}},
      {{1, 0, 0}, {1, 0, 0}},         {{-1, 0, 0}, {-1, 0, 0}},
      {{0, 0, 1}, {0, 0, 1}},         {{0, 0, -1}, {0, 0, -1}},
      {{0, -1e-300, 0}, {0, -1, 0}},  {{3e300, -3e300, 0}, {h, -h, 0}},
      {{0, -0.0, 1e-320}, {0, 0, 1}}, {{-0.0, -1, 0}, {0, -1, 0}},
  };
  for (const auto& [d, unit] : cases) {
    SCOPED_TRACE(testing::Message() << d.x << " " << d.y << " " << d.z);
    expect_orthonormal(orthonormal_basis(d), unit, 2e-16);
  }
}

TEST(Basis, ContinuousForLightsAboveTheHorizon) {
  // A sun moving over the sky (travel direction y < 0) never flips its basis: neighbouring
  // directions give neighbouring bases.
  std::mt19937_64 rng(7);
  for (int i = 0; i < 10000; ++i) {
    glm::dvec3 d = test::random_direction(rng);
    d.y = -std::abs(d.y) - 1e-3;
    const glm::dvec3 e = d + test::uniform3(rng, -1e-7, 1e-7);
    const Basis a = orthonormal_basis(d);
    const Basis b = orthonormal_basis(e);
    ASSERT_LT(glm::length(a.x - b.x), 1e-3) << i;
    ASSERT_LT(glm::length(a.y - b.y), 1e-3) << i;
  }
}

TEST(Projection, OrthographicMapsBoxToNdcAndDepthByConvention) {
  const glm::dvec3 lo(-3.0, 10.0, 5.0);
  const glm::dvec3 hi(7.0, 14.0, 25.0);
  const glm::dmat4 rev = orthographic_projection(lo, hi, DepthConvention::reverse_z);
  const glm::dmat4 std_z = orthographic_projection(lo, hi, DepthConvention::standard);
  const glm::dvec3 a = project_point(rev, lo);
  const glm::dvec3 b = project_point(rev, hi);
  EXPECT_NEAR(a.x, -1.0, 1e-15);
  EXPECT_NEAR(a.y, -1.0, 1e-15);
  EXPECT_NEAR(a.z, 1.0, 1e-15);  // near -> 1
  EXPECT_NEAR(b.x, 1.0, 1e-15);
  EXPECT_NEAR(b.y, 1.0, 1e-15);
  EXPECT_NEAR(b.z, 0.0, 1e-15);  // far -> 0
  EXPECT_NEAR(project_point(std_z, lo).z, 0.0, 1e-15);
  EXPECT_NEAR(project_point(std_z, hi).z, 1.0, 1e-15);
  EXPECT_NEAR(project_point(rev, glm::dvec3(2.0, 12.0, 15.0)).z, 0.5, 1e-15);
  // uv: ndc -1 -> 0, no flip.
  EXPECT_EQ(ndc_to_uv(glm::dvec2(-1.0, 1.0)), glm::dvec2(0.0, 1.0));
}

TEST(Projection, PerspectiveNearFarAndSlopes) {
  const double n = 0.5;
  const double f = 40.0;
  for (const DepthConvention depth : kDepths) {
    const glm::dmat4 p = perspective_projection(0.5, 0.25, n, f, depth);
    const bool rev = depth == DepthConvention::reverse_z;
    EXPECT_NEAR(project_point(p, glm::dvec3(0, 0, n)).z, rev ? 1.0 : 0.0, 1e-15);
    EXPECT_NEAR(project_point(p, glm::dvec3(0, 0, f)).z, rev ? 0.0 : 1.0, 1e-15);
    const glm::dvec3 edge = project_point(p, glm::dvec3(0.5 * 8.0, -0.25 * 8.0, 8.0));
    EXPECT_NEAR(edge.x, 1.0, 1e-15);
    EXPECT_NEAR(edge.y, -1.0, 1e-15);
    // Monotone in z.
    double previous = project_point(p, glm::dvec3(0, 0, n)).z;
    for (double z = 0.6; z < f; z *= 1.3) {
      const double d = project_point(p, glm::dvec3(0, 0, z)).z;
      if (rev) {
        EXPECT_LT(d, previous);
      } else {
        EXPECT_GT(d, previous);
      }
      previous = d;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Cascade fitting

struct Containment {
  double max_ndc = 0.0;
  double min_depth = 2.0;
  double max_depth = -2.0;
};

// Every slice corner and `samples` random points of each cascade's fit range.
Containment slice_containment(const CascadeSet& set, const Camera& camera, int samples,
                              std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  Containment c;
  for (const Cascade& cascade : set.cascades) {
    std::vector<glm::dvec3> points;
    for (const double d : {cascade.fit_near, cascade.fit_far}) {
      for (const double sx : {-1.0, 1.0}) {
        for (const double sy : {-1.0, 1.0}) points.push_back(frustum_point(camera, d, sx, sy));
      }
    }
    for (int i = 0; i < samples; ++i) {
      points.push_back(frustum_point(camera, test::uniform(rng, cascade.fit_near, cascade.fit_far),
                                     test::uniform(rng, -1.0, 1.0), test::uniform(rng, -1.0, 1.0)));
    }
    for (const glm::dvec3& p : points) {
      const glm::dvec3 ndc = project_point(cascade.view_proj, p);
      c.max_ndc = std::max({c.max_ndc, std::abs(ndc.x), std::abs(ndc.y)});
      c.min_depth = std::min(c.min_depth, ndc.z);
      c.max_depth = std::max(c.max_depth, ndc.z);
    }
  }
  return c;
}

TEST(Cascades, EverySlicePointInsideItsCascade) {
  for (const CascadeFit fit : kFits) {
    for (const DepthConvention depth : kDepths) {
      for (const bool clamp : {true, false}) {
        for (const std::uint32_t guard : {0u, 1u, 4u}) {
          SCOPED_TRACE(testing::Message() << fit_name(fit) << " depth " << int(depth) << " clamp "
                                          << clamp << " guard " << guard);
          ShadowConfig config;
          config.fit = fit;
          config.depth = depth;
          config.depth_clamp = clamp;
          config.guard_texels = guard;
          const Camera camera = default_camera();
          const CascadeSet set = compute_cascades(config, camera, default_light(), default_scene());
          ASSERT_EQ(set.cascades.size(), 4u);
          const Containment c = slice_containment(set, camera, 500, 11);
          // The guard texels stay free on each side.
          EXPECT_LE(c.max_ndc, 1.0 - 2.0 * guard / config.resolution + 1e-12);
          EXPECT_GT(c.min_depth, 0.0);
          EXPECT_LT(c.max_depth, 1.0);
        }
      }
    }
  }
}

TEST(Cascades, BlendRegionOfPreviousSliceIsCoveredByNextCascade) {
  ShadowConfig config;
  config.blend_fraction = 0.2;
  const CascadeSet set =
      compute_cascades(config, default_camera(), default_light(), default_scene());
  for (std::size_t i = 1; i < set.cascades.size(); ++i) {
    const double expected = set.splits[i] - 0.2 * (set.splits[i] - set.splits[i - 1]);
    EXPECT_DOUBLE_EQ(set.cascades[i].fit_near, expected);
    EXPECT_EQ(set.cascades[i].fit_far, set.splits[i + 1]);
  }
  EXPECT_EQ(set.cascades[0].fit_near, set.splits[0]);
}

TEST(Cascades, SceneCornersInsideDepthRange) {
  const Aabb scene = default_scene();
  for (const CascadeFit fit : kFits) {
    for (const DepthConvention depth : kDepths) {
      for (const bool clamp : {false, true}) {
        SCOPED_TRACE(testing::Message()
                     << fit_name(fit) << " depth " << int(depth) << " clamp " << clamp);
        ShadowConfig config;
        config.fit = fit;
        config.depth = depth;
        config.depth_clamp = clamp;
        const Camera camera = default_camera();
        const CascadeSet set = compute_cascades(config, camera, default_light(), scene);
        const bool rev = depth == DepthConvention::reverse_z;
        for (const Cascade& cascade : set.cascades) {
          for (int i = 0; i < 8; ++i) {
            const glm::dvec3 corner((i & 1) ? scene.max.x : scene.min.x,
                                    (i & 2) ? scene.max.y : scene.min.y,
                                    (i & 4) ? scene.max.z : scene.min.z);
            const double d = project_point(cascade.view_proj, corner).z;
            // Never beyond the far plane.
            EXPECT_TRUE(rev ? d > 0.0 : d < 1.0) << d;
            // Without depth clamp the near plane covers the scene, too.
            if (!clamp) {
              EXPECT_TRUE(rev ? d < 1.0 : d > 0.0) << d;
            }
          }
        }
      }
    }
  }
}

TEST(Cascades, DepthClampPutsNearPlaneAtReceivers) {
  // A tall scene (a 2 km mountain) above a camera near the ground: with pancaking the near plane
  // of the first cascade is at its receivers, far behind the mountain top.
  Aabb scene = default_scene();
  scene.max.y = 2000.0;
  const DirectionalLight light = default_light();
  ShadowConfig config;
  config.depth_clamp = true;
  const CascadeSet clamped = compute_cascades(config, default_camera(), light, scene);
  config.depth_clamp = false;
  const CascadeSet unclamped = compute_cascades(config, default_camera(), light, scene);
  const Cascade& c = clamped.cascades[0];
  const Cascade& u = unclamped.cascades[0];
  EXPECT_GT(c.box_min.z, u.box_min.z + 500.0);
  // Same far plane (up to the 1e-4 relative padding of the depth range).
  EXPECT_NEAR(c.box_max.z, u.box_max.z, 1e-3 * (u.box_max.z - u.box_min.z));
  // The receivers of the first cascade still use the whole depth range's front part: the
  // largest receiver depth (reverse-Z) is close to 1.
  const Containment r = slice_containment(clamped, default_camera(), 200, 3);
  EXPECT_GT(r.max_depth, 0.5);
  EXPECT_LT(r.max_depth, 1.0);
}

// Maximum fractional texel drift of fixed world points under camera translations.
double translation_drift(const ShadowConfig& config, const glm::dvec3& origin, int trials,
                         double spread, std::uint64_t seed, bool* texel_size_constant) {
  std::mt19937_64 rng(seed);
  const DirectionalLight light = default_light();
  const Aabb scene = default_scene(origin);
  std::vector<glm::dvec3> points;
  for (int i = 0; i < 16; ++i) points.push_back(origin + test::uniform3(rng, -spread, spread));
  const CascadeSet reference =
      compute_cascades(config, default_camera(origin + glm::dvec3(0, 2, 0)), light, scene);
  double drift = 0.0;
  *texel_size_constant = true;
  for (int t = 0; t < trials; ++t) {
    const Camera camera =
        default_camera(origin + glm::dvec3(0, 2, 0) + test::uniform3(rng, -spread, spread));
    const CascadeSet set = compute_cascades(config, camera, light, scene);
    for (std::size_t c = 0; c < set.cascades.size(); ++c) {
      if (set.cascades[c].texel_world_size != reference.cascades[c].texel_world_size) {
        *texel_size_constant = false;
      }
      for (const glm::dvec3& p : points) {
        const glm::dvec2 a = texel_coord(set.cascades[c].view_proj, p, set.resolution);
        const glm::dvec2 b = texel_coord(reference.cascades[c].view_proj, p, set.resolution);
        drift = std::max({drift, fractional_distance(a.x, b.x), fractional_distance(a.y, b.y)});
      }
    }
  }
  return drift;
}

TEST(Cascades, TranslationMovesCascadesByWholeTexels) {
  for (const CascadeFit fit : kFits) {
    SCOPED_TRACE(fit_name(fit));
    ShadowConfig config;
    config.fit = fit;
    bool constant = false;
    const double drift = translation_drift(config, glm::dvec3(0.0), 500, 30.0, 5, &constant);
    EXPECT_TRUE(constant);
    EXPECT_LT(drift, 1e-3);
  }
}

TEST(Cascades, WithoutSnappingTheSameCheckSeesDrift) {
  // Negative control: the snapping check above is able to fail.
  ShadowConfig config;
  config.snap_to_texels = false;
  bool constant = false;
  const double drift = translation_drift(config, glm::dvec3(0.0), 100, 30.0, 5, &constant);
  EXPECT_GT(drift, 0.1);
}

Camera random_orientation(Camera camera, std::mt19937_64& rng) {
  camera.forward = test::random_direction(rng);
  do {
    camera.up = test::random_direction(rng);
  } while (glm::length(glm::cross(camera.forward, camera.up)) < 0.1);
  return camera;
}

TEST(Cascades, CameraSphereIsBitIdenticalUnderRotation) {
  ShadowConfig config;
  config.fit = CascadeFit::camera_sphere;
  const glm::dvec3 origin(1234.5, 6.25, -987.125);
  const Camera camera = default_camera(origin);
  const CascadeSet reference = compute_cascades(config, camera, default_light(), default_scene());
  const ShadowGpu reference_gpu = pack_shadow(reference, origin);
  std::mt19937_64 rng(17);
  for (int i = 0; i < 300; ++i) {
    const Camera turned = random_orientation(camera, rng);
    const CascadeSet set = compute_cascades(config, turned, default_light(), default_scene());
    ASSERT_EQ(set.cascades.size(), reference.cascades.size());
    for (std::size_t c = 0; c < set.cascades.size(); ++c) {
      ASSERT_EQ(std::memcmp(&set.cascades[c].view_proj, &reference.cascades[c].view_proj,
                            sizeof(glm::dmat4)),
                0)
          << "rotation " << i << " cascade " << c;
    }
    const ShadowGpu gpu = pack_shadow(set, origin);
    ASSERT_EQ(std::memcmp(gpu.cascades, reference_gpu.cascades, sizeof(gpu.cascades)), 0);
    ASSERT_EQ(std::memcmp(gpu.splits, reference_gpu.splits, sizeof(gpu.splits)), 0);
  }
  // Control: the other fits do change when the camera turns.
  for (const CascadeFit fit : {CascadeFit::box, CascadeFit::slice_sphere}) {
    config.fit = fit;
    const CascadeSet a = compute_cascades(config, camera, default_light(), default_scene());
    const CascadeSet b =
        compute_cascades(config, random_orientation(camera, rng), default_light(), default_scene());
    EXPECT_NE(std::memcmp(&a.cascades[0].view_proj, &b.cascades[0].view_proj, sizeof(glm::dmat4)),
              0);
  }
}

TEST(Cascades, CameraSphereContainsSliceInEveryOrientation) {
  ShadowConfig config;
  config.fit = CascadeFit::camera_sphere;
  std::mt19937_64 rng(23);
  for (int i = 0; i < 50; ++i) {
    const Camera camera = random_orientation(default_camera(), rng);
    const CascadeSet set = compute_cascades(config, camera, default_light(), default_scene());
    const Containment c = slice_containment(set, camera, 50, 100 + i);
    EXPECT_LT(c.max_ndc, 1.0);
    EXPECT_GT(c.min_depth, 0.0);
    EXPECT_LT(c.max_depth, 1.0);
  }
}

TEST(Cascades, SliceSphereGridStaysFixedUnderRotationAndTranslation) {
  ShadowConfig config;
  config.fit = CascadeFit::slice_sphere;
  std::mt19937_64 rng(29);
  const Camera camera = default_camera();
  const CascadeSet reference = compute_cascades(config, camera, default_light(), default_scene());
  std::vector<glm::dvec3> points;
  for (int i = 0; i < 16; ++i) points.push_back(test::uniform3(rng, -40.0, 40.0));
  double drift = 0.0;
  for (int t = 0; t < 300; ++t) {
    Camera moved = random_orientation(camera, rng);
    moved.position += test::uniform3(rng, -20.0, 20.0);
    const CascadeSet set = compute_cascades(config, moved, default_light(), default_scene());
    for (std::size_t c = 0; c < set.cascades.size(); ++c) {
      ASSERT_EQ(set.cascades[c].texel_world_size, reference.cascades[c].texel_world_size);
      for (const glm::dvec3& p : points) {
        const glm::dvec2 a = texel_coord(set.cascades[c].view_proj, p, set.resolution);
        const glm::dvec2 b = texel_coord(reference.cascades[c].view_proj, p, set.resolution);
        drift = std::max({drift, fractional_distance(a.x, b.x), fractional_distance(a.y, b.y)});
      }
    }
  }
  EXPECT_LT(drift, 1e-3);
}

TEST(Cascades, BoxFitIsTighterThanSpheres) {
  ShadowConfig config;
  std::vector<double> texel[3];
  for (const CascadeFit fit : kFits) {
    config.fit = fit;
    const CascadeSet set =
        compute_cascades(config, default_camera(), default_light(), default_scene());
    for (const Cascade& c : set.cascades) {
      texel[static_cast<int>(fit)].push_back(c.texel_world_size);
    }
  }
  for (std::size_t i = 0; i < texel[0].size(); ++i) {
    EXPECT_LT(texel[0][i], texel[2][i]);  // box < slice sphere
    EXPECT_LT(texel[2][i], texel[1][i]);  // slice sphere < camera sphere
  }
}

TEST(Cascades, OneCascadeCoversTheWholeRange) {
  ShadowConfig config;
  config.cascade_count = 1;
  for (const CascadeFit fit : kFits) {
    config.fit = fit;
    const Camera camera = default_camera();
    const CascadeSet set = compute_cascades(config, camera, default_light(), default_scene());
    ASSERT_EQ(set.cascades.size(), 1u);
    ASSERT_EQ(set.splits.size(), 2u);
    EXPECT_EQ(set.splits[0], camera.near);
    EXPECT_EQ(set.splits[1], config.max_distance);
    const Containment c = slice_containment(set, camera, 1000, 1);
    EXPECT_LT(c.max_ndc, 1.0);
    EXPECT_GT(c.min_depth, 0.0);
    EXPECT_LT(c.max_depth, 1.0);
  }
}

TEST(Cascades, LightStraightDownAndUp) {
  for (const glm::dvec3 dir : {glm::dvec3(0, -1, 0), glm::dvec3(0, 1, 0),
                               glm::dvec3(1e-7, -1, -1e-7), glm::dvec3(1, 0, 0)}) {
    DirectionalLight light;
    light.direction = dir;
    for (const CascadeFit fit : kFits) {
      ShadowConfig config;
      config.fit = fit;
      const Camera camera = default_camera();
      const CascadeSet set = compute_cascades(config, camera, light, default_scene());
      const Containment c = slice_containment(set, camera, 100, 9);
      EXPECT_LT(c.max_ndc, 1.0);
      EXPECT_GT(c.min_depth, 0.0);
      EXPECT_LT(c.max_depth, 1.0);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Clipmap

TEST(Clipmap, EightLevelsEachTwiceThePrevious) {
  ClipmapConfig config;
  config.level_count = 8;
  config.base_extent = 20.0;
  config.resolution = 1024;
  const glm::dvec3 camera(12.3, 4.5, -6.7);
  const Aabb scene = default_scene();
  const CascadeSet set = compute_clipmap(config, camera, default_light(), scene);
  ASSERT_EQ(set.cascades.size(), 8u);
  EXPECT_EQ(set.layout, ShadowLayout::clipmap);
  const Basis& basis = set.light_basis;
  const glm::dvec2 camera_ls(glm::dot(basis.x, camera), glm::dot(basis.y, camera));
  for (std::size_t i = 0; i < set.cascades.size(); ++i) {
    const Cascade& c = set.cascades[i];
    const double width = c.box_max.x - c.box_min.x;
    EXPECT_EQ(width, c.box_max.y - c.box_min.y);
    EXPECT_EQ(width, 20.0 * std::ldexp(1.0, static_cast<int>(i)));
    if (i > 0) {
      EXPECT_EQ(width, 2.0 * (set.cascades[i - 1].box_max.x - set.cascades[i - 1].box_min.x));
      EXPECT_EQ(c.texel_world_size, 2.0 * set.cascades[i - 1].texel_world_size);
    }
    // Concentric around the camera: within half a texel of the centre.
    const glm::dvec2 center = 0.5 * (glm::dvec2(c.box_min) + glm::dvec2(c.box_max));
    EXPECT_LE(std::abs(center.x - camera_ls.x), 0.5 * c.texel_world_size + 1e-9);
    EXPECT_LE(std::abs(center.y - camera_ls.y), 0.5 * c.texel_world_size + 1e-9);
    // The edges are on the level's texel grid.
    EXPECT_NEAR(fractional_distance(c.box_min.x / c.texel_world_size, 0.0), 0.0, 1e-6);
    // The camera maps to the centre texel; the scene corners lie inside the depth range.
    const glm::dvec3 ndc = project_point(c.view_proj, camera);
    EXPECT_LE(std::abs(ndc.x), 1.0 / config.resolution + 1e-12);
    EXPECT_LE(std::abs(ndc.y), 1.0 / config.resolution + 1e-12);
    for (int k = 0; k < 8; ++k) {
      const glm::dvec3 corner((k & 1) ? scene.max.x : scene.min.x,
                              (k & 2) ? scene.max.y : scene.min.y,
                              (k & 4) ? scene.max.z : scene.min.z);
      const double d = project_point(c.view_proj, corner).z;
      EXPECT_GT(d, 0.0);
      EXPECT_LT(d, 1.0);
    }
    EXPECT_EQ(set.splits[i + 1], c.fit_far);
  }
  const ShadowGpu gpu = pack_shadow(set, camera);
  EXPECT_EQ(gpu.counts, glm::uvec4(8u, 1u, 1024u, 1u));
  EXPECT_FLOAT_EQ(gpu.splits[1].w, static_cast<float>(set.cascades[7].fit_far));
  EXPECT_EQ(gpu.camera_position, glm::vec4(0, 0, 0, 1));
}

TEST(Clipmap, TranslationMovesLevelsByWholeTexels) {
  ClipmapConfig config;
  config.level_count = 5;
  std::mt19937_64 rng(31);
  const DirectionalLight light = default_light();
  const CascadeSet reference = compute_clipmap(config, glm::dvec3(0.0), light, default_scene());
  std::vector<glm::dvec3> points;
  for (int i = 0; i < 16; ++i) points.push_back(test::uniform3(rng, -10.0, 10.0));
  double drift = 0.0;
  for (int t = 0; t < 500; ++t) {
    const CascadeSet set =
        compute_clipmap(config, test::uniform3(rng, -30.0, 30.0), light, default_scene());
    for (std::size_t c = 0; c < set.cascades.size(); ++c) {
      for (const glm::dvec3& p : points) {
        const glm::dvec2 a = texel_coord(set.cascades[c].view_proj, p, set.resolution);
        const glm::dvec2 b = texel_coord(reference.cascades[c].view_proj, p, set.resolution);
        drift = std::max({drift, fractional_distance(a.x, b.x), fractional_distance(a.y, b.y)});
      }
    }
  }
  EXPECT_LT(drift, 1e-3);
}

// ---------------------------------------------------------------------------------------------
// Spot lights

TEST(Spot, ConeEdgeMapsToNdcEdge) {
  SpotLight light;
  light.position = glm::dvec3(3.0, 7.0, -2.0);
  light.direction = glm::dvec3(0.2, -1.0, 0.4);
  light.outer_angle = 0.6;
  light.range = 30.0;
  for (const DepthConvention depth : kDepths) {
    SpotShadowConfig config;
    config.depth = depth;
    const SpotShadow s = compute_spot_shadow(light, config);
    const Basis& b = s.basis;
    const double c = std::cos(light.outer_angle);
    const double sn = std::sin(light.outer_angle);
    for (const double dist : {1.0, 10.0, 25.0}) {
      const glm::dvec3 px = light.position + dist * (c * b.z + sn * b.x);
      const glm::dvec3 nx = light.position + dist * (c * b.z - sn * b.x);
      const glm::dvec3 py = light.position + dist * (c * b.z + sn * b.y);
      const glm::dvec3 ny = light.position + dist * (c * b.z - sn * b.y);
      EXPECT_NEAR(project_point(s.view_proj, px).x, 1.0, 1e-12);
      EXPECT_NEAR(project_point(s.view_proj, px).y, 0.0, 1e-12);
      EXPECT_NEAR(project_point(s.view_proj, nx).x, -1.0, 1e-12);
      EXPECT_NEAR(project_point(s.view_proj, py).y, 1.0, 1e-12);
      EXPECT_NEAR(project_point(s.view_proj, ny).y, -1.0, 1e-12);
      // The cone is inscribed: a diagonal edge ray stays inside.
      const glm::dvec3 diag = light.position + dist * (c * b.z + sn * glm::normalize(b.x + b.y));
      const glm::dvec3 ndc = project_point(s.view_proj, diag);
      EXPECT_LT(std::abs(ndc.x), 1.0);
      EXPECT_LT(std::abs(ndc.y), 1.0);
    }
    const bool rev = depth == DepthConvention::reverse_z;
    EXPECT_NEAR(project_point(s.view_proj, light.position + config.near * b.z).z, rev ? 1.0 : 0.0,
                1e-12);
    EXPECT_NEAR(project_point(s.view_proj, light.position + light.range * b.z).z, rev ? 0.0 : 1.0,
                1e-12);
    const glm::dvec3 axis = project_point(s.view_proj, light.position + 5.0 * b.z);
    EXPECT_NEAR(axis.x, 0.0, 1e-15);
    EXPECT_NEAR(axis.y, 0.0, 1e-15);
  }
}

// ---------------------------------------------------------------------------------------------
// Point lights

const glm::dvec3 kAxes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};

// The Vulkan specification's cube-map face selection table, written out independently of the
// library: returns the face and (s, t) in [0, 1]^2.
std::pair<int, glm::dvec2> spec_cube_lookup(const glm::dvec3& r) {
  const glm::dvec3 a = glm::abs(r);
  int face = 0;
  double sc = 0.0;
  double tc = 0.0;
  double ma = 0.0;
  if (a.z >= a.x && a.z >= a.y) {
    face = r.z >= 0 ? 4 : 5;
    sc = r.z >= 0 ? r.x : -r.x;
    tc = -r.y;
    ma = a.z;
  } else if (a.y >= a.x) {
    face = r.y >= 0 ? 2 : 3;
    sc = r.x;
    tc = r.y >= 0 ? r.z : -r.z;
    ma = a.y;
  } else {
    face = r.x >= 0 ? 0 : 1;
    sc = r.x >= 0 ? -r.z : r.z;
    tc = -r.y;
    ma = a.x;
  }
  return {face, glm::dvec2(0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0))};
}

TEST(Point, AxisPointsLandAtFaceCentres) {
  PointLight light;
  light.position = glm::dvec3(-4.0, 2.5, 9.0);
  light.range = 25.0;
  const PointShadow s = compute_point_shadow(light, PointShadowConfig{});
  for (int f = 0; f < 6; ++f) {
    const glm::dvec3 p = light.position + 7.0 * kAxes[f];
    EXPECT_EQ(static_cast<int>(cube_face_for_direction(p - light.position)), f);
    const glm::dvec3 ndc = project_point(s.face_view_proj[f], p);
    EXPECT_NEAR(ndc.x, 0.0, 1e-15) << f;
    EXPECT_NEAR(ndc.y, 0.0, 1e-15) << f;
    EXPECT_GT(ndc.z, 0.0);
    EXPECT_LT(ndc.z, 1.0);
    // Behind the other faces' view (w <= 0) or outside their square.
    for (int g = 0; g < 6; ++g) {
      if (g == f) continue;
      const glm::dvec4 clip = s.face_view_proj[g] * glm::dvec4(p, 1.0);
      EXPECT_TRUE(clip.w <= 0.0 || std::abs(clip.x) > clip.w || std::abs(clip.y) > clip.w);
    }
  }
}

TEST(Point, FacesMatchVulkanCubeSampling) {
  PointLight light;
  light.position = glm::dvec3(1.0, -2.0, 3.0);
  light.range = 50.0;
  const PointShadow s = compute_point_shadow(light, PointShadowConfig{});
  std::mt19937_64 rng(41);
  for (int i = 0; i < 20000; ++i) {
    const glm::dvec3 dir = test::random_direction(rng);
    const glm::dvec3 p = light.position + test::uniform(rng, 0.1, 49.0) * dir;
    const auto [face, st] = spec_cube_lookup(p - light.position);
    ASSERT_EQ(static_cast<int>(cube_face_for_direction(p - light.position)), face);
    const glm::dvec3 ndc = project_point(s.face_view_proj[face], p);
    const glm::dvec2 uv = ndc_to_uv(glm::dvec2(ndc));
    ASSERT_NEAR(uv.x, st.x, 1e-12) << i;
    ASSERT_NEAR(uv.y, st.y, 1e-12) << i;
  }
}

TEST(Point, StoredDepthIsDistanceOverRange) {
  PointLight light;
  light.position = glm::dvec3(0.5, 1.5, -2.5);
  light.range = 40.0;
  std::mt19937_64 rng(43);
  for (const DepthConvention depth : kDepths) {
    PointShadowConfig config;
    config.depth = depth;
    const PointShadow s = compute_point_shadow(light, config);
    EXPECT_EQ(s.depth_near, 0.0);
    EXPECT_EQ(s.depth_far, light.range);
    const PointShadowGpu gpu = pack_point_shadow(s, light.position);
    for (int i = 0; i < 1000; ++i) {
      const double dist = test::uniform(rng, 0.0, light.range);
      const glm::dvec3 p = light.position + dist * test::random_direction(rng);
      const double expected =
          depth == DepthConvention::reverse_z ? 1.0 - dist / light.range : dist / light.range;
      ASSERT_NEAR(point_shadow_depth(s, p), expected, 1e-14);
      // The shader's formula on the packed data.
      const double t = std::clamp((dist - gpu.depth_range.x) * gpu.depth_range.z, 0.0, 1.0);
      ASSERT_NEAR(gpu.info.y == 1u ? 1.0 - t : t, expected, 1e-6);
      // The face projection does not clip points within [near * sqrt(3), range].
      if (dist > config.near * std::sqrt(3.0)) {
        const int face = static_cast<int>(cube_face_for_direction(p - light.position));
        const glm::dvec4 clip = s.face_view_proj[face] * glm::dvec4(p, 1.0);
        ASSERT_GE(clip.z, -1e-12 * clip.w);
        ASSERT_LE(clip.z, clip.w * (1.0 + 1e-12));
      }
    }
    EXPECT_EQ(point_shadow_depth(s, light.position + glm::dvec3(100.0, 0, 0)),
              depth == DepthConvention::reverse_z ? 0.0 : 1.0);
  }
}

TEST(Point, FaceViewsAreMirrored) {
  // Documented in local_lights.hpp: the depth pass must not cull by winding as usual.
  for (int f = 0; f < 6; ++f) {
    const glm::dmat4 v = cube_face_view(static_cast<CubeFace>(f), glm::dvec3(0.0));
    EXPECT_EQ(glm::determinant(glm::dmat3(v)), -1.0) << f;
  }
}

// A star far away lights a field of asteroids; the camera sees part of the field.
struct AsteroidField {
  std::vector<Aabb> objects;
  Camera camera;
  glm::dvec3 star;
};

AsteroidField make_field(const glm::dvec3& star, std::uint64_t seed) {
  AsteroidField field;
  field.star = star;
  field.camera.position = glm::dvec3(0.0);
  field.camera.forward = glm::dvec3(0.1, 0.05, 1.0);
  field.camera.up = glm::dvec3(0.0, 1.0, 0.0);
  field.camera.fov_y = 0.9;
  field.camera.aspect = 1.5;
  field.camera.near = 0.5;
  field.camera.far = 6000.0;
  std::mt19937_64 rng(seed);
  for (int i = 0; i < 400; ++i) {
    const glm::dvec3 c(test::uniform(rng, -1500, 1500), test::uniform(rng, -1500, 1500),
                       test::uniform(rng, -800, 3500));
    const glm::dvec3 h = test::uniform3(rng, 0.5, 15.0);
    field.objects.push_back(Aabb{c - h, c + h});
  }
  return field;
}

void check_fit(const AsteroidField& field, DepthConvention depth, std::uint64_t seed,
               int* visible_count) {
  PointShadowConfig config;
  config.depth = depth;
  const PointShadow s = fit_point_shadow(field.star, field.camera, 5000.0, field.objects, config);
  ASSERT_GT(s.depth_near, 0.0);
  ASSERT_GT(s.depth_far, s.depth_near);
  ASSERT_NE(s.face_mask, 0u);
  for (const glm::dmat4& m : s.face_view_proj) ASSERT_TRUE(is_finite(m));
  std::mt19937_64 rng(seed);
  const test::Frame frame = test::frame_of(field.camera);
  *visible_count = 0;
  for (const Aabb& box : field.objects) {
    // Nearest point of every object closer than depth_far is not in front of depth_near.
    const glm::dvec3 closest = glm::clamp(field.star, box.min, box.max);
    if (glm::length(closest - field.star) < s.depth_far) {
      EXPECT_GE(glm::length(closest - field.star), s.depth_near);
    }
    // Receivers: test points of the box that are inside the camera frustum.
    std::vector<glm::dvec3> points;
    for (int k = 0; k < 8; ++k) {
      points.emplace_back((k & 1) ? box.max.x : box.min.x, (k & 2) ? box.max.y : box.min.y,
                          (k & 4) ? box.max.z : box.min.z);
    }
    for (int k = 0; k < 16; ++k) {
      points.push_back(glm::dvec3(test::uniform(rng, box.min.x, box.max.x),
                                  test::uniform(rng, box.min.y, box.max.y),
                                  test::uniform(rng, box.min.z, box.max.z)));
    }
    for (const glm::dvec3& p : points) {
      const glm::dvec3 rel = p - field.camera.position;
      const double z = glm::dot(rel, frame.forward);
      const bool in_view = z >= field.camera.near && z <= 5000.0 &&
                           std::abs(glm::dot(rel, frame.right)) <= z * frame.tan_x &&
                           std::abs(glm::dot(rel, frame.up)) <= z * frame.tan_y;
      if (!in_view) continue;
      ++*visible_count;
      const double dist = glm::length(p - field.star);
      const double t = (dist - s.depth_near) / (s.depth_far - s.depth_near);
      EXPECT_GE(t, 0.0);
      EXPECT_LE(t, 1.0);
      const int face = static_cast<int>(cube_face_for_direction(p - field.star));
      EXPECT_TRUE(s.face_mask & (1u << face)) << "face " << face;
      const glm::dvec4 clip = s.face_view_proj[face] * glm::dvec4(p, 1.0);
      EXPECT_LE(std::abs(clip.x), clip.w * (1 + 1e-12));
      EXPECT_LE(std::abs(clip.y), clip.w * (1 + 1e-12));
      EXPECT_GE(clip.z, -1e-9 * clip.w);
      EXPECT_LE(clip.z, clip.w * (1 + 1e-9));
    }
  }
}

TEST(Point, FitToCameraFrustumForAsteroidField) {
  for (const DepthConvention depth : kDepths) {
    // A nearby star among the asteroids (all six faces may be needed) and a distant one.
    for (const glm::dvec3 star :
         {glm::dvec3(300.0, 200.0, 1200.0), glm::dvec3(2.0e5, 5.0e4, 1.0e3)}) {
      const AsteroidField field = make_field(star, 47);
      int visible = 0;
      check_fit(field, depth, 53, &visible);
      EXPECT_GT(visible, 100);
    }
  }
  // The distant star: the linear range spans the field, not the distance to the star, and only
  // the faces towards the field are rendered.
  const AsteroidField field = make_field(glm::dvec3(2.0e5, 5.0e4, 1.0e3), 47);
  const PointShadow s = fit_point_shadow(field.star, field.camera, 5000.0, field.objects, {});
  EXPECT_LT(s.depth_far - s.depth_near, 10000.0);
  EXPECT_GT(s.depth_near, 1.9e5);
  EXPECT_LE(std::popcount(s.face_mask), 2);
  EXPECT_TRUE(s.face_mask & (1u << static_cast<int>(CubeFace::negative_x)));
}

// A ground plane under a lamp, seen by a camera looking away from the lamp: the plane's box
// touches every face but +Y, yet only the part in view needs a face. Each object is clipped to
// the view's box first, so the faces behind the camera are not rendered, and every visible
// point is still in a rendered face and inside the depth range (check_fit).
TEST(Point, FitClipsLargeReceiversToTheView) {
  AsteroidField field;
  field.star = glm::dvec3(0.0, 3.0, 0.0);
  field.camera.position = glm::dvec3(3.0, 2.5, 3.0);
  field.camera.forward = glm::normalize(glm::dvec3(6.0, -2.5, 6.0));
  field.camera.up = glm::dvec3(0.0, 1.0, 0.0);
  field.camera.fov_y = 0.9;
  field.camera.aspect = 16.0 / 9.0;
  field.camera.near = 0.1;
  field.camera.far = 400.0;
  field.objects.push_back(Aabb{glm::dvec3(-30.0, -0.01, -30.0), glm::dvec3(30.0, 0.0, 30.0)});
  field.objects.push_back(Aabb{glm::dvec3(5.5, 0.0, 4.5), glm::dvec3(6.5, 1.5, 5.5)});
  field.objects.push_back(Aabb{glm::dvec3(-5.5, 0.0, -4.5), glm::dvec3(-4.5, 1.0, -3.5)});
  for (const DepthConvention depth : kDepths) {
    int visible = 0;
    check_fit(field, depth, 61, &visible);
    EXPECT_GT(visible, 4);
  }
  const PointShadow s = fit_point_shadow(field.star, field.camera, 60.0, field.objects, {});
  EXPECT_FALSE(s.face_mask & (1u << static_cast<int>(CubeFace::negative_x))) << s.face_mask;
  EXPECT_FALSE(s.face_mask & (1u << static_cast<int>(CubeFace::negative_z))) << s.face_mask;
  EXPECT_FALSE(s.face_mask & (1u << static_cast<int>(CubeFace::positive_y))) << s.face_mask;
  EXPECT_TRUE(s.face_mask & (1u << static_cast<int>(CubeFace::positive_x))) << s.face_mask;
}

TEST(Point, FitWithNothingVisibleRendersNoFace) {
  AsteroidField field = make_field(glm::dvec3(0.0, 1000.0, 0.0), 59);
  field.camera.forward = glm::dvec3(0.0, 0.0, -1.0);  // looking away from the field
  for (Aabb& box : field.objects) {
    box.min.z = std::abs(box.min.z) + 10.0;
    box.max.z = box.min.z + 5.0;
  }
  const PointShadow s = fit_point_shadow(field.star, field.camera, 1000.0, field.objects, {});
  EXPECT_EQ(s.face_mask, 0u);
  for (const glm::dmat4& m : s.face_view_proj) EXPECT_TRUE(is_finite(m));
  const PointShadow empty = fit_point_shadow(field.star, field.camera, 1000.0, {}, {});
  EXPECT_EQ(empty.face_mask, 0u);
}

// ---------------------------------------------------------------------------------------------
// GPU packing

TEST(Pack, ShadowGpuFieldsAndRebasing) {
  ShadowConfig config;
  config.cascade_count = 3;
  const glm::dvec3 origin(5000.0, 12.0, -7000.0);
  const Camera camera = default_camera(origin + glm::dvec3(0.25, 2.0, 0.5));
  const DirectionalLight light = default_light();
  const CascadeSet set = compute_cascades(config, camera, light, default_scene(origin));
  const glm::dvec3 render_origin = camera.position;
  const ShadowGpu gpu = pack_shadow(set, render_origin);
  EXPECT_EQ(gpu.counts, glm::uvec4(3u, 1u, 2048u, 0u));
  EXPECT_FLOAT_EQ(gpu.splits[0].x, static_cast<float>(set.splits[1]));
  EXPECT_FLOAT_EQ(gpu.splits[0].z, static_cast<float>(set.splits[3]));
  EXPECT_FLOAT_EQ(gpu.splits[1].w, static_cast<float>(set.splits[3]));  // unused repeat last
  EXPECT_FLOAT_EQ(gpu.selection.x, 0.1f);
  EXPECT_FLOAT_EQ(gpu.selection.z, 150.0f);
  const glm::dvec3 to_light = -glm::normalize(light.direction);
  EXPECT_NEAR(gpu.light_dir_angular.x, to_light.x, 1e-7);
  EXPECT_NEAR(gpu.light_dir_angular.y, to_light.y, 1e-7);
  EXPECT_FLOAT_EQ(gpu.light_dir_angular.w, static_cast<float>(light.angular_diameter));
  EXPECT_NEAR(gpu.pcss.x, std::tan(light.angular_diameter / 2), 1e-9);
  EXPECT_EQ(gpu.camera_position, glm::vec4(0, 0, 0, 1));
  EXPECT_EQ(gpu.cascades[3].params, glm::vec4(0.0f));
  std::mt19937_64 rng(61);
  for (std::uint32_t c = 0; c < 3; ++c) {
    const Cascade& cascade = set.cascades[c];
    EXPECT_FLOAT_EQ(gpu.cascades[c].params.x, static_cast<float>(cascade.texel_world_size));
    EXPECT_FLOAT_EQ(gpu.cascades[c].params.w,
                    static_cast<float>(cascade.box_max.x - cascade.box_min.x));
    for (int i = 0; i < 200; ++i) {
      const glm::dvec3 p =
          frustum_point(camera, test::uniform(rng, cascade.fit_near, cascade.fit_far),
                        test::uniform(rng, -1, 1), test::uniform(rng, -1, 1));
      // The float matrix on origin-relative positions agrees with the double one.
      const glm::dvec2 a = texel_coord(cascade.view_proj, p, set.resolution);
      const glm::dvec2 b =
          test::texel_coord_gpu(gpu.cascades[c].view_proj, p, render_origin, set.resolution);
      EXPECT_NEAR(a.x, b.x, 2e-3);
      EXPECT_NEAR(a.y, b.y, 2e-3);
      // params.yz is the depth range measured along the light from the render origin.
      const double s = glm::dot(-glm::dvec3(gpu.light_dir_angular), p - render_origin);
      const double reverse =
          (gpu.cascades[c].params.z - s) / (gpu.cascades[c].params.z - gpu.cascades[c].params.y);
      EXPECT_NEAR(reverse, project_point(cascade.view_proj, p).z, 1e-4);
    }
  }
}

TEST(Pack, SpotAndPointGpu) {
  SpotLight spot;
  spot.position = glm::dvec3(10.0, 5.0, 3.0);
  spot.outer_angle = 0.5;
  const SpotShadow s = compute_spot_shadow(spot, SpotShadowConfig{});
  const SpotShadowGpu sg = pack_spot_shadow(s, glm::dvec3(10.0, 0.0, 0.0));
  EXPECT_EQ(glm::vec3(sg.position_near), glm::vec3(0.0f, 5.0f, 3.0f));
  EXPECT_FLOAT_EQ(sg.params.x, static_cast<float>(std::cos(0.5)));
  EXPECT_FLOAT_EQ(sg.params.y, static_cast<float>(std::tan(0.5)));
  EXPECT_EQ(sg.info, glm::uvec4(1024u, 1u, 0u, 0u));
  const glm::dvec3 p = spot.position + glm::dvec3(0.3, -4.0, 0.2);
  const glm::dvec3 expected = project_point(s.view_proj, p);
  const glm::vec4 clip = sg.view_proj * glm::vec4(glm::vec3(p - glm::dvec3(10.0, 0.0, 0.0)), 1.0f);
  EXPECT_NEAR(clip.x / clip.w, expected.x, 1e-5);
  EXPECT_NEAR(clip.z / clip.w, expected.z, 1e-5);

  const PointShadow ps = compute_point_shadow(PointLight{glm::dvec3(1, 2, 3), 8.0}, {});
  const PointShadowGpu pg = pack_point_shadow(ps, glm::dvec3(1, 2, 3));
  EXPECT_EQ(pg.position, glm::vec4(0, 0, 0, 1));
  EXPECT_EQ(pg.depth_range, glm::vec4(0.0f, 8.0f, 0.125f, 0.05f));
  EXPECT_EQ(pg.info, glm::uvec4(0x3fu, 1u, 512u, 0u));
}

}  // namespace
}  // namespace penumbra::shadow
