// The program registry: programs are rebuilt exactly when a file they read changes, a failed
// compile or create keeps the last good program, and the dependency lists follow the includes.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
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
           "void main() { v[0] = " +
           call + "; }\n";
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
  t.write("lib/b.glsl", "float b() { return 2.5; }\n");  // new code: a pipeline is made
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

// A reload says which rebuilt programs got the SPIR-V they had: a comment, or a function they do
// not call, changes no code, and such a program keeps its pipelines (none is made, the GPU is
// not waited for).
TEST(ProgramRegistry, SaysWhichRebuiltProgramsKeptTheirSpirvAndKeepsTheirPipelines) {
  Tree t;
  t.write("lib/a.glsl", "float a() { return 1.0; }\nfloat unused() { return 3.0; }\n");
  ProgramRegistry r(t.root);
  int creates = 0, waits = 0;
  r.add("one", {{"one.comp", {}}}, [&](const Spirvs&) { ++creates; });
  EXPECT_EQ(creates, 1);
  t.write("lib/a.glsl", "// a comment\nfloat a() { return 1.0; }\nfloat unused() { return 4.0; }\n");
  auto res = r.reload({t.root / "lib/a.glsl"}, [&] { ++waits; });
  EXPECT_THAT(res.rebuilt, ElementsAre("one"));
  EXPECT_THAT(res.same_spirv, ElementsAre("one"));
  EXPECT_EQ(creates, 1) << "the same SPIR-V made a pipeline again";
  EXPECT_EQ(waits, 0);
  t.write("lib/a.glsl", "float a() { return 1.5; }\n");
  res = r.reload({t.root / "lib/a.glsl"}, [&] { ++waits; });
  EXPECT_THAT(res.rebuilt, ElementsAre("one"));
  EXPECT_THAT(res.same_spirv, IsEmpty()) << "a() returns another value";
  EXPECT_EQ(creates, 2);
  EXPECT_EQ(waits, 1);
}

