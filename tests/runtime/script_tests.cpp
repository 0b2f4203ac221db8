// penumbra-view's automation mode: a script that sets parameters, renders, takes screenshots and
// edits shaders end to end (the real executable, on a copy of the shader tree), and errors that
// name the script line.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <sstream>

#include "script.hpp"
#include "temp_tree.hpp"

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using testing::GpuTest;
using ::testing::HasSubstr;
using ::testing::Not;
using testing::TempTree;

struct Run {
  int status = 0;
  std::string output;
};

Run view(const std::string& args) {
  const std::string cmd = std::string(PENUMBRA_VIEW_EXE) + " --headless " + args + " 2>&1";
  Run r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return {-1, "popen failed"};
  char buf[512];
  while (fgets(buf, sizeof buf, p)) r.output += buf;
  r.status = pclose(p);
  return r;
}

TEST(SplitCommand, SplitsOnSpacesAndKeepsQuotedText) {
  EXPECT_EQ(runtime::split_command("  set shadows.filter   pcss # comment"),
            (std::vector<std::string>{"set", "shadows.filter", "pcss"}));
  EXPECT_EQ(runtime::split_command(R"(replace f.glsl "a b;" "c \"d\"\n")"),
            (std::vector<std::string>{"replace", "f.glsl", "a b;", "c \"d\"\n"}));
  EXPECT_TRUE(runtime::split_command("# only a comment").empty());
  EXPECT_THROW(runtime::split_command("echo \"open"), Error);
}

TEST(ScriptEndToEnd, SetsRendersScreenshotsAndReloadsWithoutValidationMessages) {
  TempTree tree(true);
  const fs::path pcf = tree.shaders() / "penumbra" / "pcf.glsl";
  const int line =
      testing::line_of(testing::read_text(pcf), "  return clamp(radius, 0, kPcfMaxRadius);");
  ASSERT_GT(line, 0);
  const fs::path script = tree.root() / "check.txt";
  const fs::path a = tree.root() / "a.png", b = tree.root() / "b.png", c = tree.root() / "c.png";
  testing::write_text(script,
                      "# a tour of the commands\n"
                      "scene default\n"
                      "size 160x90\n"
                      "set shadows.resolution 512\n"
                      "set shadows.filter pcss\n"
                      "set contact.steps 0\n"
                      "set shadows.pcf_radius 3\n"
                      "set camera.position 0.5, 2.6, 6.2\n"
                      "view cascades\n"
                      "render 2\n"
                      "screenshot " +
                          a.string() +
                          "\n"
                          "view lit\n"
                          "replace penumbra/pcf.glsl \"kPcfMaxRadius);\" \"kPcfMaxRadius) +;\"\n"
                          "expect_reload_error penumbra/pcf.glsl:" +
                          std::to_string(line) +
                          ":\n"
                          "screenshot " +
                          b.string() +
                          "\n"
                          "replace penumbra/pcf.glsl \"kPcfMaxRadius) +;\" \"kPcfMaxRadius);\"\n"
                          "expect_reload_ok\n"
                          "expect_rebuilt shadow-resolve\n"
                          "screenshot " +
                          c.string() +
                          "\n"
                          "timings\n"
                          "quit\n"
                          "this line is never read\n");
  const auto r = view("--shader-dir " + tree.shaders().string() + " --script " + script.string());
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("[reload] error: "));
  EXPECT_THAT(r.output, HasSubstr("pcf.glsl:" + std::to_string(line) + ":"));
  EXPECT_THAT(r.output, HasSubstr("[reload] rebuilt: shadow-resolve"));
  EXPECT_THAT(r.output, HasSubstr("[reload] latency"));
  EXPECT_THAT(r.output, HasSubstr("reload latency (file event -> first frame"));
  EXPECT_THAT(r.output, HasSubstr("validation:  0 messages"));
  EXPECT_THAT(r.output, Not(HasSubstr("contact-shadows "))) << "contact.steps 0 removes the pass";
  ASSERT_TRUE(fs::exists(a) && fs::exists(b) && fs::exists(c)) << r.output;
  // The cascades view differs from the lit one; the broken edit left the image as it was and
  // the fix restored the same source, so b == c byte for byte (PNG encoding is deterministic).
  EXPECT_NE(testing::read_text(a), testing::read_text(b));
  EXPECT_EQ(testing::read_text(b), testing::read_text(c));
}

