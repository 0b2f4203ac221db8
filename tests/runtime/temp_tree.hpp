#pragma once

// A temporary directory for one test (removed afterwards), optionally holding a copy of the
// repository's shader tree, and small file helpers. Tests never edit the repo's shaders/.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace penumbra::testing {

class TempTree {
 public:
  explicit TempTree(bool copy_shaders) {
    std::string pattern = (std::filesystem::temp_directory_path() / "penumbra-rt-XXXXXX").string();
    if (!mkdtemp(pattern.data())) throw std::runtime_error("mkdtemp failed");
    root_ = std::filesystem::weakly_canonical(pattern);
    if (copy_shaders) {
      std::filesystem::copy(PENUMBRA_SHADER_DIR, root_ / "shaders",
                            std::filesystem::copy_options::recursive);
    }
  }
  ~TempTree() {
    std::error_code ec;
    std::filesystem::remove_all(root_, ec);
  }
  TempTree(const TempTree&) = delete;
  TempTree& operator=(const TempTree&) = delete;

  const std::filesystem::path& root() const { return root_; }
  std::filesystem::path shaders() const { return root_ / "shaders"; }

 private:
  std::filesystem::path root_;
};

inline std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline void write_text(const std::filesystem::path& file, const std::string& text) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out << text;
}

// Writes a temporary file next to `file` and renames it over the original (editors' atomic save).
inline void atomic_save(const std::filesystem::path& file, const std::string& text) {
  const auto tmp = file.parent_path() / ("." + file.filename().string() + ".swp");
  write_text(tmp, text);
  std::filesystem::rename(tmp, file);
}

// The text with the first `from` replaced by `to`; fails the test when `from` does not occur.
inline std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "'" << from << "' not found";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// 1-based number of the line holding `needle` (0 when absent).
inline int line_of(const std::string& text, const std::string& needle) {
  const auto at = text.find(needle);
  if (at == std::string::npos) return 0;
  int line = 1;
  for (size_t i = 0; i < at; ++i) line += text[i] == '\n' ? 1 : 0;
  return line;
}

}  // namespace penumbra::testing
