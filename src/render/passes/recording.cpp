#include <cstdio>
// What the passes share: FrameResources' build helpers and the recording helpers.

#include <algorithm>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/check.hpp>
#include <penumbra/shader/reflection.hpp>

#include "passes.hpp"

namespace penumbra::render::passes {
namespace {

std::string format_name(VkFormat f) {
  switch (f) {
    case VK_FORMAT_D32_SFLOAT:
      return "D32_SFLOAT";
    case VK_FORMAT_R16G16B16A16_SFLOAT:
      return "RGBA16F";
    case VK_FORMAT_R8G8B8A8_UNORM:
      return "RGBA8";
    case VK_FORMAT_R32_SFLOAT:
      return "R32F";
    case VK_FORMAT_R16G16_SFLOAT:
      return "RG16F";
    case VK_FORMAT_R32G32_SFLOAT:
      return "RG32F";
    case VK_FORMAT_R32G32B32A32_SFLOAT:
      return "RGBA32F";
    default:
      return std::to_string(int(f));
  }
}

void viewport(VkCommandBuffer cmd, uint32_t w, uint32_t h) {
  VkViewport vp{0, 0, float(w), float(h), 0, 1};
  VkRect2D sc{{0, 0}, {w, h}};
  vkCmdSetViewport(cmd, 0, 1, &vp);
  vkCmdSetScissor(cmd, 0, 1, &sc);
}

}  // namespace

namespace {

std::string bytes_text(double bytes) {
  char text[32];
  if (bytes >= 1024.0 * 1024 * 1024)
    std::snprintf(text, sizeof text, "%.2f GiB", bytes / (1024.0 * 1024 * 1024));
  else
    std::snprintf(text, sizeof text, "%.1f MiB", bytes / (1024.0 * 1024));
  return text;
}

}  // namespace

gpu::Image FrameResources::make_image(const std::string& name, gpu::ImageKind kind, VkFormat format,
                                      uint32_t w, uint32_t h, uint32_t layers,
                                      VkImageUsageFlags usage, uint32_t mip_levels,
                                      const std::string& sized_by) {
  // ---- what the device allows, before anything is created ----
  const std::string what =
      (sized_by.empty() ? "render size " + std::to_string(width) + "x" + std::to_string(height) +
                              " (render.width, render.height or --size)"
                        : sized_by) +
      ": the " + name + " image (" + std::to_string(w) + "x" + std::to_string(h) +
      (layers > 1 ? "x" + std::to_string(layers) : "") + " " + format_name(format) + ")";
  const bool cube = kind == gpu::ImageKind::cube || kind == gpu::ImageKind::cube_array;
  VkImageFormatProperties fp{};
  const VkResult supported = vkGetPhysicalDeviceImageFormatProperties(
      ctx.physical_device(), format, VK_IMAGE_TYPE_2D, VK_IMAGE_TILING_OPTIMAL, usage,
      cube ? VK_IMAGE_CREATE_CUBE_COMPATIBLE_BIT : 0, &fp);
  const std::string device = "device " + ctx.info().name;
  if (supported != VK_SUCCESS)
    throw Error(what + ": " + device + " cannot make such an image (format and usage)");
  const auto& limits = ctx.info().limits;
  if (w > fp.maxExtent.width || h > fp.maxExtent.height) {
    throw Error(what + " is larger than " + device + " allows for it (" +
                std::to_string(fp.maxExtent.width) + "x" + std::to_string(fp.maxExtent.height) +
                ")");
  }
  if (cube && w > limits.maxImageDimensionCube) {
    throw Error(what + ": cube faces are at most " + std::to_string(limits.maxImageDimensionCube) +
                " on " + device + " (maxImageDimensionCube)");
  }
  if (layers > fp.maxArrayLayers) {
    throw Error(what + " has " + std::to_string(layers) + " layers; " + device + " allows " +
                std::to_string(fp.maxArrayLayers) + " (maxArrayLayers)");
  }
  double bytes = 0;
  for (uint32_t m = 0; m < mip_levels; ++m) {
    bytes += double(std::max(1u, w >> m)) * double(std::max(1u, h >> m)) * layers *
             gpu::format_texel_size(format);
  }
  if (bytes > double(fp.maxResourceSize)) {
    throw Error(what + " needs " + bytes_text(bytes) + "; " + device + " allows " +
                bytes_text(double(fp.maxResourceSize)) + " per image (maxResourceSize)");
  }
  VkPhysicalDeviceMemoryProperties mp{};
  vkGetPhysicalDeviceMemoryProperties(ctx.physical_device(), &mp);
  VkDeviceSize heap = 0;
  for (uint32_t i = 0; i < mp.memoryHeapCount; ++i)
    if (mp.memoryHeaps[i].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
      heap = std::max(heap, mp.memoryHeaps[i].size);
  if (heap > 0 && double(image_bytes) + bytes > double(heap)) {
    throw Error(what + " needs " + bytes_text(bytes) + " on top of " +
                bytes_text(double(image_bytes)) + " of images already made; " + device +
                " has " + bytes_text(double(heap)) + " of device memory");
  }
  image_bytes += uint64_t(bytes);

  gpu::ImageDesc d;
  d.kind = kind;
  d.format = format;
  d.width = w;
  d.height = h;
  d.layers = layers;
  d.usage = usage;
  d.mip_levels = mip_levels;
  report.images.push_back(name + " " + std::to_string(w) + "x" + std::to_string(h) +
                          (layers > 1 ? "x" + std::to_string(layers) : "") + " " +
                          format_name(format) +
                          (mip_levels > 1 ? ", " + std::to_string(mip_levels) + " mips" : ""));
  return gpu::Image(ctx, d);
}

void FrameResources::add_prepared_pipeline(const std::string& name,
                                           std::vector<shader::ProgramSource> sources,
                                           shader::ProgramRegistry::Prepare prepare) {
  registry.add_prepared(name, std::move(sources), std::move(prepare));
  report.pipelines.push_back(name);
}

VkCompareOp FrameResources::depth_test(bool strict) const {
  if (strict) return reverse_z ? VK_COMPARE_OP_GREATER : VK_COMPARE_OP_LESS;
  return reverse_z ? VK_COMPARE_OP_GREATER_OR_EQUAL : VK_COMPARE_OP_LESS_OR_EQUAL;
}

gpu::VertexInput vertex_input() {
  gpu::VertexInput v;
  v.bindings = {{0, sizeof(scene::Vertex), VK_VERTEX_INPUT_RATE_VERTEX}};
  v.attributes = {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)},
                  {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, normal)},
                  {2, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(scene::Vertex, uv)}};
  return v;
}

