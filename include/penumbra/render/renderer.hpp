#pragma once

// The frame: sun shadow depth per cascade → spot / point shadow maps → depth + normal prepass →
// shadow resolve (compute, shadow.glsl) → contact shadows (compute) → forward lighting →
// tonemap + debug views. Passes, pipelines, images and shader variants are created only for
// what the scene declares; created() lists them.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <penumbra/gpu/context.hpp>
#include <penumbra/gpu/resources.hpp>
#include <penumbra/render/frame_types.hpp>
#include <penumbra/scene/scene.hpp>
#include <penumbra/shader/registry.hpp>
#include <string>
#include <vector>

namespace penumbra::render {

struct RendererOptions {
  // Where the stage shaders (render/…) and the library (penumbra/…) live.
  std::filesystem::path shader_dir;  // empty: the repo's shaders/ (compiled in)
  // Read where shader_dir lacks a file (an overlay of a few files over the installed library):
  // shader::ProgramRegistry's library directories.
  std::vector<std::filesystem::path> library_shader_dirs;
  uint32_t width = 0, height = 0;    // 0: the scene's [render] size
  // The forward pass also writes each light's visibility as the lighting uses it (two RGBA32F
  // targets, read_visibility()): what the ray-traced reference compares with. Off by default:
  // a frame that nobody measures does not pay for it.
  bool visibility_output = false;
  // The shadow resolves are specialized per frame by the filters in use and the debug view, so
  // the driver compiles only that code (docs/architecture.md). Off: one pipeline each, every
  // filter compiled, the values read from the frame; the images are the same bit for bit.
  bool specialize = true;
  // How the sun's resolves read its cascades (ShadowMapPass): from a map the grid's window is
  // written into each frame, by a copy or by a draw that writes each texel's depth (the same
  // texels either way), or from the toroidal grid itself, in place, through a window offset and
  // repeat addressing (pcf.glsl's windowed lookups: nothing written but what the cascades newly
  // reach and where moving casters were and are; EVSM2's moments are made through the windows
  // too). `automatic` reads in place: on an H100 writing depth that is not a raster's output
  // costs as much as drawing the casters, and on lavapipe the copies cost a walk 8 times what
  // drawing the strips does (docs/performance.md).
  enum class SunWindow { automatic, copy, draw, in_place };
  SunWindow sun_window = SunWindow::automatic;
  // Whether a sun cascade that moved by whole texels keeps what it holds and is drawn only where
  // it newly reaches (through the grid image), or is drawn whole into its map again. Scrolling
  // needs the cascade's window written into the map each frame it moved, unless it is read in
  // place: `automatic` scrolls where the sun is read in place, and through a copy on a CPU
  // device. The images are the same with the cache on and off either way.
  enum class Scroll { automatic, on, off };
  Scroll scroll_cascades = Scroll::automatic;
};

// Slots of read_visibility(): the sun, then the spot lights, then the point lights.
inline constexpr uint32_t kSunVisibilitySlot = 0;
inline constexpr uint32_t spot_visibility_slot(uint32_t spot) {
  return 1 + spot;
}
inline constexpr uint32_t point_visibility_slot(uint32_t point) {
  return 1 + kMaxSpotLights + point;
}
inline constexpr uint32_t kVisibilitySlots = 8;
static_assert(1 + kMaxSpotLights + kMaxPointLights <= kVisibilitySlots);

// The camera of the last frame as the GPU used it: the float matrices widened to double, and
// the render origin (the world position that camera-relative positions are relative to).
struct FrameCamera {
  glm::dmat4 view{1.0}, proj{1.0};
  glm::dvec3 origin{0.0};
  bool reverse_z = true;
};

// The last frame's depth + normal prepass, read back: depth as stored (D32), view-space unit
// normals in rgb with 1 in alpha for geometry (0: sky), row-major, top row first.
struct GBuffer {
  uint32_t width = 0, height = 0;
  std::vector<float> depth;
  std::vector<glm::vec4> normal_view;
  FrameCamera camera;
};

// What the shadow-map cache drew in the last frame (shadows.cache).
struct ShadowCacheStats {
  std::uint32_t layers = 0;        // map layers (cascades, spot maps, cube faces) in the frame
  std::uint32_t drawn = 0;         // drawn whole (every layer without the cache)
  std::uint32_t scrolled = 0;      // cascades moved by whole texels: only the new strips drawn
  std::uint32_t moving_drawn = 0;  // restored from the still casters, the moving drawn over
  std::uint64_t texels_drawn = 0;  // texels drawn: whole layers, strips, layers with moving casters
  // Caster triangles submitted to the maps (a layer's, a strip's or a rectangle's draws, each
  // whole where it is scissored): with the cache, only the clusters of a mesh that can reach.
  std::uint64_t triangles_drawn = 0;
};

struct PassTiming {
  std::string name;
  double gpu_ms = 0.0;  // from timestamp queries
};

// What the renderer built for a scene, one line per object ("pass sun-shadow: 4 cascades …").
struct BuildReport {
  std::vector<std::string> passes;     // names of the passes that record work
  std::vector<std::string> pipelines;  // pipeline names (with their shader variant defines)
  std::vector<std::string> images;     // render targets and shadow maps with sizes and formats
  // The frame graph's steps in the order they run, each with the images it reads and writes
  // ("shadow-resolve: reads depth (sampled), ...; writes shadow-info (storage write)").
  std::vector<std::string> graph;
  std::string to_string() const;
  bool has_pass(const std::string& name) const;
  bool has_pipeline(const std::string& name) const;
};

// What a reload did (the program registry's result): pipelines rebuilt, pipelines whose new
// sources failed (the last good pipeline keeps running), and the errors with file:line.
using ReloadResult = shader::ReloadResult;

class Renderer {
 public:
  Renderer(gpu::Context& ctx, const scene::Scene& scene, RendererOptions options = {});
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Records, submits and waits for one frame (prepare() first).
  void render(uint32_t frame_index = 0);
  // The same, calling while_gpu_busy right after the submit and then every couple of
  // milliseconds until the frame is done: it may start prepare_reload on another thread, and
  // must call nothing else of this renderer.
  void render(uint32_t frame_index, const std::function<void()>& while_gpu_busy);
  // Makes what the scene as it is now needs that the last frame did not: the resolves compile
  // only the filters the scene's lights use, so a filter changed through scene() compiles the
  // resolve again. Throws penumbra::Error (with file:line) when that does not compile; the
  // renderer is then as it was, and render() throws the same until the scene or the file changes.
  void prepare();
  // With shadows.temporal: the next frame starts the accumulation afresh (a camera cut). The
  // renderer does so itself on its first frame, after a reload that rebuilt a pipeline, and when
  // a parameter other than the camera, the sun's direction and temporal_weight changed.
  void reset_history();
  // The last frame's tonemapped image, RGBA8, row-major, top row first.
  std::vector<uint8_t> read_rgba8();
  // Raw shadow info of the last frame (visibility, cascade, penumbra, density), RGBA float.
  std::vector<float> read_shadow_info();
  // The last frame's G-buffer (depth + normals) and camera.
  GBuffer read_gbuffer();
  // One slot of the last frame's per-light visibility (width × height floats; 1 where the
  // slot's light does not exist). Throws unless RendererOptions::visibility_output was set.
  std::vector<float> read_visibility(uint32_t slot);
  // Every shadow map's texels as stored (the sun's cascades, the spot maps, the point cubes, in
  // that order; those the scene has), for checks that two renderers drew the same maps.
  std::vector<std::vector<std::byte>> read_shadow_maps();
  // Depth texels of one sun cascade's shadow map (resolution² floats); empty without a sun.
  std::vector<float> read_sun_shadow_map(uint32_t cascade);

