// Full-frame render checks on the device: every case of tests/golden/cases.toml against its
// golden for this device class, the budget gate of `penumbra-golden update`, and the shader
// mutations the goldens must catch.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <penumbra/golden/golden.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <sstream>
#include <string>

namespace penumbra::golden {
namespace {
namespace fs = std::filesystem;
using testing::GpuTest;

std::vector<Case> shipped_cases() {
  try {
    return load_cases(golden_root() / "cases.toml");
  } catch (const std::exception&) {
    return {};  // GoldenCases.* (golden_tests) reports the error
  }
}

Case find_case(const std::string& name) {
  for (const auto& c : shipped_cases())
    if (c.name == name) return c;
  throw std::runtime_error("no golden case " + name);
}

fs::path report_root() {
  if (const char* env = std::getenv("PENUMBRA_GOLDEN_REPORT_DIR"); env && *env) return env;
  return fs::current_path() / "golden-report";
}

// ---- every case -----------------------------------------------------------------------------
class GoldenFrame : public GpuTest, public ::testing::WithParamInterface<std::string> {};

TEST_P(GoldenFrame, MatchesItsGoldenRegionByRegion) {
  const Case c = find_case(GetParam());
  const std::string cls = device_class(ctx().info());
  const auto g = load_golden(golden_root() / cls / c.name);
  if (!g)
    GTEST_SKIP() << "no golden for device class " << cls
                 << " (tools/penumbra-golden update --case " << c.name << " writes one)";
  const Frame f = render_case(ctx(), c);
  const Comparison cmp = compare(g->frame, f);
  std::printf("%s (%s):\n%s", c.name.c_str(), cls.c_str(), cmp.summary().c_str());
  if (!cmp.passed()) {
    const fs::path page =
        write_report(report_root() / c.name,
                     {c.name + " (" + cls + ")", "golden by " + g->device, "golden", "actual"},
                     g->frame, f, cmp);
    std::ostringstream msg;
    for (const auto& line : cmp.failures()) msg << "  " << line << "\n";
    ADD_FAILURE() << c.name << " differs from its golden (" << cls << "):\n"
                  << msg.str() << "report: " << page.string();
  }
  // The golden was accepted within its budget (penumbra-golden update records the metrics).
  for (const auto& l : g->frame.lights) {
    ASSERT_TRUE(l.metrics) << l.light << ": golden.toml has no metrics against the reference";
    EXPECT_LE(l.metrics->false_light, c.budget.false_light) << l.light;
    EXPECT_LE(l.metrics->false_shadow, c.budget.false_shadow) << l.light;
  }
}

std::vector<std::string> case_names() {
  std::vector<std::string> names;
  for (const auto& c : shipped_cases()) names.push_back(c.name);
  return names;
}

std::string test_name(const ::testing::TestParamInfo<std::string>& info) {
  std::string s = info.param;
  for (char& ch : s)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return s;
}

INSTANTIATE_TEST_SUITE_P(Cases, GoldenFrame, ::testing::ValuesIn(case_names()), test_name);

// ---- the budget gate ------------------------------------------------------------------------
class GoldenBudget : public GpuTest {};

// update accepts a frame only within its case's budget against the reference: the default
// scene passes the issue-13 budget and fails one that asks for no error at all.
TEST_F(GoldenBudget, AFrameOverItsBudgetIsNotAccepted) {
  Case c = find_case("default");
  c.width = 160;
  c.height = 90;
  reference::MeasureOptions mo;
  mo.trace.samples = 32;
  EXPECT_TRUE(measure_case(ctx(), c, mo).over_budget.empty());
  c.budget.false_light = 0.0;
  c.budget.false_shadow = 0.0;
  c.budget.misclassified = 0.0;
  const auto m = measure_case(ctx(), c, mo);
  ASSERT_FALSE(m.over_budget.empty());
  EXPECT_EQ(m.over_budget[0].rfind("sun: false light", 0), 0u) << m.over_budget[0];
  // The regions come with the measurement: every kind is there.
  ASSERT_EQ(m.frame.lights.size(), 1u);
  for (Region r : {Region::umbra, Region::lit, Region::penumbra, Region::silhouette})
    EXPECT_NE(std::count(m.frame.lights[0].regions.begin(), m.frame.lights[0].regions.end(), r),
              0)
        << to_string(r);
}

// ---- mutations the goldens must catch -------------------------------------------------------
struct Mutation {
  std::string name;
  std::string file;  // under shaders/
  std::string from, to;
  std::string target;  // the case that must fail
};

std::ostream& operator<<(std::ostream& os, const Mutation& m) {
  return os << m.name;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

const std::vector<Mutation>& mutations() {
  static const std::vector<Mutation> m = {
      // A copy of the tree as it is: the copy and --shader-dir themselves change nothing.
      {"unmutated", "penumbra/pcf.glsl", "", "", "default-pcf"},
      // PCF radius + 1 (box PCF on the sun's cascades and the spot maps).
      {"pcf_radius_plus_1", "penumbra/pcf.glsl", "int r = pcf_clamp_radius(radius);",
       "int r = pcf_clamp_radius(radius + 1);", "default-pcf"},
      // The world-space depth bias doubled.
      {"depth_bias_times_2", "penumbra/bias.glsl",
       "return slope_scaled_bias(n_dot_l, c, s * t, c + m * t);",
       "return 2.0 * slope_scaled_bias(n_dot_l, c, s * t, c + m * t);", "default"},
      // The normal offset doubled.
      {"normal_offset_times_2", "penumbra/bias.glsl",
       "float filter_normal_offset_texels(float base_texels, float reach_texels) {",
       "float filter_normal_offset_texels(float base_texels, float reach_texels) {\n"
       "  base_texels *= 2.0;",
       "default"},
      // The blocker test's compare op swapped (PCSS finds the receivers in front of it).
      {"swapped_blocker_compare", "penumbra/pcss.glsl",
       "return reverse_z ? stored > receiver : stored < receiver;",
       "return reverse_z ? stored < receiver : stored > receiver;", "grazing"},
  };
  return m;
}

class GoldenMutation : public GpuTest, public ::testing::WithParamInterface<Mutation> {};

TEST_P(GoldenMutation, TheGoldenCheckCatchesIt) {
  const Mutation& mu = GetParam();
  const Case c = find_case(mu.target);
  const std::string cls = device_class(ctx().info());
  const auto g = load_golden(golden_root() / cls / c.name);
  if (!g) GTEST_SKIP() << "no golden for device class " << cls;
  // A copy of the shader tree with the one edit.
  const fs::path tree = fs::temp_directory_path() /
                        ("penumbra-mutation-" + mu.name + "-" + std::to_string(::getpid()));
  fs::remove_all(tree);
  fs::copy(PENUMBRA_SHADER_DIR, tree, fs::copy_options::recursive);
  if (!mu.from.empty()) {
    const fs::path file = tree / mu.file;
    std::string text = read_text(file);
    size_t count = 0;
    for (size_t at = text.find(mu.from); at != std::string::npos;
         at = text.find(mu.from, at + mu.to.size())) {
      text.replace(at, mu.from.size(), mu.to);
      ++count;
    }
    ASSERT_GT(count, 0u) << mu.file << " no longer contains '" << mu.from
                         << "': update the mutation";
    std::ofstream(file, std::ios::binary) << text;
  }
  const Frame f = render_case(ctx(), c, tree);
  fs::remove_all(tree);
  const Comparison cmp = compare(g->frame, f);
  std::printf("%s on %s:\n%s", mu.name.c_str(), c.name.c_str(), cmp.summary().c_str());
  if (mu.from.empty())
    EXPECT_TRUE(cmp.passed()) << cmp.summary();
  else
    EXPECT_FALSE(cmp.passed()) << "the golden of " << c.name << " does not see " << mu.name;
}

INSTANTIATE_TEST_SUITE_P(Shaders, GoldenMutation, ::testing::ValuesIn(mutations()),
                         [](const ::testing::TestParamInfo<Mutation>& p) {
                           return p.param.name;
                         });

}  // namespace
}  // namespace penumbra::golden