std::string variant(const std::string& name, const std::vector<shader::Define>& defines) {
  std::string s = name;
  for (const auto& x : defines) s += " " + x.name + "=" + x.value;
  return s;
}

std::vector<shader::Define> light_defines(const FrameResources& r) {
  return {{"PENUMBRA_SUN_SHADOWS", r.req.sun_shadows ? "1" : "0"},
          {"PENUMBRA_CONTACT", r.contact_mask != nullptr ? "1" : "0"},
          {"PENUMBRA_SPOT_SHADOWS", std::to_string(r.req.spot_shadow_maps)},
          {"PENUMBRA_POINT_SHADOWS", std::to_string(r.req.point_shadow_cubes)}};
}

std::vector<shader::Define> mask_defines(const FrameResources& r) {
  return {{"PENUMBRA_MASK_TEXTURES", std::to_string(r.mask_textures.size())}};
}

std::vector<std::vector<gpu::BindingDesc>> draw_sets(const FrameResources& r,
                                                     std::vector<gpu::BindingDesc> set0) {
  std::vector<std::vector<gpu::BindingDesc>> sets{std::move(set0)};
  if (!r.mask_textures.empty()) sets.push_back(mask_set_bindings(r));
  return sets;
}

std::vector<gpu::BindingDesc> mask_set_bindings(const FrameResources& r) {
  return {{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, uint32_t(r.mask_textures.size()),
           VK_SHADER_STAGE_FRAGMENT_BIT}};
}

