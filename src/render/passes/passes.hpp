#pragma once

// The renderer's passes (internal to penumbra::render). Each pass builds its pipelines and
// descriptor sets from the shared FrameResources and returns its steps: the images each reads
// and writes, and its commands, without barriers. The renderer (renderer.cpp) owns the
// resources and hands every step to the frame graph (../graph.hpp), which orders them and
// moves the images; it writes the timestamps and keeps the build report. docs/architecture.md has
// the data path of a frame and where to change what.

#include <functional>
#include <map>
#include <memory>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/gpu/resources.hpp>
#include <penumbra/render/contact_shadows.hpp>
#include <penumbra/render/frame_pack.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/shader/registry.hpp>
#include <string>
#include <vector>

#include "../graph.hpp"
#include "../clusters.hpp"

namespace penumbra::render::passes {

inline constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
inline constexpr VkFormat kNormalFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
inline constexpr VkFormat kHdrFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
inline constexpr VkFormat kInfoFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
inline constexpr VkFormat kLdrFormat = VK_FORMAT_R8G8B8A8_UNORM;
inline constexpr VkFormat kVisibilityFormat = VK_FORMAT_R32G32B32A32_SFLOAT;

struct GpuMesh {
  gpu::Buffer vertices, indices;
  uint32_t index_count = 0;
  // The shadow maps' draws: the triangles in clusters (clusters.hpp), from their own index
  // buffer where there is more than one cluster (else from `indices`).
  gpu::Buffer cluster_indices;
  std::vector<Cluster> clusters;
  const gpu::Buffer& caster_indices() const {
    return cluster_indices.handle() != VK_NULL_HANDLE ? cluster_indices : indices;
  }
};

// A range of a mesh's caster indices (GpuMesh::caster_indices): some of its clusters.
struct IndexRange {
  uint32_t first = 0, count = 0;
};

// What every pass builds from and records against.
struct FrameResources {
  FrameResources(gpu::Context& c, scene::Scene& s, BuildReport& r, shader::ProgramRegistry& g)
      : ctx(c), scene(s), report(r), registry(g), pool(c, 16) {}

  gpu::Context& ctx;
  scene::Scene& scene;  // the renderer's (set() may change frame-only keys between frames)
  BuildReport& report;
  shader::ProgramRegistry& registry;
  gpu::DescriptorPool pool;
  uint32_t width = 0, height = 0;
  bool reverse_z = true;
  bool visibility_output = false;
  bool specialize = true;  // RendererOptions::specialize
  RendererOptions::SunWindow sun_window = RendererOptions::SunWindow::automatic;
  RendererOptions::Scroll scroll_cascades = RendererOptions::Scroll::automatic;
  scene::Scene::Requirements req{};
  // Run before each frame is recorded (Renderer::prepare): what a pass needs ready for the scene
  // as it is now (PerPixelCompute::prepare).
  std::vector<std::function<void()>> before_frame;

  std::vector<GpuMesh> meshes;
  gpu::Buffer frame_ubo;
  // The analytic spheres (PackedFrame::analytic_spheres), when the scene has any
  // (SphereShadowPass).
  gpu::Buffer sphere_ubo;
  // Screen-sized images: depth and view-space normals (prepass), the sun's shadow info (shadow
  // resolve), the lit HDR colour and per-light visibility (forward), the output (tonemap).
  // The local lights' visibility (local shadow resolve), one channel per light, and the debug
  // views' data of the primary shadowed local light.
  gpu::Image depth, normal, info, local_info, local_debug, hdr, ldr;
  // With shadows.temporal (TemporalShadowPass): the accumulated visibility the forward pass
  // reads (local lights; the sun and the history's distance and normal), and the last frame's.
  gpu::Image temporal_local, temporal_aux, history_local, history_aux;
  gpu::Buffer temporal_ubo;
  gpu::Image visibility[2];
  gpu::Image* contact_mask = nullptr;  // the contact pass's, when it is built
  // filter = evsm2 (EvsmPass): the sun's blurred moments, one layer per cascade, and the linear
  // clamping sampler the resolve reads them through.
  gpu::Image sun_moments;
  // A point light's own filter = evsm2 (EvsmPass over the cubes): every cube's moments, a cube
  // array like the cubes.
  gpu::Image point_moments;
  gpu::Image spot_moments;  // a spot light's own filter = evsm2: every spot map's moments
  gpu::Sampler linear_clamp;
  gpu::Sampler nearest, shadow_compare, raw_depth;
  // The scene's mask textures (R8, Scene::mask_images() order) with their linear, repeating
  // sampler, and set 1 of the draw passes' layouts that holds them (create_mask_textures).
  std::vector<gpu::Image> mask_textures;
  gpu::Sampler mask_sampler;
  std::unique_ptr<gpu::PipelineLayout> mask_set_layout;  // owns the set's layout
  VkDescriptorSet mask_set = VK_NULL_HANDLE;
  PackedFrame packed;  // this frame's GPU data (pack_frame)

