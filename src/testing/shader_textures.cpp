// The shader-function harness's textures: depth, sampled and storage images made for a test's
// resources, and reading a storage image back (shader_function.hpp).
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

namespace {
VkFormat float_format(uint32_t channels, bool half, const char* what) {
  switch (channels) {
    case 1:
      return half ? VK_FORMAT_R16_SFLOAT : VK_FORMAT_R32_SFLOAT;
    case 2:
      return half ? VK_FORMAT_R16G16_SFLOAT : VK_FORMAT_R32G32_SFLOAT;
    case 4:
      return half ? VK_FORMAT_R16G16B16A16_SFLOAT : VK_FORMAT_R32G32B32A32_SFLOAT;
    default:
      throw Error(std::string(what) + ".channels = " + std::to_string(channels) +
                  ": must be 1, 2 or 4");
  }
}
}  // namespace

// ---- textures --------------------------------------------------------------------------------

namespace {

// The kind, size and layers of a texture's image (a cube has six layers per cube), refused
// when it is a cube array and the device has none. `what` names the desc in the error.
template <class Desc>
void set_shape(gpu::ImageDesc& d, const Desc& desc, const gpu::Context& ctx, const char* what) {
  const bool array = desc.array || desc.layers > 1;
  d.kind = desc.cube ? (array ? gpu::ImageKind::cube_array : gpu::ImageKind::cube)
           : array   ? gpu::ImageKind::image_2d_array
                     : gpu::ImageKind::image_2d;
  if (d.kind == gpu::ImageKind::cube_array && !ctx.info().image_cube_array)
    throw Error(std::string(what) + ": device " + ctx.info().name +
                " has no cube-map arrays (imageCubeArray)");
  d.width = desc.width;
  d.height = desc.height;
  d.layers = desc.cube ? 6 * std::max(desc.layers, 1u) : desc.layers;
}

}  // namespace

std::shared_ptr<Texture> make_depth_texture(const DepthTextureDesc& desc,
                                            std::span<const float> depth) {
  auto& ctx = shared_context();
  gpu::ImageDesc d;
  if (desc.format != VK_FORMAT_D32_SFLOAT && desc.format != VK_FORMAT_D16_UNORM &&
      desc.format != VK_FORMAT_X8_D24_UNORM_PACK32) {
    throw Error("DepthTextureDesc.format = " + std::to_string(int(desc.format)) +
                ": must be D32_SFLOAT, D16_UNORM or X8_D24_UNORM_PACK32");
  }
  d.format = desc.format;
  set_shape(d, desc, ctx, "DepthTextureDesc");
  d.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  if (!desc.sampler.compare && desc.sampler.filter == VK_FILTER_LINEAR &&
      !ctx.info().linear_filter_d32) {
    throw Error("DepthTextureDesc.sampler: device " + ctx.info().name +
                " cannot linearly filter D32_SFLOAT without depth compare; use a nearest sampler "
                "or a float texture");
  }
  if (desc.format != VK_FORMAT_D32_SFLOAT) {
    VkFormatProperties fp{};
    vkGetPhysicalDeviceFormatProperties(ctx.physical_device(), d.format, &fp);
    if ((fp.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT) == 0) {
      throw Error("DepthTextureDesc.format: device " + ctx.info().name + " cannot sample " +
                  (desc.format == VK_FORMAT_D16_UNORM ? "D16_UNORM" : "X8_D24_UNORM_PACK32") +
                  " images");
    }
  }
  auto t =
      std::make_shared<Texture>(Texture{gpu::Image(ctx, d), gpu::Sampler(ctx, desc.sampler), true});
  auto unorm = [](float v, double steps) {
    const double c = std::isnan(v) ? 0.0 : std::clamp(double(v), 0.0, 1.0);
    return std::nearbyint(c * steps);
  };
  if (desc.format == VK_FORMAT_D16_UNORM) {
    std::vector<uint16_t> bits(depth.size());
    for (size_t i = 0; i < depth.size(); ++i) bits[i] = uint16_t(unorm(depth[i], 65535.0));
    t->image.upload(std::as_bytes(std::span<const uint16_t>(bits)));
  } else if (desc.format == VK_FORMAT_X8_D24_UNORM_PACK32) {
    std::vector<uint32_t> bits(depth.size());
    for (size_t i = 0; i < depth.size(); ++i) bits[i] = uint32_t(unorm(depth[i], 16777215.0));
    t->image.upload(std::as_bytes(std::span<const uint32_t>(bits)));
  } else {
    t->image.upload_floats(depth);
  }
  return t;
}

