#include <algorithm>
#include <cstring>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/check.hpp>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/resources.hpp>
#include <utility>

namespace penumbra::gpu {
namespace {

VkDeviceMemory allocate(Context& ctx, const VkMemoryRequirements& req, MemoryUse use) {
  VkMemoryPropertyFlags props =
      use == MemoryUse::host
          ? (VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT)
          : VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
  VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  ai.allocationSize = req.size;
  ai.memoryTypeIndex = ctx.memory_type(req.memoryTypeBits, props);
  VkDeviceMemory memory = VK_NULL_HANDLE;
  check(vkAllocateMemory(ctx.device(), &ai, nullptr, &memory), "vkAllocateMemory");
  return memory;
}

VkImageViewType view_type(ImageKind kind, uint32_t layers) {
  switch (kind) {
    case ImageKind::image_2d:
      return VK_IMAGE_VIEW_TYPE_2D;
    case ImageKind::image_2d_array:
      return VK_IMAGE_VIEW_TYPE_2D_ARRAY;
    case ImageKind::cube:
      return layers > 6 ? VK_IMAGE_VIEW_TYPE_CUBE_ARRAY : VK_IMAGE_VIEW_TYPE_CUBE;
    case ImageKind::cube_array:
      return VK_IMAGE_VIEW_TYPE_CUBE_ARRAY;
  }
  return VK_IMAGE_VIEW_TYPE_2D;
}

// Access and stage masks that cover every use of a layout (coarse but always correct).
void layout_scope(VkImageLayout layout, VkPipelineStageFlags2& stage, VkAccessFlags2& access) {
  switch (layout) {
    case VK_IMAGE_LAYOUT_UNDEFINED:
      stage = VK_PIPELINE_STAGE_2_TOP_OF_PIPE_BIT;
      access = 0;
      break;
    default:
      stage = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
      access = VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT;
      break;
  }
}

}  // namespace

// ---- Buffer ---------------------------------------------------------------------------------

Buffer::Buffer(Context& ctx, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUse use)
    : ctx_(&ctx), size_(size) {
  if (size == 0) throw Error("Buffer: size must be > 0");
  VkBufferCreateInfo bi{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bi.size = size;
  bi.usage = usage | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  bi.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  check(vkCreateBuffer(ctx.device(), &bi, nullptr, &buffer_), "vkCreateBuffer");
  try {
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(ctx.device(), buffer_, &req);
    memory_ = allocate(ctx, req, use);
    check(vkBindBufferMemory(ctx.device(), buffer_, memory_, 0), "vkBindBufferMemory");
    if (use == MemoryUse::host) {
      check(vkMapMemory(ctx.device(), memory_, 0, VK_WHOLE_SIZE, 0, &mapped_), "vkMapMemory");
    }
  } catch (...) {
    release();
    throw;
  }
}

Buffer::~Buffer() {
  release();
}

void Buffer::release() {
  if (ctx_ == nullptr) return;
  if (mapped_ != nullptr) vkUnmapMemory(ctx_->device(), memory_);
  if (buffer_ != VK_NULL_HANDLE) vkDestroyBuffer(ctx_->device(), buffer_, nullptr);
  if (memory_ != VK_NULL_HANDLE) vkFreeMemory(ctx_->device(), memory_, nullptr);
  buffer_ = VK_NULL_HANDLE;
  memory_ = VK_NULL_HANDLE;
  mapped_ = nullptr;
  ctx_ = nullptr;
}

Buffer::Buffer(Buffer&& o) noexcept
    : ctx_(std::exchange(o.ctx_, nullptr)),
      buffer_(std::exchange(o.buffer_, VK_NULL_HANDLE)),
      memory_(std::exchange(o.memory_, VK_NULL_HANDLE)),
      size_(std::exchange(o.size_, 0)),
      mapped_(std::exchange(o.mapped_, nullptr)) {}

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this != &o) {
    release();
    ctx_ = std::exchange(o.ctx_, nullptr);
    buffer_ = std::exchange(o.buffer_, VK_NULL_HANDLE);
    memory_ = std::exchange(o.memory_, VK_NULL_HANDLE);
    size_ = std::exchange(o.size_, 0);
    mapped_ = std::exchange(o.mapped_, nullptr);
  }
  return *this;
}