  // A render target or shadow map, listed in the build report. Before anything is created it is
  // checked against the device: the format's limits for this usage (extent, layers, resource
  // size), cube sizes, and the device-local memory all images so far leave. An image beyond
  // them is an error naming `sized_by` (the scene key and value that sized it, e.g.
  // "shadows.resolution = 16384"; empty: the render size), the image and the limit.
  gpu::Image make_image(const std::string& name, gpu::ImageKind kind, VkFormat format, uint32_t w,
                        uint32_t h, uint32_t layers, VkImageUsageFlags usage,
                        uint32_t mip_levels = 1, const std::string& sized_by = {});
  uint64_t image_bytes = 0;  // every image made so far
  // A pipeline in the program registry: a shader edit rebuilds exactly the pipelines whose
  // sources (or their includes) read the edited file. In two steps (ProgramRegistry::
  // add_prepared): at a reload `make` builds the new pipeline on a worker thread, next to the
  // other programs' and while the GPU runs the old one; then it is moved into `target` with the
  // GPU idle. `make` must only read what it captures.
  void add_prepared_pipeline(const std::string& name, std::vector<shader::ProgramSource> sources,
                             shader::ProgramRegistry::Prepare prepare);
  template <class P, class Make>
  void add_pipeline(const std::string& name, std::vector<shader::ProgramSource> sources,
                    std::unique_ptr<P>& target, Make make) {
    add_prepared_pipeline(
        name, std::move(sources),
        [&target, make](const shader::Spirvs& spirv) -> shader::ProgramRegistry::Install {
          auto fresh = std::make_shared<std::unique_ptr<P>>(make(spirv));
          return [&target, fresh] { target = std::move(*fresh); };
        });
  }
  VkCompareOp depth_test(bool strict) const;  // nearer passes (reverse-Z: greater)
};

// A pass is its steps (graph.hpp): each declares the images it reads and writes and records its
// commands without barriers; the frame graph orders the steps and moves the images. steps() is
// called once, after every pass is built; the steps may hold `this` and `r`.
class Pass {
 public:
  virtual ~Pass() = default;
  virtual std::vector<Step> steps(FrameResources& r) = 0;
};

// ---- shared recording helpers (recording.cpp) --------------------------------------------

gpu::VertexInput vertex_input();
// "forward-opaque PENUMBRA_SUN_SHADOWS=1 ...": a pipeline name with its variant defines.
std::string variant(const std::string& name, const std::vector<shader::Define>& defines);
// Mask textures (shaders/render/alpha_mask.glsl): at most this many distinct ones per scene.
inline constexpr uint32_t kMaxMaskTextures = 32;
// Uploads the scene's mask textures and writes the set that holds them; nothing when it has none.
void create_mask_textures(FrameResources& r);
// A draw pass's sets: set 0 as given, then (when the scene samples mask textures) set 1 with
// the textures; and the define that sizes the shaders' array (PENUMBRA_MASK_TEXTURES).
std::vector<std::vector<gpu::BindingDesc>> draw_sets(const FrameResources& r,
                                                     std::vector<gpu::BindingDesc> set0);
std::vector<gpu::BindingDesc> mask_set_bindings(const FrameResources& r);
std::vector<shader::Define> mask_defines(const FrameResources& r);
// Every draw of the frame (casters only, or all), opaque then masked, with `index` pushed (its w
// replaced by the draw's mask texture); binds the mask set (set 1) when there is one.
void draw_meshes(VkCommandBuffer cmd, FrameResources& r, const gpu::PipelineLayout& layout,
                 VkPipeline opaque, VkPipeline masked, bool casters_only, glm::uvec4 index);
// Which of the shadow-map casters a draw takes (Draw::moves).
enum class Casters { all, still, moving };
// The shadow-map casters (Draw::in_maps) of `which`, each with its model from `models` (the
// draw's world transform rebased on the map's anchor) instead of the camera-relative one;
// with `parts`, only the draws it takes, each whole from its own indices or in the ranges of
// its caster indices (clusters) listed there. Returns the indices drawn.
struct CasterParts {
  std::vector<uint8_t> take;                     // per draw: drawn at all
  std::vector<std::vector<IndexRange>> ranges;  // per draw; none: the mesh whole
};
uint64_t draw_casters(VkCommandBuffer cmd, FrameResources& r, const gpu::PipelineLayout& layout,
                      VkPipeline opaque, VkPipeline masked, glm::uvec4 index,
                      const std::vector<glm::mat4>& models, Casters which,
                      const CasterParts* parts = nullptr);
// A specialization constant a pass sets per frame: its constant_id, its name in the shader
// (checked against the SPIR-V's reflection when the pipeline is made) and its value.
struct SpecValue {
  uint32_t id = 0;
  const char* name = "";
  uint32_t value = 0;
  bool operator<(const SpecValue& o) const { return id != o.id ? id < o.id : value < o.value; }
};
using SpecValues = std::vector<SpecValue>;
using Specialize = std::function<SpecValues(const FrameResources&)>;
// Defines a pass compiles its program with for the frame being recorded, besides its source's.
using Variant = std::function<std::vector<shader::Define>(const FrameResources&)>;

// A compute program run once per pixel of the frame (8x8 groups): its layout (set 0 only), its
// pipeline in the program registry (a reload replaces it) and its descriptor set. The compute
// passes (the shadow resolves, tonemap) build one and write their resources into set().
//
// With `specialize`, the pipeline is specialized by the values it returns for the frame being
// recorded (the sun resolve: its filter and whether the penumbra view is on), so the driver
// compiles only the code that frame runs. Each set of values is a pipeline of its own, made
// the first time a frame needs it and kept until a reload; a reload makes only the one the
// current frame needs (the others follow when a frame needs them).
//
// With `variant`, the program itself depends on the frame: its defines are the source's and
// those `variant` returns (the resolves: PENUMBRA_FILTERS_2D/_CUBE, the filters the scene's
// lights use, so the SPIR-V holds no other filter). One variant is in the program registry at a
// time: before a frame whose defines differ, prepare() compiles the new one (a failure throws and
// leaves the old one running) and the registry forgets the old.
class PerPixelCompute {
 public:
  PerPixelCompute(FrameResources& r, const std::string& name, shader::ProgramSource source,
                  std::vector<gpu::BindingDesc> bindings, Specialize specialize = {},
                  Variant variant = {});
  VkDescriptorSet set() const { return set_; }
  void dispatch(VkCommandBuffer cmd, const FrameResources& r);
  size_t pipeline_count() const { return pipelines_.size(); }
  // The program variant this frame needs, compiled if it is not the one registered.
  void prepare(FrameResources& r);