std::shared_ptr<Texture> make_float_texture(const FloatTextureDesc& desc,
                                            std::span<const float> texels) {
  auto& ctx = shared_context();
  gpu::ImageDesc d;
  set_shape(d, desc, ctx, "FloatTextureDesc");
  d.format = float_format(desc.channels, desc.half, "FloatTextureDesc");
  if (desc.sampler.filter == VK_FILTER_LINEAR) {
    VkFormatProperties fp{};
    vkGetPhysicalDeviceFormatProperties(ctx.physical_device(), d.format, &fp);
    if ((fp.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT) == 0) {
      throw Error("FloatTextureDesc.sampler: device " + ctx.info().name +
                  " cannot linearly filter a " + std::to_string(desc.channels) + "-channel " +
                  (desc.half ? "16" : "32") + "-bit float texture");
    }
  }
  auto t = std::make_shared<Texture>(
      Texture{gpu::Image(ctx, d), gpu::Sampler(ctx, desc.sampler), false});
  if (desc.half) {
    std::vector<uint16_t> halves(texels.size());
    for (size_t i = 0; i < texels.size(); ++i) halves[i] = glm::packHalf1x16(texels[i]);
    t->image.upload(std::as_bytes(std::span<const uint16_t>(halves)));
  } else {
    t->image.upload(std::as_bytes(texels));
  }
  return t;
}

std::shared_ptr<Texture> make_storage_image(const StorageImageDesc& desc,
                                            std::span<const float> texels) {
  auto& ctx = shared_context();
  gpu::ImageDesc d;
  d.kind =
      (desc.array || desc.layers > 1) ? gpu::ImageKind::image_2d_array : gpu::ImageKind::image_2d;
  d.format = float_format(desc.channels, desc.half, "StorageImageDesc");
  if (desc.width == 0 || desc.height == 0 || desc.layers == 0) {
    throw Error("StorageImageDesc: width, height and layers must be > 0 (got " +
                std::to_string(desc.width) + "x" + std::to_string(desc.height) + "x" +
                std::to_string(desc.layers) + ")");
  }
  d.width = desc.width;
  d.height = desc.height;
  d.layers = desc.layers;
  d.usage = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
            VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  VkFormatProperties fp{};
  vkGetPhysicalDeviceFormatProperties(ctx.physical_device(), d.format, &fp);
  if ((fp.optimalTilingFeatures & VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT) == 0 ||
      (desc.channels == 2 && !ctx.info().storage_image_extended_formats)) {
    throw Error("StorageImageDesc: device " + ctx.info().name + " has no " +
                std::to_string(desc.channels) + "-channel " + (desc.half ? "16" : "32") +
                "-bit float storage images" +
                (desc.channels == 2 ? " (shaderStorageImageExtendedFormats)" : ""));
  }
  const size_t n = size_t(desc.width) * desc.height * desc.layers * desc.channels;
  if (!texels.empty() && texels.size() != n) {
    throw Error("make_storage_image: " + std::to_string(texels.size()) + " floats given for " +
                std::to_string(desc.width) + "x" + std::to_string(desc.height) + "x" +
                std::to_string(desc.layers) + " texels of " + std::to_string(desc.channels) +
                " channel(s) (" + std::to_string(n) + " expected)");
  }
  auto t = std::make_shared<Texture>();
  t->image = gpu::Image(ctx, d);
  t->storage = true;
  std::vector<float> values(texels.begin(), texels.end());
  if (values.empty()) values.assign(n, 0.0f);
  if (desc.half) {
    std::vector<uint16_t> halves(n);
    for (size_t i = 0; i < n; ++i) halves[i] = glm::packHalf1x16(values[i]);
    t->image.upload(std::as_bytes(std::span<const uint16_t>(halves)), VK_IMAGE_LAYOUT_GENERAL);
  } else {
    t->image.upload(std::as_bytes(std::span<const float>(values)), VK_IMAGE_LAYOUT_GENERAL);
  }
  return t;
}

std::vector<float> read_storage_image(Texture& image) {
  if (!image.storage) throw Error("read_storage_image: not a storage image (make_storage_image)");
  const auto bytes = image.image.download(0);
  const VkFormat f = image.image.desc().format;
  const bool half = f == VK_FORMAT_R16_SFLOAT || f == VK_FORMAT_R16G16_SFLOAT ||
                    f == VK_FORMAT_R16G16B16A16_SFLOAT;
  std::vector<float> out(bytes.size() / (half ? 2 : 4));
  if (half) {
    for (size_t i = 0; i < out.size(); ++i) {
      uint16_t h = 0;
      std::memcpy(&h, bytes.data() + 2 * i, 2);
      out[i] = glm::unpackHalf1x16(h);
    }
  } else {
    std::memcpy(out.data(), bytes.data(), out.size() * 4);
  }
  return out;
}

}  // namespace penumbra::testing
