// GLSL coverage from the shader-function harness (penumbra/testing/coverage.hpp): exact line,
// branch and function counts for a fixture whose control flow is known, on the GPU with the
// validation layer on (it validates the instrumented SPIR-V too).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/coverage.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

namespace fs = std::filesystem;
using penumbra::testing::ShaderFunction;
using ::testing::HasSubstr;
using ::testing::Not;

namespace {

const fs::path kFixture = fs::path(PENUMBRA_TEST_DATA_DIR) / "harness" / "coverage.glsl";

// The line of the fixture that ends in "// @marker".
uint32_t line_of(const std::string& marker) {
  std::ifstream in(kFixture);
  std::string text;
  for (uint32_t n = 1; std::getline(in, text); ++n) {
    const auto at = text.find("// @" + marker);
    if (at != std::string::npos &&
        text.substr(at + 4 + marker.size()).find_first_not_of(' ') == std::string::npos)
      return n;
  }
  ADD_FAILURE() << "no marker @" << marker << " in " << kFixture;
  return 0;
}

// One file's record of an LCOV tracefile.
struct Record {
  std::map<uint32_t, uint64_t> lines;                              // DA
  std::map<std::string, uint64_t> functions;                       // FNDA
  std::map<std::tuple<uint32_t, int, int>, std::string> branches;  // BRDA line, block, side
};

std::map<std::string, Record> parse(const std::string& tracefile) {
  std::map<std::string, Record> files;
  Record* r = nullptr;
  std::istringstream in(tracefile);
  for (std::string l; std::getline(in, l);) {
    if (l.rfind("SF:", 0) == 0) r = &files[l.substr(3)];
    if (r == nullptr) continue;
    if (l.rfind("DA:", 0) == 0) {
      const auto comma = l.find(',');
      r->lines[uint32_t(std::stoul(l.substr(3, comma - 3)))] = std::stoull(l.substr(comma + 1));
    } else if (l.rfind("FNDA:", 0) == 0) {
      const auto comma = l.find(',');
      r->functions[l.substr(comma + 1)] = std::stoull(l.substr(5, comma - 5));
    } else if (l.rfind("BRDA:", 0) == 0) {
      std::vector<std::string> f;
      std::istringstream fs(l.substr(5));
      for (std::string x; std::getline(fs, x, ',');) f.push_back(x);
      r->branches[{uint32_t(std::stoul(f[0])), std::stoi(f[1]), std::stoi(f[2])}] = f[3];
    }
  }
  return files;
}

const fs::path kDirectory = fs::path(PENUMBRA_COVERAGE_TEST_DIR);

}  // namespace

// First, before any wrapper turns coverage on: a directory that cannot be made is an error
// that names it (the test that compiles the wrapper fails), never a silent loss.
TEST(Coverage, ADirectoryThatCannotBeMadeIsAnErrorNamingIt) {
  ::setenv("PENUMBRA_COVERAGE", "/dev/null/coverage", 1);
  try {
    (void)penumbra::testing::coverage_directory();
    FAIL() << "no error";
  } catch (const penumbra::Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("PENUMBRA_COVERAGE='/dev/null/coverage'"));
  }
}

TEST(Coverage, LinesBranchesAndFunctionsAreCountedExactly) {
  ::setenv("PENUMBRA_COVERAGE", kDirectory.c_str(), 1);
  ShaderFunction<int(float)> classify(kFixture, "classify");
  const auto before = parse(penumbra::testing::coverage_tracefile());
  const std::vector<float> xs{-3, -1, -0.5f, -1e-6f, 0, 0.5f, 1, 2, 3, 4};  // 4 negative
  std::vector<std::tuple<float>> cases(xs.begin(), xs.end());
  const auto got = classify.run(cases);
  for (size_t i = 0; i < xs.size(); ++i) EXPECT_EQ(got[i], xs[i] < 0 ? -1 : 3) << xs[i];

  const auto files = parse(penumbra::testing::coverage_tracefile());
  for (const auto& [file, r] : files) EXPECT_THAT(file, Not(HasSubstr("penumbra-wrapper")));
  const std::string name = fs::canonical(kFixture).string();
  ASSERT_TRUE(files.count(name)) << penumbra::testing::coverage_tracefile();
  const Record& r = files.at(name);
  const Record none;
  const Record& r0 = before.count(name) ? before.at(name) : none;
  // What this run added (the process's totals may hold earlier tests' runs).
  auto da = [&](const char* marker) -> int64_t {
    const uint32_t line = line_of(marker);
    if (!r.lines.count(line)) return -1;  // not an instrumented line: fails below
    return int64_t(r.lines.at(line)) - (r0.lines.count(line) ? int64_t(r0.lines.at(line)) : 0);
  };
  auto calls = [&](const std::string& f) -> int64_t {
    if (!r.functions.count(f)) return -1;
    return int64_t(r.functions.at(f)) - (r0.functions.count(f) ? int64_t(r0.functions.at(f)) : 0);
  };
  auto branch = [&](const char* marker, int side) -> int64_t {
    const std::tuple<uint32_t, int, int> key{line_of(marker), 0, side};
    auto value = [&](const Record& rec) -> int64_t {
      if (!rec.branches.count(key)) return 0;
      const std::string& v = rec.branches.at(key);
      return v == "-" ? 0 : std::stoll(v);
    };
    if (!r.branches.count(key)) return -1;
    return value(r) - value(r0);
  };
  EXPECT_EQ(da("classify-decl"), 10);
  EXPECT_EQ(da("if"), 10);
  EXPECT_EQ(da("negative"), 4);
  EXPECT_EQ(da("after-if"), 6);
  EXPECT_EQ(da("loop"), 24);  // the condition: 4 tests in each of 6 invocations
  EXPECT_EQ(da("loop-body"), 18);
  EXPECT_EQ(da("return"), 6);
  // Kept although nothing calls it: its lines count as not run.
  EXPECT_EQ(da("never-decl"), 0);
  EXPECT_EQ(da("never-body"), 0);
  EXPECT_EQ(r.lines.at(line_of("never-body")), 0u);
  EXPECT_EQ(calls("classify(float)"), 10);
  EXPECT_EQ(calls("never_called(int)"), 0);
  EXPECT_EQ(r.functions.at("never_called(int)"), 0u);
  // glslang's mangled names, readable (and without the commas LCOV's records cannot hold).
  EXPECT_EQ(r.functions.at("sample_twice(sampler2DShadow; vec3; mat3x4[2])"), 0u)
      << penumbra::testing::coverage_tracefile();
  EXPECT_EQ(r.lines.at(line_of("sample-body")), 0u);
  // if: true 4, false 6; the loop's condition: true 18, false 6.
  EXPECT_EQ(branch("if", 0), 4);
  EXPECT_EQ(branch("if", 1), 6);
  EXPECT_EQ(branch("loop", 0), 18);
  EXPECT_EQ(branch("loop", 1), 6);
}