 private:
  void add_variant(FrameResources& r, const std::vector<shader::Define>& defines);
  SpecValues values_for(const FrameResources& r) const;  // none when not specializing
  std::unique_ptr<gpu::ComputePipeline> make(const FrameResources& r,
                                             const std::vector<uint32_t>& spirv,
                                             const SpecValues& values) const;
  std::string name_;
  std::string full_name_;  // the registry name without the variant's defines
  shader::ProgramSource source_;
  Variant variant_;
  std::string registered_;  // the variant in the registry: its name
  std::unique_ptr<gpu::PipelineLayout> layout_;
  Specialize specialize_;
  std::vector<uint32_t> spirv_;  // the running program's
  std::map<SpecValues, std::shared_ptr<gpu::ComputePipeline>> pipelines_;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
};

// Dynamic rendering into an optional colour target (cleared to `clear`, extra targets cleared
// to 0) and a depth target (cleared to far, or loaded), with a full viewport and scissor.
void begin_rendering(VkCommandBuffer cmd, const FrameResources& r, uint32_t w, uint32_t h,
                     VkImageView color, VkClearColorValue clear, VkImageView depth_view,
                     VkImageLayout depth_layout, bool clear_depth,
                     const std::vector<VkImageView>& extra_colors = {});

// ---- the passes, in frame order ----------------------------------------------------------

// Every light's shadow maps as one list of shadow views: the sun's cascades (a 2D array), the
// spot maps (a 2D array) and the point cubes (a cube array).

// Every light's shadow maps as one list of shadow views: the sun's cascades (a 2D array), the
// spot maps (a 2D array) and the point cubes (a cube array). Each view is drawn in a space of its
// own (its anchor: a point fixed while its light is), so that what a map holds does not depend on
// the camera; with shadows.cache a layer is drawn again only when its key (its matrices, its
// casters and their transforms, a reload) changed.
class ShadowMapPass final : public Pass {
 public:
  explicit ShadowMapPass(FrameResources& r);
  ~ShadowMapPass() override;
  std::vector<Step> steps(FrameResources& r) override;
  // The light matrices of this frame, and which layers the cache draws.
  void prepare(FrameResources& r);
  // Every layer is drawn in the next frame (a reload gave a program that draws the maps new code).
  void invalidate();
  // Whether the program of this name draws the maps (their depth pipelines, and the grid's
  // window pipeline): a reload that gives one new code must invalidate the cache. New code in any
  // other program (a resolve, the forward pass) leaves every map as it was, bit for bit.
  bool draws_maps(const std::string& program) const;
  const ShadowCacheStats& stats() const { return stats_; }