TEST(ScriptEndToEnd, AnErrorNamesTheScriptLineAndFails) {
  TempTree tree(false);
  const fs::path script = tree.root() / "bad.txt";
  testing::write_text(script, "size 160x90\n\nset shadows.pcf_radius 9\nrender\n");
  auto r = view("--script " + script.string());
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.output,
              HasSubstr("bad.txt:3: set shadows.pcf_radius 9: expected an integer in [0, 5]"));

  testing::write_text(script, "size 160x90\nrendr 2\n");
  r = view("--script " + script.string());
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.output, HasSubstr("bad.txt:2: unknown command 'rendr'"));

  // A reload of a file that does not exist, and that no pipeline reads, is an error.
  r = view("--size 160x90 --command \"reload /nonexistent.glsl\"");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.output, HasSubstr("--command 1: reload /nonexistent.glsl: /nonexistent.glsl does "
                                  "not exist, and no pipeline reads it"));

  r = view("--size 160x90 --command \"set shadows.filter pcx\"");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(
      r.output,
      HasSubstr("--command 1: set shadows.filter pcx: expected one of hard, pcf, pcss, poisson, "
                "evsm2"));
}

// --set overrides a parameter-table key for the headless frames (what penumbra-bench uses), and
// a bad one is an error naming the flag, the key and the value.
TEST(ViewSet, OverridesAKeyAndRejectsBadOnes) {
  TempTree tree(false);
  const fs::path out = tree.root() / "out";
  auto r = view("--size 160x90 --frames 1 --view lit --out " + out.string() +
                " --set shadows.filter=hard --set contact.steps=0");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_THAT(r.output, Not(HasSubstr("contact-shadows")));  // the pass is not built at 0 steps
  EXPECT_TRUE(fs::exists(out / "lit.png"));
  r = view("--size 160x90 --frames 1 --set shadows.pcf_radius=9");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.output, HasSubstr("--set shadows.pcf_radius=9: "));
  EXPECT_THAT(r.output, HasSubstr("[0, 5]"));
  r = view("--set shadows.pcf_radius");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.output, HasSubstr("expected KEY=VALUE"));
  r = view("--set shadows.filter=hard --command \"render 1\"");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.output, HasSubstr("does not combine"));
}