void Buffer::write(std::span<const std::byte> bytes, VkDeviceSize offset) {
  if (offset + bytes.size() > size_) {
    throw Error("Buffer::write of " + std::to_string(bytes.size()) + " bytes at offset " +
                std::to_string(offset) + " overruns the buffer (" + std::to_string(size_) +
                " bytes)");
  }
  if (bytes.empty()) return;
  if (mapped_ != nullptr) {
    std::memcpy(static_cast<std::byte*>(mapped_) + offset, bytes.data(), bytes.size());
    return;
  }
  Buffer staging(*ctx_, bytes.size(), 0, MemoryUse::host);
  staging.write(bytes);
  submit_one_shot(*ctx_, [&](VkCommandBuffer cmd) {
    VkBufferCopy region{0, offset, bytes.size()};
    vkCmdCopyBuffer(cmd, staging.handle(), buffer_, 1, &region);
  });
}

void Buffer::read(std::span<std::byte> bytes, VkDeviceSize offset) const {
  if (offset + bytes.size() > size_) {
    throw Error("Buffer::read of " + std::to_string(bytes.size()) + " bytes at offset " +
                std::to_string(offset) + " overruns the buffer (" + std::to_string(size_) +
                " bytes)");
  }
  if (bytes.empty()) return;
  if (mapped_ != nullptr) {
    std::memcpy(bytes.data(), static_cast<const std::byte*>(mapped_) + offset, bytes.size());
    return;
  }
  Buffer staging(*ctx_, bytes.size(), 0, MemoryUse::host);
  submit_one_shot(*ctx_, [&](VkCommandBuffer cmd) {
    VkBufferCopy region{offset, 0, bytes.size()};
    vkCmdCopyBuffer(cmd, buffer_, staging.handle(), 1, &region);
  });
  staging.read(bytes);
}

// ---- formats ----------------------------------------------------------------------------------

bool is_depth_format(VkFormat f) {
  return f == VK_FORMAT_D16_UNORM || f == VK_FORMAT_D32_SFLOAT ||
         f == VK_FORMAT_X8_D24_UNORM_PACK32 || f == VK_FORMAT_D24_UNORM_S8_UINT ||
         f == VK_FORMAT_D32_SFLOAT_S8_UINT || f == VK_FORMAT_D16_UNORM_S8_UINT;
}

bool has_stencil(VkFormat f) {
  return f == VK_FORMAT_D24_UNORM_S8_UINT || f == VK_FORMAT_D32_SFLOAT_S8_UINT ||
         f == VK_FORMAT_D16_UNORM_S8_UINT;
}

VkImageAspectFlags aspect_of(VkFormat f) {
  return is_depth_format(f) ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT;
}

uint32_t format_texel_size(VkFormat f) {
  switch (f) {
    case VK_FORMAT_R8_UNORM:
      return 1;
    case VK_FORMAT_D16_UNORM:
    case VK_FORMAT_R16_SFLOAT:
    case VK_FORMAT_R16_UNORM:
    case VK_FORMAT_D16_UNORM_S8_UINT:
      return 2;
    case VK_FORMAT_D32_SFLOAT:
    case VK_FORMAT_X8_D24_UNORM_PACK32:
    case VK_FORMAT_D24_UNORM_S8_UINT:
    case VK_FORMAT_D32_SFLOAT_S8_UINT:
    case VK_FORMAT_R32_SFLOAT:
    case VK_FORMAT_R32_UINT:
    case VK_FORMAT_R8G8B8A8_UNORM:
    case VK_FORMAT_R8G8B8A8_SRGB:
    case VK_FORMAT_B8G8R8A8_UNORM:
    case VK_FORMAT_B8G8R8A8_SRGB:
    case VK_FORMAT_R16G16_SFLOAT:
    case VK_FORMAT_A2B10G10R10_UNORM_PACK32:
    case VK_FORMAT_B10G11R11_UFLOAT_PACK32:
      return 4;
    case VK_FORMAT_R32G32_SFLOAT:
    case VK_FORMAT_R16G16B16A16_SFLOAT:
      return 8;
    case VK_FORMAT_R32G32B32A32_SFLOAT:
      return 16;
    default:
      throw Error("format_texel_size: format " + std::to_string(static_cast<int>(f)) +
                  " is not supported by Penumbra's upload path");
  }
}