  gpu::Image sun_map, spot_maps, point_cubes;  // empty when not required
  gpu::Buffer sun_ubo, spot_ubo, point_ubo;    // the lookups' matrices (camera-relative)
  uint64_t cache_bytes = 0;                    // the still copies' memory
  // The sun's samplers for the resolves: the renderer's (clamp to edge), or repeat ones when the
  // resolves read the cascades in place (sun_map is then their toroidal grid).
  VkSampler sun_compare = VK_NULL_HANDLE, sun_raw = VK_NULL_HANDLE;
  bool sun_in_place = false;
  // Where cascade c's map lies on sun_map this frame (its window offset, whole texels in
  // [0, resolution)); 0 unless read in place.
  glm::ivec2 sun_offset(uint32_t c) const;
  struct View;  // one light kind's maps (shadow_view.hpp)

 private:
  std::vector<View> views_;
  bool cache_ = true;
  uint64_t generation_ = 0;
  std::vector<std::string> programs_;  // the programs this pass added (draws_maps)
  ShadowCacheStats stats_;
  // Per draw, its mesh's clusters' bounds this frame (none for a mesh of one cluster, and none
  // without the cache); every view culls with them.
  std::vector<std::vector<scene::Bounds>> cluster_bounds_;
  gpu::Sampler repeat_compare_, repeat_raw_;
};

class PrepassPass final : public Pass {
 public:
  explicit PrepassPass(FrameResources& r);
  std::vector<Step> steps(FrameResources& r) override;

 private:
  std::unique_ptr<gpu::PipelineLayout> layout_;
  std::unique_ptr<gpu::GraphicsPipeline> opaque_, masked_;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
};

// The sun's EVSM2 moments (filter = evsm2): each cascade's depths warped into moments and
// box-blurred, x then y (shaders/render/evsm_moments.comp), into sun-moments.
// Which shadow maps the evsm pass turns into moments: the sun's cascades, the point lights'
// cubes (face by face, into a cube array the local resolve samples), or the spot lights' maps
// (made linear first, each with its own planes).
enum class MomentSource { sun, points, spots };

class EvsmPass final : public Pass {
 public:
  EvsmPass(FrameResources& r, ShadowMapPass& maps, MomentSource source);
  ~EvsmPass() override;
  std::vector<Step> steps(FrameResources& r) override;

