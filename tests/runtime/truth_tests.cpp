// --truth's deltas as text (runtime/truth.hpp): a change within the noise is called so, and two
// snapshots of different views (the camera moved, a setting changed between saves) say that
// their deltas compare two views.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "truth.hpp"

namespace penumbra::runtime {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::Not;

TruthSnapshot snapshot(double ms, std::vector<std::string> settings) {
  TruthSnapshot s;
  s.frame_ms = ms;
  s.spread_ms = 0.1;
  s.settings = std::move(settings);
  TruthLight sun;
  sun.name = "sun";
  sun.mean_abs = 0.001;
  s.lights.push_back(sun);
  s.pixels = {1, 2, 3, 4};
  return s;
}

std::string joined(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& l : lines) out += l + "\n";
  return out;
}

TEST(Truth, DeltasSayWhenTheViewChangedBetweenSnapshots) {
  const TruthSnapshot a = snapshot(10.0, {"camera.fov_y=50", "camera.position=0,2,6"});
  TruthSnapshot b = snapshot(10.1, {"camera.fov_y=50", "camera.position=0,2,6"});
  EXPECT_THAT(changed_settings(a, b), IsEmpty());
  EXPECT_TRUE(gpu_change_is_noise(a, b));
  EXPECT_THAT(joined(truth_lines(a, b)), Not(HasSubstr("view changed")));
  EXPECT_THAT(joined(truth_lines(a, b)), HasSubstr("within the noise"));

  b.settings = {"camera.fov_y=50", "camera.position=1,2,6"};
  EXPECT_THAT(changed_settings(a, b), ElementsAre("camera.position"));
  EXPECT_THAT(joined(truth_lines(a, b)),
              HasSubstr("the view changed since the last snapshot (camera.position)"));
  EXPECT_THAT(joined(truth_since(a, b)), HasSubstr("the view changed since then"));
  // A key only one side has counts too (a light added by a rebuilt scene).
  b.settings.push_back("spot[0].range=20");
  EXPECT_THAT(changed_settings(a, b), ElementsAre("camera.position", "spot[0].range"));
  b.frame_ms = 20.0;
  EXPECT_FALSE(gpu_change_is_noise(a, b));
}

}  // namespace
}  // namespace penumbra::runtime