// ---- Image ------------------------------------------------------------------------------------

Image::Image(Context& ctx, const ImageDesc& desc) : ctx_(&ctx), desc_(desc) {
  if (desc.width == 0 || desc.height == 0 || desc.layers == 0 || desc.mip_levels == 0) {
    throw Error("ImageDesc: width, height, layers and mip_levels must be > 0 (got " +
                std::to_string(desc.width) + "x" + std::to_string(desc.height) + ", " +
                std::to_string(desc.layers) + " layers, " + std::to_string(desc.mip_levels) +
                " mips)");
  }
  const bool cube = desc.kind == ImageKind::cube || desc.kind == ImageKind::cube_array;
  if (cube && (desc.layers % 6 != 0 || desc.width != desc.height)) {
    throw Error("ImageDesc: a cube image needs square faces and a multiple of 6 layers (got " +
                std::to_string(desc.width) + "x" + std::to_string(desc.height) + ", " +
                std::to_string(desc.layers) + " layers)");
  }
  VkImageCreateInfo ii{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ii.flags = cube ? VK_IMAGE_CREATE_CUBE_COMPATIBLE_BIT : 0;
  ii.imageType = VK_IMAGE_TYPE_2D;
  ii.format = desc.format;
  ii.extent = {desc.width, desc.height, 1};
  ii.mipLevels = desc.mip_levels;
  ii.arrayLayers = desc.layers;
  ii.samples = VK_SAMPLE_COUNT_1_BIT;
  ii.tiling = VK_IMAGE_TILING_OPTIMAL;
  ii.usage = desc.usage | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  ii.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  ii.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  check(vkCreateImage(ctx.device(), &ii, nullptr, &image_), "vkCreateImage");
  try {
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(ctx.device(), image_, &req);
    memory_ = allocate(ctx, req, MemoryUse::device);
    check(vkBindImageMemory(ctx.device(), image_, memory_, 0), "vkBindImageMemory");
    VkImageViewCreateInfo vi{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vi.image = image_;
    vi.viewType = view_type(desc.kind, desc.layers);
    vi.format = desc.format;
    vi.subresourceRange = {aspect_of(desc.format), 0, desc.mip_levels, 0, desc.layers};
    check(vkCreateImageView(ctx.device(), &vi, nullptr, &view_), "vkCreateImageView");
    layer_views_.assign(desc.layers, VK_NULL_HANDLE);
  } catch (...) {
    release();
    throw;
  }
}

Image::~Image() {
  release();
}

void Image::release() {
  if (ctx_ == nullptr) return;
  for (VkImageView v : layer_views_)
    if (v != VK_NULL_HANDLE) vkDestroyImageView(ctx_->device(), v, nullptr);
  layer_views_.clear();
  if (array_view_ != VK_NULL_HANDLE) vkDestroyImageView(ctx_->device(), array_view_, nullptr);
  array_view_ = VK_NULL_HANDLE;
  if (view_ != VK_NULL_HANDLE) vkDestroyImageView(ctx_->device(), view_, nullptr);
  if (image_ != VK_NULL_HANDLE) vkDestroyImage(ctx_->device(), image_, nullptr);
  if (memory_ != VK_NULL_HANDLE) vkFreeMemory(ctx_->device(), memory_, nullptr);
  view_ = VK_NULL_HANDLE;
  image_ = VK_NULL_HANDLE;
  memory_ = VK_NULL_HANDLE;
  ctx_ = nullptr;
}

Image::Image(Image&& o) noexcept
    : ctx_(std::exchange(o.ctx_, nullptr)),
      desc_(o.desc_),
      image_(std::exchange(o.image_, VK_NULL_HANDLE)),
      memory_(std::exchange(o.memory_, VK_NULL_HANDLE)),
      view_(std::exchange(o.view_, VK_NULL_HANDLE)),
      layer_views_(std::move(o.layer_views_)),
      array_view_(std::exchange(o.array_view_, VK_NULL_HANDLE)),
      layout_(o.layout_) {}

Image& Image::operator=(Image&& o) noexcept {
  if (this != &o) {
    release();
    ctx_ = std::exchange(o.ctx_, nullptr);
    desc_ = o.desc_;
    image_ = std::exchange(o.image_, VK_NULL_HANDLE);
    memory_ = std::exchange(o.memory_, VK_NULL_HANDLE);
    view_ = std::exchange(o.view_, VK_NULL_HANDLE);
    layer_views_ = std::move(o.layer_views_);
    array_view_ = std::exchange(o.array_view_, VK_NULL_HANDLE);
    layout_ = o.layout_;
  }
  return *this;
}

VkImageView Image::layer_view(uint32_t layer) {
  if (layer >= desc_.layers) {
    throw Error("Image::layer_view: layer " + std::to_string(layer) + " out of range (" +
                std::to_string(desc_.layers) + " layers)");
  }
  if (layer_views_[layer] == VK_NULL_HANDLE) {
    VkImageViewCreateInfo vi{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vi.image = image_;
    vi.viewType = VK_IMAGE_VIEW_TYPE_2D;
    vi.format = desc_.format;
    vi.subresourceRange = {aspect(), 0, 1, layer, 1};
    check(vkCreateImageView(ctx_->device(), &vi, nullptr, &layer_views_[layer]),
          "vkCreateImageView(layer)");
  }
  return layer_views_[layer];
}

VkImageView Image::array_view() {
  if (array_view_ == VK_NULL_HANDLE) {
    VkImageViewCreateInfo vi{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vi.image = image_;
    vi.viewType = VK_IMAGE_VIEW_TYPE_2D_ARRAY;
    vi.format = desc_.format;
    vi.subresourceRange = {aspect(), 0, 1, 0, desc_.layers};
    check(vkCreateImageView(ctx_->device(), &vi, nullptr, &array_view_),
          "vkCreateImageView(array)");
  }
  return array_view_;
}

void Image::transition(VkCommandBuffer cmd, VkImageLayout new_layout) {
  VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
  layout_scope(layout_, b.srcStageMask, b.srcAccessMask);
  layout_scope(new_layout, b.dstStageMask, b.dstAccessMask);
  if (new_layout == VK_IMAGE_LAYOUT_UNDEFINED) {
    throw Error("Image::transition: cannot transition to VK_IMAGE_LAYOUT_UNDEFINED");
  }
  b.oldLayout = layout_;
  b.newLayout = new_layout;
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image_;
  b.subresourceRange = {aspect(), 0, desc_.mip_levels, 0, desc_.layers};
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dep);
  layout_ = new_layout;
}

void Image::upload(std::span<const std::byte> texels, VkImageLayout final_layout) {
  const size_t expected =
      size_t{format_texel_size(desc_.format)} * desc_.width * desc_.height * desc_.layers;
  if (texels.size() != expected) {
    throw Error("Image::upload: got " + std::to_string(texels.size()) + " bytes, expected " +
                std::to_string(expected) + " (" + std::to_string(desc_.width) + "x" +
                std::to_string(desc_.height) + "x" + std::to_string(desc_.layers) + " texels of " +
                std::to_string(format_texel_size(desc_.format)) + " bytes)");
  }
  if (has_stencil(desc_.format)) {
    throw Error(
        "Image::upload: combined depth/stencil formats are not uploadable; use D32_SFLOAT, "
        "D16_UNORM or X8_D24");
  }
  Buffer staging(*ctx_, texels.size(), 0, MemoryUse::host);
  staging.write(texels);
  submit_one_shot(*ctx_, [&](VkCommandBuffer cmd) {
    transition(cmd, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    VkBufferImageCopy region{};
    region.imageSubresource = {aspect(), 0, 0, desc_.layers};
    region.imageExtent = {desc_.width, desc_.height, 1};
    vkCmdCopyBufferToImage(cmd, staging.handle(), image_, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1,
                           &region);
    transition(cmd, final_layout);
  });
}

void Image::upload_floats(std::span<const float> values, VkImageLayout final_layout) {
  if (desc_.format != VK_FORMAT_D32_SFLOAT && desc_.format != VK_FORMAT_R32_SFLOAT) {
    throw Error("Image::upload_floats needs a D32_SFLOAT or R32_SFLOAT image");
  }
  upload(std::as_bytes(values), final_layout);
}

uint32_t full_mip_count(uint32_t width, uint32_t height) {
  uint32_t levels = 1;
  for (uint32_t size = std::max(width, height); size > 1; size /= 2) ++levels;
  return levels;
}

bool mips_supported(Context& ctx, VkFormat format) {
  VkFormatProperties props{};
  vkGetPhysicalDeviceFormatProperties(ctx.physical_device(), format, &props);
  const VkFormatFeatureFlags need = VK_FORMAT_FEATURE_BLIT_SRC_BIT |
                                    VK_FORMAT_FEATURE_BLIT_DST_BIT |
                                    VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT;
  return (props.optimalTilingFeatures & need) == need;
}

void Image::generate_mips(VkCommandBuffer cmd, VkImageLayout final_layout) {
  if (final_layout == VK_IMAGE_LAYOUT_UNDEFINED) {
    throw Error("Image::generate_mips: cannot leave the image in VK_IMAGE_LAYOUT_UNDEFINED");
  }
  // One barrier per step over a range of levels; the whole-pipeline scope of transition().
  auto barrier = [&](uint32_t level, uint32_t count, VkImageLayout from, VkImageLayout to) {
    VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
    layout_scope(from, b.srcStageMask, b.srcAccessMask);
    layout_scope(to, b.dstStageMask, b.dstAccessMask);
    b.oldLayout = from;
    b.newLayout = to;
    b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = image_;
    b.subresourceRange = {aspect(), level, count, 0, desc_.layers};
    VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
    dep.imageMemoryBarrierCount = 1;
    dep.pImageMemoryBarriers = &b;
    vkCmdPipelineBarrier2(cmd, &dep);
  };
  const uint32_t levels = desc_.mip_levels;
  barrier(0, 1, layout_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
  if (levels > 1) {
    // The levels below are overwritten whole: their old contents need not survive.
    barrier(1, levels - 1, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
  }
  int32_t w = int32_t(desc_.width), h = int32_t(desc_.height);
  for (uint32_t level = 1; level < levels; ++level) {
    const int32_t nw = std::max(w / 2, 1), nh = std::max(h / 2, 1);
    VkImageBlit blit{};
    blit.srcSubresource = {aspect(), level - 1, 0, desc_.layers};
    blit.srcOffsets[1] = {w, h, 1};
    blit.dstSubresource = {aspect(), level, 0, desc_.layers};
    blit.dstOffsets[1] = {nw, nh, 1};
    vkCmdBlitImage(cmd, image_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, image_,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_LINEAR);
    barrier(level, 1, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    w = nw;
    h = nh;
  }
  barrier(0, levels, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, final_layout);
  layout_ = final_layout;
}

std::vector<std::byte> Image::download(uint32_t level) {
  if (level >= desc_.mip_levels) {
    throw Error("Image::download: mip " + std::to_string(level) + " out of range (" +
                std::to_string(desc_.mip_levels) + " mips)");
  }
  const uint32_t width = std::max(desc_.width >> level, 1u);
  const uint32_t height = std::max(desc_.height >> level, 1u);
  const size_t bytes = size_t{format_texel_size(desc_.format)} * width * height * desc_.layers;
  Buffer staging(*ctx_, bytes, 0, MemoryUse::host);
  const VkImageLayout keep =
      layout_ == VK_IMAGE_LAYOUT_UNDEFINED ? VK_IMAGE_LAYOUT_GENERAL : layout_;
  submit_one_shot(*ctx_, [&](VkCommandBuffer cmd) {
    transition(cmd, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    VkBufferImageCopy region{};
    region.imageSubresource = {aspect(), level, 0, desc_.layers};
    region.imageExtent = {width, height, 1};
    vkCmdCopyImageToBuffer(cmd, image_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, staging.handle(), 1,
                           &region);
    transition(cmd, keep);
  });
  std::vector<std::byte> out(bytes);
  staging.read(out);
  return out;
}

// ---- Sampler ----------------------------------------------------------------------------------

Sampler::Sampler(Context& ctx, const SamplerDesc& desc) : ctx_(&ctx), desc_(desc) {
  VkSamplerCreateInfo si{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  si.magFilter = desc.filter;
  si.minFilter = desc.filter;
  si.mipmapMode = desc.mip;
  si.addressModeU = si.addressModeV = si.addressModeW = desc.address;
  si.compareEnable = desc.compare ? VK_TRUE : VK_FALSE;
  si.compareOp = desc.compare_op;
  si.minLod = 0.0f;
  si.maxLod = desc.unnormalized ? 0.0f : VK_LOD_CLAMP_NONE;
  si.borderColor = desc.border;
  si.unnormalizedCoordinates = desc.unnormalized ? VK_TRUE : VK_FALSE;
  check(vkCreateSampler(ctx.device(), &si, nullptr, &sampler_), "vkCreateSampler");
}

Sampler::~Sampler() {
  if (ctx_ != nullptr && sampler_ != VK_NULL_HANDLE)
    vkDestroySampler(ctx_->device(), sampler_, nullptr);
}

Sampler::Sampler(Sampler&& o) noexcept
    : ctx_(std::exchange(o.ctx_, nullptr)),
      sampler_(std::exchange(o.sampler_, VK_NULL_HANDLE)),
      desc_(o.desc_) {}

Sampler& Sampler::operator=(Sampler&& o) noexcept {
  if (this != &o) {
    if (ctx_ != nullptr && sampler_ != VK_NULL_HANDLE)
      vkDestroySampler(ctx_->device(), sampler_, nullptr);
    ctx_ = std::exchange(o.ctx_, nullptr);
    sampler_ = std::exchange(o.sampler_, VK_NULL_HANDLE);
    desc_ = o.desc_;
  }
  return *this;
}

const char* compare_op_name(VkCompareOp op) {
  switch (op) {
    case VK_COMPARE_OP_NEVER:
      return "never";
    case VK_COMPARE_OP_LESS:
      return "less";
    case VK_COMPARE_OP_EQUAL:
      return "equal";
    case VK_COMPARE_OP_LESS_OR_EQUAL:
      return "less_or_equal";
    case VK_COMPARE_OP_GREATER:
      return "greater";
    case VK_COMPARE_OP_NOT_EQUAL:
      return "not_equal";
    case VK_COMPARE_OP_GREATER_OR_EQUAL:
      return "greater_or_equal";
    case VK_COMPARE_OP_ALWAYS:
      return "always";
    default:
      return "unknown";
  }
}

}  // namespace penumbra::gpu
