// The compiler's file reading, #version blanking and on-disk SPIR-V cache (compiler_detail.hpp).
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>

#include "compiler_detail.hpp"

namespace penumbra::shader::detail {

// A shader source: a regular file (after symlinks) of at most 64 MiB; anything else (a FIFO,
// /dev/zero, a directory) is not read at all.
std::optional<std::string> read_file(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return std::nullopt;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec || size > (std::uintmax_t(64) << 20)) return std::nullopt;
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) return std::nullopt;
  return std::move(ss).str();
}

// Why read_file(path) gave nothing, for a message: "is a character device, not a regular
// file", "not found", "is larger than 64 MiB" or "cannot be read".
std::string unreadable_reason(const fs::path& path) {
  if (std::string problem = file_problem(path); !problem.empty()) return problem;
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (!ec && size > (std::uintmax_t(64) << 20)) return "is larger than 64 MiB";
  return "cannot be read";
}

fs::path canonical_path(const fs::path& path) {
  std::error_code ec;
  fs::path result = fs::weakly_canonical(fs::absolute(path), ec);
  if (ec) return fs::absolute(path).lexically_normal();
  return result;
}

bool is_file(const fs::path& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

// A leading `#version` line of an included file (after blank lines and comments), blanked in
// place so that every later line keeps its number; the directive, or nothing when there is none.
std::optional<std::string> blank_leading_version(std::string& text) {
  size_t pos = 0;
  bool in_block = false;
  while (pos < text.size()) {
    const size_t end = std::min(text.find('\n', pos), text.size());
    std::string_view line(text.data() + pos, end - pos);
    size_t i = 0;
    while (i < line.size()) {
      if (in_block) {
        const size_t close = line.find("*/", i);
        if (close == std::string_view::npos) {
          i = line.size();
          break;
        }
        in_block = false;
        i = close + 2;
      } else if (line[i] == ' ' || line[i] == '\t' || line[i] == '\r') {
        ++i;
      } else if (line.substr(i).starts_with("//")) {
        i = line.size();
      } else if (line.substr(i).starts_with("/*")) {
        in_block = true;
        i += 2;
      } else {
        break;
      }
    }
    if (i < line.size()) {
      std::string_view rest = line.substr(i);
      if (!rest.starts_with("#")) return std::nullopt;
      rest.remove_prefix(1);
      while (!rest.empty() && (rest[0] == ' ' || rest[0] == '\t')) rest.remove_prefix(1);
      if (!rest.starts_with("version")) return std::nullopt;
      std::string directive(line.substr(i));
      while (!directive.empty() && directive.back() == '\r') directive.pop_back();
      std::fill(text.begin() + std::ptrdiff_t(pos + i), text.begin() + std::ptrdiff_t(end), ' ');
      return directive;
    }
    pos = end + 1;
  }
  return std::nullopt;
}

namespace {
constexpr std::string_view kDiskMagic = "penumbra-spirv-cache 2\n";

std::string hex64(uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

}  // namespace

uint64_t content_hash(std::string_view text) {
  Fnv1a h;
  h.add_field(text);
  return h.value();
}


// The entry for direct_key when every file it lists still hashes the same; nothing otherwise
// (missing, unreadable, malformed or stale entries alike).
std::optional<DiskEntry> disk_lookup(const fs::path& dir, uint64_t direct_key) {
  const std::optional<std::string> file = read_file(dir / (hex64(direct_key) + ".spv"));
  if (!file || !file->starts_with(kDiskMagic)) return std::nullopt;
  std::string_view rest = std::string_view(*file).substr(kDiskMagic.size());
  auto line = [&rest]() -> std::optional<std::string_view> {
    const size_t end = rest.find('\n');
    if (end == std::string_view::npos) return std::nullopt;
    std::string_view l = rest.substr(0, end);
    rest.remove_prefix(end + 1);
    return l;
  };
  DiskEntry entry;
  const auto key_line = line();
  if (!key_line || !key_line->starts_with("key ")) return std::nullopt;
  entry.key = std::strtoull(std::string(key_line->substr(4)).c_str(), nullptr, 16);
  for (;;) {
    const auto l = line();
    if (!l) return std::nullopt;
    if (l->starts_with("spirv ")) {
      const size_t words = std::strtoull(std::string(l->substr(6)).c_str(), nullptr, 10);
      if (words == 0 || rest.size() != words * sizeof(uint32_t)) return std::nullopt;
      entry.spirv.resize(words);
      std::memcpy(entry.spirv.data(), rest.data(), rest.size());
      return entry;
    }
    if (l->starts_with("note ")) {
      entry.notes.emplace_back(l->substr(5));
      continue;
    }
    if (l->starts_with("absent ")) {
      std::error_code ec;
      if (fs::symlink_status(fs::path(std::string(l->substr(7))), ec).type() !=
          fs::file_type::not_found)
        return std::nullopt;  // something is there now: the include may resolve elsewhere
      entry.absent.emplace_back(l->substr(7));
      continue;
    }
    if (!l->starts_with("dep ") || l->size() < 4 + 16 + 2) return std::nullopt;
    const uint64_t want = std::strtoull(std::string(l->substr(4, 16)).c_str(), nullptr, 16);
    const fs::path path(std::string(l->substr(4 + 16 + 1)));
    const std::optional<std::string> text = read_file(path);
    if (!text || content_hash(*text) != want) return std::nullopt;
    entry.dependencies.push_back(path);
  }
}

// Writes the entry through a temporary file renamed into place; false when it could not.
bool disk_store(const fs::path& dir, uint64_t direct_key, const DiskEntry& entry,
                const std::vector<uint64_t>& dependency_hashes) {
  std::string text(kDiskMagic);
  text += "key " + hex64(entry.key) + "\n";
  for (size_t i = 0; i < entry.dependencies.size(); ++i) {
    const std::string path = entry.dependencies[i].string();
    if (path.find('\n') != std::string::npos) return false;
    text += "dep " + hex64(dependency_hashes[i]) + " " + path + "\n";
  }
  for (const std::string& absent : entry.absent) {
    if (absent.find('\n') != std::string::npos) return false;
    text += "absent " + absent + "\n";
  }
  for (const std::string& note : entry.notes) {
    if (note.find('\n') != std::string::npos) return false;
    text += "note " + note + "\n";
  }
  text += "spirv " + std::to_string(entry.spirv.size()) + "\n";
  text.append(reinterpret_cast<const char*>(entry.spirv.data()),
              entry.spirv.size() * sizeof(uint32_t));
  std::error_code ec;
  fs::create_directories(dir, ec);
  static std::atomic<uint64_t> counter{0};
  const fs::path final_path = dir / (hex64(direct_key) + ".spv");
  const fs::path temp = dir / (hex64(direct_key) + ".tmp." + std::to_string(::getpid()) + "." +
                               std::to_string(counter++));
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) return false;
    out.write(text.data(), std::streamsize(text.size()));
    out.close();
    if (!out) {
      fs::remove(temp, ec);
      return false;
    }
  }
  fs::rename(temp, final_path, ec);
  if (ec) fs::remove(temp, ec);
  return !ec;
}

}  // namespace penumbra::shader::detail
