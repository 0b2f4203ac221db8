#pragma once
// Atomic file output: every file written for a reader (timings, metrics, the reference cache)
// goes through here, so a reader never sees half a file and a failed write is an error.
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <string>
#include <string_view>
#include <system_error>

#include <unistd.h>

namespace penumbra {

// Writes `bytes` to `path` through a temporary file next to it (named for this process, so
// processes writing the same path do not share one) and a rename. Throws penumbra::Error
// naming the path when the file cannot be written or moved; the temporary file is removed then.
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

}  // namespace penumbra
