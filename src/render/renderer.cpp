#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/packing.hpp>
#include <map>
#include <optional>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/check.hpp>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/gpu/resources.hpp>
#include <penumbra/render/contact_shadows.hpp>
#include <penumbra/render/frame_pack.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/shader/compiler.hpp>
#include <penumbra/shadow/cascades.hpp>
#include <penumbra/shadow/local_lights.hpp>
#include <penumbra/shadow/pack.hpp>
#include <set>
#include <sstream>

namespace penumbra::render {
namespace fs = std::filesystem;

namespace {

constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr VkFormat kNormalFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr VkFormat kHdrFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr VkFormat kInfoFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr VkFormat kLdrFormat = VK_FORMAT_R8G8B8A8_UNORM;
constexpr VkFormat kVisibilityFormat = VK_FORMAT_R32G32B32A32_SFLOAT;

struct GpuMesh {
  gpu::Buffer vertices, indices;
  uint32_t index_count = 0;
};

VkVertexInputBindingDescription vertex_binding() {
  return {0, sizeof(scene::Vertex), VK_VERTEX_INPUT_RATE_VERTEX};
}

gpu::VertexInput vertex_input() {
  gpu::VertexInput v;
  v.bindings = {vertex_binding()};
  v.attributes = {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)},
                  {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, normal)},
                  {2, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(scene::Vertex, uv)}};
  return v;
}

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
    case VK_FORMAT_R32G32B32A32_SFLOAT:
      return "RGBA32F";
    default:
      return std::to_string(int(f));
  }
}

// The halves of an RGBA16F download, as floats.
std::vector<float> unpack_halves(const std::vector<std::byte>& bytes) {
  const auto* h = reinterpret_cast<const uint16_t*>(bytes.data());
  std::vector<float> out(bytes.size() / 2);
  for (size_t i = 0; i < out.size(); ++i) out[i] = glm::unpackHalf1x16(h[i]);
  return out;
}

}  // namespace

