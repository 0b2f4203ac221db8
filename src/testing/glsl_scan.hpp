#pragma once
// The functions a GLSL file declares (and the files it includes), found by scanning the text:
// what a ShaderFunction whose wrapper does not compile reports, so that a misspelled name or a
// C++ signature that matches no overload explains itself.
#include <filesystem>
#include <string>
#include <vector>

namespace penumbra::testing::detail {

struct GlslFunction {
  std::filesystem::path file;
  int line = 0;
  std::string name;
  std::string signature;  // "float lambert(vec3 n, vec3 l)", whitespace collapsed
};

// Top-level function declarations and definitions of `file` and of what it #includes (quoted
// and angled, searched in the including file's folder, then `include_dirs`), in file order.
// Comments and preprocessor lines are skipped; an unreadable include is skipped too (the
// compiler reports it).
std::vector<GlslFunction> glsl_functions(const std::filesystem::path& file,
                                         const std::vector<std::filesystem::path>& include_dirs);

// The lines explaining that no GLSL function matches `wanted` ("float lambret(float, vec3)"):
// the functions named `name`, then those with a near name (an edit distance of at most 2, or
// equal ignoring case), each as "file:line: signature". Empty when the files declare neither.
std::string explain_no_match(const std::vector<GlslFunction>& declared, const std::string& name,
                             const std::string& wanted);

}  // namespace penumbra::testing::detail
