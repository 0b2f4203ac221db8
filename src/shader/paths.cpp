// default_shader_dir(), alone in its file: it is compiled twice, with the source tree's shaders/
// for the build tree's targets (penumbra_shader_paths) and with the installed
// share/penumbra/shaders for the installed package (penumbra_shader_paths_installed), so that an
// installed Penumbra never reads the tree it was built from.
#include <cstdlib>
#include <penumbra/core/file.hpp>
#include <penumbra/shader/compiler.hpp>
#include <string>

namespace penumbra::shader {

namespace {

std::string& package_dir() {
  static std::string dir;
  return dir;
}

}  // namespace

bool set_package_shader_dir(const char* dir) {
  package_dir() = dir ? dir : "";
  return true;
}

std::filesystem::path default_shader_dir() {
  // PENUMBRA_SHADER_DIR in the environment points every tool at another shader tree (a snapshot
  // to measure against while the repository's tree is being edited, or a relocated install).
  if (const char* dir = std::getenv("PENUMBRA_SHADER_DIR"); dir != nullptr && *dir != '\0')
    return dir;
  // The installed package's copy, where the consumer's find_package found it.
  if (!package_dir().empty()) return package_dir();
  // An installed tool (penumbra-view, penumbra-reference): the shaders installed beside it.
  if (const auto share = installed_share_dir(); !share.empty()) return share / "shaders";
  return PENUMBRA_SHADER_DIR;
}

}  // namespace penumbra::shader