std::string BuildReport::to_string() const {
  std::ostringstream s;
  for (const auto& p : passes) s << "pass      " << p << "\n";
  for (const auto& p : pipelines) s << "pipeline  " << p << "\n";
  for (const auto& i : images) s << "image     " << i << "\n";
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
  uint32_t width = 0, height = 0;
  bool reverse_z = true;
  bool visibility_output = false;
  scene::Scene::Requirements req{};
  BuildReport report;
  std::vector<PassTiming> timings;

  shader::ProgramRegistry registry;  // every pipeline's sources, for hot reload
  std::vector<GpuMesh> meshes;

  // Uniform data.
  gpu::Buffer frame_ubo, shadow_ubo, spot_ubo, point_ubo;
  PackedFrame packed;  // this frame's GPU data (pack_frame)

  // Images.
  gpu::Image depth, normal, hdr, info, ldr;
  gpu::Image visibility[2];  // only with visibility_output
  gpu::Image sun_map;
  std::vector<gpu::Image> spot_maps;
  std::vector<gpu::Image> point_maps;
  gpu::Sampler nearest, shadow_compare, raw_depth;
  gpu::Buffer readback;

  // Pipelines (null when the scene does not need them).
  std::unique_ptr<gpu::PipelineLayout> geo_layout, shadow_layout, spot_layout, point_layout,
      resolve_layout, tonemap_layout;
  std::unique_ptr<gpu::GraphicsPipeline> prepass_opaque, prepass_masked, forward_opaque,
      forward_masked, shadow_opaque, shadow_masked, spot_opaque, spot_masked, point_pipe;
  std::unique_ptr<gpu::ComputePipeline> resolve, tonemap;
  gpu::DescriptorPool pool;
  VkDescriptorSet geo_set = VK_NULL_HANDLE, forward_set = VK_NULL_HANDLE,
                  shadow_set = VK_NULL_HANDLE, spot_set = VK_NULL_HANDLE,
                  point_set = VK_NULL_HANDLE, resolve_set = VK_NULL_HANDLE,
                  tonemap_set = VK_NULL_HANDLE;
  std::unique_ptr<gpu::PipelineLayout> forward_layout;
  std::unique_ptr<ContactShadowPass> contact;
  gpu::TimestampPool timestamps;
  gpu::CommandRecorder recorder;

  Impl(gpu::Context& c, const scene::Scene& s, const RendererOptions& o)
      : ctx(c),
        scene(s),
        shader_dir(o.shader_dir.empty() ? shader::default_shader_dir() : o.shader_dir),
        width(o.width ? o.width : s.render.width),
        height(o.height ? o.height : s.render.height),
        reverse_z(s.shadows.reverse_z),
        visibility_output(o.visibility_output),
        registry(shader_dir),
        pool(c, 16),
        timestamps(c, 32),
        recorder(c) {}

  // ---- the pipelines, in the program registry: a shader edit rebuilds exactly the pipelines
  // whose sources (or their includes) read the edited file.
  using Source = shader::ProgramSource;
  using Spirvs = shader::Spirvs;

  void add_pipeline(const std::string& name, std::vector<Source> sources,
                    std::function<void(const Spirvs&)> create) {
    registry.add(name, std::move(sources), std::move(create));
    report.pipelines.push_back(name);
  }

  ReloadResult reload(const std::vector<fs::path>& changed) {
    return registry.reload(changed, [this] { vkDeviceWaitIdle(ctx.device()); });
  }

  static std::string variant(const std::string& name, const std::vector<shader::Define>& d) {
    std::string s = name;
    for (const auto& x : d) s += " " + x.name + "=" + x.value;
    return s;
  }

  gpu::Image make_image(const std::string& name, gpu::ImageKind kind, VkFormat format, uint32_t w,
                        uint32_t h, uint32_t layers, VkImageUsageFlags usage) {
    gpu::ImageDesc d;
    d.kind = kind;
    d.format = format;
    d.width = w;
    d.height = h;
    d.layers = layers;
    d.usage = usage;
    report.images.push_back(name + " " + std::to_string(w) + "x" + std::to_string(h) +
                            (layers > 1 ? "x" + std::to_string(layers) : "") + " " +
                            format_name(format));
    return gpu::Image(ctx, d);
  }

  void upload_meshes() {
    for (const auto& m : scene.meshes) {
      GpuMesh g;
      if (m.vertices.empty() || m.indices.empty()) {
        meshes.push_back(std::move(g));
        continue;
      }
      g.vertices = gpu::Buffer(ctx, m.vertices.size() * sizeof(scene::Vertex),
                               VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, gpu::MemoryUse::device);
      g.vertices.write(std::as_bytes(std::span(m.vertices)));
      g.indices = gpu::Buffer(ctx, m.indices.size() * sizeof(uint32_t),
                              VK_BUFFER_USAGE_INDEX_BUFFER_BIT, gpu::MemoryUse::device);
      g.indices.write(std::as_bytes(std::span(m.indices)));
      g.index_count = static_cast<uint32_t>(m.indices.size());
      meshes.push_back(std::move(g));
    }
  }

  void build() {
    req = scene.requirements();
    upload_meshes();
    const VkImageUsageFlags sampled = VK_IMAGE_USAGE_SAMPLED_BIT;
    depth = make_image("depth", gpu::ImageKind::image_2d, kDepthFormat, width, height, 1,
                       VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | sampled);
    normal = make_image("normal", gpu::ImageKind::image_2d, kNormalFormat, width, height, 1,
                        VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | sampled);
    hdr = make_image("hdr", gpu::ImageKind::image_2d, kHdrFormat, width, height, 1,
                     VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | sampled);
    ldr = make_image("ldr", gpu::ImageKind::image_2d, kLdrFormat, width, height, 1,
                     VK_IMAGE_USAGE_STORAGE_BIT);
    readback = gpu::Buffer(ctx, size_t{width} * height * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
    if (visibility_output)
      for (int i = 0; i < 2; ++i)
        visibility[i] =
            make_image("visibility" + std::to_string(i), gpu::ImageKind::image_2d,
                       kVisibilityFormat, width, height, 1, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT);

    nearest = gpu::Sampler(ctx, gpu::SamplerDesc{});
    gpu::SamplerDesc cmp;
    cmp.filter = VK_FILTER_LINEAR;
    cmp.compare = true;
    cmp.compare_op = reverse_z ? VK_COMPARE_OP_GREATER_OR_EQUAL : VK_COMPARE_OP_LESS_OR_EQUAL;
    shadow_compare = gpu::Sampler(ctx, cmp);
    raw_depth = gpu::Sampler(ctx, gpu::SamplerDesc{});

    frame_ubo = gpu::Buffer(ctx, sizeof(FrameGpu), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    const VkShaderStageFlags all = VK_SHADER_STAGE_ALL;

    // Geometry: prepass + forward share the vertex stage and the frame block.
    geo_layout =
        std::make_unique<gpu::PipelineLayout>(ctx,
                                              std::vector<std::vector<gpu::BindingDesc>>{
                                                  {{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, all}}},
                                              uint32_t(sizeof(DrawPush)), all);
    for (bool masked : {false, true}) {
      if (masked && !req.masked_materials) continue;
      add_pipeline(std::string("prepass-") + (masked ? "masked" : "opaque"),
                   {{"render/geometry.vert", {}}, {"render/prepass.frag", {}}},
                   [this, masked](const Spirvs& spirv) {
                     gpu::GraphicsPipelineDesc d;
                     d.vertex_spirv = spirv[0];
                     d.fragment_spirv = spirv[1];
                     d.vertex_input = vertex_input();
                     d.color_formats = {kNormalFormat};
                     d.depth_format = kDepthFormat;
                     d.depth_compare = reverse_z ? VK_COMPARE_OP_GREATER : VK_COMPARE_OP_LESS;
                     d.cull = masked ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT;
                     (masked ? prepass_masked : prepass_opaque) =
                         std::make_unique<gpu::GraphicsPipeline>(ctx, d, *geo_layout);
                   });
    }
    geo_set = pool.allocate(geo_layout->set_layout(0));
    gpu::DescriptorWriter()
        .buffer(0, frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
        .update(ctx, geo_set);
    report.passes.push_back("prepass: depth + normals");

    if (req.sun_shadows) build_sun();
    if (req.spot_shadow_maps > 0) build_spots();
    if (req.point_shadow_cubes > 0) build_points();
    build_contact();
    build_forward();
    build_tonemap();
  }

  // The depth-only caster pipelines of a light: opaque casters with no fragment stage, and (when
  // the scene has masked materials) alpha-tested casters. Dynamic depth bias on both.
  void add_caster_pipelines(const std::string& name, const std::string& vertex,
                            const gpu::PipelineLayout& layout,
                            std::unique_ptr<gpu::GraphicsPipeline>& opaque,
                            std::unique_ptr<gpu::GraphicsPipeline>& masked_out, bool depth_clamp) {
    for (bool masked : {false, true}) {
      if (masked && !req.masked_materials) continue;
      std::vector<Source> sources{{vertex, {}}};
      if (masked) sources.push_back({"render/shadow_masked.frag", {}});
      auto& target = masked ? masked_out : opaque;
      add_pipeline(name + (masked ? "-masked" : "-opaque (no fragment stage)"), sources,
                   [this, masked, depth_clamp, &layout, &target](const Spirvs& spirv) {
                     gpu::GraphicsPipelineDesc d;
                     d.vertex_spirv = spirv[0];
                     if (masked) d.fragment_spirv = spirv[1];
                     d.vertex_input = vertex_input();
                     d.depth_format = kDepthFormat;
                     d.depth_compare =
                         reverse_z ? VK_COMPARE_OP_GREATER_OR_EQUAL : VK_COMPARE_OP_LESS_OR_EQUAL;
                     d.depth_bias = true;
                     d.depth_clamp = depth_clamp;
                     d.cull = VK_CULL_MODE_NONE;
                     target = std::make_unique<gpu::GraphicsPipeline>(ctx, d, layout);
                   });
    }
  }

  void build_sun() {
    const uint32_t res = scene.shadows.resolution;
    const uint32_t n = req.cascades;
    sun_map =
        make_image("sun-shadow-map", gpu::ImageKind::image_2d_array, kDepthFormat, res, res, n,
                   VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
    shadow_ubo = gpu::Buffer(ctx, sizeof(shadow::ShadowGpu), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    shadow_layout = std::make_unique<gpu::PipelineLayout>(
        ctx,
        std::vector<std::vector<gpu::BindingDesc>>{
            {{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_ALL}}},
        uint32_t(sizeof(DrawPush)), VK_SHADER_STAGE_ALL);
    add_caster_pipelines("sun-shadow", "render/shadow_depth.vert", *shadow_layout, shadow_opaque,
                         shadow_masked, ctx.info().depth_clamp);
    shadow_set = pool.allocate(shadow_layout->set_layout(0));
    gpu::DescriptorWriter()
        .buffer(0, shadow_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
        .update(ctx, shadow_set);
    report.passes.push_back("sun-shadow: " + std::to_string(n) + " cascade(s) " +
                            std::to_string(res) + "^2");

    info = make_image("shadow-info", gpu::ImageKind::image_2d, kInfoFormat, width, height, 1,
                      VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
    resolve_layout = std::make_unique<gpu::PipelineLayout>(
        ctx, std::vector<std::vector<gpu::BindingDesc>>{
                 {{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
                  {1, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
                  {2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
                  {3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
                  {4, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
                  {5, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
                  {6, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT}}});
    add_pipeline("shadow-resolve", {{"render/shadow_resolve.comp", {}}},
                 [this](const Spirvs& spirv) {
                   resolve = std::make_unique<gpu::ComputePipeline>(ctx, spirv[0], *resolve_layout);
                 });
    resolve_set = pool.allocate(resolve_layout->set_layout(0));
    gpu::DescriptorWriter()
        .buffer(0, frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
        .buffer(1, shadow_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
        .combined_image(2, depth.view(), nearest.handle())
        .combined_image(3, normal.view(), nearest.handle())
        .combined_image(4, sun_map.view(), shadow_compare.handle())
        .combined_image(5, sun_map.view(), raw_depth.handle())
        .storage_image(6, info.view())
        .update(ctx, resolve_set);
    report.passes.push_back("shadow-resolve: compute");
  }

  void build_spots() {
    const uint32_t n = req.spot_shadow_maps;
    uint32_t res = 16;
    for (const auto& s : scene.spots)
      if (s.shadows) res = std::max(res, s.resolution);
    gpu::Image arr =
        make_image("spot-shadow-maps", gpu::ImageKind::image_2d_array, kDepthFormat, res, res, n,
                   VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
    spot_maps.push_back(std::move(arr));
    spot_ubo = gpu::Buffer(ctx, sizeof(shadow::SpotShadowGpu) * kMaxSpotLights,
                           VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    spot_layout = std::make_unique<gpu::PipelineLayout>(
        ctx,
        std::vector<std::vector<gpu::BindingDesc>>{
            {{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_ALL}}},
        uint32_t(sizeof(DrawPush)), VK_SHADER_STAGE_ALL);
    add_caster_pipelines("spot-shadow", "render/spot_depth.vert", *spot_layout, spot_opaque,
                         spot_masked, false);
    spot_set = pool.allocate(spot_layout->set_layout(0));
    gpu::DescriptorWriter()
        .buffer(0, spot_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
        .update(ctx, spot_set);
    report.passes.push_back("spot-shadow: " + std::to_string(n) + " map(s) " + std::to_string(res) +
                            "^2");
  }

  void build_points() {
    const uint32_t n = req.point_shadow_cubes;
    uint32_t res = 16;
    for (const auto& p : scene.points)
      if (p.shadows) res = std::max(res, p.resolution);
    // One cube array: the forward pass indexes it by layer, not by descriptor.
    point_maps.push_back(
        make_image("point-shadow-cubes", gpu::ImageKind::cube_array, kDepthFormat, res, res, 6 * n,
                   VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT));
    point_ubo = gpu::Buffer(ctx, sizeof(shadow::PointShadowGpu) * kMaxPointLights,
                            VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    point_layout = std::make_unique<gpu::PipelineLayout>(
        ctx,
        std::vector<std::vector<gpu::BindingDesc>>{
            {{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_ALL}}},
        uint32_t(sizeof(DrawPush)), VK_SHADER_STAGE_ALL);
    add_pipeline("point-shadow-cube (linear distance)",
                 {{"render/point_depth.vert", {}}, {"render/point_depth.frag", {}}},
                 [this](const Spirvs& spirv) {
                   gpu::GraphicsPipelineDesc d;
                   d.vertex_spirv = spirv[0];
                   d.fragment_spirv = spirv[1];
                   d.vertex_input = vertex_input();
                   d.depth_format = kDepthFormat;
                   d.depth_compare =
                       reverse_z ? VK_COMPARE_OP_GREATER_OR_EQUAL : VK_COMPARE_OP_LESS_OR_EQUAL;
                   d.cull = VK_CULL_MODE_NONE;  // cube face views are mirrored
                   point_pipe = std::make_unique<gpu::GraphicsPipeline>(ctx, d, *point_layout);
                 });
    point_set = pool.allocate(point_layout->set_layout(0));
    gpu::DescriptorWriter()
        .buffer(0, point_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
        .update(ctx, point_set);
    report.passes.push_back("point-shadow: " + std::to_string(n) + " cube(s) x 6 faces");
  }

  // Contact shadows march toward the sun; without a sun (or with 0 steps) there is no pass.
  // The pass compiles and owns its two compute pipelines; the registry record makes an edit to
  // its shaders (or their includes) recreate it, and rebinds its mask where it is read.
  void build_contact() {
    if (!req.contact_pass || !scene.sun) return;
    ContactShadowPassDesc desc;
    desc.width = width;
    desc.height = height;
    desc.settings = scene.contact;
    desc.shader_dir = shader_dir;
    if (desc.settings.step_count == 0) return;
    add_pipeline("contact-shadows (depth resolve + march)",
                 {{"contact_shadows.comp", {}}, {"depth_resolve.comp", {}}},
                 [this, desc](const Spirvs& spirv) {
                   ContactShadowPassDesc d = desc;
                   d.march_spirv = spirv[0];
                   d.resolve_spirv = spirv[1];
                   auto pass = std::make_unique<ContactShadowPass>(ctx, d);
                   contact = std::move(pass);
                   bind_contact_mask();
                 });
    report.passes.push_back("contact-shadows: compute (" +
                            std::to_string(desc.settings.step_count) + " steps)");
    report.images.push_back("contact-mask " + std::to_string(width) + "x" + std::to_string(height) +
                            " R8 + resolved depth R32F");
  }

  // Points the forward and tonemap descriptor sets at the current contact mask (after the pass
  // was recreated by a reload; at build time the sets do not exist yet).
  void bind_contact_mask() {
    if (!contact) return;
    if (forward_set != VK_NULL_HANDLE)
      gpu::DescriptorWriter()
          .combined_image(2, contact->mask()->view(), nearest.handle())
          .update(ctx, forward_set);
    if (tonemap_set != VK_NULL_HANDLE)
      gpu::DescriptorWriter()
          .combined_image(3, contact->mask()->view(), nearest.handle())
          .update(ctx, tonemap_set);
  }

  bool contact_active() const { return contact != nullptr; }

  void record_contact(VkCommandBuffer cmd) {
    ContactShadowFrame f;
    const auto cam = shadow_camera();
    f.camera = ContactCamera::from(
        cam, reverse_z ? shadow::DepthConvention::reverse_z : shadow::DepthConvention::standard);
    f.light_dir_view = to_contact_view(cam, -glm::dvec3(scene.sun->direction));
    f.frame = packed.frame.mode.x;
    contact->record(cmd, depth, normal, f);
  }

  std::vector<shader::Define> light_defines() const {
    return {{"PENUMBRA_SUN_SHADOWS", req.sun_shadows ? "1" : "0"},
            {"PENUMBRA_CONTACT", contact_active() ? "1" : "0"},
            {"PENUMBRA_SPOT_SHADOWS", std::to_string(req.spot_shadow_maps)},
            {"PENUMBRA_POINT_SHADOWS", std::to_string(req.point_shadow_cubes)}};
  }

  void build_forward() {
    const VkShaderStageFlags all = VK_SHADER_STAGE_ALL;
    std::vector<gpu::BindingDesc> b{{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, all}};
    if (req.sun_shadows) b.push_back({1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, all});
    if (contact_active()) b.push_back({2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, all});
    if (req.spot_shadow_maps) {
      b.push_back({3, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, all});
      b.push_back({4, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, all});
    }
    if (req.point_shadow_cubes) {
      b.push_back({5, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, all});
      b.push_back({6, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, all});
    }
    forward_layout = std::make_unique<gpu::PipelineLayout>(
        ctx, std::vector<std::vector<gpu::BindingDesc>>{b}, uint32_t(sizeof(DrawPush)), all);
    auto defines = light_defines();
    if (visibility_output) defines.push_back({"PENUMBRA_VISIBILITY_OUTPUT", "1"});
    for (bool masked : {false, true}) {
      if (masked && !req.masked_materials) continue;
      add_pipeline(variant(std::string("forward-") + (masked ? "masked" : "opaque"), defines),
                   {{"render/geometry.vert", {}}, {"render/forward.frag", defines}},
                   [this, masked](const Spirvs& spirv) {
                     gpu::GraphicsPipelineDesc d;
                     d.vertex_spirv = spirv[0];
                     d.fragment_spirv = spirv[1];
                     d.vertex_input = vertex_input();
                     d.color_formats = {kHdrFormat};
                     if (visibility_output)
                       d.color_formats.insert(d.color_formats.end(), 2, kVisibilityFormat);
                     d.depth_format = kDepthFormat;
                     d.depth_write = false;
                     // The prepass wrote the nearest surface; "not behind it" rather than EQUAL
                     // tolerates last-bit differences between two pipelines.
                     d.depth_compare =
                         reverse_z ? VK_COMPARE_OP_GREATER_OR_EQUAL : VK_COMPARE_OP_LESS_OR_EQUAL;
                     d.cull = masked ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT;
                     (masked ? forward_masked : forward_opaque) =
                         std::make_unique<gpu::GraphicsPipeline>(ctx, d, *forward_layout);
                   });
    }
    forward_set = pool.allocate(forward_layout->set_layout(0));
    gpu::DescriptorWriter w;
    w.buffer(0, frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER);
    if (req.sun_shadows) w.combined_image(1, info.view(), nearest.handle());
    if (contact) w.combined_image(2, contact->mask()->view(), nearest.handle());
    if (req.spot_shadow_maps) {
      w.buffer(3, spot_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER);
      w.combined_image(4, spot_maps[0].view(), shadow_compare.handle());
    }
    if (req.point_shadow_cubes) {
      w.buffer(5, point_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER);
      w.combined_image(6, point_maps[0].view(), shadow_compare.handle());
    }
    w.update(ctx, forward_set);
    report.passes.push_back("forward: lighting");
  }

  void build_tonemap() {
    std::vector<gpu::BindingDesc> b{
        {0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
        {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT},
        {4, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT}};
    if (req.sun_shadows)
      b.push_back({2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT});
    if (contact_active())
      b.push_back({3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT});
    tonemap_layout =
        std::make_unique<gpu::PipelineLayout>(ctx, std::vector<std::vector<gpu::BindingDesc>>{b});
    const auto defines = std::vector<shader::Define>{light_defines()[0], light_defines()[1]};
    add_pipeline(variant("tonemap", defines), {{"render/tonemap.comp", defines}},
                 [this](const Spirvs& spirv) {
                   tonemap = std::make_unique<gpu::ComputePipeline>(ctx, spirv[0], *tonemap_layout);
                 });
    tonemap_set = pool.allocate(tonemap_layout->set_layout(0));
    gpu::DescriptorWriter w;
    w.buffer(0, frame_ubo.handle(), VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER)
        .combined_image(1, hdr.view(), nearest.handle())
        .storage_image(4, ldr.view());
    if (req.sun_shadows) w.combined_image(2, info.view(), nearest.handle());
    if (contact) w.combined_image(3, contact->mask()->view(), nearest.handle());
    w.update(ctx, tonemap_set);
    report.passes.push_back("tonemap: compute");
  }

  // ---- per frame -------------------------------------------------------------------------

  shadow::Camera shadow_camera() const { return frame_camera(scene, width, height); }

  // The frame's GPU data from pack_frame (pure, tested without a GPU), uploaded.
  void update(uint32_t frame_index) {
    FrameCaps caps;
    caps.depth_clamp = ctx.info().depth_clamp;
    caps.contact_pass = contact_active();
    caps.sun_shadows = req.sun_shadows;
    caps.spot_shadow_maps = req.spot_shadow_maps;
    caps.point_shadow_cubes = req.point_shadow_cubes;
    packed = pack_frame(scene, width, height, caps, frame_index);
    frame_ubo.write(std::as_bytes(std::span(&packed.frame, 1)));
    if (req.spot_shadow_maps) spot_ubo.write(std::as_bytes(std::span(packed.spot_gpu)));
    if (req.point_shadow_cubes) point_ubo.write(std::as_bytes(std::span(packed.point_gpu)));
    if (req.sun_shadows) shadow_ubo.write(std::as_bytes(std::span(&packed.shadow, 1)));
  }

  void draw_meshes(VkCommandBuffer cmd, const gpu::PipelineLayout& layout, VkPipeline opaque,
                   VkPipeline masked, bool casters_only, glm::uvec4 index) {
    for (int pass = 0; pass < 2; ++pass) {
      VkPipeline p = pass == 0 ? opaque : masked;
      if (p == VK_NULL_HANDLE) continue;
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p);
      for (const auto& d : packed.draws) {
        if (d.masked != (pass == 1) || (casters_only && !d.casts)) continue;
        const GpuMesh& m = meshes[d.mesh];
        if (m.index_count == 0) continue;
        DrawPush push = d.push;
        push.index = index;
        vkCmdPushConstants(cmd, layout.handle(), VK_SHADER_STAGE_ALL, 0, sizeof(DrawPush), &push);
        VkDeviceSize offset = 0;
        VkBuffer vb = m.vertices.handle();
        vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &offset);
        vkCmdBindIndexBuffer(cmd, m.indices.handle(), 0, VK_INDEX_TYPE_UINT32);
        vkCmdDrawIndexed(cmd, m.index_count, 1, 0, 0, 0);
      }
    }
  }

  static void viewport(VkCommandBuffer cmd, uint32_t w, uint32_t h) {
    VkViewport vp{0, 0, float(w), float(h), 0, 1};
    VkRect2D sc{{0, 0}, {w, h}};
    vkCmdSetViewport(cmd, 0, 1, &vp);
    vkCmdSetScissor(cmd, 0, 1, &sc);
  }

  // Caster-side depth bias pushes caster depth away from the light: negative under reverse-Z.
  void set_caster_bias(VkCommandBuffer cmd) {
    const float sign = reverse_z ? -1.0f : 1.0f;
    vkCmdSetDepthBias(cmd, 0.0f, 0.0f, sign * 1.0f);
  }

  // Renders every caster into `layers` layers of a depth array (cascades, spot maps, cube
  // faces), leaving it ready for sampling.
  template <class IndexFn>
  void render_shadow_layers(VkCommandBuffer cmd, gpu::Image& target, uint32_t layers,
                            const gpu::PipelineLayout& layout, VkDescriptorSet set,
                            const gpu::GraphicsPipeline* opaque,
                            const gpu::GraphicsPipeline* masked, bool caster_bias, IndexFn index) {
    target.transition(cmd, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
    for (uint32_t l = 0; l < layers; ++l) {
      begin_rendering(cmd, target.desc().width, target.desc().width, VK_NULL_HANDLE, {},
                      target.layer_view(l), VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, true);
      if (caster_bias) set_caster_bias(cmd);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout.handle(), 0, 1, &set, 0,
                              nullptr);
      draw_meshes(cmd, layout, opaque->handle(), masked ? masked->handle() : VK_NULL_HANDLE, true,
                  index(l));
      vkCmdEndRendering(cmd);
    }
    target.transition(cmd, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  }

  // Begins dynamic rendering into an optional colour target (cleared to `clear`) and a depth
  // target (cleared to far, or loaded), with a full-size viewport and scissor.
  // Extra colour targets (cleared to 0) follow the first.
  void begin_rendering(VkCommandBuffer cmd, uint32_t w, uint32_t h, VkImageView color,
                       VkClearColorValue clear, VkImageView depth_view, VkImageLayout depth_layout,
                       bool clear_depth, const std::vector<VkImageView>& extra_colors = {}) {
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
    da.clearValue.depthStencil = {reverse_z ? 0.0f : 1.0f, 0};
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = {{0, 0}, {w, h}};
    ri.layerCount = 1;
    ri.colorAttachmentCount = color != VK_NULL_HANDLE ? uint32_t(cas.size()) : 0;
    ri.pColorAttachments = color != VK_NULL_HANDLE ? cas.data() : nullptr;
    ri.pDepthAttachment = &da;
    vkCmdBeginRendering(cmd, &ri);
    viewport(cmd, w, h);
  }

  void record(VkCommandBuffer cmd) {
    uint32_t q = 0;
    std::vector<std::string> names;
    timestamps.reset(cmd);
    auto mark = [&](const std::string& name) {
      timestamps.write(cmd, q++, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT);
      if (!name.empty()) names.push_back(name);
    };
    mark("");
    if (req.sun_shadows) {
      render_shadow_layers(cmd, sun_map, req.cascades, *shadow_layout, shadow_set,
                           shadow_opaque.get(), shadow_masked.get(), true,
                           [](uint32_t c) { return glm::uvec4(c, 0, 0, 0); });
      mark("sun-shadow");
    }
    if (req.spot_shadow_maps) {
      render_shadow_layers(cmd, spot_maps[0], uint32_t(packed.spot_shadows.size()), *spot_layout,
                           spot_set, spot_opaque.get(), spot_masked.get(), true,
                           [](uint32_t i) { return glm::uvec4(i, 0, 0, 0); });
      mark("spot-shadow");
    }
    if (req.point_shadow_cubes) {
      // Layer 6·i + f is face f of light i. One pipeline draws opaque and masked casters: its
      // fragment stage writes the linear distance and alpha-tests.
      render_shadow_layers(cmd, point_maps[0], 6 * uint32_t(packed.point_shadows.size()),
                           *point_layout, point_set, point_pipe.get(), point_pipe.get(), false,
                           [](uint32_t l) { return glm::uvec4(l % 6, l / 6, 0, 0); });
      mark("point-shadow");
    }

    // Prepass.
    depth.transition(cmd, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
    normal.transition(cmd, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
    begin_rendering(cmd, width, height, normal.view(), {{0, 0, 0, 0}}, depth.view(),
                    VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, true);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, geo_layout->handle(), 0, 1,
                            &geo_set, 0, nullptr);
    draw_meshes(cmd, *geo_layout, prepass_opaque->handle(),
                prepass_masked ? prepass_masked->handle() : VK_NULL_HANDLE, false, glm::uvec4(0));
    vkCmdEndRendering(cmd);
    depth.transition(cmd, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    normal.transition(cmd, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    mark("prepass");

    if (req.sun_shadows) {
      info.transition(cmd, VK_IMAGE_LAYOUT_GENERAL);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolve->handle());
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolve_layout->handle(), 0, 1,
                              &resolve_set, 0, nullptr);
      vkCmdDispatch(cmd, (width + 7) / 8, (height + 7) / 8, 1);
      info.transition(cmd, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
      mark("shadow-resolve");
    }
    if (contact) {
      record_contact(cmd);
      mark("contact-shadows");
    }

    // Forward.
    depth.transition(cmd, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL);
    hdr.transition(cmd, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
    std::vector<VkImageView> visibility_views;
    if (visibility_output)
      for (auto& v : visibility) {
        v.transition(cmd, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
        visibility_views.push_back(v.view());
      }
    const glm::vec3 sky =
        scene.sun ? glm::vec3(0.45f, 0.6f, 0.85f) : glm::vec3(0.01f, 0.01f, 0.02f);
    begin_rendering(cmd, width, height, hdr.view(), {{sky.r, sky.g, sky.b, 1.0f}}, depth.view(),
                    VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, false, visibility_views);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, forward_layout->handle(), 0, 1,
                            &forward_set, 0, nullptr);
    draw_meshes(cmd, *forward_layout, forward_opaque->handle(),
                forward_masked ? forward_masked->handle() : VK_NULL_HANDLE, false, glm::uvec4(0));
    vkCmdEndRendering(cmd);
    hdr.transition(cmd, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    mark("forward");

    ldr.transition(cmd, VK_IMAGE_LAYOUT_GENERAL);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, tonemap->handle());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, tonemap_layout->handle(), 0, 1,
                            &tonemap_set, 0, nullptr);
    vkCmdDispatch(cmd, (width + 7) / 8, (height + 7) / 8, 1);
    mark("tonemap");

    ldr.transition(cmd, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {width, height, 1};
    vkCmdCopyImageToBuffer(cmd, ldr.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                           readback.handle(), 1, &region);
    gpu::full_barrier(cmd);
    pass_names = names;
  }

  std::vector<std::string> pass_names;

  void render(uint32_t frame_index) {
    update(frame_index);
    VkCommandBuffer cmd = recorder.begin();
    record(cmd);
    recorder.submit_and_wait();
    const auto ns = timestamps.read_ns(uint32_t(pass_names.size() + 1));
    timings.clear();
    for (size_t i = 0; i < pass_names.size(); ++i)
      timings.push_back({pass_names[i], (ns[i + 1] - ns[i]) * 1e-6});
  }
};

Renderer::Renderer(gpu::Context& ctx, const scene::Scene& scene, RendererOptions options)
    : impl_(std::make_unique<Impl>(ctx, scene, options)) {
  if (impl_->width == 0 || impl_->height == 0) {
    throw Error("Renderer: width and height must be > 0 (got " + std::to_string(impl_->width) +
                "x" + std::to_string(impl_->height) + ")");
  }
  impl_->build();
}

ReloadResult Renderer::reload(const std::vector<fs::path>& changed_files) {
  return impl_->reload(changed_files);
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

std::vector<uint8_t> Renderer::read_rgba8() {
  std::vector<uint8_t> px(size_t{impl_->width} * impl_->height * 4);
  impl_->readback.read(std::as_writable_bytes(std::span(px)));
  return px;
}

std::vector<float> Renderer::read_shadow_info() {
  if (!impl_->req.sun_shadows) return {};
  return unpack_halves(impl_->info.download());
}

GBuffer Renderer::read_gbuffer() {
  auto& m = *impl_;
  GBuffer g;
  g.width = m.width;
  g.height = m.height;
  const size_t n = size_t{m.width} * m.height;
  const auto depth_bytes = m.depth.download();
  g.depth.resize(n);
  std::memcpy(g.depth.data(), depth_bytes.data(), n * sizeof(float));
  const std::vector<float> normals = unpack_halves(m.normal.download());
  g.normal_view.resize(n);
  std::memcpy(g.normal_view.data(), normals.data(), n * sizeof(glm::vec4));
  g.camera.view = glm::dmat4(m.packed.frame.view);
  g.camera.proj = glm::dmat4(m.packed.frame.proj);
  g.camera.origin = m.packed.origin;
  g.camera.reverse_z = m.reverse_z;
  return g;
}

std::vector<float> Renderer::read_visibility(uint32_t slot) {
  auto& m = *impl_;
  if (!m.visibility_output)
    throw Error("Renderer::read_visibility: the renderer was built without visibility_output");
  if (slot >= kVisibilitySlots)
    throw Error("Renderer::read_visibility: slot " + std::to_string(slot) + " is not in [0, " +
                std::to_string(kVisibilitySlots) + ")");
  const auto bytes = m.visibility[slot / 4].download();
  const auto* f = reinterpret_cast<const float*>(bytes.data());
  std::vector<float> out(size_t{m.width} * m.height);
  for (size_t i = 0; i < out.size(); ++i) out[i] = f[4 * i + slot % 4];
  return out;
}

std::vector<float> Renderer::read_sun_shadow_map(uint32_t cascade) {
  if (!impl_->req.sun_shadows || cascade >= impl_->req.cascades) return {};
  const auto bytes = impl_->sun_map.download();
  const size_t texels = size_t{impl_->sun_map.desc().width} * impl_->sun_map.desc().height;
  std::vector<float> out(texels);
  std::memcpy(out.data(), bytes.data() + cascade * texels * 4, texels * 4);
  return out;
}

uint32_t Renderer::width() const {
  return impl_->width;
}
uint32_t Renderer::height() const {
  return impl_->height;
}
const BuildReport& Renderer::built() const {
  return impl_->report;
}
const std::vector<PassTiming>& Renderer::timings() const {
  return impl_->timings;
}
const gpu::Image& Renderer::output_image() const {
  return impl_->ldr;
}

void Renderer::set_debug_view(scene::DebugView view) {
  impl_->scene.render.view = view;
}
scene::Scene& Renderer::scene() {
  return impl_->scene;
}

}  // namespace penumbra::render
