// The renderer: owns the frame's shared resources (passes/passes.hpp), builds the passes a scene
// requires and the frame graph of their steps (graph.hpp: the order and the barriers come from
// the images each step declares), and owns the timestamps, the readbacks and the build report.
// A frame: pack_frame (CPU) -> upload -> shadow maps -> prepass -> shadow resolves -> shadow
// temporal -> contact shadows -> forward -> tonemap -> copy to the readback buffer.

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/packing.hpp>
#include <optional>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/check.hpp>
#include <penumbra/render/renderer.hpp>
#include <sstream>

#include "passes/passes.hpp"

namespace penumbra::render {
namespace fs = std::filesystem;
using namespace passes;

namespace {

// The halves of an RGBA16F download, as floats.
std::vector<float> unpack_halves(const std::vector<std::byte>& bytes) {
  const auto* h = reinterpret_cast<const uint16_t*>(bytes.data());
  std::vector<float> out(bytes.size() / 2);
  for (size_t i = 0; i < out.size(); ++i) out[i] = glm::unpackHalf1x16(h[i]);
  return out;
}

// What resets the temporal history when it changes: the packed frame without the camera, the
// sun's direction and the frame index (FNV-1a over the bytes of the members that stay).
uint64_t history_key(const FrameGpu& f) {
  uint64_t h = 1469598103934665603ull;
  auto add = [&h](const auto& v) {
    const auto* b = reinterpret_cast<const unsigned char*>(&v);
    for (size_t i = 0; i < sizeof(v); ++i) h = (h ^ b[i]) * 1099511628211ull;
  };
  add(f.sun_direction.w);
  add(f.sun_color);
  add(f.ambient);
  add(f.viewport);
  add(f.projection);
  add(f.bias);
  add(f.filter_params);
  add(f.mode.y);
  add(f.mode.z);
  add(f.mode.w);
  add(f.counts);
  for (const auto& l : f.spots) add(l.color_intensity), add(l.params), add(l.direction_cos.w);
  for (const auto& l : f.points) add(l.color_intensity), add(l.params);
  add(f.pcss);
  add(f.filter_world);
  add(f.evsm);
  return h;
}

}  // namespace

std::string BuildReport::to_string() const {
  std::ostringstream s;
  for (const auto& p : passes) s << "pass      " << p << "\n";
  for (const auto& p : pipelines) s << "pipeline  " << p << "\n";
  for (const auto& i : images) s << "image     " << i << "\n";
  for (const auto& g : graph) s << "step      " << g << "\n";
  return s.str();
}

bool BuildReport::has_pass(const std::string& name) const {
  return std::any_of(passes.begin(), passes.end(),
                     [&](const std::string& p) { return p.rfind(name, 0) == 0; });
}

bool BuildReport::has_pipeline(const std::string& name) const {
  return std::any_of(pipelines.begin(), pipelines.end(),
                     [&](const std::string& p) { return p.rfind(name, 0) == 0; });
}

struct Renderer::Impl {
  gpu::Context& ctx;
  scene::Scene scene;
  fs::path shader_dir;
  BuildReport report;
  std::vector<PassTiming> timings;
  shader::ProgramRegistry registry;  // every pipeline's sources, for hot reload
  FrameResources res;
  gpu::Buffer readback;
  gpu::TimestampPool timestamps;
  gpu::CommandRecorder recorder;

  // The passes, in frame order (null when the scene does not require them).
  std::unique_ptr<ShadowMapPass> shadow_maps;
  std::vector<std::unique_ptr<Pass>> passes;
  FrameGraph graph;                     // every pass's steps, ordered, with their barriers
  std::vector<std::string> pass_names;  // the timestamps of the last frame

