#include <filesystem>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <string>
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
  // Encoded in memory, then written next to the target and renamed over it
  // (write_file_atomic): a reader never sees half a PNG, and a failed write (a full disk, a file
  // size limit) is an error that leaves the old file as it was. stbi_write_png itself ignores
  // fwrite's result.
  std::string bytes;
  const auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), size_t(size));
  };
  if (stbi_write_png_to_func(append, &bytes, int(width), int(height), 4, rgba.data(),
                             int(width * 4)) == 0) {
    throw Error("write_png: cannot encode " + path.string());
  }
  write_file_atomic(path, bytes);
}

}  // namespace penumbra::render
