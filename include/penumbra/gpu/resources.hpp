#pragma once

#include <vulkan/vulkan.h>

#include <cstddef>
#include <cstdint>
#include <penumbra/gpu/context.hpp>
#include <span>
#include <vector>

namespace penumbra::gpu {

enum class MemoryUse {
  host,    // host-visible, coherent, persistently mapped (uploads, read-backs, small data)
  device,  // device-local; filled through staging copies
};

// A VkBuffer with its own allocation. Move-only.
class Buffer {
 public:
  Buffer() = default;
  Buffer(Context& ctx, VkDeviceSize size, VkBufferUsageFlags usage,
         MemoryUse use = MemoryUse::host);
  ~Buffer();
  Buffer(Buffer&& other) noexcept;
  Buffer& operator=(Buffer&& other) noexcept;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  VkBuffer handle() const { return buffer_; }
  VkDeviceSize size() const { return size_; }
  bool mapped() const { return mapped_ != nullptr; }
  void* data() const { return mapped_; }

  // Copies bytes in/out. Host buffers copy directly; device buffers go through a staging buffer
  // and a one-shot submission.
  void write(std::span<const std::byte> bytes, VkDeviceSize offset = 0);
  void read(std::span<std::byte> bytes, VkDeviceSize offset = 0) const;
  template <class T>
  void write_span(std::span<const T> values, VkDeviceSize offset = 0) {
    write(std::as_bytes(values), offset);
  }
  template <class T>
  std::vector<T> read_vector(size_t count, VkDeviceSize offset = 0) const {
    std::vector<T> out(count);
    read(std::as_writable_bytes(std::span<T>(out)), offset);
    return out;
  }

 private:
  void release();
  Context* ctx_ = nullptr;
  VkBuffer buffer_ = VK_NULL_HANDLE;
  VkDeviceMemory memory_ = VK_NULL_HANDLE;
  VkDeviceSize size_ = 0;
  void* mapped_ = nullptr;
};

enum class ImageKind { image_2d, image_2d_array, cube, cube_array };

struct ImageDesc {
  ImageKind kind = ImageKind::image_2d;
  VkFormat format = VK_FORMAT_R8G8B8A8_UNORM;
  uint32_t width = 1, height = 1;
  uint32_t layers = 1;  // array layers (2D array); cube: 6; cube_array: 6·n
  uint32_t mip_levels = 1;
  VkImageUsageFlags usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
};

bool is_depth_format(VkFormat format);
// The number of levels of a full mip chain down to 1x1 for a width x height image.
uint32_t full_mip_count(uint32_t width, uint32_t height);
class Context;
// Whether Image::generate_mips works for optimal-tiling images of this format on ctx's device.
bool mips_supported(Context& ctx, VkFormat format);
bool has_stencil(VkFormat format);
uint32_t format_texel_size(VkFormat format);    // bytes per texel of the main aspect
VkImageAspectFlags aspect_of(VkFormat format);  // depth aspect for depth formats, else color

// A VkImage with its own allocation and a default view matching its kind (2D, 2D array, cube).
// Tracks the layout it was last transitioned to by the helpers below.
class Image {
 public:
  Image() = default;
  Image(Context& ctx, const ImageDesc& desc);
  ~Image();
  Image(Image&& other) noexcept;
  Image& operator=(Image&& other) noexcept;
  Image(const Image&) = delete;
  Image& operator=(const Image&) = delete;

  VkImage handle() const { return image_; }
  VkImageView view() const { return view_; }
  const ImageDesc& desc() const { return desc_; }
  VkImageLayout layout() const { return layout_; }
  VkImageAspectFlags aspect() const { return aspect_of(desc_.format); }

  // A view of one layer as a plain 2D image (e.g. a render target for one cascade or cube face).
  VkImageView layer_view(uint32_t layer);
  // A view of every layer as a plain 2D array (e.g. a cube array read or written face by face).
  VkImageView array_view();

  // Records a barrier moving every subresource to new_layout (whole-pipeline scope; simple and
  // correct, not minimal) and remembers it.
  void transition(VkCommandBuffer cmd, VkImageLayout new_layout);
  // Tells the tracker that a render pass or another recorder moved the image.
  void assume_layout(VkImageLayout layout) { layout_ = layout; }

  // Uploads tightly packed texels of every layer (layer-major, row-major, mip 0) and leaves the
  // image in final_layout. For depth formats the data goes to the depth aspect: D32_SFLOAT takes
  // float, D16_UNORM takes uint16, X8_D24 takes uint32 with the depth in the low 24 bits.
  void upload(std::span<const std::byte> texels,
              VkImageLayout final_layout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  // Convenience: D32_SFLOAT depth (or R32_SFLOAT) from floats.
  void upload_floats(std::span<const float> values,
                     VkImageLayout final_layout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  // Fills mips 1.. of every layer from mip 0 by repeated 2x linear blits (each level the box
  // average of the one above; odd sizes round down) and leaves every level in final_layout.
  // Needs the format's BLIT_SRC, BLIT_DST and linear-filter features (mips_supported).
  void generate_mips(VkCommandBuffer cmd,
                     VkImageLayout final_layout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  // Reads back mip `level` of every layer (layer-major), leaving the image in its current layout.
  std::vector<std::byte> download(uint32_t level = 0);

 private:
  void release();
  Context* ctx_ = nullptr;
  ImageDesc desc_;
  VkImage image_ = VK_NULL_HANDLE;
  VkDeviceMemory memory_ = VK_NULL_HANDLE;
  VkImageView view_ = VK_NULL_HANDLE;
  std::vector<VkImageView> layer_views_;
  VkImageView array_view_ = VK_NULL_HANDLE;
  VkImageLayout layout_ = VK_IMAGE_LAYOUT_UNDEFINED;
};

struct SamplerDesc {
  VkFilter filter = VK_FILTER_NEAREST;  // mag and min
  VkSamplerMipmapMode mip = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  VkSamplerAddressMode address = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  VkBorderColor border = VK_BORDER_COLOR_FLOAT_OPAQUE_WHITE;
  bool compare = false;  // a depth-compare sampler (sampler2DShadow & co.)
  VkCompareOp compare_op = VK_COMPARE_OP_LESS_OR_EQUAL;
  bool unnormalized = false;
};

class Sampler {
 public:
  Sampler() = default;
  Sampler(Context& ctx, const SamplerDesc& desc);
  ~Sampler();
  Sampler(Sampler&& other) noexcept;
  Sampler& operator=(Sampler&& other) noexcept;
  Sampler(const Sampler&) = delete;
  Sampler& operator=(const Sampler&) = delete;

  VkSampler handle() const { return sampler_; }
  const SamplerDesc& desc() const { return desc_; }

 private:
  Context* ctx_ = nullptr;
  VkSampler sampler_ = VK_NULL_HANDLE;
  SamplerDesc desc_;
};

const char* compare_op_name(VkCompareOp op);

}  // namespace penumbra::gpu