  Impl(gpu::Context& c, const scene::Scene& s, const RendererOptions& o)
      : ctx(c),
        scene(s),
        shader_dir(o.shader_dir.empty() ? shader::default_shader_dir() : o.shader_dir),
        registry(shader_dir, o.library_shader_dirs),
        res(c, scene, report, registry),
        timestamps(c, 32),
        recorder(c) {
    res.width = o.width ? o.width : s.render.width;
    res.height = o.height ? o.height : s.render.height;
    res.reverse_z = s.shadows.reverse_z;
    res.visibility_output = o.visibility_output;
    res.specialize = o.specialize;
    res.sun_window = o.sun_window;
    res.scroll_cascades = o.scroll_cascades;
    // PENUMBRA_SUN_WINDOW (copy, draw, in_place) and PENUMBRA_SCROLL_CASCADES (on, off) pick
    // the sun's route where the options leave it automatic: to measure or look at another
    // device's route (docs/performance.md).
    using SunWindow = RendererOptions::SunWindow;
    using Scroll = RendererOptions::Scroll;
    if (const char* e = std::getenv("PENUMBRA_SUN_WINDOW");
        e && res.sun_window == SunWindow::automatic) {
      const std::string v = e;
      if (v == "copy") res.sun_window = SunWindow::copy;
      else if (v == "draw") res.sun_window = SunWindow::draw;
      else if (v == "in_place") res.sun_window = SunWindow::in_place;
      else if (!v.empty() && v != "automatic")
        throw Error("PENUMBRA_SUN_WINDOW=" + v + ": expected copy, draw, in_place or automatic");
    }
    if (const char* e = std::getenv("PENUMBRA_SCROLL_CASCADES");
        e && res.scroll_cascades == Scroll::automatic) {
      const std::string v = e;
      if (v == "on") res.scroll_cascades = Scroll::on;
      else if (v == "off") res.scroll_cascades = Scroll::off;
      else if (!v.empty() && v != "automatic")
        throw Error("PENUMBRA_SCROLL_CASCADES=" + v + ": expected on, off or automatic");
    }
  }

  // The temporal history (shadows.temporal): the last frame's camera, and what resets it.
  struct LastCamera {
    glm::dmat4 view{1.0}, proj{1.0};
    glm::dvec3 origin{0.0};
  };
  std::optional<LastCamera> last_camera;
  uint64_t last_key = 0;

  ReloadResult reload(const std::vector<fs::path>& changed) {
    return finish_reload(registry.prepare_reload(changed));
  }
  ReloadResult finish_reload(shader::PreparedReload prepared) {
    ReloadResult result =
        registry.finish_reload(std::move(prepared), [this] { vkDeviceWaitIdle(ctx.device()); });
    // The programs with new code (one whose SPIR-V did not change keeps its pipelines).
    std::vector<std::string> new_code;
    for (const std::string& p : result.rebuilt)
      if (std::find(result.same_spirv.begin(), result.same_spirv.end(), p) ==
          result.same_spirv.end())
        new_code.push_back(p);
    if (!new_code.empty()) last_camera.reset();
    // The maps' cache holds what the map programs drew: only new code of theirs redraws every
    // layer (a resolve's or the forward pass's edit keeps the maps, which those programs read).
    if (std::any_of(new_code.begin(), new_code.end(),
                    [this](const std::string& p) { return shadow_maps->draws_maps(p); }))
      shadow_maps->invalidate();
    return result;
  }

  void upload_meshes() {
    for (const auto& m : scene.meshes) {
      GpuMesh g;
      if (!m.vertices.empty() && !m.indices.empty()) {
        g.vertices = gpu::Buffer(ctx, m.vertices.size() * sizeof(scene::Vertex),
                                 VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, gpu::MemoryUse::device);
        g.vertices.write(std::as_bytes(std::span(m.vertices)));
        g.indices = gpu::Buffer(ctx, m.indices.size() * sizeof(uint32_t),
                                VK_BUFFER_USAGE_INDEX_BUFFER_BIT, gpu::MemoryUse::device);
        g.indices.write(std::as_bytes(std::span(m.indices)));
        g.index_count = static_cast<uint32_t>(m.indices.size());
        ClusteredMesh c = cluster_triangles(m.vertices, m.indices);
        g.clusters = std::move(c.clusters);
        if (g.clusters.size() > 1) {
          g.cluster_indices = gpu::Buffer(ctx, c.indices.size() * sizeof(uint32_t),
                                          VK_BUFFER_USAGE_INDEX_BUFFER_BIT,
                                          gpu::MemoryUse::device);
          g.cluster_indices.write(std::as_bytes(std::span(c.indices)));
        }
      }
      res.meshes.push_back(std::move(g));
    }
  }

