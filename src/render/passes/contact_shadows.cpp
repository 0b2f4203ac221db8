#include <cmath>
#include <map>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/check.hpp>
#include <penumbra/render/contact_shadows.hpp>
#include <penumbra/shader/compiler.hpp>
#include <span>
#include <sstream>
#include <utility>

#include "../graph.hpp"

namespace penumbra::render {

namespace {

constexpr std::uint32_t kGroupSize = 8;  // local_size_x/y of both stages

std::string str(double v) {
  std::ostringstream s;
  s.precision(9);
  s << v;
  return s.str();
}

[[noreturn]] void fail(const std::string& what, const std::string& field, double value,
                       const std::string& rule) {
  throw Error(what + "." + field + " = " + str(value) + ": " + rule);
}

bool has_features(gpu::Context& ctx, VkFormat format, VkFormatFeatureFlags features) {
  VkFormatProperties props{};
  vkGetPhysicalDeviceFormatProperties(ctx.physical_device(), format, &props);
  return (props.optimalTilingFeatures & features) == features;
}

std::string dispatch_text(const char* name, std::uint32_t x, std::uint32_t y) {
  return std::string("dispatch ") + name + " " + std::to_string(x) + "x" + std::to_string(y) + "x1";
}

}  // namespace

std::filesystem::path default_shader_dir() {
  return shader::default_shader_dir();
}

void validate(const ContactShadowSettings& s) {
  const std::string w = "ContactShadowSettings";
  if (s.step_count > kContactMaxSteps) {
    fail(w, "step_count", s.step_count,
         "must be in [0, " + std::to_string(kContactMaxSteps) + "] (0 disables the pass)");
  }
  if (!(std::isfinite(s.max_distance) && s.max_distance >= 0.0f)) {
    fail(w, "max_distance", s.max_distance, "must be finite and >= 0");
  }
  if (!(std::isfinite(s.thickness) && s.thickness > 0.0f)) {
    fail(w, "thickness", s.thickness, "must be finite and > 0");
  }
  if (!(s.intensity >= 0.0f && s.intensity <= 1.0f)) {
    fail(w, "intensity", s.intensity, "must be in [0, 1]");
  }
  if (!(s.depth_bias >= 0.0f && s.depth_bias < 1.0f)) {
    fail(w, "depth_bias", s.depth_bias, "must be in [0, 1)");
  }
  if (!(s.step_exponent >= 1.0f && s.step_exponent <= 8.0f)) {
    fail(w, "step_exponent", s.step_exponent, "must be in [1, 8]");
  }
  if (!(s.edge_fade >= 0.0f && s.edge_fade <= 0.5f)) {
    fail(w, "edge_fade", s.edge_fade, "must be in [0, 0.5]");
  }
}

ContactCamera ContactCamera::from(const shadow::Camera& camera, shadow::DepthConvention depth) {
  ContactCamera c;
  c.tan_half_fov_y = std::tan(camera.fov_y * 0.5);
  c.aspect = camera.aspect;
  c.near = camera.near;
  c.far = camera.far;
  c.depth = depth;
  return c;
}

void validate(const ContactCamera& c) {
  const std::string w = "ContactCamera";
  if (!(std::isfinite(c.tan_half_fov_y) && c.tan_half_fov_y > 0.0)) {
    fail(w, "tan_half_fov_y", c.tan_half_fov_y, "must be finite and > 0");
  }
  if (!(std::isfinite(c.aspect) && c.aspect > 0.0)) {
    fail(w, "aspect", c.aspect, "must be finite and > 0");
  }
  if (!(std::isfinite(c.near) && c.near > 0.0)) {
    fail(w, "near", c.near, "must be finite and > 0");
  }
  if (!(c.far > c.near)) fail(w, "far", c.far, "must be > near (" + str(c.near) + ")");
  // The GPU sees floats: a finite far plane must stay distinct from the near plane there.
  const float near_f = static_cast<float>(c.near), far_f = static_cast<float>(c.far);
  if (!(near_f > 0.0f)) fail(w, "near", c.near, "must be representable as a positive float");
  if (!std::isinf(far_f) && !(far_f > near_f)) {
    fail(w, "far", c.far, "must be > near (" + str(c.near) + ") also when rounded to float");
  }
  if (c.depth != shadow::DepthConvention::reverse_z &&
      c.depth != shadow::DepthConvention::standard) {
    fail(w, "depth", static_cast<double>(c.depth), "must be standard (0) or reverse_z (1)");
  }
}

glm::dmat3 contact_view_basis(const shadow::Camera& camera) {
  const double fl = glm::length(camera.forward);
  if (!(fl > 0.0) || !std::isfinite(fl)) {
    throw Error("contact_view_basis: camera.forward must be finite and non-zero");
  }
  const glm::dvec3 forward = camera.forward / fl;
  const glm::dvec3 right_raw = glm::cross(forward, camera.up);
  const double rl = glm::length(right_raw);
  if (!(rl > 0.0) || !std::isfinite(rl)) {
    throw Error("contact_view_basis: camera.up must be finite and not parallel to forward");
  }
  const glm::dvec3 right = right_raw / rl;
  const glm::dvec3 up = glm::cross(right, forward);  // right x up = -forward
  // Rows x, y, z: view = basis * world (glm is column-major, so transpose the columns).
  return glm::transpose(glm::dmat3(right, up, -forward));
}

glm::dvec3 to_contact_view(const shadow::Camera& camera, const glm::dvec3& world_direction) {
  return contact_view_basis(camera) * world_direction;
}

ContactShadowGpu pack_contact_shadow(const ContactShadowSettings& settings,
                                     const ContactShadowFrame& frame, std::uint32_t width,
                                     std::uint32_t height) {
  validate(settings);
  validate(frame.camera);
  if (width == 0 || height == 0) {
    throw Error("pack_contact_shadow: extent " + std::to_string(width) + "x" +
                std::to_string(height) + " must not be empty");
  }
  const ContactCamera& c = frame.camera;
  ContactShadowGpu g;
  if (frame.light_position_view) {
    const glm::dvec3 p = *frame.light_position_view;
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw Error("ContactShadowFrame.light_position_view = (" + str(p.x) + ", " + str(p.y) + ", " +
                  str(p.z) + "): must be finite");
    g.light_dir = glm::vec4(glm::vec3(p), 1.0f);
  } else {
    const glm::dvec3 l = frame.light_dir_view;
    const double len = glm::length(l);
    if (!(len > 0.0) || !std::isfinite(len)) {
      throw Error("ContactShadowFrame.light_dir_view = (" + str(l.x) + ", " + str(l.y) + ", " +
                  str(l.z) + "): must be finite and non-zero");
    }
    g.light_dir = glm::vec4(glm::vec3(l / len), 0.0f);
  }
  g.extent = glm::vec2(static_cast<float>(width), static_cast<float>(height));
  g.tan_half_fov_y = static_cast<float>(c.tan_half_fov_y);
  g.aspect = static_cast<float>(c.aspect);
  g.near_plane = static_cast<float>(c.near);
  const float far_f = static_cast<float>(c.far);  // +inf for an infinite (or huge) far plane
  g.far_plane = std::isinf(far_f) ? 0.0f : far_f;
  g.max_distance = settings.max_distance;
  g.thickness = settings.thickness;
  g.depth_bias = settings.depth_bias;
  g.intensity = settings.intensity;
  g.step_exponent = settings.step_exponent;
  g.edge_fade = settings.edge_fade;
  g.step_count = settings.step_count;
  g.frame = frame.frame;
  g.reverse_z = c.depth == shadow::DepthConvention::reverse_z ? 1u : 0u;
  g.caster_mask = frame.caster_mask ? 1u : 0u;
  return g;
}

// ---- the pass ------------------------------------------------------------------------------

struct ContactShadowPass::Gpu {
  Gpu(gpu::Context& ctx, std::span<const std::uint32_t> resolve_spirv,
      std::span<const std::uint32_t> march_spirv, gpu::Specialization march_spec)
      : resolve_layout(
            ctx, {{{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
                   {1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT}}}),
        march_layout(
            ctx,
            {{{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
              {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
              {2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
              {3, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT}}},
            sizeof(ContactShadowGpu), VK_SHADER_STAGE_COMPUTE_BIT),
        resolve(ctx, resolve_spirv, resolve_layout),
        march(ctx, march_spirv, march_layout, std::move(march_spec)),
        nearest(ctx, gpu::SamplerDesc{}),
        linear(ctx, gpu::SamplerDesc{VK_FILTER_LINEAR}),
        pool(ctx, kMaxCachedPairs * 2) {}

  static constexpr std::uint32_t kMaxCachedPairs = 16;

  gpu::PipelineLayout resolve_layout;
  gpu::PipelineLayout march_layout;
  gpu::ComputePipeline resolve;
  gpu::ComputePipeline march;
  gpu::Sampler nearest;  // texelFetch only; any valid sampler
  gpu::Sampler linear;   // the bilinear read of the resolved depth
  gpu::DescriptorPool pool;
  struct Sets {
    VkDescriptorSet resolve = VK_NULL_HANDLE;
    VkDescriptorSet march = VK_NULL_HANDLE;
  };
  std::map<std::pair<VkImageView, VkImageView>, Sets> sets;
};

ContactShadowPass::ContactShadowPass(gpu::Context& ctx, const ContactShadowPassDesc& desc)
    : ctx_(ctx),
      width_(desc.width),
      height_(desc.height),
      settings_(desc.settings),
      reads_(desc.reads),
      shader_dir_(desc.shader_dir.empty() ? default_shader_dir() : desc.shader_dir),
      given_march_spirv_(desc.march_spirv),
      given_resolve_spirv_(desc.resolve_spirv) {
  validate(settings_);
  if (given_march_spirv_.empty() != given_resolve_spirv_.empty())
    throw Error("ContactShadowPassDesc: give both stages' SPIR-V (march and resolve) or neither");
  if (width_ == 0 || height_ == 0) {
    throw Error("ContactShadowPassDesc: extent " + std::to_string(width_) + "x" +
                std::to_string(height_) + " must not be empty");
  }
  if (enabled()) create();
}

ContactShadowPass::~ContactShadowPass() {
  destroy();
}

void ContactShadowPass::set_settings(const ContactShadowSettings& settings) {
  validate(settings);
  const bool was = enabled();
  settings_ = settings;
  if (enabled() && !was) create();
  if (!enabled() && was) destroy();
}

VkSampler ContactShadowPass::filtered_sampler() const {
  return gpu_ ? gpu_->linear.handle() : VK_NULL_HANDLE;
}

std::uint32_t ContactShadowPass::pipeline_count() const {
  return gpu_ ? 2u : 0u;
}

void ContactShadowPass::create() {
  if (!has_features(ctx_, VK_FORMAT_R32_SFLOAT,
                    VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT | VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT |
                        VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT)) {
    throw Error("ContactShadowPass: " + ctx_.info().name +
                " cannot store to and linearly filter R32_SFLOAT images");
  }
  if (!has_features(ctx_, VK_FORMAT_R8_UNORM,
                    VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT | VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT)) {
    throw Error("ContactShadowPass: " + ctx_.info().name + " cannot store to R8_UNORM images");
  }
  create_pipelines();

  gpu::ImageDesc r;
  r.format = VK_FORMAT_R32_SFLOAT;
  r.width = width_;
  r.height = height_;
  r.usage =
      VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  resolved_ = std::make_unique<gpu::Image>(ctx_, r);
  gpu::ImageDesc m = r;
  m.format = VK_FORMAT_R8_UNORM;
  mask_ = std::make_unique<gpu::Image>(ctx_, m);
}

void ContactShadowPass::create_pipelines() {
  if (!given_march_spirv_.empty()) {
    resolve_spirv_ = given_resolve_spirv_;
    march_spirv_ = given_march_spirv_;
  } else {
    shader::CompileOptions options;
    options.include_dirs = {shader_dir_};
    options.disk_cache_dir = shader::default_disk_cache_dir();
    shader::Compiler compiler(options);
    resolve_spirv_ = compiler.compile_file(shader_dir_ / "depth_resolve.comp").spirv;
    march_spirv_ = compiler.compile_file(shader_dir_ / "contact_shadows.comp").spirv;
  }
  gpu_ = std::make_unique<Gpu>(ctx_, resolve_spirv_, march_spirv_, specialization());
}

gpu::Specialization ContactShadowPass::specialization() const {
  gpu::Specialization spec;
  spec.set<std::uint32_t>(0, reads_ != ContactDepthReads::nearest_only ? 1u : 0u);
  spec.set<std::uint32_t>(1, reads_ != ContactDepthReads::bilinear_only ? 1u : 0u);
  return spec;
}

struct ContactShadowPass::Prepared {
  std::vector<std::uint32_t> march, resolve;
  std::unique_ptr<Gpu> gpu;  // null when the pass was disabled
};

std::shared_ptr<ContactShadowPass::Prepared> ContactShadowPass::prepare_spirv(
    std::vector<std::uint32_t> march_spirv, std::vector<std::uint32_t> resolve_spirv) const {
  if (march_spirv.empty() || resolve_spirv.empty())
    throw Error("ContactShadowPass::set_spirv: both stages' SPIR-V are needed");
  auto p = std::make_shared<Prepared>();
  p->march = std::move(march_spirv);
  p->resolve = std::move(resolve_spirv);
  if (enabled()) p->gpu = std::make_unique<Gpu>(ctx_, p->resolve, p->march, specialization());
  return p;
}

void ContactShadowPass::install(const std::shared_ptr<Prepared>& prepared) {
  given_march_spirv_ = prepared->march;
  given_resolve_spirv_ = prepared->resolve;
  if (!enabled()) return;
  if (!prepared->gpu) {  // enabled since it was prepared
    create_pipelines();
    return;
  }
  march_spirv_ = given_march_spirv_;
  resolve_spirv_ = given_resolve_spirv_;
  gpu_ = std::move(prepared->gpu);
}

void ContactShadowPass::set_spirv(std::vector<std::uint32_t> march_spirv,
                                  std::vector<std::uint32_t> resolve_spirv) {
  install(prepare_spirv(std::move(march_spirv), std::move(resolve_spirv)));
}

void ContactShadowPass::destroy() {
  gpu_.reset();
  resolved_.reset();
  mask_.reset();
  march_spirv_.clear();
  resolve_spirv_.clear();
}

std::pair<VkDescriptorSet, VkDescriptorSet> ContactShadowPass::sets_for(gpu::Image& depth,
                                                                        gpu::Image& normals) {
  const auto check_image = [&](const gpu::Image& image, const char* what) {
    const gpu::ImageDesc& d = image.desc();
    if (d.width != width_ || d.height != height_ || d.kind != gpu::ImageKind::image_2d) {
      throw Error(std::string("ContactShadowPass: the ") + what + " image is " +
                  std::to_string(d.width) + "x" + std::to_string(d.height) +
                  ", the pass was created for a 2D image of " + std::to_string(width_) + "x" +
                  std::to_string(height_));
    }
    if ((d.usage & VK_IMAGE_USAGE_SAMPLED_BIT) == 0) {
      throw Error(std::string("ContactShadowPass: the ") + what +
                  " image needs VK_IMAGE_USAGE_SAMPLED_BIT");
    }
  };
  check_image(depth, "depth");
  check_image(normals, "normal");
  if (gpu::is_depth_format(depth.desc().format) && gpu::has_stencil(depth.desc().format)) {
    throw Error("ContactShadowPass: depth/stencil formats are not supported (" +
                std::to_string(depth.desc().format) + "); use a depth-only format");
  }
  // Descriptor sets, cached per (depth, normals) pair.
  const auto key = std::make_pair(depth.view(), normals.view());
  auto it = gpu_->sets.find(key);
  if (it == gpu_->sets.end()) {
    if (gpu_->sets.size() >= Gpu::kMaxCachedPairs) {
      // Only reached when many different images are used; sets of earlier pairs may still be
      // referenced by pending command buffers, which the caller must have waited for.
      gpu_->sets.clear();
      gpu_->pool.reset();
    }
    Gpu::Sets s;
    s.resolve = gpu_->pool.allocate(gpu_->resolve_layout.set_layout(0));
    s.march = gpu_->pool.allocate(gpu_->march_layout.set_layout(0));
    gpu::DescriptorWriter()
        .combined_image(0, depth.view(), gpu_->nearest.handle())
        .storage_image(1, resolved_->view())
        .update(ctx_, s.resolve);
    gpu::DescriptorWriter()
        .combined_image(0, resolved_->view(), gpu_->linear.handle())
        .combined_image(1, depth.view(), gpu_->nearest.handle())
        .combined_image(2, normals.view(), gpu_->nearest.handle())
        .storage_image(3, mask_->view())
        .update(ctx_, s.march);
    it = gpu_->sets.emplace(key, s).first;
  }

  return {it->second.resolve, it->second.march};
}

glm::uvec2 ContactShadowPass::groups() const {
  return (glm::uvec2(width_, height_) + kGroupSize - 1u) / kGroupSize;
}

void ContactShadowPass::record_resolve(VkCommandBuffer cmd, gpu::Image& depth,
                                       gpu::Image& normals) {
  if (!enabled()) return;
  const VkDescriptorSet set = sets_for(depth, normals).first;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, gpu_->resolve.handle());
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, gpu_->resolve_layout.handle(), 0, 1,
                          &set, 0, nullptr);
  vkCmdDispatch(cmd, groups().x, groups().y, 1);
  ++dispatch_count_;
}

void ContactShadowPass::record_march(VkCommandBuffer cmd, gpu::Image& depth, gpu::Image& normals,
                                     const ContactShadowFrame& frame) {
  if (!enabled()) return;
  const ContactShadowGpu params = pack_contact_shadow(settings_, frame, width_, height_);
  const VkDescriptorSet set = sets_for(depth, normals).second;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, gpu_->march.handle());
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, gpu_->march_layout.handle(), 0, 1,
                          &set, 0, nullptr);
  vkCmdPushConstants(cmd, gpu_->march_layout.handle(), VK_SHADER_STAGE_COMPUTE_BIT, 0,
                     sizeof(ContactShadowGpu), &params);
  vkCmdDispatch(cmd, groups().x, groups().y, 1);
  ++dispatch_count_;
  last_params_ = params;
}

void ContactShadowPass::record(VkCommandBuffer cmd, gpu::Image& depth, gpu::Image& normals,
                               const ContactShadowFrame& frame) {
  recorded_.clear();
  if (!enabled()) return;  // step_count 0: no commands at all
  // Every error before the first command: the images, the settings and the frame.
  sets_for(depth, normals);
  pack_contact_shadow(settings_, frame, width_, height_);
  using passes::Use;
  passes::FrameGraph graph(
      {{"contact-resolve",
        {{"depth", &depth, Use::sampled}, {"resolved_depth", resolved_.get(), Use::storage_write}},
        [&](VkCommandBuffer c) {
          record_resolve(c, depth, normals);
          recorded_.push_back(dispatch_text("depth_resolve", groups().x, groups().y));
        },
        {}},
       {"contact-march",
        {{"resolved_depth", resolved_.get(), Use::sampled},
         {"depth", &depth, Use::sampled},
         {"normals", &normals, Use::sampled},
         {"mask", mask_.get(), Use::storage_write}},
        [&](VkCommandBuffer c) {
          record_march(c, depth, normals, frame);
          recorded_.push_back(dispatch_text("contact_shadows", groups().x, groups().y));
        },
        {}}},
      {&depth, &normals});
  const passes::BarrierLog log = [this](const std::string& image, VkImageLayout layout) {
    recorded_.push_back("barrier " + image + " -> " + passes::layout_name(layout));
  };
  graph.record(cmd, {}, log);
  graph.finish(cmd, {{"mask", mask_.get(), Use::sampled}}, log);
}

}  // namespace penumbra::render
