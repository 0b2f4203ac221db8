#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <cstring>
#include <optional>
#include <penumbra/gpu/context.hpp>
#include <span>
#include <vector>

namespace penumbra::gpu {

struct BindingDesc {
  uint32_t binding = 0;
  VkDescriptorType type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  uint32_t count = 1;
  VkShaderStageFlags stages = VK_SHADER_STAGE_ALL;
};

// Descriptor set layouts (one per set index, in order) plus one push-constant range.
class PipelineLayout {
 public:
  PipelineLayout(Context& ctx, const std::vector<std::vector<BindingDesc>>& sets,
                 uint32_t push_constant_size = 0,
                 VkShaderStageFlags push_stages = VK_SHADER_STAGE_ALL);
  ~PipelineLayout();
  PipelineLayout(const PipelineLayout&) = delete;
  PipelineLayout& operator=(const PipelineLayout&) = delete;

  VkPipelineLayout handle() const { return layout_; }
  VkDescriptorSetLayout set_layout(uint32_t set) const { return set_layouts_.at(set); }
  uint32_t set_count() const { return static_cast<uint32_t>(set_layouts_.size()); }
  const std::vector<BindingDesc>& bindings(uint32_t set) const { return sets_.at(set); }
  uint32_t push_constant_size() const { return push_size_; }
  VkShaderStageFlags push_stages() const { return push_stages_; }

 private:
  Context& ctx_;
  std::vector<std::vector<BindingDesc>> sets_;
  std::vector<VkDescriptorSetLayout> set_layouts_;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  uint32_t push_size_ = 0;
  VkShaderStageFlags push_stages_ = 0;
};

// Specialization constants by constant_id (4-byte scalars: int, uint, float, bool as uint).
class Specialization {
 public:
  template <class T>
  Specialization& set(uint32_t id, T value) {
    static_assert(sizeof(T) == 4, "specialization constants are 32-bit scalars");
    std::byte bytes[4];
    std::memcpy(bytes, &value, 4);
    for (auto& e : entries_) {
      if (e.constantID == id) {
        std::memcpy(data_.data() + e.offset, bytes, 4);
        return *this;
      }
    }
    entries_.push_back({id, static_cast<uint32_t>(data_.size()), 4});
    data_.insert(data_.end(), bytes, bytes + 4);
    return *this;
  }
  bool empty() const { return entries_.empty(); }
  // Valid while this object lives and is not modified.
  const VkSpecializationInfo* info() {
    info_ = {static_cast<uint32_t>(entries_.size()), entries_.data(), data_.size(), data_.data()};
    return entries_.empty() ? nullptr : &info_;
  }

 private:
  std::vector<VkSpecializationMapEntry> entries_;
  std::vector<std::byte> data_;
  VkSpecializationInfo info_{};
};

class ShaderModule {
 public:
  ShaderModule(Context& ctx, std::span<const uint32_t> spirv);
  ~ShaderModule();
  ShaderModule(const ShaderModule&) = delete;
  ShaderModule& operator=(const ShaderModule&) = delete;
  VkShaderModule handle() const { return module_; }

 private:
  Context& ctx_;
  VkShaderModule module_ = VK_NULL_HANDLE;
};

class ComputePipeline {
 public:
  ComputePipeline(Context& ctx, std::span<const uint32_t> spirv, const PipelineLayout& layout,
                  Specialization spec = {}, VkPipelineCache cache = VK_NULL_HANDLE);
  ~ComputePipeline();
  ComputePipeline(const ComputePipeline&) = delete;
  ComputePipeline& operator=(const ComputePipeline&) = delete;
  VkPipeline handle() const { return pipeline_; }
  const PipelineLayout& layout() const { return layout_; }

 private:
  Context& ctx_;
  const PipelineLayout& layout_;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
};

struct VertexInput {
  std::vector<VkVertexInputBindingDescription> bindings;
  std::vector<VkVertexInputAttributeDescription> attributes;
};

// A graphics pipeline for dynamic rendering. No fragment shader → a depth-only pipeline.
// Viewport and scissor are dynamic; depth bias is dynamic when depth_bias is set.
struct GraphicsPipelineDesc {
  std::span<const uint32_t> vertex_spirv;
  std::span<const uint32_t> fragment_spirv;  // empty: depth only
  VertexInput vertex_input;
  std::vector<VkFormat> color_formats;
  VkFormat depth_format = VK_FORMAT_UNDEFINED;
  bool depth_test = true;
  bool depth_write = true;
  VkCompareOp depth_compare = VK_COMPARE_OP_GREATER_OR_EQUAL;  // reverse-Z
  bool depth_bias = false;                                     // vkCmdSetDepthBias at record time
  bool depth_clamp = false;                                    // needs the depthClamp feature
  VkCullModeFlags cull = VK_CULL_MODE_BACK_BIT;
  VkFrontFace front_face = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  VkPrimitiveTopology topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  Specialization vertex_spec;
  Specialization fragment_spec;
};

class GraphicsPipeline {
 public:
  GraphicsPipeline(Context& ctx, GraphicsPipelineDesc desc, const PipelineLayout& layout,
                   VkPipelineCache cache = VK_NULL_HANDLE);
  ~GraphicsPipeline();
  GraphicsPipeline(const GraphicsPipeline&) = delete;
  GraphicsPipeline& operator=(const GraphicsPipeline&) = delete;
  VkPipeline handle() const { return pipeline_; }
  const PipelineLayout& layout() const { return layout_; }

 private:
  Context& ctx_;
  const PipelineLayout& layout_;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
};

// A descriptor pool sized for simple use (tests, passes). Sets are freed with the pool.
class DescriptorPool {
 public:
  explicit DescriptorPool(Context& ctx, uint32_t max_sets = 64);
  ~DescriptorPool();
  DescriptorPool(const DescriptorPool&) = delete;
  DescriptorPool& operator=(const DescriptorPool&) = delete;
  VkDescriptorSet allocate(VkDescriptorSetLayout layout);
  void reset();

 private:
  Context& ctx_;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
};

// Accumulates descriptor writes and applies them with one vkUpdateDescriptorSets.
class DescriptorWriter {
 public:
  DescriptorWriter& buffer(uint32_t binding, VkBuffer buffer,
                           VkDescriptorType type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                           VkDeviceSize offset = 0, VkDeviceSize range = VK_WHOLE_SIZE);
  DescriptorWriter& combined_image(uint32_t binding, VkImageView view, VkSampler sampler,
                                   VkImageLayout layout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                                   uint32_t array_element = 0);
  DescriptorWriter& storage_image(uint32_t binding, VkImageView view,
                                  VkImageLayout layout = VK_IMAGE_LAYOUT_GENERAL);
  void update(Context& ctx, VkDescriptorSet set);

 private:
  struct Pending {
    uint32_t binding;
    uint32_t element;
    VkDescriptorType type;
    size_t index;  // into buffers_ or images_
    bool is_buffer;
  };
  std::vector<Pending> pending_;
  std::vector<VkDescriptorBufferInfo> buffers_;
  std::vector<VkDescriptorImageInfo> images_;
};

}  // namespace penumbra::gpu