void create_mask_textures(FrameResources& r) {
  const auto images = r.scene.mask_images();
  if (images.empty()) return;
  const uint32_t limit =
      std::min(kMaxMaskTextures, r.ctx.info().limits.maxPerStageDescriptorSamplers / 2);
  if (images.size() > limit) {
    throw Error("scene " + r.scene.source.string() + ": " + std::to_string(images.size()) +
                " distinct mask textures (mask_texture); the renderer takes at most " +
                std::to_string(limit));
  }
  for (const auto& image : images) {
    gpu::ImageDesc d;
    d.format = VK_FORMAT_R8_UNORM;
    d.width = image->width;
    d.height = image->height;
    gpu::Image& texture = r.mask_textures.emplace_back(r.ctx, d);
    texture.upload(std::as_bytes(std::span(image->texels)));
    r.report.images.push_back("mask-texture " + image->source.filename().string() + " " +
                              std::to_string(image->width) + "x" +
                              std::to_string(image->height) + " R8_UNORM");
  }
  gpu::SamplerDesc s;
  s.filter = VK_FILTER_LINEAR;
  s.address = VK_SAMPLER_ADDRESS_MODE_REPEAT;
  r.mask_sampler = gpu::Sampler(r.ctx, s);
  r.mask_set_layout = std::make_unique<gpu::PipelineLayout>(
      r.ctx, std::vector<std::vector<gpu::BindingDesc>>{mask_set_bindings(r)});
  r.mask_set = r.pool.allocate(r.mask_set_layout->set_layout(0));
  gpu::DescriptorWriter w;
  for (uint32_t i = 0; i < r.mask_textures.size(); ++i)
    w.combined_image(0, r.mask_textures[i].view(), r.mask_sampler.handle(),
                     VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, i);
  w.update(r.ctx, r.mask_set);
}

PerPixelCompute::PerPixelCompute(FrameResources& r, const std::string& name,
                                 shader::ProgramSource source,
                                 std::vector<gpu::BindingDesc> bindings, Specialize specialize,
                                 Variant variant)
    : name_(name.substr(0, name.find(' '))),
      full_name_(name),
      source_(std::move(source)),
      variant_(std::move(variant)),
      layout_(std::make_unique<gpu::PipelineLayout>(
          r.ctx, std::vector<std::vector<gpu::BindingDesc>>{std::move(bindings)})),
      specialize_(std::move(specialize)) {
  add_variant(r, variant_ ? variant_(r) : std::vector<shader::Define>{});
  if (variant_) r.before_frame.push_back([this, &r] { prepare(r); });
  set_ = r.pool.allocate(layout_->set_layout(0));
}

void PerPixelCompute::add_variant(FrameResources& r, const std::vector<shader::Define>& defines) {
  const std::string name = variant(full_name_, defines);
  shader::ProgramSource source = source_;
  source.defines.insert(source.defines.end(), defines.begin(), defines.end());
  auto prepare = [this, &r](const shader::Spirvs& spirv) -> shader::ProgramRegistry::Install {
    // The variant this frame needs; at the install the others, made from the old code, go.
    const SpecValues values = values_for(r);
    std::shared_ptr<gpu::ComputePipeline> fresh = make(r, spirv[0], values);
    return [this, values, fresh, code = spirv[0]] {
      pipelines_.clear();
      pipelines_.emplace(values, fresh);
      spirv_ = code;
    };
  };
  if (registered_.empty()) {
    r.add_prepared_pipeline(name, {std::move(source)}, std::move(prepare));
  } else {
    // Compiled and installed first (a failure throws with the old variant still running), then
    // the old one is forgotten; the build report names the running variant.
    r.registry.add_prepared(name, {std::move(source)}, std::move(prepare));
    r.registry.remove(registered_);
    std::replace(r.report.pipelines.begin(), r.report.pipelines.end(), registered_, name);
  }
  registered_ = name;
}