  // The shared images and buffers, then the passes the scene requires (Scene::requirements()
  // decides; the contact pass needs a sun to march toward for now).
  void build() {
    res.req = scene.requirements();
    const auto& req = res.req;
    const uint32_t w = res.width, h = res.height;
    upload_meshes();
    const VkImageUsageFlags sampled = VK_IMAGE_USAGE_SAMPLED_BIT;
    res.depth = res.make_image("depth", gpu::ImageKind::image_2d, kDepthFormat, w, h, 1,
                               VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | sampled);
    res.normal = res.make_image("normal", gpu::ImageKind::image_2d, kNormalFormat, w, h, 1,
                                VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | sampled);
    res.hdr = res.make_image("hdr", gpu::ImageKind::image_2d, kHdrFormat, w, h, 1,
                             VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | sampled);
    res.ldr = res.make_image("ldr", gpu::ImageKind::image_2d, kLdrFormat, w, h, 1,
                             VK_IMAGE_USAGE_STORAGE_BIT);
    readback = gpu::Buffer(ctx, size_t{w} * h * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
    if (res.visibility_output)
      for (int i = 0; i < 2; ++i)
        res.visibility[i] =
            res.make_image("visibility" + std::to_string(i), gpu::ImageKind::image_2d,
                           kVisibilityFormat, w, h, 1, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT);
    res.nearest = gpu::Sampler(ctx, gpu::SamplerDesc{});
    gpu::SamplerDesc cmp;
    cmp.filter = VK_FILTER_LINEAR;
    cmp.compare = true;
    cmp.compare_op = res.depth_test(false);
    res.shadow_compare = gpu::Sampler(ctx, cmp);
    res.raw_depth = gpu::Sampler(ctx, gpu::SamplerDesc{});
    res.frame_ubo = gpu::Buffer(ctx, sizeof(FrameGpu), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    create_mask_textures(res);

    auto prepass = std::make_unique<PrepassPass>(res);
    shadow_maps = std::make_unique<ShadowMapPass>(res);
    std::unique_ptr<Pass> evsm;  // before the resolve, which samples its moments
    if (req.sun_moments) evsm = std::make_unique<EvsmPass>(res, *shadow_maps, MomentSource::sun);
    std::unique_ptr<Pass> point_evsm;  // before the local resolve, which samples its moments
    if (req.point_moments)
      point_evsm = std::make_unique<EvsmPass>(res, *shadow_maps, MomentSource::points);
    std::unique_ptr<Pass> spot_evsm;
    if (req.spot_moments)
      spot_evsm = std::make_unique<EvsmPass>(res, *shadow_maps, MomentSource::spots);
    std::unique_ptr<Pass> resolve;
    if (req.sun_shadows) resolve = std::make_unique<ShadowResolvePass>(res, *shadow_maps);
    std::unique_ptr<Pass> local_resolve;
    if (req.spot_shadow_maps > 0 || req.point_shadow_cubes > 0)
      local_resolve = std::make_unique<LocalShadowResolvePass>(res, *shadow_maps);
    std::unique_ptr<Pass> spheres;  // after the resolves, whose images it multiplies
    if (req.analytic_spheres > 0) spheres = std::make_unique<SphereShadowPass>(res, *shadow_maps);
    std::unique_ptr<Pass> temporal;  // before the forward pass, which reads its images
    if (req.temporal) temporal = std::make_unique<TemporalShadowPass>(res);
    std::unique_ptr<Pass> contact;
    if (req.contact_pass)  // steps > 0 and a light to march towards (the primary one)
      contact = std::make_unique<ContactPass>(res);
    auto forward = std::make_unique<ForwardPass>(res);
    auto tonemap = std::make_unique<TonemapPass>(res);
    passes.push_back(std::move(prepass));
    if (evsm) passes.push_back(std::move(evsm));
    if (point_evsm) passes.push_back(std::move(point_evsm));
    if (spot_evsm) passes.push_back(std::move(spot_evsm));
    if (resolve) passes.push_back(std::move(resolve));
    if (local_resolve) passes.push_back(std::move(local_resolve));
    if (spheres) passes.push_back(std::move(spheres));
    if (temporal) passes.push_back(std::move(temporal));
    if (contact) passes.push_back(std::move(contact));
    passes.push_back(std::move(forward));
    passes.push_back(std::move(tonemap));
    build_graph();
  }

  // The frame graph of every pass's steps, and the copy of the output into the readback
  // buffer; its order and barriers come from the images the steps declare.
  void build_graph() {
    std::vector<Step> steps = shadow_maps->steps(res);
    for (auto& pass : passes)
      for (Step& step : pass->steps(res)) steps.push_back(std::move(step));
    steps.push_back({"readback",
                     {{"ldr", &res.ldr, Use::copy_source}},
                     [this](VkCommandBuffer cmd) {
                       VkBufferImageCopy region{};
                       region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
                       region.imageExtent = {res.width, res.height, 1};
                       vkCmdCopyImageToBuffer(cmd, res.ldr.handle(),
                                              VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                                              readback.handle(), 1, &region);
                     },
                     {}});
    graph = FrameGraph(std::move(steps));
    report.graph = graph.describe();
  }

  void update(uint32_t frame_index) {
    FrameCaps caps;
    caps.depth_clamp = ctx.info().depth_clamp;
    caps.contact_pass = res.contact_mask != nullptr;
    caps.sun_shadows = res.req.sun_shadows;
    caps.sun_moments = res.req.sun_moments;
    caps.point_moments = res.req.point_moments;
    caps.spot_moments = res.req.spot_moments;
    caps.sun_layers = res.req.cascades;
    caps.spot_shadow_maps = res.req.spot_shadow_maps;
    caps.point_shadow_cubes = res.req.point_shadow_cubes;
    scene.pose(frame_index);
    res.packed = pack_frame(scene, res.width, res.height, caps, frame_index);
    res.frame_ubo.write(std::as_bytes(std::span(&res.packed.frame, 1)));
    if (res.req.analytic_spheres > 0)
      res.sphere_ubo.write(std::as_bytes(std::span(res.packed.analytic_spheres)));
    shadow_maps->prepare(res);
    if (res.req.temporal) update_temporal();
  }

  // The temporal block: this frame's points in the last frame's view, and whether the history
  // holds this scene as it is now.
  void update_temporal() {
    const FrameGpu& f = res.packed.frame;
    const uint64_t key = history_key(f);
    if (key != last_key) last_camera.reset();
    last_key = key;
    TemporalGpu t{};
    const float weight = std::clamp(scene.shadows.temporal_weight, 0.0f, 1.0f);
    t.params = glm::vec4(weight, last_camera ? 1.0f : 0.0f, kTemporalSurfaceFraction,
                         kTemporalSurfaceConstant);
    if (last_camera) {
      // (world - origin) -> (world - last origin) -> the last view: in double, so that a world
      // far from its origin keeps the sub-millimetre shift between the origins.
      const glm::dmat4 shift =
          glm::translate(glm::dmat4(1.0), res.packed.origin - last_camera->origin);
      t.to_previous_view = glm::mat4(last_camera->view * shift);
      t.previous_proj = glm::mat4(last_camera->proj);
    }
    res.temporal_ubo.write(std::as_bytes(std::span(&t, 1)));
    last_camera = LastCamera{glm::dmat4(f.view), glm::dmat4(f.proj), res.packed.origin};
  }

  void record(VkCommandBuffer cmd) {
    uint32_t q = 0;
    std::vector<std::string> names;
    timestamps.reset(cmd);
    const auto mark = [&](const std::string& name) {
      timestamps.write(cmd, q++, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT);
      if (!name.empty()) names.push_back(name);
    };
    mark("");
    graph.record(cmd, mark);
    gpu::full_barrier(cmd);
    pass_names = names;
  }

  void prepare() {
    for (const auto& f : res.before_frame) f();
  }
  void render(uint32_t frame_index, const std::function<void()>& while_gpu_busy = {}) {
    prepare();
    update(frame_index);
    VkCommandBuffer cmd = recorder.begin();
    record(cmd);
    recorder.submit_and_wait(while_gpu_busy);
    const auto ns = timestamps.read_ns(uint32_t(pass_names.size() + 1));
    timings.clear();
    for (size_t i = 0; i < pass_names.size(); ++i)
      timings.push_back({pass_names[i], (ns[i + 1] - ns[i]) * 1e-6});
  }
};

Renderer::Renderer(gpu::Context& ctx, const scene::Scene& scene, RendererOptions options)
    : impl_(std::make_unique<Impl>(ctx, scene, options)) {
  if (impl_->res.width == 0 || impl_->res.height == 0) {
    throw Error("Renderer: width and height must be > 0 (got " + std::to_string(impl_->res.width) +
                "x" + std::to_string(impl_->res.height) + ")");
  }
  const auto& l = ctx.info().limits;
  const uint32_t max_w = std::min(l.maxFramebufferWidth, l.maxViewportDimensions[0]);
  const uint32_t max_h = std::min(l.maxFramebufferHeight, l.maxViewportDimensions[1]);
  if (impl_->res.width > max_w || impl_->res.height > max_h) {
    throw Error("render size " + std::to_string(impl_->res.width) + "x" +
                std::to_string(impl_->res.height) +
                " (render.width, render.height or --size): device " + ctx.info().name +
                " renders at most " + std::to_string(max_w) + "x" + std::to_string(max_h) +
                " (maxFramebufferWidth/Height, maxViewportDimensions)");
  }
  impl_->build();
}

ReloadResult Renderer::reload(const std::vector<fs::path>& changed_files) {
  return impl_->reload(changed_files);
}

shader::PreparedReload Renderer::prepare_reload(const std::vector<fs::path>& changed_files) const {
  return impl_->registry.prepare_reload(changed_files);
}

ReloadResult Renderer::finish_reload(shader::PreparedReload prepared) {
  return impl_->finish_reload(std::move(prepared));
}

std::vector<fs::path> Renderer::shader_files() const {
  return impl_->registry.files();
}

std::vector<std::string> Renderer::pipelines_reading(const fs::path& file) const {
  return impl_->registry.programs_reading(file);
}

Renderer::~Renderer() {
  if (impl_) vkDeviceWaitIdle(impl_->ctx.device());
}

void Renderer::render(uint32_t frame_index) {
  impl_->render(frame_index);
}

void Renderer::render(uint32_t frame_index, const std::function<void()>& while_gpu_busy) {
  impl_->render(frame_index, while_gpu_busy);
}

void Renderer::prepare() {
  impl_->prepare();
}

void Renderer::reset_history() {
  impl_->last_camera.reset();
}

std::vector<uint8_t> Renderer::read_rgba8() {
  std::vector<uint8_t> px(size_t{impl_->res.width} * impl_->res.height * 4);
  impl_->readback.read(std::as_writable_bytes(std::span(px)));
  return px;
}

std::vector<float> Renderer::read_shadow_info() {
  if (!impl_->res.req.sun_shadows) return {};
  return unpack_halves(impl_->res.info.download());
}

GBuffer Renderer::read_gbuffer() {
  auto& m = *impl_;
  GBuffer g;
  g.width = m.res.width;
  g.height = m.res.height;
  const size_t n = size_t{m.res.width} * m.res.height;
  const auto depth_bytes = m.res.depth.download();
  g.depth.resize(n);
  std::memcpy(g.depth.data(), depth_bytes.data(), n * sizeof(float));
  const std::vector<float> normals = unpack_halves(m.res.normal.download());
  g.normal_view.resize(n);
  std::memcpy(g.normal_view.data(), normals.data(), n * sizeof(glm::vec4));
  g.camera.view = glm::dmat4(m.res.packed.frame.view);
  g.camera.proj = glm::dmat4(m.res.packed.frame.proj);
  g.camera.origin = m.res.packed.origin;
  g.camera.reverse_z = m.res.reverse_z;
  return g;
}

std::vector<float> Renderer::read_visibility(uint32_t slot) {
  auto& m = *impl_;
  if (!m.res.visibility_output)
    throw Error("Renderer::read_visibility: the renderer was built without visibility_output");
  if (slot >= kVisibilitySlots)
    throw Error("Renderer::read_visibility: slot " + std::to_string(slot) + " is not in [0, " +
                std::to_string(kVisibilitySlots) + ")");
  const auto bytes = m.res.visibility[slot / 4].download();
  const auto* f = reinterpret_cast<const float*>(bytes.data());
  std::vector<float> out(size_t{m.res.width} * m.res.height);
  for (size_t i = 0; i < out.size(); ++i) out[i] = f[4 * i + slot % 4];
  return out;
}

std::vector<std::vector<std::byte>> Renderer::read_shadow_maps() {
  std::vector<std::vector<std::byte>> out;
  auto& m = *impl_->shadow_maps;
  for (gpu::Image* image : {&m.sun_map, &m.spot_maps, &m.point_cubes})
    if (image->handle() != VK_NULL_HANDLE) out.push_back(image->download());
  return out;
}

std::vector<float> Renderer::read_sun_shadow_map(uint32_t cascade) {
  if (!impl_->res.req.sun_shadows || cascade >= impl_->res.req.cascades) return {};
  const auto bytes = impl_->shadow_maps->sun_map.download();
  const size_t texels =
      size_t{impl_->shadow_maps->sun_map.desc().width} * impl_->shadow_maps->sun_map.desc().height;
  std::vector<float> layer(texels), out(texels);
  std::memcpy(layer.data(), bytes.data() + cascade * texels * 4, texels * 4);
  // Read in place, sun_map is the cascades' toroidal grid: map texel t at (t + offset) mod n.
  const glm::ivec2 o = impl_->shadow_maps->sun_offset(cascade);
  const uint32_t n = impl_->shadow_maps->sun_map.desc().width;
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x)
      out[size_t(y) * n + x] = layer[size_t((y + uint32_t(o.y)) % n) * n + (x + uint32_t(o.x)) % n];
  return out;
}

uint32_t Renderer::width() const {
  return impl_->res.width;
}
uint32_t Renderer::height() const {
  return impl_->res.height;
}
const BuildReport& Renderer::built() const {
  return impl_->report;
}
const std::vector<PassTiming>& Renderer::timings() const {
  return impl_->timings;
}
const ShadowCacheStats& Renderer::shadow_cache_stats() const {
  return impl_->shadow_maps->stats();
}
const gpu::Image& Renderer::output_image() const {
  return impl_->res.ldr;
}

void Renderer::set_debug_view(scene::DebugView view) {
  impl_->scene.render.view = view;
}
scene::Scene& Renderer::scene() {
  return impl_->scene;
}

}  // namespace penumbra::render