  uint32_t width() const;
  uint32_t height() const;
  const BuildReport& built() const;
  const std::vector<PassTiming>& timings() const;
  // What the last frame drew into the shadow maps (all of them without shadows.cache).
  const ShadowCacheStats& shadow_cache_stats() const;

  void set_debug_view(scene::DebugView view);
  // The last frame's tonemapped image (RGBA8, the size above); after render() it is in
  // VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL (output_image().layout()) and the GPU is idle.
  const gpu::Image& output_image() const;

  // Hot reload: rebuilds exactly the pipelines whose shader sources or includes read one of
  // these files. A source that fails to compile leaves its pipeline as it was.
  ReloadResult reload(const std::vector<std::filesystem::path>& changed_files);
  // The same in two steps (shader::ProgramRegistry::prepare_reload): prepare_reload compiles and
  // makes the new pipelines and changes nothing, so it may run on another thread while render()
  // waits for the GPU (and nothing else is called); finish_reload swaps them in.
  shader::PreparedReload prepare_reload(
      const std::vector<std::filesystem::path>& changed_files) const;
  ReloadResult finish_reload(shader::PreparedReload prepared);
  // Every file the pipelines' shaders read (stage files and includes), weakly canonical.
  std::vector<std::filesystem::path> shader_files() const;
  // The pipelines that read `file` (directly or through includes).
  std::vector<std::string> pipelines_reading(const std::filesystem::path& file) const;
  scene::Scene& scene();  // parameters may be edited between frames (filter, biases, …)

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// Writes RGBA8 pixels as a PNG (stb_image_write); throws naming the path on failure.
void write_png(const std::filesystem::path& path, uint32_t width, uint32_t height,
               const std::vector<uint8_t>& rgba);

}  // namespace penumbra::render
