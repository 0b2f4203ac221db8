// Invalid inputs are rejected with a penumbra::Error naming the field and its value.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>
#include <limits>
#include <penumbra/core/error.hpp>
#include <penumbra/shadow/shadow.hpp>
#include <string>
#include <vector>

#include "shadow_test_util.hpp"

namespace penumbra::shadow {
namespace {

using testing::HasSubstr;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

struct Inputs {
  ShadowConfig config;
  Camera camera = test::default_camera();
  DirectionalLight light = test::default_light();
  Aabb scene = test::default_scene();
};

// Runs compute_cascades on default inputs changed by `mutate`; returns the error message ("" if
// it did not throw a penumbra::Error).
std::string cascade_error(const std::function<void(Inputs&)>& mutate) {
  Inputs in;
  mutate(in);
  try {
    const CascadeSet set = compute_cascades(in.config, in.camera, in.light, in.scene);
    for (const Cascade& c : set.cascades) {
      EXPECT_TRUE(is_finite(c.view_proj));
    }
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

struct Case {
  const char* name;
  std::function<void(Inputs&)> mutate;
  std::vector<std::string> expected;  // substrings of the message
};

TEST(Validation, ExactMessageFormat) {
  EXPECT_EQ(cascade_error([](Inputs& in) { in.config.cascade_count = 0; }),
            "ShadowConfig.cascade_count = 0: must be in [1, 8]");
  EXPECT_EQ(cascade_error([](Inputs& in) { in.config.split_lambda = 1.5; }),
            "ShadowConfig.split_lambda = 1.5: must be in [0, 1]");
}

TEST(Validation, InvalidCascadeInputsAreRejectedWithTheirField) {
  const std::vector<Case> cases = {
      {"count 0", [](Inputs& in) { in.config.cascade_count = 0; }, {"cascade_count", "= 0"}},
      {"count 9", [](Inputs& in) { in.config.cascade_count = 9; }, {"cascade_count", "= 9"}},
      {"lambda -0.1", [](Inputs& in) { in.config.split_lambda = -0.1; }, {"split_lambda", "-0.1"}},
      {"lambda nan", [](Inputs& in) { in.config.split_lambda = kNan; }, {"split_lambda", "nan"}},
      {"max 0", [](Inputs& in) { in.config.max_distance = 0.0; }, {"max_distance", "= 0"}},
      {"max -5", [](Inputs& in) { in.config.max_distance = -5.0; }, {"max_distance", "-5"}},
      {"max nan", [](Inputs& in) { in.config.max_distance = kNan; }, {"max_distance", "nan"}},
      {"max inf", [](Inputs& in) { in.config.max_distance = kInf; }, {"max_distance", "inf"}},
      {"max below near",
       [](Inputs& in) { in.config.max_distance = 0.05; },
       {"ShadowConfig.max_distance = 0.05", "Camera.near"}},
      {"resolution 8", [](Inputs& in) { in.config.resolution = 8; }, {"resolution", "= 8"}},
      {"resolution huge",
       [](Inputs& in) { in.config.resolution = 100000; },
       {"resolution", "100000"}},
      {"guard", [](Inputs& in) { in.config.guard_texels = 1000; }, {"guard_texels", "1000"}},
      {"blend", [](Inputs& in) { in.config.blend_fraction = 0.7; }, {"blend_fraction", "0.7"}},
      {"fade", [](Inputs& in) { in.config.fade_fraction = kNan; }, {"fade_fraction", "nan"}},
      {"fit", [](Inputs& in) { in.config.fit = static_cast<CascadeFit>(7); }, {"fit", "7"}},
      {"depth",
       [](Inputs& in) { in.config.depth = static_cast<DepthConvention>(5); },
       {"ShadowConfig.depth", "5"}},
      {"pcss search",
       [](Inputs& in) { in.config.pcss.blocker_search_texels = 0.0; },
       {"pcss.blocker_search_texels"}},
      {"pcss filter",
       [](Inputs& in) { in.config.pcss.max_filter_texels = 0.5; },
       {"pcss.max_filter_texels", "0.5"}},
      {"near 0", [](Inputs& in) { in.camera.near = 0.0; }, {"Camera.near", "= 0"}},
      {"near -1", [](Inputs& in) { in.camera.near = -1.0; }, {"Camera.near", "-1"}},
      {"near nan", [](Inputs& in) { in.camera.near = kNan; }, {"Camera.near", "nan"}},
      {"far < near", [](Inputs& in) { in.camera.far = 0.05; }, {"Camera.far", "0.05"}},
      {"far nan", [](Inputs& in) { in.camera.far = kNan; }, {"Camera.far", "nan"}},
      {"fov 0", [](Inputs& in) { in.camera.fov_y = 0.0; }, {"Camera.fov_y"}},
      {"fov 4", [](Inputs& in) { in.camera.fov_y = 4.0; }, {"Camera.fov_y", "4"}},
      {"aspect", [](Inputs& in) { in.camera.aspect = 0.0; }, {"Camera.aspect"}},
      {"forward zero",
       [](Inputs& in) { in.camera.forward = glm::dvec3(0.0); },
       {"Camera.forward", "(0, 0, 0)"}},
      {"up parallel",
       [](Inputs& in) { in.camera.up = 2.0 * in.camera.forward; },
       {"Camera.up", "parallel"}},
      {"position nan", [](Inputs& in) { in.camera.position.y = kNan; }, {"Camera.position", "nan"}},
      {"light zero",
       [](Inputs& in) { in.light.direction = glm::dvec3(0.0); },
       {"DirectionalLight.direction", "(0, 0, 0)"}},
      {"light nan",
       [](Inputs& in) { in.light.direction.x = kNan; },
       {"DirectionalLight.direction", "nan"}},
      {"light inf",
       [](Inputs& in) { in.light.direction.z = kInf; },
       {"DirectionalLight.direction", "inf"}},
      {"angular",
       [](Inputs& in) { in.light.angular_diameter = -0.01; },
       {"angular_diameter", "-0.01"}},
      {"scene point",
       [](Inputs& in) {
         in.scene = Aabb{glm::dvec3(1.0), glm::dvec3(1.0)};
       },
       {"scene_bounds", "positive size"}},
      {"scene inverted",
       [](Inputs& in) { std::swap(in.scene.min.x, in.scene.max.x); },
       {"scene_bounds", "min must be <= max"}},
      {"scene nan", [](Inputs& in) { in.scene.max.z = kNan; }, {"scene_bounds.max", "nan"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string message = cascade_error(c.mutate);
    ASSERT_FALSE(message.empty()) << "accepted";
    for (const std::string& s : c.expected) EXPECT_THAT(message, HasSubstr(s));
  }
}

TEST(Validation, ValidEdgeInputsAreAccepted) {
  // Control for the cases above: the boundaries themselves are valid.
  const std::vector<std::function<void(Inputs&)>> valid = {
      [](Inputs& in) { in.config.cascade_count = 1; },
      [](Inputs& in) { in.config.cascade_count = 8; },
      [](Inputs& in) { in.config.split_lambda = 0.0; },
      [](Inputs& in) { in.config.split_lambda = 1.0; },
      [](Inputs& in) { in.camera.far = kInf; },
      [](Inputs& in) { in.light.angular_diameter = 0.0; },
      [](Inputs& in) { in.config.guard_texels = 0; },
      // A flat ground plane is a valid scene.
      [](Inputs& in) { in.scene.max.y = in.scene.min.y; },
  };
  for (std::size_t i = 0; i < valid.size(); ++i) {
    EXPECT_EQ(cascade_error(valid[i]), "") << i;
  }
}

template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Validation, SplitsClipmapSpotAndPoint) {
  EXPECT_THAT(error_of([] { pssm_splits(0.0, 10.0, 4, 0.5); }), HasSubstr("pssm_splits.near"));
  EXPECT_THAT(error_of([] { pssm_splits(1.0, 1.0, 4, 0.5); }), HasSubstr("pssm_splits.far"));
  EXPECT_THAT(error_of([] { pssm_splits(1.0, 10.0, 0, 0.5); }), HasSubstr("pssm_splits.count"));
  EXPECT_THAT(error_of([] { pssm_splits(1.0, 10.0, 4, kNan); }),
              HasSubstr("pssm_splits.lambda = nan"));

  const auto clipmap = [](ClipmapConfig config) {
    return error_of([&] {
      compute_clipmap(config, glm::dvec3(0.0), test::default_light(), test::default_scene());
    });
  };
  ClipmapConfig cm;
  cm.level_count = 0;
  EXPECT_THAT(clipmap(cm), HasSubstr("ClipmapConfig.level_count = 0"));
  cm.level_count = 9;
  EXPECT_THAT(clipmap(cm), HasSubstr("ClipmapConfig.level_count = 9"));
  cm = ClipmapConfig{};
  cm.base_extent = -2.0;
  EXPECT_THAT(clipmap(cm), HasSubstr("ClipmapConfig.base_extent = -2"));
  EXPECT_THAT(error_of([] {
                compute_clipmap(ClipmapConfig{}, glm::dvec3(kNan), test::default_light(),
                                test::default_scene());
              }),
              HasSubstr("camera_position"));

  const auto spot = [](SpotLight light, SpotShadowConfig config) {
    return error_of([&] { compute_spot_shadow(light, config); });
  };
  SpotLight sl;
  sl.outer_angle = 0.0;
  EXPECT_THAT(spot(sl, {}), HasSubstr("SpotLight.outer_angle = 0"));
  sl.outer_angle = 1.6;
  EXPECT_THAT(spot(sl, {}), HasSubstr("SpotLight.outer_angle = 1.6"));
  sl = SpotLight{};
  sl.direction = glm::dvec3(0.0);
  EXPECT_THAT(spot(sl, {}), HasSubstr("SpotLight.direction"));
  sl = SpotLight{};
  sl.range = kNan;
  EXPECT_THAT(spot(sl, {}), HasSubstr("SpotLight.range = nan"));
  SpotShadowConfig sc;
  sc.near = 30.0;
  EXPECT_THAT(spot(SpotLight{}, sc), HasSubstr("SpotShadowConfig.near = 30"));

  const auto point = [](PointLight light, PointShadowConfig config) {
    return error_of([&] { compute_point_shadow(light, config); });
  };
  EXPECT_THAT(point(PointLight{glm::dvec3(0.0), 0.0}, {}), HasSubstr("PointLight.range = 0"));
  PointShadowConfig pc;
  pc.near = 20.0;
  EXPECT_THAT(point(PointLight{glm::dvec3(0.0), 10.0}, pc),
              HasSubstr("PointShadowConfig.near = 20"));
  pc = PointShadowConfig{};
  pc.resolution = 4;
  EXPECT_THAT(point(PointLight{}, pc), HasSubstr("PointShadowConfig.resolution = 4"));

  const std::vector<Aabb> inverted = {Aabb{glm::dvec3(0.0), glm::dvec3(1.0)},
                                      Aabb{glm::dvec3(1.0), glm::dvec3(0.0)}};
  EXPECT_THAT(error_of([&] {
                fit_point_shadow(glm::dvec3(0.0), test::default_camera(), 100.0, inverted, {});
              }),
              HasSubstr("objects[1]"));
  EXPECT_THAT(error_of([&] {
                fit_point_shadow(glm::dvec3(0.0), test::default_camera(), kNan, inverted, {});
              }),
              HasSubstr("max_distance = nan"));
}

}  // namespace
}  // namespace penumbra::shadow