// An overlay over a library (penumbra-view --shader-dir DIR over the installed shaders): stage
// files and includes come from the overlay when it has them, else from the library; a file that
// appears in or leaves the overlay rebuilds the programs that read its name in either layer.
TEST(ProgramRegistry, AnOverlayWinsWhereItHasAFileAndTheLibraryGivesTheRest) {
  Tree t;
  const fs::path over = t.root / "over";
  fs::create_directories(over / "lib");
  ProgramRegistry r(over, {t.root});
  std::map<std::string, Spirvs> made;
  r.add("one", {{"one.comp", {}}}, [&](const Spirvs& s) { made["one"] = s; });
  r.add("two", {{"two.comp", {}}}, [&](const Spirvs& s) { made["two"] = s; });
  const Spirvs library_one = made["one"];
  EXPECT_THAT(r.search_path(), ElementsAre(fs::weakly_canonical(over), fs::weakly_canonical(t.root)));
  EXPECT_EQ(r.resolve("one.comp"), fs::weakly_canonical(t.root) / "one.comp");
  EXPECT_EQ(r.layered_name(t.root / "lib/a.glsl"), "lib/a.glsl");
  EXPECT_EQ(r.layered_name(over / "lib/a.glsl"), "lib/a.glsl");

  // The overlay gets its own a.glsl: "one" reads it, "two" is untouched.
  std::ofstream(over / "lib/a.glsl") << "float a() { return 5.0; }\n";
  auto res = r.reload({over / "lib/a.glsl"});
  EXPECT_THAT(res.rebuilt, ElementsAre("one"));
  EXPECT_NE(made["one"], library_one);
  EXPECT_THAT(r.programs_reading(over / "lib/a.glsl"), ElementsAre("one"));
  // A stage file in the overlay.
  t.write("over/two.comp", Tree::stage("lib/a.glsl", "a() + 1.0"));
  res = r.reload({over / "two.comp"});
  EXPECT_THAT(res.rebuilt, ElementsAre("two"));
  EXPECT_EQ(r.resolve("two.comp"), fs::weakly_canonical(over) / "two.comp");
  // Removed from the overlay: the library's again, bit for bit.
  fs::remove(over / "lib/a.glsl");
  res = r.reload({t.root / "lib/a.glsl"});
  EXPECT_THAT(res.rebuilt, ElementsAre("one", "two"));
  EXPECT_EQ(made["one"], library_one);
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

// An edit that compiles but moves a binding, changes its type, shifts a block member, changes
// the push constants, the workgroup size or an output is refused before anything is created,
// naming the file:line of the declaration; dropping a binding or a trailing member is not a
// change the pipeline cares about.
TEST(ProgramRegistry, AnEditThatChangesTheInterfaceIsRefusedNamingTheDeclaration) {
  Tree t;
  const std::string good =
      "#version 460\n"
      "layout(local_size_x = 8) in;\n"
      "struct Params { vec4 scale; vec4 offset; };\n"
      "layout(std140, set = 0, binding = 0) uniform P { Params params; };\n"
      "layout(std430, set = 0, binding = 1) buffer B { float v[]; };\n"
      "layout(push_constant) uniform Push { uint count; } pc;\n"
      "void main() { v[gl_GlobalInvocationID.x] = params.scale.x + params.offset.y + "
      "float(pc.count); }\n";
  t.write("i.comp", good);
  ProgramRegistry r(t.root);
  int created = 0;
  r.add("i", {{"i.comp", {}}}, [&](const Spirvs&) { ++created; });
  struct Case {
    std::string from, to, says;
    int line;
  };
  const std::vector<Case> refused{
      {"set = 0, binding = 1) buffer", "set = 1, binding = 1) buffer",
       "set 1, binding 1 (storage_buffer 'B') is new", 5},
      {"set = 0, binding = 1) buffer", "set = 0, binding = 9) buffer",
       "set 0, binding 9 (storage_buffer 'B') is new", 5},
      {"binding = 0) uniform P", "binding = 1) uniform P",
       "set 0, binding 1 was storage_buffer 'B', is now uniform_buffer 'P'", 4},
      {"struct Params { vec4 scale; vec4 offset; }",
       "struct Params { vec4 scale; vec4 extra; vec4 offset; }",
       "P.params.offset was vec4 at offset 16 (size 16), is now vec4 at offset 32", 3},
      {"uint count; } pc", "uint pad; uint count; } pc",
       "Push.count was uint at offset 0 (size 4), is now uint at offset 4", 6},
      {"local_size_x = 8", "local_size_x = 16",
       "workgroup size ('local_size_x') was 8x1x1, is now 16x1x1: the pass sizes its dispatch "
       "for 8x1x1 when the pipeline is built, so a new size takes a restart",
       2},
  };
  for (const Case& c : refused) {
    std::string edited = good;
    ASSERT_NE(edited.find(c.from), std::string::npos) << c.from;
    edited.replace(edited.find(c.from), c.from.size(), c.to);
    t.write("i.comp", edited);
    const auto res = r.reload({t.root / "i.comp"});
    EXPECT_THAT(res.failed, ElementsAre("i")) << c.to;
    EXPECT_THAT(res.rebuilt, IsEmpty());
    ASSERT_EQ(res.errors.size(), 1u);
    EXPECT_THAT(res.errors[0], HasSubstr("changes the interface")) << res.errors[0];
    EXPECT_THAT(res.errors[0], HasSubstr(c.says)) << res.errors[0];
    EXPECT_THAT(res.errors[0],
                HasSubstr((t.root / "i.comp").string() + ":" + std::to_string(c.line) + ": "))
        << res.errors[0];
    EXPECT_EQ(created, 1) << "nothing is created for a refused edit: " << c.to;
  }
  // Using less is fine: no push constants, no uniform block (the layout keeps them unused).
  t.write("i.comp",
          "#version 460\nlayout(local_size_x = 8) in;\n"
          "layout(std430, set = 0, binding = 1) buffer B { float v[]; };\n"
          "void main() { v[gl_GlobalInvocationID.x] = 1.0; }\n");
  const auto res = r.reload({t.root / "i.comp"});
  EXPECT_THAT(res.rebuilt, ElementsAre("i")) << ::testing::PrintToString(res.errors);
  EXPECT_EQ(created, 2);
}

// Graphics stages: a new vertex input or a changed output type is refused.
TEST(ProgramRegistry, VertexInputsAndFragmentOutputsMustStayAsTheyWere) {
  Tree t;
  t.write("s.vert",
          "#version 460\nlayout(location = 0) in vec3 pos;\nlayout(location = 0) out vec2 uv;\n"
          "void main() { uv = pos.xy; gl_Position = vec4(pos, 1.0); }\n");
  t.write("s.frag",
          "#version 460\nlayout(location = 0) in vec2 uv;\nlayout(location = 0) out vec4 color;\n"
          "void main() { color = vec4(uv, 0.0, 1.0); }\n");
  ProgramRegistry r(t.root);
  int created = 0;
  r.add("s", {{"s.vert", {}}, {"s.frag", {}}}, [&](const Spirvs& s) {
    EXPECT_EQ(s.size(), 2u);
    ++created;
  });
  t.write("s.vert",
          "#version 460\nlayout(location = 0) in vec3 pos;\nlayout(location = 3) in vec4 tint;\n"
          "layout(location = 0) out vec2 uv;\n"
          "void main() { uv = pos.xy + tint.xy; gl_Position = vec4(pos, 1.0); }\n");
  auto res = r.reload({t.root / "s.vert"});
  ASSERT_EQ(res.errors.size(), 1u);
  EXPECT_THAT(res.errors[0], HasSubstr("s.vert:3: input at location 3 (vec4 'tint') is new"));
  t.write("s.vert",
          "#version 460\nlayout(location = 0) in vec3 pos;\nlayout(location = 0) out vec2 uv;\n"
          "void main() { uv = pos.xy; gl_Position = vec4(pos, 1.0); }\n");
  t.write("s.frag",
          "#version 460\nlayout(location = 0) in vec2 uv;\n"
          "layout(location = 0) out uvec4 color;\nvoid main() { color = uvec4(uv, 0, 1); }\n");
  res = r.reload({t.root / "s.frag"});
  ASSERT_EQ(res.errors.size(), 1u);
  EXPECT_THAT(res.errors[0], HasSubstr("s.frag:3: output at location 0 was vec4 'color', is now "
                                       "uvec4 'color'"));
  EXPECT_EQ(created, 1);
}

// One edit reaching several programs swaps all of them or none: a compile error in one keeps
// the others' last good pipelines too; a creation that fails puts back those already swapped.
TEST(ProgramRegistry, AReloadIsAllOrNothingAcrossTheProgramsAnEditReaches) {
  Tree t;
  t.write("lib/shared.glsl", "float shared_value() { return 1.0; }\n");
  t.write("one.comp", Tree::stage("lib/shared.glsl", "shared_value()"));
  t.write("two.comp", Tree::stage("lib/shared.glsl", "shared_value() + 1.0"));
  t.write("three.comp", Tree::stage("lib/shared.glsl", "shared_value() * 2.0"));
  ProgramRegistry r(t.root);
  std::map<std::string, std::vector<Spirvs>> made;
  bool fail_three = false;
  for (std::string name : {"one", "two", "three"}) {
    r.add(name, {{name + ".comp", {}}}, [&, name](const Spirvs& s) {
      if (name == "three" && fail_three) throw Error("three: pipeline creation failed");
      made[name].push_back(s);
    });
  }
  // `two` stops compiling against the new helper; `one` and `three` would compile.
  t.write("two.comp", Tree::stage("lib/shared.glsl", "shared_value() + missing_helper()"));
  t.write("lib/shared.glsl", "float shared_value() { return 5.0; }\n");
  auto res = r.reload({t.root / "lib/shared.glsl", t.root / "two.comp"});
  EXPECT_THAT(res.failed, ElementsAre("two"));
  EXPECT_THAT(res.held, ElementsAre("one", "three"));
  EXPECT_THAT(res.rebuilt, IsEmpty());
  for (const auto& [name, list] : made) EXPECT_EQ(list.size(), 1u) << name;

  // All compile, but creating `three` fails: `one` and `two` were swapped, and are put back.
  t.write("two.comp", Tree::stage("lib/shared.glsl", "shared_value() + 1.0"));
  fail_three = true;
  res = r.reload({t.root / "lib/shared.glsl", t.root / "two.comp"});
  EXPECT_THAT(res.failed, ElementsAre("three"));
  EXPECT_THAT(res.held, ElementsAre("one", "two"));
  EXPECT_THAT(res.rebuilt, IsEmpty());
  for (std::string name : {"one", "two"}) {
    ASSERT_EQ(made[name].size(), 3u) << name;  // added, swapped, put back
    EXPECT_EQ(made[name][2], made[name][0]) << name << " runs its last good SPIR-V again";
    EXPECT_NE(made[name][1], made[name][0]) << name;
  }
  // Then it works, and all three swap.
  fail_three = false;
  t.write("lib/shared.glsl", "float shared_value() { return 6.0; }\n");
  res = r.reload({t.root / "lib/shared.glsl"});
  EXPECT_THAT(res.rebuilt, ElementsAre("one", "two", "three"));
  EXPECT_TRUE(res.held.empty());
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
  t.write("lib/b.glsl", "float b() { return 2.5; }\n");
  const auto res = r.reload({t.root / "lib/b.glsl"});
  EXPECT_THAT(res.failed, ElementsAre("one"));
  EXPECT_THAT(res.errors, ElementsAre("create failed"));
  EXPECT_THROW(r.add("bad", {{"missing.comp", {}}}, [](const Spirvs&) {}), Error);
}

// Programs added in two steps: at a reload every program's pipelines are made at once (here a
// rendezvous that each maker waits at until all three arrived: made one after another, the
// first would wait alone), and installed only after before_first_create (the GPU idle), each
// once. A maker that throws installs nothing anywhere and waits for nothing.
TEST(ProgramRegistry, PreparedProgramsAreMadeInParallelAndInstalledTogether) {
  Tree t;
  t.write("lib/shared.glsl", "float shared_value() { return 1.0; }\n");
  std::vector<std::string> names{"one", "two", "three"};
  for (const auto& n : names)
    t.write(n + ".comp", Tree::stage("lib/shared.glsl", "shared_value()"));
  ProgramRegistry r(t.root);
  std::mutex m;
  std::condition_variable cv;
  int arrived = 0;
  bool rendezvous = false, fail_two = false;
  std::vector<std::string> events;
  std::map<std::string, int> met;  // makers that saw all three arrive
  for (const auto& name : names) {
    r.add_prepared(
        name, {{name + ".comp", {}}}, [&, name](const Spirvs&) -> ProgramRegistry::Install {
          if (rendezvous) {
            std::unique_lock lock(m);
            ++arrived;
            cv.notify_all();
            if (cv.wait_for(lock, std::chrono::seconds(10), [&] { return arrived == 3; }))
              ++met[name];
          }
          if (fail_two && name == "two") throw Error("two: pipeline creation failed");
          std::lock_guard lock(m);
          events.push_back("made " + name);
          return [&, name] {
            std::lock_guard install_lock(m);
            events.push_back("installed " + name);
          };
        });
  }
  EXPECT_EQ(events.size(), 6u);  // each made and installed at add()
  events.clear();
  rendezvous = true;
  t.write("lib/shared.glsl", "float shared_value() { return 2.0; }\n");
  auto res = r.reload({t.root / "lib/shared.glsl"}, [&] {
    std::lock_guard lock(m);
    events.push_back("gpu idle");
  });
  EXPECT_THAT(res.rebuilt, ElementsAre("one", "two", "three"));
  for (const auto& n : names) EXPECT_EQ(met[n], 1) << n << " was made alone";
  ASSERT_EQ(events.size(), 7u);
  for (size_t i = 0; i < 3; ++i) EXPECT_THAT(events[i], ::testing::StartsWith("made "));
  EXPECT_EQ(events[3], "gpu idle");
  EXPECT_THAT(std::vector<std::string>(events.begin() + 4, events.end()),
              ElementsAre("installed one", "installed two", "installed three"));

  events.clear();
  rendezvous = false;
  fail_two = true;
  t.write("lib/shared.glsl", "float shared_value() { return 3.0; }\n");
  res = r.reload({t.root / "lib/shared.glsl"}, [&] { events.push_back("gpu idle"); });
  EXPECT_THAT(res.failed, ElementsAre("two"));
  EXPECT_THAT(res.held, ElementsAre("one", "three"));
  EXPECT_THAT(res.errors, ElementsAre("two: pipeline creation failed"));
  EXPECT_THAT(events, ::testing::UnorderedElementsAre("made one", "made three"));
}

}  // namespace
}  // namespace penumbra::shader
