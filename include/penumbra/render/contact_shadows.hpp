#pragma once

// Screen-space contact shadows: a compute pass that copies the depth buffer into an R32F image
// (shaders/depth_resolve.comp) and marches every pixel's ray towards the directional light
// through it (shaders/contact_shadows.comp, penumbra/contact_shadows.glsl), writing a mask
// (R8_UNORM, 1 = lit) that the lighting multiplies into the light's visibility.
//
//   render::ContactShadowPassDesc desc;
//   desc.width = 1280;
//   desc.height = 720;
//   desc.settings.step_count = 16;            // 0: the pass creates nothing and records nothing
//   render::ContactShadowPass pass(ctx, desc);
//   render::ContactShadowFrame frame;
//   frame.camera = render::ContactCamera::from(camera, shadow::DepthConvention::reverse_z);
//   frame.light_dir_view = render::to_contact_view(camera, sun_direction_towards_light);
//   pass.record(cmd, depth_image, normal_image, frame);   // mask(): SHADER_READ_ONLY_OPTIMAL
//
// View space of the pass is shaders/penumbra/depth.glsl's: right-handed, x right, y up, the
// camera looks down -z (GLM's lookAt), with the Vulkan Y flip in the projection (view +y is the
// top of the image, uv = ndc * 0.5 + 0.5). Normals in the normal image and the light direction
// are in this space.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <glm/glm.hpp>
#include <memory>
#include <optional>
#include <penumbra/gpu/context.hpp>
#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/gpu/resources.hpp>
#include <penumbra/scene/scene.hpp>
#include <penumbra/shadow/types.hpp>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::render {

// The most march steps per pixel (kContactMaxSteps in the GLSL).
inline constexpr std::uint32_t kContactMaxSteps = scene::kMaxContactSteps;

// The parameters of one dispatch, mirrored member for member by ContactShadowGpu in
// shaders/penumbra/contact_shadows.glsl (passed as push constants). The layout is identical
// under std140, std430 and C++; tests/render/contact_pass_tests.cpp checks every offset against
// SPIR-V reflection.
struct alignas(16) ContactShadowGpu {
  // w 0: xyz the unit direction towards a directional light (view space); w 1: xyz the
  // position of a spot or point light (view space)
  glm::vec4 light_dir;
  glm::vec2 extent;             // width, height in pixels
  float tan_half_fov_y = 1.0f;  // tan(vertical fov / 2)
  float aspect = 1.0f;          // width / height of the projection
  float near_plane = 0.1f;      // > 0
  float far_plane = 0.0f;       // > near_plane; 0 for an infinite far plane
  float max_distance = 0.0f;
  float thickness = 0.0f;
  float depth_bias = 0.0f;
  float intensity = 0.0f;
  float step_exponent = 2.0f;
  float edge_fade = 0.0f;
  std::uint32_t step_count = 0;
  std::uint32_t frame = 0;
  std::uint32_t reverse_z = 1;
  // 1: the normal image's alpha marks the surfaces that cast shadows (>= 0.75; the renderer's
  // prepass writes 1 for casters, 0.5 for receivers that cast none, 0 for sky) and a tap on any
  // other surface never occludes; 0: every surface occludes (alpha is not read)
  std::uint32_t caster_mask = 0;
};
static_assert(sizeof(ContactShadowGpu) == 80);
static_assert(alignof(ContactShadowGpu) == 16);
static_assert(offsetof(ContactShadowGpu, light_dir) == 0);
static_assert(offsetof(ContactShadowGpu, extent) == 16);
static_assert(offsetof(ContactShadowGpu, tan_half_fov_y) == 24);
static_assert(offsetof(ContactShadowGpu, aspect) == 28);
static_assert(offsetof(ContactShadowGpu, near_plane) == 32);
static_assert(offsetof(ContactShadowGpu, far_plane) == 36);
static_assert(offsetof(ContactShadowGpu, max_distance) == 40);
static_assert(offsetof(ContactShadowGpu, thickness) == 44);
static_assert(offsetof(ContactShadowGpu, depth_bias) == 48);
static_assert(offsetof(ContactShadowGpu, intensity) == 52);
static_assert(offsetof(ContactShadowGpu, step_exponent) == 56);
static_assert(offsetof(ContactShadowGpu, edge_fade) == 60);
static_assert(offsetof(ContactShadowGpu, step_count) == 64);
static_assert(offsetof(ContactShadowGpu, frame) == 68);
static_assert(offsetof(ContactShadowGpu, reverse_z) == 72);
static_assert(offsetof(ContactShadowGpu, caster_mask) == 76);