// The same commands in process, for the error cases that need no frame.
class ScriptTest : public GpuTest {
 protected:
  std::string error_of(const std::string& text) {
    runtime::ScriptSetup setup;
    setup.session.shader_dir = tree.shaders();
    setup.session.width = 160;
    setup.session.height = 90;
    setup.session.log = [](const std::string&) {};
    setup.timeout = std::chrono::milliseconds(300);
    runtime::Script script(ctx(), setup);
    std::istringstream in(text);
    try {
      script.run(in, "t.txt");
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  }
  TempTree tree{true};
};

TEST_F(ScriptTest, ErrorsNameTheLineTheCommandAndTheValue) {
  EXPECT_THAT(error_of("\nscene nowhere_to_be_found\n"), HasSubstr("t.txt:2: scene"));
  EXPECT_THAT(error_of("set shadows.filtr pcf\n"),
              HasSubstr("t.txt:1: set: unknown parameter 'shadows.filtr' (did you mean "
                        "'shadows.filter'?)"));
  EXPECT_THAT(error_of("set camera.position 1,2\n"),
              HasSubstr("t.txt:1: set camera.position 1,2: expected three numbers"));
  EXPECT_THAT(error_of("view wireframe\n"),
              HasSubstr("t.txt:1: view: render.view wireframe: expected one of lit,"));
  EXPECT_THAT(error_of("render 1 2\n"), HasSubstr("t.txt:1: render: expected [N]"));
  EXPECT_THAT(error_of("screenshot out.jpg\n"), HasSubstr("expected a .png path"));
  EXPECT_THAT(error_of("wait_reload 100\n"), HasSubstr("t.txt:1: wait_reload: no edit"));
  EXPECT_THAT(error_of("expect_reload_ok\n"), HasSubstr("t.txt:1: expect_reload_ok: no reload"));
  EXPECT_THAT(error_of("replace penumbra/pcf.glsl \"no such text\" \"x\"\n"),
              HasSubstr("does not occur in"));
  EXPECT_THAT(error_of("echo \"unterminated\n"), HasSubstr("t.txt:1: unterminated"));
  EXPECT_THAT(error_of("\nreload pen" + std::string(1, '\0') + "cf.glsl\n"),
              HasSubstr("t.txt:2: 'reload pen\\0cf.glsl' holds a NUL byte (column 11)"));
  // A reload whose target no pipeline reads says what the path is.
  EXPECT_THAT(error_of("reload penumbra/nothere.glsl\n"),
              HasSubstr("t.txt:1: reload penumbra/nothere.glsl: " +
                        (tree.shaders() / "penumbra/nothere.glsl").string() +
                        " does not exist, and no pipeline reads it"));
  EXPECT_THAT(error_of("reload /dev/zero\n"),
              HasSubstr("t.txt:1: reload /dev/zero: /dev/zero is a character device, not a "
                        "regular file, and no pipeline reads it"));
  testing::write_text(tree.shaders() / "unused.glsl", "float unused() { return 1.0; }\n");
  EXPECT_THAT(error_of("reload unused.glsl\n"),
              HasSubstr("unused.glsl is read by no pipeline: nothing to reload"));
  EXPECT_EQ(error_of("reload penumbra/pcf.glsl\n"), "") << "a file pipelines read reloads";
  EXPECT_EQ(error_of("# nothing but a comment\n\nquit\nrendr\n"), "") << "quit stops the script";
}

TEST_F(ScriptTest, ReplaceRefusesTheRepositoryShaders) {
  runtime::ScriptSetup setup;  // no shader_dir: the repo's shaders/
  setup.session.width = 160;
  setup.session.height = 90;
  setup.session.log = [](const std::string&) {};
  runtime::Script script(ctx(), setup);
  try {
    script.run_line("replace penumbra/pcf.glsl \"a\" \"b\"", "t.txt:1");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("refusing to edit the repository's shaders/"));
  }
}

// Command-line values out of range are errors naming the flag and the range; a directory or a
// device is not a script, a device or a missing path no shader dir; nothing is rendered or written
// for them.
TEST(ViewFlags, OutOfRangeValuesAndADirectoryScriptAreErrors) {
  TempTree tree(false);
  const std::vector<std::pair<std::string, std::string>> cases{
      {"--size 16385x16", "--size 16385x16: width 16385: out of range; must be in [16, 16384]"},
      {"--size 100000x1", "--size 100000x1: width 100000: out of range"},
      {"--size 99999x99999", "out of range; must be in [16, 16384]"},
      {"--size 64x", "--size 64x: height : expected a whole number"},
      {"--frames 0", "--frames 0: out of range; must be in [1, 10000]"},
      {"--frames 1000000", "--frames 1000000: out of range"},
      {"--frames -1", "--frames -1: expected a whole number"},
      {"--script " + tree.root().string(), "is a directory, not a script file"},
      {"--script " + (tree.root() / "missing.txt").string(), "missing.txt: no such file"},
      {"--script /dev/zero", "--script /dev/zero: is a character device, not a script file"},
      {"--shader-dir /dev/zero", "--shader-dir /dev/zero: is a character device, not a directory"},
      {"--shader-dir " + (tree.root() / "none").string(), "none: not found"},
  };
  for (const auto& [flags, says] : cases) {
    const auto r = view(flags + " --out " + (tree.root() / "out").string());
    EXPECT_NE(r.status, 0) << flags;
    EXPECT_THAT(r.output, HasSubstr(says)) << flags;
    EXPECT_FALSE(fs::exists(tree.root() / "out" / "lit.png")) << flags;
  }
}

