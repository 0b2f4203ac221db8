#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <penumbra/shader/compiler.hpp>
#include <penumbra/shader/reflection.hpp>
#include <random>
#include <string>
#include <thread>

namespace penumbra::shader {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Not;

constexpr uint32_t kSpirvMagic = 0x07230203;

fs::path data_dir() {
  return fs::weakly_canonical(fs::path(PENUMBRA_TEST_DATA_DIR) / "shader");
}
fs::path data(const std::string& name) {
  return fs::weakly_canonical(data_dir() / name);
}

// A fresh directory under the system temp dir, removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = fs::temp_directory_path() /
            ("penumbra_shader_test_" + std::to_string(rd()) + "_" + std::to_string(rd()));
    fs::create_directories(path_);
    path_ = fs::weakly_canonical(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

void write_file(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

// Runs `fn`, expects a CompileError and returns it.
template <typename Fn>
CompileError expect_compile_error(Fn&& fn) {
  try {
    fn();
  } catch (const CompileError& e) {
    return e;
  }
  ADD_FAILURE() << "expected a CompileError";
  return CompileError("no error", {});
}

// ---------------------------------------------------------------------------------------------
// Stages

TEST(ShaderStage, FromPathAndToString) {
  EXPECT_EQ(stage_from_path("a/b/x.vert"), Stage::vertex);
  EXPECT_EQ(stage_from_path("x.frag"), Stage::fragment);
  EXPECT_EQ(stage_from_path("/abs/x.comp"), Stage::compute);
  EXPECT_EQ(to_string(Stage::vertex), "vertex");
  EXPECT_EQ(to_string(Stage::fragment), "fragment");
  EXPECT_EQ(to_string(Stage::compute), "compute");
}

TEST(ShaderStage, UnknownExtensionNamesTheFile) {
  try {
    stage_from_path("shaders/thing.glsl");
    FAIL() << "expected penumbra::Error";
  } catch (const penumbra::Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("shaders/thing.glsl"));
  }
}

// ---------------------------------------------------------------------------------------------
// Successful compiles

TEST(ShaderCompiler, CompilesComputeVertexFragmentFromFiles) {
  Compiler compiler;
  for (const char* name : {"simple.comp", "simple.vert", "simple.frag"}) {
    const CompiledShader shader = compiler.compile_file(data(name));
    ASSERT_FALSE(shader.spirv.empty()) << name;
    EXPECT_EQ(shader.spirv[0], kSpirvMagic) << name;
    EXPECT_EQ(shader.spirv[1], 0x00010500u) << name << ": SPIR-V 1.5 expected";
    EXPECT_EQ(shader.stage, stage_from_path(name));
    EXPECT_EQ(shader.name, data(name).string());
    EXPECT_THAT(shader.dependencies, ElementsAre(data(name)));
    EXPECT_FALSE(shader.from_cache);
    EXPECT_NE(shader.key, 0u);
  }
  EXPECT_EQ(compiler.stats().compiles, 3u);
  EXPECT_EQ(compiler.stats().cache_hits, 0u);
}

TEST(ShaderCompiler, ExplicitStageOverridesExtension) {
  TempDir dir;
  write_file(dir.path() / "kernel.glsl",
             "#version 460\nlayout(local_size_x = 4) in;\nvoid main() {}\n");
  Compiler compiler;
  const CompiledShader shader = compiler.compile_file(dir.path() / "kernel.glsl", Stage::compute);
  EXPECT_EQ(shader.stage, Stage::compute);
  EXPECT_EQ(reflect(shader.spirv).workgroup_size, (std::array<uint32_t, 3>{4, 1, 1}));
  EXPECT_THROW(compiler.compile_file(dir.path() / "kernel.glsl"), penumbra::Error);
}

TEST(ShaderCompiler, CompilesFromStrings) {
  Compiler compiler;
  const CompiledShader comp =
      compiler.compile_source("#version 460\nlayout(local_size_x = 16) in;\nvoid main() {}\n",
                              "inline.comp", Stage::compute);
  EXPECT_EQ(comp.spirv.at(0), kSpirvMagic);
  EXPECT_EQ(comp.name, "inline.comp");
  EXPECT_TRUE(comp.dependencies.empty());

  const CompiledShader vert = compiler.compile_source(
      "#version 460\nvoid main() { gl_Position = vec4(0.0); }\n", "inline.vert", Stage::vertex);
  EXPECT_EQ(vert.spirv.at(0), kSpirvMagic);
  EXPECT_EQ(vert.stage, Stage::vertex);

  const CompiledShader frag = compiler.compile_source(
      "#version 460\nlayout(location = 0) out vec4 c;\nvoid main() { c = vec4(1.0); }\n",
      "inline.frag", Stage::fragment);
  EXPECT_EQ(frag.spirv.at(0), kSpirvMagic);
  EXPECT_EQ(frag.stage, Stage::fragment);
}

TEST(ShaderCompiler, MissingFileIsAnError) {
  Compiler compiler;
  try {
    compiler.compile_file(data_dir() / "no_such_file.comp");
    FAIL() << "expected penumbra::Error";
  } catch (const penumbra::Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("no_such_file.comp"));
  }
}

// ---------------------------------------------------------------------------------------------
// Diagnostics

TEST(ShaderCompiler, ErrorReportsFileAndLineOfMainFile) {
  Compiler compiler({.defines = {{"UNUSED_A", "1"}, {"UNUSED_B", ""}}});
  const CompileError e =
      expect_compile_error([&] { compiler.compile_file(data("error_line7.comp")); });
  ASSERT_FALSE(e.diagnostics().empty());
  EXPECT_EQ(e.diagnostics()[0].file, data("error_line7.comp"));
  EXPECT_EQ(e.diagnostics()[0].line, 7);
  EXPECT_THAT(e.diagnostics()[0].message, HasSubstr("not_declared_anywhere"));
  const std::string what = e.what();
  EXPECT_THAT(what, HasSubstr("error_line7.comp:7: error: "));
  EXPECT_EQ(what.rfind(data("error_line7.comp").string() + ":7: error: ", 0), 0u) << what;
  EXPECT_THAT(what, Not(HasSubstr("compilation terminated")));
  EXPECT_THAT(what, Not(HasSubstr("compilation errors")));
  EXPECT_EQ(compiler.stats().compiles, 1u);
}

TEST(ShaderCompiler, ErrorInsideIncludeReportsTheIncludedFile) {
  Compiler compiler;
  const CompileError e =
      expect_compile_error([&] { compiler.compile_file(data("error_in_include.comp")); });
  ASSERT_FALSE(e.diagnostics().empty());
  EXPECT_EQ(e.diagnostics()[0].file, data("inc/bad.glsl"));
  EXPECT_EQ(e.diagnostics()[0].line, 4);
  EXPECT_THAT(e.diagnostics()[0].message, HasSubstr("missing_symbol"));
  const std::string what = e.what();
  EXPECT_EQ(what.rfind(data("inc/bad.glsl").string() + ":4: error: ", 0), 0u) << what;
  EXPECT_THAT(what, Not(HasSubstr("error_in_include.comp:4")));
}

// An include cut short (an editor's half-written save) leaves a conditional open; glslang says
// "missing #endif" at the end of the file that included it. The error names the include and the
// line of the innermost block it leaves open.
TEST(ShaderCompiler, AnIncludeCutShortIsBlamedWhereItsOpenBlockBegan) {
  TempDir dir;
  write_file(dir.path() / "cut.glsl",
             "// a guarded helper file\n"
             "#ifndef CUT_GLSL\n"
             "#define CUT_GLSL\n"
             "float cut_a() { return 1.0; }\n"
             "#if defined(FOO)\n"
             "float cut_b() { return 2.0; }\n"
             "#endif\n"
             "#ifdef BAR\n"
             "float cut_c() { return 3.0; }\n");
  write_file(dir.path() / "main.comp",
             "#version 460\n#extension GL_GOOGLE_include_directive : require\n"
             "#include \"cut.glsl\"\nlayout(local_size_x = 1) in;\nvoid main() {}\n");
  Compiler compiler;
  const CompileError e =
      expect_compile_error([&] { compiler.compile_file(dir.path() / "main.comp"); });
  ASSERT_FALSE(e.diagnostics().empty());
  EXPECT_EQ(e.diagnostics()[0].file, dir.path() / "cut.glsl");
  EXPECT_EQ(e.diagnostics()[0].line, 8);
  EXPECT_THAT(e.diagnostics()[0].message, HasSubstr("unterminated #ifdef"));
  EXPECT_THAT(e.diagnostics()[0].message, HasSubstr("1 enclosing block(s) also open"));
  const std::string what = e.what();
  EXPECT_EQ(what.rfind((dir.path() / "cut.glsl").string() + ":8: error: ", 0), 0u) << what;

  // Balanced, the same file compiles; the main file's own open block is glslang's to report.
  write_file(dir.path() / "cut.glsl", "#ifndef CUT_GLSL\n#define CUT_GLSL\n#endif\n");
  EXPECT_NO_THROW(compiler.compile_file(dir.path() / "main.comp"));
  write_file(dir.path() / "main.comp",
             "#version 460\n#extension GL_GOOGLE_include_directive : require\n"
             "#include \"cut.glsl\"\n#ifdef X\nlayout(local_size_x = 1) in;\nvoid main() {}\n");
  const CompileError own =
      expect_compile_error([&] { compiler.compile_file(dir.path() / "main.comp"); });
  EXPECT_EQ(own.diagnostics()[0].file, dir.path() / "main.comp");
}

TEST(ShaderCompiler, FirstDiagnosticIsTheRealError) {
  Compiler compiler;
  const CompileError e =
      expect_compile_error([&] { compiler.compile_file(data("syntax_error.comp")); });
  ASSERT_FALSE(e.diagnostics().empty());
  EXPECT_EQ(e.diagnostics()[0].line, 5);
  EXPECT_EQ(e.diagnostics()[0].message, "syntax error, unexpected SEMICOLON");
  for (const auto& diag : e.diagnostics()) {
    EXPECT_THAT(diag.message, Not(HasSubstr("compilation terminated")));
    EXPECT_THAT(diag.message, Not(HasSubstr("compilation errors")));
  }
}

TEST(ShaderCompiler, ErrorInVirtualSourceUsesTheVirtualName) {
  Compiler compiler;
  const CompileError e = expect_compile_error([&] {
    compiler.compile_source(
        "#version 460\nlayout(local_size_x = 1) in;\nvoid main() {\n  oops();\n}\n",
        "generated/wrapper.comp", Stage::compute);
  });
  EXPECT_EQ(e.diagnostics()[0].file, fs::path("generated/wrapper.comp"));
  EXPECT_EQ(e.diagnostics()[0].line, 4);
  EXPECT_EQ(std::string(e.what()).rfind("generated/wrapper.comp:4: error: ", 0), 0u) << e.what();
}

TEST(ShaderCompiler, MissingIncludeNamesHeaderIncluderAndSearchedDirs) {
  Compiler compiler({.include_dirs = {data_dir() / "lib"}});
  const CompileError e =
      expect_compile_error([&] { compiler.compile_file(data("missing_include.comp")); });
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_EQ(e.diagnostics()[0].file, data("missing_include.comp"));
  EXPECT_EQ(e.diagnostics()[0].line, 3);
  const std::string expected =
      data("missing_include.comp").string() +
      ":3: error: cannot find include \"does_not_exist.glsl\" (searched: " +
      data_dir().generic_string() + ", " + data("lib").generic_string() + ")";
  EXPECT_EQ(std::string(e.what()), expected);
}

// An include or a stage file that exists but is no regular file (a link to /dev/zero, a
// directory) says what it is, at the #include line: "cannot find" would send the user looking
// for a file that is there. A header that a later include directory holds as a file still wins.
TEST(ShaderCompiler, AnIncludeThatIsNoRegularFileSaysWhatItIs) {
  TempDir dir;
  fs::create_directories(dir.path() / "a");
  fs::create_directories(dir.path() / "b");
  write_file(dir.path() / "main.comp",
             "#version 460\nlayout(local_size_x = 1) in;\n#include \"h.glsl\"\n"
             "layout(std430, binding = 0) buffer O { float r; };\nvoid main() { r = h(); }\n");
  fs::create_symlink("/dev/zero", dir.path() / "a/h.glsl");
  Compiler compiler({.include_dirs = {dir.path() / "a", dir.path() / "b"}});
  CompileError e = expect_compile_error([&] { compiler.compile_file(dir.path() / "main.comp"); });
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_EQ(e.diagnostics()[0].line, 3);
  EXPECT_EQ(e.diagnostics()[0].message, "include \"h.glsl\" (" +
                                            (dir.path() / "a/h.glsl").string() +
                                            ") is a character device, not a regular file");
  fs::create_directories(dir.path() / "h.glsl");  // the includer's own directory comes first
  e = expect_compile_error([&] { compiler.compile_file(dir.path() / "main.comp"); });
  EXPECT_EQ(e.diagnostics()[0].message, "include \"h.glsl\" (" + (dir.path() / "h.glsl").string() +
                                            ") is a directory, not a file");
  write_file(dir.path() / "b/h.glsl", "float h() { return 2.0; }\n");
  EXPECT_NO_THROW(compiler.compile_file(dir.path() / "main.comp"));

  try {
    compiler.compile_file(dir.path() / "a/h.glsl", Stage::compute);
    ADD_FAILURE() << "a stage file that is /dev/zero must not compile";
  } catch (const penumbra::Error& err) {
    EXPECT_EQ(std::string(err.what()), "cannot read shader file: '" +
                                           (dir.path() / "a/h.glsl").string() +
                                           "' is a character device, not a regular file");
  }
}

TEST(ShaderCompiler, IncludeCycleIsAnError) {
  Compiler compiler;
  const CompileError e = expect_compile_error([&] { compiler.compile_file(data("cycle.comp")); });
  ASSERT_EQ(e.diagnostics().size(), 1u) << e.what();
  EXPECT_EQ(e.diagnostics()[0].file, data("inc/cycle_b.glsl"));
  EXPECT_EQ(e.diagnostics()[0].line, 2);
  EXPECT_EQ(e.diagnostics()[0].message,
            "include cycle: inc/cycle_a.glsl -> inc/cycle_b.glsl -> inc/cycle_a.glsl");
}

TEST(ShaderCompiler, SelfIncludeIsACycle) {
  TempDir dir;
  write_file(
      dir.path() / "self.comp",
      "#version 460\n#include \"self.comp\"\nlayout(local_size_x = 1) in;\nvoid main() {}\n");
  Compiler compiler;
  const CompileError e =
      expect_compile_error([&] { compiler.compile_file(dir.path() / "self.comp"); });
  EXPECT_EQ(e.diagnostics()[0].message, "include cycle: self.comp -> self.comp");
  EXPECT_EQ(e.diagnostics()[0].line, 2);
}

// ---------------------------------------------------------------------------------------------
// Includes

TEST(ShaderCompiler, DiamondIncludesWorkAndDependenciesAreExact) {
  Compiler compiler;
  const CompiledShader shader = compiler.compile_file(data("diamond.comp"));
  EXPECT_EQ(shader.spirv.at(0), kSpirvMagic);
  EXPECT_THAT(shader.dependencies, ElementsAre(data("diamond.comp"), data("inc/left.glsl"),
                                               data("inc/common.glsl"), data("inc/right.glsl")));
}

TEST(ShaderCompiler, IncludeDirectoriesForQuotedAndAngleIncludes) {
  Compiler compiler({.include_dirs = {data_dir() / "inc", data_dir() / "lib"}});
  const CompiledShader shader = compiler.compile_file(data("uses_lib.comp"));
  EXPECT_THAT(shader.dependencies, ElementsAre(data("uses_lib.comp"), data("lib/lib_math.glsl")));

  Compiler without_dirs;
  const CompileError e =
      expect_compile_error([&] { without_dirs.compile_file(data("uses_lib.comp")); });
  EXPECT_EQ(e.diagnostics()[0].line, 2);
  EXPECT_THAT(e.diagnostics()[0].message, HasSubstr("cannot find include \"lib_math.glsl\""));
}

TEST(ShaderCompiler, VirtualSourceIncludesFromIncludeDirs) {
  Compiler compiler({.include_dirs = {data_dir() / "lib"}});
  const CompiledShader shader = compiler.compile_source(
      "#version 460\n#include \"lib_math.glsl\"\nlayout(local_size_x = 1) in;\n"
      "layout(std430, binding = 0) buffer O { float r; };\nvoid main() { r = lib_square(2.0); }\n",
      "wrapper.comp", Stage::compute);
  EXPECT_THAT(shader.dependencies, ElementsAre(data("lib/lib_math.glsl")));
}

TEST(ShaderCompiler, ExplicitIncludeExtensionLineStillWorks) {
  Compiler compiler;
  const CompiledShader shader = compiler.compile_file(data("explicit_extension.comp"));
  EXPECT_THAT(shader.dependencies,
              ElementsAre(data("explicit_extension.comp"), data("inc/good.glsl")));
}

// ---------------------------------------------------------------------------------------------
// Defines

TEST(ShaderCompiler, DefinesAreInjected) {
  Compiler plain;
  const CompileError e =
      expect_compile_error([&] { plain.compile_file(data("needs_defines.comp")); });
  EXPECT_EQ(e.diagnostics()[0].line, 3);
  EXPECT_THAT(e.diagnostics()[0].message, HasSubstr("FOO must be defined"));

  // FOO from the options (no value), WIDTH and SCALE per call.
  Compiler compiler({.defines = {{"FOO", ""}}});
  const CompiledShader shader =
      compiler.compile_file(data("needs_defines.comp"), {}, {{"WIDTH", "32"}, {"SCALE", "0.25"}});
  const Reflection reflection = reflect(shader.spirv);
  EXPECT_EQ(reflection.workgroup_size, (std::array<uint32_t, 3>{32, 1, 1}));
  const DescriptorBinding* out = reflection.find_binding("Out");
  ASSERT_NE(out, nullptr);
  ASSERT_TRUE(out->block);
  EXPECT_EQ(out->block->size, 32u * 4u);

  // A different value is a different shader.
  const CompiledShader other =
      compiler.compile_file(data("needs_defines.comp"), {}, {{"WIDTH", "16"}, {"SCALE", "0.25"}});
  EXPECT_NE(other.key, shader.key);
  EXPECT_FALSE(other.from_cache);
  EXPECT_EQ(reflect(other.spirv).workgroup_size, (std::array<uint32_t, 3>{16, 1, 1}));
}

TEST(ShaderCompiler, ExtraDefinesOverrideOptionDefines) {
  Compiler compiler({.defines = {{"FOO", ""}, {"WIDTH", "8"}, {"SCALE", "1.0"}}});
  const CompiledShader base = compiler.compile_file(data("needs_defines.comp"));
  EXPECT_EQ(reflect(base.spirv).workgroup_size, (std::array<uint32_t, 3>{8, 1, 1}));
  const CompiledShader wide =
      compiler.compile_file(data("needs_defines.comp"), {}, {{"WIDTH", "64"}});
  EXPECT_EQ(reflect(wide.spirv).workgroup_size, (std::array<uint32_t, 3>{64, 1, 1}));
  EXPECT_NE(wide.key, base.key);
}

TEST(ShaderCompiler, InvalidDefineIsAnError) {
  Compiler compiler;
  EXPECT_THROW(compiler.compile_file(data("simple.comp"), {}, {{"1BAD", "1"}}), penumbra::Error);
  EXPECT_THROW(compiler.compile_file(data("simple.comp"), {}, {{"", "1"}}), penumbra::Error);
  EXPECT_THROW(compiler.compile_file(data("simple.comp"), {}, {{"X", "1\n#define Y"}}),
               penumbra::Error);
  EXPECT_THROW(compiler.compile_file(data("simple.comp"), {}, {{"X", "1 \\"}}), penumbra::Error);
}

TEST(ShaderCompiler, OptimizeIsPartOfTheKey) {
  Compiler plain;
  Compiler optimizing({.optimize = true});
  const CompiledShader a = plain.compile_file(data("diamond.comp"));
  const CompiledShader b = optimizing.compile_file(data("diamond.comp"));
  EXPECT_EQ(b.spirv.at(0), kSpirvMagic);
  EXPECT_NE(a.key, b.key);
  EXPECT_NE(reflect(b.spirv).find_binding("Out"), nullptr);
}

TEST(ShaderCompiler, SeparateCompilersRunConcurrently) {
  std::vector<std::thread> threads;
  std::vector<int> ok(4, 0);
  for (size_t t = 0; t < ok.size(); ++t) {
    threads.emplace_back([&, t] {
      Compiler compiler;
      for (int i = 0; i < 5; ++i) {
        const CompiledShader shader = compiler.compile_file(
            data("needs_defines.comp"), {},
            {{"FOO", ""}, {"WIDTH", std::to_string(8 * (t + 1))}, {"SCALE", std::to_string(i)}});
        if (reflect(shader.spirv).workgroup_size[0] == 8 * (t + 1)) ++ok[t];
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  EXPECT_THAT(ok, ::testing::Each(5));
}

// ---------------------------------------------------------------------------------------------
// Cache

TEST(ShaderCompiler, RecompileIsACacheHitWithDependencies) {
  Compiler compiler;
  const CompiledShader first = compiler.compile_file(data("diamond.comp"));
  const CompiledShader second = compiler.compile_file(data("diamond.comp"));
  EXPECT_FALSE(first.from_cache);
  EXPECT_TRUE(second.from_cache);
  EXPECT_EQ(first.key, second.key);
  EXPECT_EQ(first.spirv, second.spirv);
  EXPECT_EQ(first.dependencies, second.dependencies);
  EXPECT_EQ(second.dependencies.size(), 4u);
  EXPECT_EQ(compiler.stats().compiles, 1u);
  EXPECT_EQ(compiler.stats().cache_hits, 1u);

  compiler.clear_cache();
  const CompiledShader third = compiler.compile_file(data("diamond.comp"));
  EXPECT_FALSE(third.from_cache);
  EXPECT_EQ(third.key, first.key);
  EXPECT_EQ(compiler.stats().compiles, 2u);
}

// A copy of the diamond test shader and its three includes, to edit.
void copy_diamond(const fs::path& to) {
  fs::copy(data_dir() / "diamond.comp", to / "diamond.comp");
  fs::create_directories(to / "inc");
  for (const char* name : {"left.glsl", "right.glsl", "common.glsl"}) {
    fs::copy(data_dir() / "inc" / name, to / "inc" / name);
  }
}

TEST(ShaderCompiler, EditingAnIncludedFileChangesTheKey) {
  TempDir dir;
  copy_diamond(dir.path());
  Compiler compiler;
  const CompiledShader first = compiler.compile_file(dir.path() / "diamond.comp");
  EXPECT_THAT(first.dependencies,
              ElementsAre(dir.path() / "diamond.comp", dir.path() / "inc/left.glsl",
                          dir.path() / "inc/common.glsl", dir.path() / "inc/right.glsl"));
  EXPECT_TRUE(compiler.compile_file(dir.path() / "diamond.comp").from_cache);

  write_file(dir.path() / "inc/common.glsl",
             "#ifndef COMMON_GLSL\n#define COMMON_GLSL\nfloat common_value() { return 0.75; }\n"
             "#endif\n");
  const CompiledShader edited = compiler.compile_file(dir.path() / "diamond.comp");
  EXPECT_FALSE(edited.from_cache);
  EXPECT_NE(edited.key, first.key);
  EXPECT_NE(edited.spirv, first.spirv);
  EXPECT_EQ(edited.dependencies, first.dependencies);
  EXPECT_EQ(compiler.stats().compiles, 2u);
  EXPECT_EQ(compiler.stats().cache_hits, 1u);

  // An error introduced in an include is reported there, with its line.
  write_file(dir.path() / "inc/right.glsl",
             "#ifndef RIGHT_GLSL\n#define RIGHT_GLSL\n#include \"common.glsl\"\n"
             "float right() { return common_value() + ; }\n#endif\n");
  const CompileError e =
      expect_compile_error([&] { compiler.compile_file(dir.path() / "diamond.comp"); });
  EXPECT_EQ(e.diagnostics()[0].file, dir.path() / "inc/right.glsl");
  EXPECT_EQ(e.diagnostics()[0].line, 4);
}

// Third-party GLSL often begins with its own #version, which glslang refuses after the main
// file's: by default a leading #version of an included file (after comments) is blanked in
// place, the lines below keep their numbers, and the notes say so; off, glslang's error stands.
TEST(ShaderCompiler, ALeadingVersionOfAnIncludedFileIsDroppedAndNoted) {
  TempDir dir;
  write_file(dir.path() / "noise.glsl",
             "// a noise library\n/* with a\n   block comment */\n#version 120\n"
             "float noise_value() { return 0.5; }\n"
             "float noise_broken() { return undefined_name; }\n");
  const std::string main =
      "#version 460\n#include \"noise.glsl\"\n"
      "layout(local_size_x = 1) in;\nvoid main() {}\n";
  write_file(dir.path() / "main.comp", main);
  Compiler compiler({{dir.path()}});
  // The error on line 6 is reported on line 6: the blanked directive kept its line.
  const CompileError error =
      expect_compile_error([&] { compiler.compile_file(dir.path() / "main.comp"); });
  EXPECT_THAT(error.what(), HasSubstr("noise.glsl:6"));
  EXPECT_THAT(error.what(), Not(HasSubstr("#version")));

  write_file(dir.path() / "noise.glsl",
             "// a noise library\n/* with a\n   block comment */\n#version 120\n"
             "float noise_value() { return 0.5; }\n");
  const CompiledShader ok = compiler.compile_file(dir.path() / "main.comp");
  ASSERT_EQ(ok.notes.size(), 1u);
  EXPECT_THAT(ok.notes[0], HasSubstr("noise.glsl: dropped '#version 120'"));

  CompileOptions keep({dir.path()});
  keep.strip_include_version = false;
  const CompileError refused =
      expect_compile_error([&] { Compiler(keep).compile_file(dir.path() / "main.comp"); });
  EXPECT_THAT(refused.what(), HasSubstr("#version"));
}

// Files without include guards that share a helper: included twice it is a redefinition;
// with include_once each file is read once per compile.
TEST(ShaderCompiler, IncludeOnceLetsGuardFreeFilesShareAHelper) {
  TempDir dir;
  write_file(dir.path() / "helper.glsl", "float helper(float x) { return x * 2.0; }\n");
  write_file(dir.path() / "a.glsl",
             "#include \"helper.glsl\"\nfloat a(float x) { return helper(x); }\n");
  write_file(dir.path() / "b.glsl",
             "#include \"helper.glsl\"\nfloat b(float x) { return helper(x) + 1.0; }\n");
  write_file(dir.path() / "main.comp",
             "#version 460\n#include \"a.glsl\"\n#include \"b.glsl\"\n"
             "layout(local_size_x = 1) in;\nvoid main() { float y = a(1.0) + b(2.0); }\n");
  const CompileError twice = expect_compile_error(
      [&] { Compiler({{dir.path()}}).compile_file(dir.path() / "main.comp"); });
  EXPECT_THAT(twice.what(), HasSubstr("helper"));
  CompileOptions once({dir.path()});
  once.include_once = true;
  const CompiledShader shader = Compiler(once).compile_file(dir.path() / "main.comp");
  EXPECT_FALSE(shader.spirv.empty());
  EXPECT_EQ(shader.dependencies.size(), 4u);
}

// The on-disk cache: a fresh Compiler (a later process) answers from disk with the SPIR-V, key
// and dependencies of the compile that wrote the entry, and compiles nothing; an edited include,
// a deleted include, other defines and a damaged entry all miss, and a cache directory that
// cannot be written costs nothing but the cache.
TEST(ShaderCompiler, DiskCacheAnswersALaterProcessUntilAFileItReadChanges) {
  TempDir dir;
  copy_diamond(dir.path());
  const fs::path shader = dir.path() / "diamond.comp";
  CompileOptions options;
  options.disk_cache_dir = dir.path() / "cache";
  auto fresh = [&] { return Compiler(options); };

  Compiler writer = fresh();
  const CompiledShader first = writer.compile_file(shader);
  EXPECT_FALSE(first.from_cache);
  EXPECT_FALSE(first.from_disk);
  Compiler reader = fresh();
  const CompiledShader again = reader.compile_file(shader);
  EXPECT_TRUE(again.from_disk);
  EXPECT_TRUE(again.from_cache);
  EXPECT_EQ(again.spirv, first.spirv);
  EXPECT_EQ(again.key, first.key);
  EXPECT_EQ(again.dependencies, first.dependencies);
  EXPECT_EQ(reader.stats().compiles, 0u);
  EXPECT_EQ(reader.stats().disk_hits, 1u);
  // Other defines are another entry.
  EXPECT_FALSE(fresh().compile_file(shader, {}, {{"EXTRA", "1"}}).from_disk);

  // An edited include misses, and the entry it writes answers the next process.
  write_file(dir.path() / "inc/common.glsl",
             "#ifndef COMMON_GLSL\n#define COMMON_GLSL\nfloat common_value() { return 0.75; }\n"
             "#endif\n");
  Compiler after_edit = fresh();
  const CompiledShader edited = after_edit.compile_file(shader);
  EXPECT_FALSE(edited.from_disk);
  EXPECT_NE(edited.spirv, first.spirv);
  EXPECT_EQ(after_edit.stats().compiles, 1u);
  const CompiledShader edited_again = fresh().compile_file(shader);
  EXPECT_TRUE(edited_again.from_disk);
  EXPECT_EQ(edited_again.spirv, edited.spirv);

  // A damaged entry (cut short) misses and is rewritten.
  std::vector<fs::path> entries;
  for (const auto& e : fs::directory_iterator(dir.path() / "cache")) entries.push_back(e.path());
  for (const fs::path& e : entries) {
    EXPECT_EQ(e.extension(), ".spv") << e;  // no temporary file left behind
    fs::resize_file(e, fs::file_size(e) - 3);
  }
  const CompiledShader repaired = fresh().compile_file(shader);
  EXPECT_FALSE(repaired.from_disk);
  EXPECT_EQ(repaired.spirv, edited.spirv);
  EXPECT_TRUE(fresh().compile_file(shader).from_disk);

  // A deleted include is a compile error naming it, never a stale answer.
  fs::remove(dir.path() / "inc/right.glsl");
  const CompileError error = expect_compile_error([&] { fresh().compile_file(shader); });
  EXPECT_THAT(error.what(), HasSubstr("right.glsl"));

  // A cache directory that is a file: every compile works, none is cached.
  write_file(dir.path() / "blocked", "not a directory");
  CompileOptions blocked;
  blocked.disk_cache_dir = dir.path() / "blocked";
  const CompiledShader plain = Compiler(blocked).compile_source(
      "#version 460\nlayout(local_size_x = 1) in;\nvoid main() {}\n", "plain.comp", Stage::compute);
  EXPECT_FALSE(plain.spirv.empty());
  EXPECT_FALSE(Compiler(blocked)
                   .compile_source("#version 460\nlayout(local_size_x = 1) in;\nvoid main() {}\n",
                                   "plain.comp", Stage::compute)
                   .from_disk);
}

// Include directories as layers (a user's overlay over a library): with overlay_include_dirs a
// library file's own-directory include reads the overlay's copy first, and a file that appears
// earlier on the search path after a compile was cached wins the next compile; the disk cache
// never answers with what it shadowed.
TEST(ShaderCompiler, AFileThatAppearsInAnOverlayWinsOverTheLibraryAndTheDiskCache) {
  TempDir dir;
  const fs::path over = dir.path() / "over", lib = dir.path() / "lib";
  fs::create_directories(over);
  write_file(lib / "main.comp",
             "#version 460\n#include \"sub/value.glsl\"\nlayout(local_size_x = 1) in;\n"
             "layout(std430, binding = 0) buffer B { float v[]; };\n"
             "void main() { v[0] = value(); }\n");
  write_file(lib / "sub/value.glsl", "#include \"two.glsl\"\nfloat value() { return two(); }\n");
  write_file(lib / "sub/two.glsl", "float two() { return 2.0; }\n");
  CompileOptions options;
  options.include_dirs = {over, lib};
  options.overlay_include_dirs = true;
  options.disk_cache_dir = dir.path() / "cache";
  auto compile = [&] { return Compiler(options).compile_file(lib / "main.comp"); };

  const CompiledShader library = compile();
  EXPECT_TRUE(compile().from_disk);
  write_file(over / "sub/two.glsl", "float two() { return 3.0; }\n");
  const CompiledShader overlaid = compile();
  EXPECT_FALSE(overlaid.from_disk);
  EXPECT_NE(overlaid.spirv, library.spirv);
  EXPECT_THAT(overlaid.dependencies, ::testing::Contains(over / "sub/two.glsl"));
  EXPECT_TRUE(compile().from_disk);
  fs::remove(over / "sub/two.glsl");
  EXPECT_EQ(compile().spirv, library.spirv);  // gone again: the library's

  // Separate libraries (the default): a file's own directory comes first, as before.
  options.overlay_include_dirs = false;
  write_file(over / "sub/two.glsl", "float two() { return 3.0; }\n");
  const CompiledShader separate = compile();
  EXPECT_EQ(separate.spirv, library.spirv);
  EXPECT_THAT(separate.dependencies, Not(::testing::Contains(over / "sub/two.glsl")));
}

TEST(ShaderCompiler, StageIsPartOfTheKey) {
  Compiler compiler;
  const std::string source = "#version 460\nvoid main() {}\n";
  const CompiledShader vert = compiler.compile_source(source, "a", Stage::vertex);
  const CompiledShader frag = compiler.compile_source(source, "a", Stage::fragment);
  EXPECT_NE(vert.key, frag.key);
  EXPECT_FALSE(frag.from_cache);
}

}  // namespace
}  // namespace penumbra::shader
