#include <filesystem>
#include <penumbra/core/error.hpp>
#include <system_error>
#include <penumbra/render/renderer.hpp>

#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wshadow"
#endif
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#include <stb/stb_image_write.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace penumbra::render {

void write_png(const std::filesystem::path& path, uint32_t width, uint32_t height,
               const std::vector<uint8_t>& rgba) {
  if (rgba.size() != size_t{width} * height * 4) {
    throw Error("write_png " + path.string() + ": " + std::to_string(rgba.size()) +
                " bytes for a " + std::to_string(width) + "x" + std::to_string(height) +
                " RGBA8 image (expected " + std::to_string(size_t{width} * height * 4) + ")");
  }
  // Written next to the target, then renamed over it: a reader never sees half a PNG.
  const std::filesystem::path tmp = path.string() + ".tmp";
  if (stbi_write_png(tmp.string().c_str(), int(width), int(height), 4, rgba.data(),
                     int(width * 4)) == 0) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw Error("write_png: cannot write " + path.string());
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw Error("write_png: cannot move " + tmp.string() + " to " + path.string() + ": " +
                ec.message());
  }
}

}  // namespace penumbra::render
