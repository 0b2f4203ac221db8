// Mask textures: reading a PNG's coverage channel (stb_image, from bytes this file reads with a
// size cap) and sampling it the way the renderer's linear, repeating sampler does.

#include <cmath>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <penumbra/scene/scene.hpp>

#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wuseless-cast"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wcast-qual"
#pragma GCC diagnostic ignored "-Wduplicated-branches"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#endif
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#define STBI_NO_STDIO
#include <stb/stb_image.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace penumbra::scene {
namespace fs = std::filesystem;

MaskImage load_mask_image(const fs::path& file) {
  const std::string where = "mask texture " + file.string();
  std::error_code ec;
  // Regular files only: a FIFO or a device would block or never end.
  if (!fs::is_regular_file(file, ec)) throw Error(where + ": not a regular file");
  const std::uintmax_t bytes = fs::file_size(file, ec);
  if (ec) throw Error(where + ": cannot read its size (" + ec.message() + ")");
  if (bytes > kMaxMaskFileBytes) {
    throw Error(where + ": " + std::to_string(bytes) + " bytes (the limit is " +
                std::to_string(kMaxMaskFileBytes) + ")");
  }
  std::vector<unsigned char> data(static_cast<size_t>(bytes));
  std::ifstream in(file, std::ios::binary);
  if (!in || !in.read(reinterpret_cast<char*>(data.data()), std::streamsize(data.size()))) {
    throw Error(where + ": cannot be read");
  }
  int w = 0, h = 0, channels = 0;
  if (stbi_info_from_memory(data.data(), int(data.size()), &w, &h, &channels) == 0) {
    throw Error(where + ": not a PNG image (" + stbi_failure_reason() + ")");
  }
  if (w <= 0 || h <= 0 || std::uint32_t(w) > kMaxMaskImageSize ||
      std::uint32_t(h) > kMaxMaskImageSize) {
    throw Error(where + ": " + std::to_string(w) + "x" + std::to_string(h) +
                " texels (at most " + std::to_string(kMaxMaskImageSize) + " a side)");
  }
  unsigned char* pixels = stbi_load_from_memory(data.data(), int(data.size()), &w, &h, &channels, 0);
  if (pixels == nullptr) throw Error(where + ": cannot be decoded (" + stbi_failure_reason() + ")");
  MaskImage image;
  image.source = file;
  image.width = std::uint32_t(w);
  image.height = std::uint32_t(h);
  // Grey + alpha and RGBA: the alpha channel; grey and RGB: the first.
  const int channel = (channels == 2 || channels == 4) ? channels - 1 : 0;
  image.texels.resize(size_t(w) * size_t(h));
  for (size_t i = 0; i < image.texels.size(); ++i)
    image.texels[i] = pixels[i * size_t(channels) + size_t(channel)];
  stbi_image_free(pixels);
  return image;
}

float texture_mask(const MaskImage& image, glm::vec2 uv, glm::vec2 scale) {
  const glm::vec2 p = uv * scale;
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || image.texels.empty()) return 1.0f;
  // Repeat, then the texel-centre convention: texel i covers [i, i + 1) and is read at i + 0.5.
  auto axis = [](float t, std::uint32_t n, std::uint32_t& i0, std::uint32_t& i1, float& a) {
    const float x = (t - std::floor(t)) * float(n) - 0.5f;
    const float fx = std::floor(x);
    a = x - fx;
    const auto i = static_cast<std::int64_t>(fx);
    i0 = std::uint32_t((i + std::int64_t(n)) % std::int64_t(n));
    i1 = (i0 + 1) % n;
  };
  std::uint32_t x0, x1, y0, y1;
  float a, b;
  axis(p.x, image.width, x0, x1, a);
  axis(p.y, image.height, y0, y1, b);
  auto texel = [&](std::uint32_t x, std::uint32_t y) {
    return float(image.texels[size_t(y) * image.width + x]) / 255.0f;
  };
  const float top = texel(x0, y0) + a * (texel(x1, y0) - texel(x0, y0));
  const float bottom = texel(x0, y1) + a * (texel(x1, y1) - texel(x0, y1));
  return top + b * (bottom - top);
}

float mask_coverage(const Material& material, glm::vec2 uv) {
  if (material.alpha != AlphaMode::masked) return 1.0f;
  if (material.mask == MaskPattern::texture) {
    return material.mask_image ? texture_mask(*material.mask_image, uv, material.mask_scale)
                               : 1.0f;
  }
  return procedural_mask(uv, material.mask, material.mask_scale);
}

bool alpha_test_discards(const Material& material, glm::vec2 uv) {
  return mask_coverage(material, uv) < material.alpha_cutoff;
}

}  // namespace penumbra::scene