// More invocations than one dispatch's counter rows hold: the run is split and every part is
// added up.
TEST(Coverage, RunsLargerThanTheCounterBufferAreAddedUpExactly) {
  ::setenv("PENUMBRA_COVERAGE", kDirectory.c_str(), 1);
  ShaderFunction<int(float)> classify(kFixture, "classify");
  const auto before = parse(penumbra::testing::coverage_tracefile());
  auto count = [&](const std::map<std::string, Record>& files, const char* marker) -> uint64_t {
    const auto f = files.find(fs::canonical(kFixture).string());
    if (f == files.end()) return 0;
    const auto l = f->second.lines.find(line_of(marker));
    return l == f->second.lines.end() ? 0 : l->second;
  };
  std::vector<std::tuple<float>> xs(1'500'000);
  size_t negative = 0;
  for (size_t i = 0; i < xs.size(); ++i) {
    xs[i] = i % 7 == 0 ? -1.0f : 1.0f;
    negative += i % 7 == 0;
  }
  const auto got = classify.run(xs);
  EXPECT_EQ(std::count(got.begin(), got.end(), -1), std::ptrdiff_t(negative));
  const auto after = parse(penumbra::testing::coverage_tracefile());
  EXPECT_EQ(count(after, "negative") - count(before, "negative"), negative);
  EXPECT_EQ(count(after, "loop-body") - count(before, "loop-body"), 3 * (xs.size() - negative));
}

TEST(Coverage, TheTracefileIsWrittenWhereAsked) {
  ::setenv("PENUMBRA_COVERAGE", kDirectory.c_str(), 1);
  ShaderFunction<int(float)> classify(kFixture, "classify");
  (void)classify.run(std::vector<std::tuple<float>>{{1.0f}});
  penumbra::testing::write_coverage();
  const fs::path written = kDirectory / ("coverage_tests." + std::to_string(::getpid()) + ".info");
  std::ifstream in(written);
  ASSERT_TRUE(in) << written;
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), penumbra::testing::coverage_tracefile());
  EXPECT_THAT(text.str(), HasSubstr("end_of_record"));
  EXPECT_FALSE(fs::exists(written.string() + ".tmp"));
}

// Coverage keeps the tested file's uncalled functions. One of funcs.glsl's reads a format-less
// storage image, which needs shaderStorageImageReadWithoutFormat; fetch_texel does not. With
// coverage on, testing fetch_texel must work wherever it works without coverage (lavapipe has no
// such reads): the checks run on the plain wrapper, and a kept function that needs more is left
// out of the covered compile.
TEST(Coverage, AnUncalledFunctionsNeedsDoNotFailTheTestedOne) {
  ::setenv("PENUMBRA_COVERAGE", kDirectory.c_str(), 1);
  penumbra::testing::FloatTextureDesc desc;
  desc.width = 4;
  desc.height = 2;
  desc.channels = 4;
  auto tex = penumbra::testing::make_float_texture(desc, std::vector<float>(4 * 2 * 4, 7.0f));
  penumbra::testing::FunctionOptions unchecked;
  unchecked.check_bounds = false;
  ShaderFunction<glm::vec4(penumbra::testing::Sampler2D, glm::ivec2)> fetch(
      fs::path(PENUMBRA_TEST_DATA_DIR) / "harness" / "funcs.glsl", "fetch_texel", unchecked);
  fetch.bind(0, tex);
  const auto got = fetch.run(std::vector<std::tuple<glm::ivec2>>{{glm::ivec2(1, 1)}});
  EXPECT_EQ(got[0], glm::vec4(7.0f));
  EXPECT_THAT(penumbra::testing::coverage_tracefile(), HasSubstr("funcs.glsl"));
}