void PerPixelCompute::prepare(FrameResources& r) {
  if (!variant_) return;
  const std::vector<shader::Define> defines = variant_(r);
  if (variant(full_name_, defines) == registered_) return;
  // The old variant's pipelines go at the install.
  gpu::check(vkDeviceWaitIdle(r.ctx.device()), "vkDeviceWaitIdle");
  add_variant(r, defines);
}

SpecValues PerPixelCompute::values_for(const FrameResources& r) const {
  return specialize_ && r.specialize ? specialize_(r) : SpecValues{};
}

std::unique_ptr<gpu::ComputePipeline> PerPixelCompute::make(const FrameResources& r,
                                                             const std::vector<uint32_t>& spirv,
                                                             const SpecValues& values) const {
  gpu::Specialization spec;
  if (!values.empty()) {
    const shader::Reflection refl = shader::reflect(spirv);
    for (const SpecValue& v : values) {
      const auto found =
          std::find_if(refl.spec_constants.begin(), refl.spec_constants.end(),
                       [&](const shader::SpecConstant& c) { return c.id == v.id; });
      if (found == refl.spec_constants.end() || found->name != v.name)
        throw Error("program '" + name_ + "': the renderer specializes constant_id " +
                    std::to_string(v.id) + " as '" + v.name + "', but the shader " +
                    (found == refl.spec_constants.end()
                         ? std::string("declares no such constant")
                         : "calls it '" + found->name + "'"));
      spec.set(v.id, v.value);
    }
  }
  return std::make_unique<gpu::ComputePipeline>(r.ctx, spirv, *layout_, std::move(spec));
}

void PerPixelCompute::dispatch(VkCommandBuffer cmd, const FrameResources& r) {
  const SpecValues values = values_for(r);
  auto it = pipelines_.find(values);
  if (it == pipelines_.end()) it = pipelines_.emplace(values, make(r, spirv_, values)).first;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, it->second->handle());
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_->handle(), 0, 1, &set_, 0,
                          nullptr);
  vkCmdDispatch(cmd, (r.width + 7) / 8, (r.height + 7) / 8, 1);
}

namespace {

// The draws `take` accepts, opaque then masked, each with its model from `model`, `index` pushed
// (z: whether it casts, which the prepass marks for the contact pass; w: its mask texture).
// Every draw layout has the mask set when the scene samples mask textures (the opaque pipelines
// share the masked ones' fragment shaders, without their alpha test, and declare it).
// `parts(i)`: null for the mesh's own indices whole, else ranges of its caster indices.
template <class Take, class Model, class Parts>
uint64_t draw_list(VkCommandBuffer cmd, FrameResources& r, const gpu::PipelineLayout& layout,
               VkPipeline opaque, VkPipeline masked, glm::uvec4 index, Take take, Model model,
               Parts parts) {
  if (r.mask_set != VK_NULL_HANDLE)
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout.handle(), 1, 1,
                            &r.mask_set, 0, nullptr);
  uint64_t indices = 0;
  for (int pass = 0; pass < 2; ++pass) {
    VkPipeline p = pass == 0 ? opaque : masked;
    if (p == VK_NULL_HANDLE) continue;
    bool bound = false;
    for (size_t i = 0; i < r.packed.draws.size(); ++i) {
      const Draw& d = r.packed.draws[i];
      if (d.masked != (pass == 1) || !take(i, d)) continue;
      const GpuMesh& m = r.meshes[d.mesh];
      if (m.index_count == 0) continue;
      if (!bound) vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p);
      bound = true;
      DrawPush push = d.push;
      push.model = model(i, d);
      push.index = index;
      push.index.z = d.casts ? 1u : 0u;
      push.index.w = d.mask_texture;
      vkCmdPushConstants(cmd, layout.handle(), VK_SHADER_STAGE_ALL, 0, sizeof(DrawPush), &push);
      VkDeviceSize offset = 0;
      VkBuffer vb = m.vertices.handle();
      vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &offset);
      const std::vector<IndexRange>* ranges = parts(i);
      vkCmdBindIndexBuffer(cmd, ranges ? m.caster_indices().handle() : m.indices.handle(), 0,
                           VK_INDEX_TYPE_UINT32);
      if (!ranges) {
        vkCmdDrawIndexed(cmd, m.index_count, 1, 0, 0, 0);
        indices += m.index_count;
      } else {
        for (const IndexRange& range : *ranges) {
          vkCmdDrawIndexed(cmd, range.count, 1, range.first, 0, 0);
          indices += range.count;
        }
      }
    }
  }
  return indices;
}

}  // namespace

