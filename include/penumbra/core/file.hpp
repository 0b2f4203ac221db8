#pragma once
// Atomic file output: every file written for a reader (timings, metrics, the reference cache)
// goes through here, so a reader never sees half a file and a failed write is an error.
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <string>
#include <string_view>
#include <system_error>

namespace penumbra {

// Writes `bytes` to `path` through a temporary file next to it (named for this process, so
// processes writing the same path do not share one) and a rename. Throws penumbra::Error
// naming the path when the file cannot be written or moved; the temporary file is removed then.
// What keeps `path` from being read as an input file, for an error message: "" for a regular
// file (or a link to one); else "not found", "is a directory, not a file", "is a character device"
// (/dev/zero), "is a block device", "is a FIFO", "is a socket" or "is not a regular file".
inline std::string file_problem(const std::filesystem::path& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  switch (st.type()) {
    case fs::file_type::regular:
      return "";
    case fs::file_type::not_found:
    case fs::file_type::none:
      return "not found";
    case fs::file_type::directory:
      return "is a directory, not a file";
    case fs::file_type::character:
      return "is a character device, not a regular file";
    case fs::file_type::block:
      return "is a block device, not a regular file";
    case fs::file_type::fifo:
      return "is a FIFO, not a regular file";
    case fs::file_type::socket:
      return "is a socket, not a regular file";
    default:
      return ec ? "cannot be examined (" + ec.message() + ")" : "is not a regular file";
  }
}

// text with NUL and other control bytes written as \0, \n, \xHH: a path that holds one is
// shown whole in a message, not cut where the byte is.
inline std::string printable(std::string_view text) {
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (u == 0)
      out += "\\0";
    else if (c == '\n')
      out += "\\n";
    else if (u < 0x20 || u == 0x7f)
      out += std::string("\\x") + hex[u >> 4] + hex[u & 15];
    else
      out += c;
  }
  return out;
}

inline void write_file_atomic(const std::filesystem::path& path, std::string_view bytes) {
  const std::filesystem::path tmp = path.string() + ".tmp" + std::to_string(::getpid());
  std::error_code ec;
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw Error("cannot write " + path.string() + ": cannot create " + tmp.string());
    errno = 0;
    out.write(bytes.data(), std::streamsize(bytes.size()));
    out.flush();
    const int err = errno;
    const bool written = bool(out);
    out.close();
    if (!written || !out) {
      std::filesystem::remove(tmp, ec);
      throw Error("cannot write " + path.string() + " (" + std::to_string(bytes.size()) +
                  " bytes)" + (!written && err != 0 ? std::string(": ") + std::strerror(err) : "") +
                  "; the file there, if any, is unchanged");
    }
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw Error("cannot move " + tmp.string() + " to " + path.string() + ": " + ec.message());
  }
}

// The share/penumbra folder of an installed Penumbra when this executable runs from one
// (<prefix>/bin/<tool> with <prefix>/share/penumbra/shaders/render installed beside it), found
// from the executable's own path, so a moved prefix works; empty elsewhere (a build tree, a
// project's own binaries).
inline std::filesystem::path installed_share_dir() {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  const fs::path share = exe.parent_path().parent_path() / "share" / "penumbra";
  return fs::is_directory(share / "shaders" / "render", ec) ? share : fs::path();
}

}  // namespace penumbra
