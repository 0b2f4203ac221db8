#pragma once
// Atomic text output: every file a tool writes for a reader (timings, metrics, reports) goes
// through here, so a reader never sees half a file and a failed write is an error.
#include <filesystem>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <string>
#include <string_view>
#include <system_error>

namespace penumbra {

// Writes `text` to `path` through `path`.tmp and a rename. Throws penumbra::Error naming the
// path when the file cannot be written or moved; the temporary file is removed then.
inline void write_text_atomic(const std::filesystem::path& path, std::string_view text) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  std::error_code ec;
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(text.data(), std::streamsize(text.size()));
    out.flush();
    if (!out) {
      std::filesystem::remove(tmp, ec);
      throw Error("cannot write " + path.string());
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
