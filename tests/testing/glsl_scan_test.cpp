// The scan of a GLSL file's functions that explains a ShaderFunction signature mismatch: it sees
// top-level declarations and definitions (also across lines and through includes) and nothing
// else: no calls, no struct members, no commented-out code, no macros.
#include "../../src/testing/glsl_scan.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace penumbra::testing::detail {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

struct Dir {
  Dir() : path(fs::temp_directory_path() / ("penumbra-scan-" + std::to_string(::getpid()))) {
    fs::create_directories(path / "lib");
  }
  ~Dir() { fs::remove_all(path); }
  void write(const std::string& name, const std::string& text) const {
    std::ofstream(path / name) << text;
  }
  fs::path path;
};

TEST(GlslScan, FindsTopLevelFunctionsOnlyWithTheirLines) {
  Dir d;
  d.write("main.glsl",
          "#include \"lib/common.glsl\"\n"                  // 1
          "// float commented(float x) { return x; }\n"     // 2
          "/* vec3 also_commented(vec3 v);\n"               // 3
          "   */\n"                                         // 4
          "struct Light { vec3 dir; float intensity; };\n"  // 5
          "#define MACRO(x) (x * 2.0)\n"                    // 6
          "const vec3 kUp = vec3(0.0, 1.0, 0.0);\n"         // 7
          "float lambert(vec3 n,\n"                         // 8
          "              vec3 l) {\n"                       // 9
          "  float k = max(dot(n, l), 0.0);\n"              // 10
          "  return clamp(k, 0.0, 1.0);\n"                  // 11
          "}\n"                                             // 12
          "float lambert(Light light, vec3 n);\n"           // 13
          "highp vec2 uv_of(in vec3 p) { return p.xy; }\n"  // 14
          "float arr[2] = float[2](1.0, 2.0);\n");          // 15
  d.write("lib/common.glsl", "\n\nfloat saturate1(float x) { return clamp(x, 0.0, 1.0); }\n");
  const auto f = glsl_functions(d.path / "main.glsl", {});
  ASSERT_EQ(f.size(), 4u);
  EXPECT_EQ(f[0].name, "lambert");
  EXPECT_EQ(f[0].line, 8);
  EXPECT_EQ(f[0].signature, "float lambert(vec3 n, vec3 l)");
  EXPECT_EQ(f[1].line, 13);
  EXPECT_EQ(f[1].signature, "float lambert(Light light, vec3 n)");
  EXPECT_EQ(f[2].signature, "highp vec2 uv_of(in vec3 p)");
  EXPECT_EQ(f[3].name, "saturate1");
  EXPECT_EQ(f[3].file, d.path / "lib/common.glsl");
  EXPECT_EQ(f[3].line, 3);
}

TEST(GlslScan, ExplainsSameNamesAndNearNames) {
  const std::vector<GlslFunction> f{{"a.glsl", 3, "lambert", "float lambert(vec3 n, vec3 l)"},
                                    {"a.glsl", 9, "Lambert", "float Lambert(vec3 n)"},
                                    {"a.glsl", 12, "phong", "float phong(vec3 n)"}};
  std::string m = explain_no_match(f, "lambert", "float lambert(vec2)");
  EXPECT_THAT(m, HasSubstr("asks for: float lambert(vec2)\n"));
  EXPECT_THAT(m,
              HasSubstr("declares 'lambert' as:\n    a.glsl:3: float lambert(vec3 n, vec3 l)\n"));
  EXPECT_THAT(m, HasSubstr("near names (did you mean one of these?):\n    a.glsl:9: float "
                           "Lambert(vec3 n)\n"));
  EXPECT_THAT(m, ::testing::Not(HasSubstr("phong")));
  m = explain_no_match(f, "lambret", "float lambret(vec3, vec3)");
  EXPECT_THAT(m, HasSubstr("no GLSL function is named 'lambret'"));
  EXPECT_THAT(m, HasSubstr("a.glsl:3: float lambert(vec3 n, vec3 l)"));
  EXPECT_EQ(explain_no_match(f, "shadow_factor", "float shadow_factor(float)"), "");
}

}  // namespace
}  // namespace penumbra::testing::detail
