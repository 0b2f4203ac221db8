#include <penumbra/core/error.hpp>
#include <penumbra/gpu/check.hpp>
#include <penumbra/gpu/pipeline.hpp>

namespace penumbra::gpu {

PipelineLayout::PipelineLayout(Context& ctx, const std::vector<std::vector<BindingDesc>>& sets,
                               uint32_t push_constant_size, VkShaderStageFlags push_stages)
    : ctx_(ctx), sets_(sets), push_size_(push_constant_size), push_stages_(push_stages) {
  try {
    for (const auto& set : sets) {
      std::vector<VkDescriptorSetLayoutBinding> bindings;
      for (const auto& b : set) bindings.push_back({b.binding, b.type, b.count, b.stages, nullptr});
      VkDescriptorSetLayoutCreateInfo li{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
      li.bindingCount = static_cast<uint32_t>(bindings.size());
      li.pBindings = bindings.data();
      VkDescriptorSetLayout layout = VK_NULL_HANDLE;
      check(vkCreateDescriptorSetLayout(ctx.device(), &li, nullptr, &layout),
            "vkCreateDescriptorSetLayout");
      set_layouts_.push_back(layout);
    }
    VkPushConstantRange range{push_stages, 0, push_constant_size};
    VkPipelineLayoutCreateInfo pi{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    pi.setLayoutCount = static_cast<uint32_t>(set_layouts_.size());
    pi.pSetLayouts = set_layouts_.data();
    pi.pushConstantRangeCount = push_constant_size > 0 ? 1 : 0;
    pi.pPushConstantRanges = &range;
    check(vkCreatePipelineLayout(ctx.device(), &pi, nullptr, &layout_), "vkCreatePipelineLayout");
  } catch (...) {
    for (auto l : set_layouts_) vkDestroyDescriptorSetLayout(ctx.device(), l, nullptr);
    throw;
  }
}

PipelineLayout::~PipelineLayout() {
  vkDestroyPipelineLayout(ctx_.device(), layout_, nullptr);
  for (auto l : set_layouts_) vkDestroyDescriptorSetLayout(ctx_.device(), l, nullptr);
}

ShaderModule::ShaderModule(Context& ctx, std::span<const uint32_t> spirv) : ctx_(ctx) {
  if (spirv.empty()) throw Error("ShaderModule: empty SPIR-V");
  VkShaderModuleCreateInfo si{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  si.codeSize = spirv.size_bytes();
  si.pCode = spirv.data();
  check(vkCreateShaderModule(ctx.device(), &si, nullptr, &module_), "vkCreateShaderModule");
}

ShaderModule::~ShaderModule() {
  vkDestroyShaderModule(ctx_.device(), module_, nullptr);
}

ComputePipeline::ComputePipeline(Context& ctx, std::span<const uint32_t> spirv,
                                 const PipelineLayout& layout, Specialization spec,
                                 VkPipelineCache cache)
    : ctx_(ctx), layout_(layout) {
  ShaderModule module(ctx, spirv);
  VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  ci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  ci.stage.module = module.handle();
  ci.stage.pName = "main";
  ci.stage.pSpecializationInfo = spec.info();
  ci.layout = layout.handle();
  check(vkCreateComputePipelines(ctx.device(), cache, 1, &ci, nullptr, &pipeline_),
        "vkCreateComputePipelines");
}

ComputePipeline::~ComputePipeline() {
  vkDestroyPipeline(ctx_.device(), pipeline_, nullptr);
}

GraphicsPipeline::GraphicsPipeline(Context& ctx, GraphicsPipelineDesc desc,
                                   const PipelineLayout& layout, VkPipelineCache cache)
    : ctx_(ctx), layout_(layout) {
  if (desc.depth_clamp && !ctx.info().depth_clamp) {
    throw Error("GraphicsPipelineDesc.depth_clamp: device " + ctx.info().name +
                " lacks the depthClamp feature");
  }
  ShaderModule vs(ctx, desc.vertex_spirv);
  std::optional<ShaderModule> fs;
  if (!desc.fragment_spirv.empty()) fs.emplace(ctx, desc.fragment_spirv);

  std::vector<VkPipelineShaderStageCreateInfo> stages;
  VkPipelineShaderStageCreateInfo st{VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  st.stage = VK_SHADER_STAGE_VERTEX_BIT;
  st.module = vs.handle();
  st.pName = "main";
  st.pSpecializationInfo = desc.vertex_spec.info();
  stages.push_back(st);
  if (fs) {
    st.stage = VK_SHADER_STAGE_FRAGMENT_BIT;
    st.module = fs->handle();
    st.pSpecializationInfo = desc.fragment_spec.info();
    stages.push_back(st);
  }

  VkPipelineVertexInputStateCreateInfo vi{
      VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  vi.vertexBindingDescriptionCount = static_cast<uint32_t>(desc.vertex_input.bindings.size());
  vi.pVertexBindingDescriptions = desc.vertex_input.bindings.data();
  vi.vertexAttributeDescriptionCount = static_cast<uint32_t>(desc.vertex_input.attributes.size());
  vi.pVertexAttributeDescriptions = desc.vertex_input.attributes.data();

  VkPipelineInputAssemblyStateCreateInfo ia{
      VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  ia.topology = desc.topology;

  VkPipelineViewportStateCreateInfo vp{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  vp.viewportCount = 1;
  vp.scissorCount = 1;

  VkPipelineRasterizationStateCreateInfo rs{
      VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  rs.depthClampEnable = desc.depth_clamp ? VK_TRUE : VK_FALSE;
  rs.polygonMode = VK_POLYGON_MODE_FILL;
  rs.cullMode = desc.cull;
  rs.frontFace = desc.front_face;
  rs.depthBiasEnable = desc.depth_bias ? VK_TRUE : VK_FALSE;
  rs.lineWidth = 1.0f;

  VkPipelineMultisampleStateCreateInfo ms{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;

  VkPipelineDepthStencilStateCreateInfo ds{
      VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  ds.depthTestEnable = desc.depth_test ? VK_TRUE : VK_FALSE;
  ds.depthWriteEnable = desc.depth_write ? VK_TRUE : VK_FALSE;
  ds.depthCompareOp = desc.depth_compare;

  std::vector<VkPipelineColorBlendAttachmentState> blends(desc.color_formats.size());
  for (auto& b : blends) {
    b = {};
    b.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                       VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  }
  VkPipelineColorBlendStateCreateInfo cb{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  cb.attachmentCount = static_cast<uint32_t>(blends.size());
  cb.pAttachments = blends.data();

  std::vector<VkDynamicState> dynamic{VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  if (desc.depth_bias) dynamic.push_back(VK_DYNAMIC_STATE_DEPTH_BIAS);
  VkPipelineDynamicStateCreateInfo dy{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dy.dynamicStateCount = static_cast<uint32_t>(dynamic.size());
  dy.pDynamicStates = dynamic.data();

  VkPipelineRenderingCreateInfo ri{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
  ri.colorAttachmentCount = static_cast<uint32_t>(desc.color_formats.size());
  ri.pColorAttachmentFormats = desc.color_formats.data();
  ri.depthAttachmentFormat = desc.depth_format;

  VkGraphicsPipelineCreateInfo gi{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO, &ri};
  gi.stageCount = static_cast<uint32_t>(stages.size());
  gi.pStages = stages.data();
  gi.pVertexInputState = &vi;
  gi.pInputAssemblyState = &ia;
  gi.pViewportState = &vp;
  gi.pRasterizationState = &rs;
  gi.pMultisampleState = &ms;
  gi.pDepthStencilState = &ds;
  gi.pColorBlendState = &cb;
  gi.pDynamicState = &dy;
  gi.layout = layout.handle();
  check(vkCreateGraphicsPipelines(ctx.device(), cache, 1, &gi, nullptr, &pipeline_),
        "vkCreateGraphicsPipelines");
}

GraphicsPipeline::~GraphicsPipeline() {
  vkDestroyPipeline(ctx_.device(), pipeline_, nullptr);
}

DescriptorPool::DescriptorPool(Context& ctx, uint32_t max_sets) : ctx_(ctx) {
  const uint32_t n = max_sets * 16;
  VkDescriptorPoolSize sizes[] = {
      {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, n},         {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, n},
      {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, n}, {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, n},
      {VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, n},          {VK_DESCRIPTOR_TYPE_SAMPLER, n},
  };
  VkDescriptorPoolCreateInfo pi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pi.maxSets = max_sets;
  pi.poolSizeCount = static_cast<uint32_t>(std::size(sizes));
  pi.pPoolSizes = sizes;
  check(vkCreateDescriptorPool(ctx.device(), &pi, nullptr, &pool_), "vkCreateDescriptorPool");
}

DescriptorPool::~DescriptorPool() {
  vkDestroyDescriptorPool(ctx_.device(), pool_, nullptr);
}

VkDescriptorSet DescriptorPool::allocate(VkDescriptorSetLayout layout) {
  VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  ai.descriptorPool = pool_;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &layout;
  VkDescriptorSet set = VK_NULL_HANDLE;
  check(vkAllocateDescriptorSets(ctx_.device(), &ai, &set), "vkAllocateDescriptorSets");
  return set;
}

void DescriptorPool::reset() {
  vkResetDescriptorPool(ctx_.device(), pool_, 0);
}

DescriptorWriter& DescriptorWriter::buffer(uint32_t binding, VkBuffer buffer, VkDescriptorType type,
                                           VkDeviceSize offset, VkDeviceSize range) {
  pending_.push_back({binding, 0, type, buffers_.size(), true});
  buffers_.push_back({buffer, offset, range});
  return *this;
}

DescriptorWriter& DescriptorWriter::combined_image(uint32_t binding, VkImageView view,
                                                   VkSampler sampler, VkImageLayout layout,
                                                   uint32_t array_element) {
  pending_.push_back(
      {binding, array_element, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, images_.size(), false});
  images_.push_back({sampler, view, layout});
  return *this;
}

DescriptorWriter& DescriptorWriter::storage_image(uint32_t binding, VkImageView view,
                                                  VkImageLayout layout) {
  pending_.push_back({binding, 0, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, images_.size(), false});
  images_.push_back({VK_NULL_HANDLE, view, layout});
  return *this;
}

void DescriptorWriter::update(Context& ctx, VkDescriptorSet set) {
  std::vector<VkWriteDescriptorSet> writes;
  for (const auto& p : pending_) {
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = set;
    w.dstBinding = p.binding;
    w.dstArrayElement = p.element;
    w.descriptorCount = 1;
    w.descriptorType = p.type;
    if (p.is_buffer)
      w.pBufferInfo = &buffers_[p.index];
    else
      w.pImageInfo = &images_[p.index];
    writes.push_back(w);
  }
  vkUpdateDescriptorSets(ctx.device(), static_cast<uint32_t>(writes.size()), writes.data(), 0,
                         nullptr);
}

}  // namespace penumbra::gpu