// The user-facing parameters, with their defaults (docs/contact-shadows.md explains each).
// The pass's options are the scene's [contact] table (one type, its defaults defined once).
using ContactShadowSettings = scene::ContactSettings;

// Throws penumbra::Error naming the field and its value when a setting is out of range.
void validate(const ContactShadowSettings& settings);

// The projection the depth buffer was rendered with (a perspective one).
struct ContactCamera {
  double tan_half_fov_y = 1.0;
  double aspect = 1.0;  // width / height
  double near = 0.1;
  double far = 1000.0;  // may be +infinity
  shadow::DepthConvention depth = shadow::DepthConvention::reverse_z;

  // From the shadow layer's camera (fov_y, aspect, near, far).
  static ContactCamera from(const shadow::Camera& camera, shadow::DepthConvention depth);
};

// Throws penumbra::Error naming the field when the camera is not a valid perspective projection.
void validate(const ContactCamera& camera);

// The pass's view basis of a camera: rows x (right), y (up, orthogonalized), z (backwards,
// -forward); right-handed, as GLM's lookAt. view = contact_view_basis(camera) * world.
glm::dmat3 contact_view_basis(const shadow::Camera& camera);
// A world-space direction expressed in the pass's view space of `camera` (not normalized).
glm::dvec3 to_contact_view(const shadow::Camera& camera, const glm::dvec3& world_direction);

// What one record() needs besides the images.
struct ContactShadowFrame {
  ContactCamera camera;
  // Direction towards the light in the pass's view space; normalized by pack (non-zero).
  glm::dvec3 light_dir_view{0.0, 1.0, 0.0};
  // A spot or point light instead: its position in the pass's view space (relative to the
  // camera, in the basis of contact_view_basis); the march goes towards it.
  std::optional<glm::dvec3> light_position_view;
  // The normal image's alpha marks shadow casters (ContactShadowGpu::caster_mask).
  bool caster_mask = false;
  std::uint32_t frame = 0;  // selects the golden-ratio noise offset
};

// The push constants of one dispatch. Throws penumbra::Error for invalid settings or camera, a
// zero or non-finite light direction, or a zero extent.
ContactShadowGpu pack_contact_shadow(const ContactShadowSettings& settings,
                                     const ContactShadowFrame& frame, std::uint32_t width,
                                     std::uint32_t height);

// Which depth reads the march makes. dual in the product; the single-read variants exist so
// that the tests can show that each read is needed.
enum class ContactDepthReads { dual, bilinear_only, nearest_only };

struct ContactShadowPassDesc {
  std::uint32_t width = 0, height = 0;
  ContactShadowSettings settings;
  ContactDepthReads reads = ContactDepthReads::dual;
  // Where contact_shadows.comp, depth_resolve.comp and penumbra/ live; empty: the source tree's
  // shaders/ directory this library was built from.
  std::filesystem::path shader_dir;
  // The two stages already compiled (by a renderer's program registry); empty: the pass
  // compiles them from shader_dir itself.
  std::vector<std::uint32_t> march_spirv, resolve_spirv;
};

// The pass. It owns its pipelines, samplers, descriptor sets, the R32F resolved depth and the
// mask; none of them exists while step_count is 0.
class ContactShadowPass {
 public:
  ContactShadowPass(gpu::Context& ctx, const ContactShadowPassDesc& desc);
  ~ContactShadowPass();
  ContactShadowPass(const ContactShadowPass&) = delete;
  ContactShadowPass& operator=(const ContactShadowPass&) = delete;

  // Whether the pass does anything (settings().step_count > 0).
  bool enabled() const { return settings_.step_count > 0; }
  const ContactShadowSettings& settings() const { return settings_; }
  // Validates and applies new settings; creates the GPU objects when the pass becomes enabled
  // and destroys them when step_count becomes 0. Must not be called while a command buffer that
  // this pass recorded is pending.
  void set_settings(const ContactShadowSettings& settings);