void draw_meshes(VkCommandBuffer cmd, FrameResources& r, const gpu::PipelineLayout& layout,
                 VkPipeline opaque, VkPipeline masked, bool casters_only, glm::uvec4 index) {
  draw_list(
      cmd, r, layout, opaque, masked, index,
      [casters_only](size_t, const Draw& d) { return !casters_only || d.in_maps; },
      [](size_t, const Draw& d) { return d.push.model; },
      [](size_t) -> const std::vector<IndexRange>* { return nullptr; });
}

uint64_t draw_casters(VkCommandBuffer cmd, FrameResources& r, const gpu::PipelineLayout& layout,
                      VkPipeline opaque, VkPipeline masked, glm::uvec4 index,
                      const std::vector<glm::mat4>& models, Casters which,
                      const CasterParts* parts) {
  return draw_list(
      cmd, r, layout, opaque, masked, index,
      [which, parts](size_t i, const Draw& d) {
        if (!d.in_maps || (parts && !parts->take[i])) return false;
        return which == Casters::all || d.moves == (which == Casters::moving);
      },
      [&models](size_t i, const Draw&) { return models[i]; },
      [parts](size_t i) -> const std::vector<IndexRange>* {
        return parts && !parts->ranges[i].empty() ? &parts->ranges[i] : nullptr;
      });
}

void begin_rendering(VkCommandBuffer cmd, const FrameResources& r, uint32_t w, uint32_t h,
                     VkImageView color, VkClearColorValue clear, VkImageView depth_view,
                     VkImageLayout depth_layout, bool clear_depth,
                     const std::vector<VkImageView>& extra_colors) {
  std::vector<VkRenderingAttachmentInfo> cas(1 + extra_colors.size(),
                                             {VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO});
  for (size_t i = 0; i < cas.size(); ++i) {
    cas[i].imageView = i == 0 ? color : extra_colors[i - 1];
    cas[i].imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    cas[i].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    cas[i].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    cas[i].clearValue.color = i == 0 ? clear : VkClearColorValue{};
  }
  VkRenderingAttachmentInfo da{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  da.imageView = depth_view;
  da.imageLayout = depth_layout;
  da.loadOp = clear_depth ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
  da.storeOp = clear_depth ? VK_ATTACHMENT_STORE_OP_STORE : VK_ATTACHMENT_STORE_OP_NONE;
  da.clearValue.depthStencil = {r.reverse_z ? 0.0f : 1.0f, 0};
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.renderArea = {{0, 0}, {w, h}};
  ri.layerCount = 1;
  ri.colorAttachmentCount = color != VK_NULL_HANDLE ? uint32_t(cas.size()) : 0;
  ri.pColorAttachments = color != VK_NULL_HANDLE ? cas.data() : nullptr;
  ri.pDepthAttachment = &da;
  vkCmdBeginRendering(cmd, &ri);
  viewport(cmd, w, h);
}

}  // namespace penumbra::render::passes