 private:
  std::unique_ptr<gpu::PipelineLayout> layout_;
  std::unique_ptr<gpu::ComputePipeline> pass_[2];  // x (from the depths), then y
  VkDescriptorSet set_[2] = {VK_NULL_HANDLE, VK_NULL_HANDLE};
  gpu::Image moments_x_;
  gpu::Image* depths_ = nullptr;  // the shadow maps it reads
  const ShadowMapPass* maps_ = nullptr;  // their windows (the sun read in place)
  gpu::Image* out_ = nullptr;     // the moments it writes
  uint32_t resolution_ = 0, layers_ = 0;
  MomentSource source_ = MomentSource::sun;
  bool mips_ = false;  // shadows.evsm_mips (the sun's moments only)
};

// The sun: cascade selection, biases and the filter, per pixel, into the shadow-info image.
class ShadowResolvePass final : public Pass {
 public:
  ShadowResolvePass(FrameResources& r, ShadowMapPass& maps);
  std::vector<Step> steps(FrameResources& r) override;

 private:
  PerPixelCompute compute_;
  ShadowMapPass& maps_;
  bool moments_ = false;  // filter = evsm2: it reads sun-moments
};

// Spot and point lights: biases and the filter, per pixel and light, into the local-shadow image
// (spot 0, spot 1, point 0, point 1).
class LocalShadowResolvePass final : public Pass {
 public:
  LocalShadowResolvePass(FrameResources& r, ShadowMapPass& maps);
  std::vector<Step> steps(FrameResources& r) override;

 private:
  PerPixelCompute compute_;
  ShadowMapPass& maps_;
  bool point_moments_ = false, spot_moments_ = false;  // lights' own evsm2: it reads their moments
};

// Analytic sphere shadows: every shadowed light's visibility (shadow-info, local-shadow) times
// what the scene's analytic spheres leave of it, in place, after the resolves.
class SphereShadowPass final : public Pass {
 public:
  SphereShadowPass(FrameResources& r, const ShadowMapPass& maps);
  std::vector<Step> steps(FrameResources& r) override;

 private:
  PerPixelCompute compute_;
  bool sun_ = false, local_ = false;
};

// Temporal accumulation of every light's visibility (shadows.temporal): the resolves' images
// blended with the last frame's, into temporal-local and temporal-aux, which the forward pass
// reads instead; then copied into the history for the next frame.
class TemporalShadowPass final : public Pass {
 public:
  explicit TemporalShadowPass(FrameResources& r);
  std::vector<Step> steps(FrameResources& r) override;

 private:
  PerPixelCompute compute_;
};

// Screen-space contact shadows toward the sun (ContactShadowPass), into the contact mask.
class ContactPass final : public Pass {
 public:
  explicit ContactPass(FrameResources& r);
  std::vector<Step> steps(FrameResources& r) override;

 private:
  ContactShadowFrame frame(const FrameResources& r) const;  // this frame's camera and light
  std::unique_ptr<ContactShadowPass> pass_;
};

// Lighting: every light with its shadows, into the HDR image (and the visibility targets).
class ForwardPass final : public Pass {
 public:
  explicit ForwardPass(FrameResources& r);
  std::vector<Step> steps(FrameResources& r) override;

 private:
  std::unique_ptr<gpu::PipelineLayout> layout_;
  std::unique_ptr<gpu::GraphicsPipeline> opaque_, masked_;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
  bool temporal_ = false;  // reads the accumulated visibility (shadows.temporal)
};

// Exposure and tonemapping, or one of the debug views, into the output image.
class TonemapPass final : public Pass {
 public:
  explicit TonemapPass(FrameResources& r);
  std::vector<Step> steps(FrameResources& r) override;

 private:
  PerPixelCompute compute_;
};

// The defines every lit pass's variant is built with (what the scene requires).
std::vector<shader::Define> light_defines(const FrameResources& r);

}  // namespace penumbra::render::passes