  // Records the depth resolve and the march into cmd (nothing at all when disabled). depth: a
  // depth (or R32_SFLOAT) image of width x height with SAMPLED usage; normals: a float colour
  // image of the same size with SAMPLED usage and view-space normals in xyz. Both are moved to
  // SHADER_READ_ONLY_OPTIMAL; the mask ends in SHADER_READ_ONLY_OPTIMAL. Descriptor sets are
  // cached per (depth, normals) pair; the images must outlive the recorded commands.
  void record(VkCommandBuffer cmd, gpu::Image& depth, gpu::Image& normals,
              const ContactShadowFrame& frame);
  // The two dispatches of record() without any barrier, for a caller that orders the images
  // itself (the renderer's frame graph): the resolve samples depth and writes
  // resolved_depth() (GENERAL); the march samples resolved_depth(), depth and normals and writes
  // mask() (GENERAL). Nothing when disabled.
  void record_resolve(VkCommandBuffer cmd, gpu::Image& depth, gpu::Image& normals);
  void record_march(VkCommandBuffer cmd, gpu::Image& depth, gpu::Image& normals,
                    const ContactShadowFrame& frame);

  // The mask (R8_UNORM, 1 = lit) and the R32F copy of the depth; nullptr while disabled.
  gpu::Image* mask() { return mask_.get(); }
  gpu::Image* resolved_depth() { return resolved_.get(); }
  // The linear clamp-to-edge sampler the march reads the resolved depth with (VK_NULL_HANDLE
  // while disabled).
  VkSampler filtered_sampler() const;

  // Dispatches recorded since construction, and a description of every command the last
  // record() call made ("barrier ...", "dispatch depth_resolve 40x30x1", ...).
  std::uint64_t dispatch_count() const { return dispatch_count_; }
  const std::vector<std::string>& recorded_commands() const { return recorded_; }
  // Compute pipelines that exist now (0 while disabled, 2 when enabled).
  std::uint32_t pipeline_count() const;

  // Hot reload: new SPIR-V for both stages. Recreates the two pipelines only; the mask and the
  // resolved depth stay the same images, so whoever samples them needs no new descriptors. On
  // an error (the pipelines cannot be created) the pass keeps its previous pipelines.
  void set_spirv(std::vector<std::uint32_t> march_spirv, std::vector<std::uint32_t> resolve_spirv);
  // The same in two steps, for a caller that makes several programs' pipelines at once (the
  // program registry): prepare_spirv makes the two pipelines and changes nothing (it may run on
  // another thread while the GPU uses the old ones; it throws when they cannot be made);
  // install swaps them in (the GPU must be done with the old ones).
  struct Prepared;
  std::shared_ptr<Prepared> prepare_spirv(std::vector<std::uint32_t> march_spirv,
                                          std::vector<std::uint32_t> resolve_spirv) const;
  void install(const std::shared_ptr<Prepared>& prepared);
  // The push constants of the last recorded march.
  const ContactShadowGpu& last_params() const { return last_params_; }

  // The SPIR-V of the two stages (compiled at construction; empty while disabled), for
  // reflection tests.
  const std::vector<std::uint32_t>& march_spirv() const { return march_spirv_; }
  const std::vector<std::uint32_t>& resolve_spirv() const { return resolve_spirv_; }

  std::uint32_t width() const { return width_; }
  std::uint32_t height() const { return height_; }

 private:
  struct Gpu;
  void create();
  void destroy();
  void create_pipelines();
  gpu::Specialization specialization() const;
  // The (resolve, march) descriptor sets of an image pair, made the first time; checks the
  // images.
  std::pair<VkDescriptorSet, VkDescriptorSet> sets_for(gpu::Image& depth, gpu::Image& normals);
  glm::uvec2 groups() const;  // the dispatches' workgroups over width x height

  gpu::Context& ctx_;
  std::uint32_t width_ = 0, height_ = 0;
  ContactShadowSettings settings_;
  ContactDepthReads reads_ = ContactDepthReads::dual;
  std::filesystem::path shader_dir_;
  std::unique_ptr<Gpu> gpu_;
  std::unique_ptr<gpu::Image> resolved_;
  std::unique_ptr<gpu::Image> mask_;
  std::vector<std::uint32_t> march_spirv_, resolve_spirv_;
  std::vector<std::uint32_t> given_march_spirv_, given_resolve_spirv_;  // from the desc
  std::uint64_t dispatch_count_ = 0;
  std::vector<std::string> recorded_;  // record()'s barriers and dispatches
  ContactShadowGpu last_params_{};
};

// shader::default_shader_dir(), for the render layer's users.
std::filesystem::path default_shader_dir();

}  // namespace penumbra::render