// --out into an existing directory reuses it and says so; --out naming a file is an error.
TEST(ViewFlags, AnExistingOutputDirectoryIsReusedAndSaidSo) {
  TempTree tree(false);
  const fs::path out = tree.root() / "out";
  auto r = view("--size 160x90 --frames 1 --view lit --out " + out.string());
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_THAT(r.output, Not(HasSubstr("into an existing directory")));
  r = view("--size 160x90 --frames 1 --view lit --out " + out.string());
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("wrote (into an existing directory"));
  testing::write_text(tree.root() / "file", "x");
  r = view("--size 160x90 --frames 1 --view lit --out " + (tree.root() / "file").string());
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.output, HasSubstr("exists and is not a directory"));
}

// A relative --shader-dir (here "shaders", run from the tree's root) reloads like an absolute
// one: the edit is seen as the file the pipelines read, not "not reloaded in 5000 ms".
TEST(ScriptEndToEnd, ARelativeShaderDirReloads) {
  TempTree tree(true);
  const fs::path script = tree.root() / "relative.txt";
  testing::write_text(
      script,
      "scene default\nsize 160x90\nset shadows.resolution 512\nrender\n"
      "replace render/tonemap.comp \"frame.ambient.w;\" \"frame.ambient.w * 0.5;\"\n"
      "expect_reload_ok\nexpect_rebuilt tonemap\nquit\n");
  const std::string cmd =
      "cd " + tree.root().string() + " && " + PENUMBRA_VIEW_EXE + " --headless --shader-dir " +
      fs::relative(tree.shaders(), tree.root()).string() + " --script " + script.string() + " 2>&1";
  std::string output;
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  char buf[512];
  while (fgets(buf, sizeof buf, p)) output += buf;
  EXPECT_EQ(pclose(p), 0) << output;
  EXPECT_THAT(output, HasSubstr("[reload] rebuilt: tonemap"));
  EXPECT_THAT(output, Not(HasSubstr("not reloaded")));
}

// penumbra-view --watch, as a user runs it: timings.csv and the PNG are complete before the
// watch loop starts (issue 18 found timings.csv empty for the whole session), an edit rewrites
// the PNG, and Ctrl-C ends it with status 0 and the median latency.
TEST(ViewWatch, WritesTimingsBeforeWatchingRewritesThePngAndStopsOnSigint) {
  TempTree tree(true);
  const fs::path out = tree.root() / "out";
  // `timeout` bounds the test should the watch loop ignore the signal.
  const std::string cmd = "echo $$; exec timeout -s KILL 180 " + std::string(PENUMBRA_VIEW_EXE) +
                          " --headless --watch --size 160x90 --frames 1 --view lit --shader-dir " +
                          tree.shaders().string() + " --out " + out.string() + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string output;
  char buf[512];
  ASSERT_TRUE(fgets(buf, sizeof buf, p));
  const long pid = std::atol(buf);
  ASSERT_GT(pid, 0);
  auto read_until = [&](const std::string& text) {
    while (fgets(buf, sizeof buf, p)) {
      output += buf;
      if (output.find(text) != std::string::npos) return true;
    }
    return false;
  };
  ASSERT_TRUE(read_until("[watch] watching")) << output;
  const std::string csv = testing::read_text(out / "timings.csv");
  EXPECT_THAT(csv, HasSubstr("device,scene,width,height,pass,median_ms,frames\n"));
  EXPECT_THAT(csv, HasSubstr(",default,160,90,tonemap,"));
  const std::string before = testing::read_text(out / "lit.png");
  EXPECT_FALSE(before.empty());
  const fs::path tonemap = tree.shaders() / "render/tonemap.comp";
  testing::write_text(tonemap, testing::replaced(testing::read_text(tonemap), "frame.ambient.w;",
                                                 "frame.ambient.w * 0.5;"));
  EXPECT_TRUE(read_until("[watch] wrote")) << output;
  EXPECT_NE(testing::read_text(out / "lit.png"), before) << "half the exposure";
  ::kill(static_cast<pid_t>(pid), SIGINT);
  read_until("\x01");  // to the end
  EXPECT_EQ(pclose(p), 0) << output;
  EXPECT_THAT(output, HasSubstr("reload latency (file event -> first frame with the new "
                                "pipelines): median"));
}

}  // namespace
}  // namespace penumbra
