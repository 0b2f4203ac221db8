// The program registry: programs are rebuilt exactly when a file they read changes, a failed
// compile or create keeps the last good program, and the dependency lists follow the includes.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <penumbra/shader/registry.hpp>
#include <string>

namespace penumbra::shader {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

struct Tree {
  fs::path root;
  Tree() {
    root = fs::temp_directory_path() /
           ("penumbra-registry-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root);
    fs::create_directories(root / "lib");
    write("lib/a.glsl", "float a() { return 1.0; }\n");
    write("lib/b.glsl", "float b() { return 2.0; }\n");
    write("one.comp", stage("lib/a.glsl", "a()"));
    write("two.comp", stage("lib/b.glsl", "b()"));
  }
  ~Tree() {
    std::error_code ec;
    fs::remove_all(root, ec);
  }
  static std::string stage(const std::string& include, const std::string& call) {
    return "#version 460\n#include \"" + include +
           "\"\nlayout(local_size_x = 1) in;\n"
           "layout(std430, binding = 0) buffer B { float v[]; };\n"
           "void main() { v[0] = " + call + "; }\n";
  }
  void write(const std::string& file, const std::string& text) const {
    std::ofstream(root / file) << text;
  }
};

TEST(ProgramRegistry, RebuildsExactlyTheProgramsThatReadAChangedFile) {
  Tree t;
  ProgramRegistry r(t.root);
  int one = 0, two = 0;
  r.add("one", {{"one.comp", {}}}, [&](const Spirvs& s) {
    ASSERT_EQ(s.size(), 1u);
    EXPECT_FALSE(s[0].empty());
    ++one;
  });
  r.add("two", {{"two.comp", {}}}, [&](const Spirvs&) { ++two; });
  EXPECT_EQ(one, 1);
  EXPECT_EQ(two, 1);
  EXPECT_THAT(r.names(), ElementsAre("one", "two"));
  EXPECT_THAT(r.programs_reading(t.root / "lib/a.glsl"), ElementsAre("one"));
  EXPECT_EQ(r.files().size(), 4u);

  int waits = 0;
  auto res = r.reload({t.root / "lib/b.glsl"}, [&] { ++waits; });
  EXPECT_THAT(res.rebuilt, ElementsAre("two"));
  EXPECT_TRUE(res.ok());
  EXPECT_EQ(one, 1);
  EXPECT_EQ(two, 2);
  EXPECT_EQ(waits, 1);
  res = r.reload({t.root / "unrelated.glsl"}, [&] { ++waits; });
  EXPECT_THAT(res.rebuilt, IsEmpty());
  EXPECT_EQ(waits, 1);  // nothing to create: no wait
}

TEST(ProgramRegistry, AFailedCompileKeepsTheLastGoodProgramAndNamesTheFile) {
  Tree t;
  ProgramRegistry r(t.root);
  int created = 0;
  r.add("one", {{"one.comp", {}}}, [&](const Spirvs&) { ++created; });
  t.write("lib/a.glsl", "float a() { return 1.0 }\n");  // missing ';'
  auto res = r.reload({t.root / "lib/a.glsl"});
  EXPECT_THAT(res.failed, ElementsAre("one"));
  ASSERT_EQ(res.errors.size(), 1u);
  EXPECT_THAT(res.errors[0], HasSubstr("a.glsl:1"));
  EXPECT_EQ(created, 1);
  t.write("lib/a.glsl", "float a() { return 3.0; }\n");
  res = r.reload({t.root / "lib/a.glsl"});
  EXPECT_THAT(res.rebuilt, ElementsAre("one"));
  EXPECT_EQ(created, 2);
}

TEST(ProgramRegistry, IncludesFollowTheEditAndCreateErrorsAreReported) {
  Tree t;
  ProgramRegistry r(t.root);
  bool fail = false;
  r.add("one", {{"one.comp", {}}}, [&](const Spirvs&) {
    if (fail) throw Error("create failed");
  });
  t.write("one.comp", Tree::stage("lib/b.glsl", "b()"));  // now reads b, not a
  EXPECT_THAT(r.reload({t.root / "one.comp"}).rebuilt, ElementsAre("one"));
  EXPECT_THAT(r.programs_reading(t.root / "lib/a.glsl"), IsEmpty());
  EXPECT_THAT(r.programs_reading(t.root / "lib/b.glsl"), ElementsAre("one"));
  fail = true;
  const auto res = r.reload({t.root / "lib/b.glsl"});
  EXPECT_THAT(res.failed, ElementsAre("one"));
  EXPECT_THAT(res.errors, ElementsAre("create failed"));
  EXPECT_THROW(r.add("bad", {{"missing.comp", {}}}, [](const Spirvs&) {}), Error);
}

}  // namespace
}  // namespace penumbra::shader
