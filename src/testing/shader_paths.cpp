// Where the shader-function harness finds GLSL files: the registered package path, the
// default shader directories and a file's resolution against them (shader_function.hpp); the
// GLSL names of the resource kinds.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <glm/gtc/packing.hpp>
#include <map>
#include <mutex>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/shader/reflection.hpp>
#include <penumbra/testing/coverage.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <set>
#include <sstream>

#include "coverage_spirv.hpp"
#include "glsl_scan.hpp"


namespace penumbra::testing {
namespace fs = std::filesystem;

const char* glsl_name(ResourceKind kind) {
  switch (kind) {
    case ResourceKind::sampler2d_shadow:
      return "sampler2DShadow";
    case ResourceKind::sampler2d_array_shadow:
      return "sampler2DArrayShadow";
    case ResourceKind::sampler_cube_shadow:
      return "samplerCubeShadow";
    case ResourceKind::sampler2d:
      return "sampler2D";
    case ResourceKind::sampler2d_array:
      return "sampler2DArray";
    case ResourceKind::sampler_cube_array_shadow:
      return "samplerCubeArrayShadow";
    case ResourceKind::sampler_cube_array:
      return "samplerCubeArray";
    case ResourceKind::sampler_cube:
      return "samplerCube";
    case ResourceKind::image2d:
      return "image2D";
    case ResourceKind::image2d_array:
      return "image2DArray";
  }
  return "?";
}

static std::string& registered_shader_path() {
  static std::string path;
  return path;
}

bool set_default_shader_path(const char* path) {
  registered_shader_path() = path ? path : "";
  return true;
}

std::vector<fs::path> default_shader_dirs() {
  std::vector<fs::path> dirs;
  const char* env = std::getenv("PENUMBRA_SHADER_PATH");
  if (!env && !registered_shader_path().empty()) env = registered_shader_path().c_str();
  if (env) {
    std::stringstream ss(env);
    std::string item;
    while (std::getline(ss, item, ':'))
      if (!item.empty()) dirs.emplace_back(item);
  }
  dirs.push_back(shader::default_shader_dir());
  return dirs;
}

fs::path resolve_shader_file(const fs::path& file, const std::vector<fs::path>& extra_dirs) {
  std::error_code ec;
  if (file.is_absolute()) {
    if (fs::is_regular_file(file, ec)) return file;
    throw Error("shader file " + file.string() + " does not exist");
  }
  std::vector<fs::path> dirs = extra_dirs;
  for (auto& d : default_shader_dirs()) dirs.push_back(d);
  std::string searched;
  for (const auto& d : dirs) {
    const fs::path candidate = d / file;
    if (fs::is_regular_file(candidate, ec)) return fs::weakly_canonical(candidate, ec);
    searched += (searched.empty() ? "" : ", ") + d.string();
  }
  if (fs::is_regular_file(file, ec)) return fs::absolute(file);
  throw Error("shader file \"" + file.string() + "\" not found (searched: " +
              (searched.empty() ? std::string("no directories") : searched) +
              ", and the working directory)");
}

}  // namespace penumbra::testing
