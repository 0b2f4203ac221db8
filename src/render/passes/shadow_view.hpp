// The shadow-map pass's views and their frame plans (shadow_maps.cpp builds them,
// shadow_plan.cpp plans a frame, shadow_steps.cpp records it; shadow_sun_view.cpp is the sun's).
#pragma once

#include <cstring>
#include <functional>

#include "passes.hpp"

namespace penumbra::render::passes {

// A view's draw block for a frame: its bytes, an anchor per light, a grid window per layer.
struct ViewDraw {
  std::vector<std::byte> bytes;
  std::vector<glm::dvec3> anchors;
  std::vector<glm::ivec2> windows;
};

struct ShadowMapPass::View {
  std::string name;   // the timestamp ("sun-shadow")
  std::string image;  // the target's name in the build report ("sun-shadow-map")
  gpu::Image* target = nullptr;
  std::function<uint32_t(const PackedFrame&)> layers;
  std::function<glm::uvec4(uint32_t)> index;
  // Whether layer l is drawn this frame (a fitted point light draws only the faces that see
  // what the camera sees; the others are cleared to the far depth: lit). Unset: every layer.
  std::function<bool(const PackedFrame&, uint32_t)> draws;
  std::unique_ptr<gpu::PipelineLayout> layout;
  std::unique_ptr<gpu::GraphicsPipeline> opaque, masked;
  VkDescriptorSet set = VK_NULL_HANDLE;
  bool caster_bias = true;  // dynamic depth bias on the casters (not the point cubes)

  // The maps' own matrices: the draw UBO's bytes for this frame's anchors (one per slot: the
  // sun's one, a spot or point light's own) and each layer's window on its grid (the sun's
  // cascades; the others 0); a layer's slot, the UBO bytes its texels depend on, and whether
  // bounds b reach a texel rectangle [lo, hi) of it (conservatively: a caster outside cannot
  // touch those texels; the sun's rectangle in grid texels, the others' ignored).
  using Packed = ViewDraw;
  gpu::Buffer draw_ubo;
  std::function<Packed(const PackedFrame&)> pack;
  std::function<uint32_t(uint32_t)> slot;
  std::function<std::pair<size_t, size_t>(uint32_t)> span;
  std::function<bool(const PackedFrame&, uint32_t, glm::ivec2, glm::ivec2, const scene::Bounds&)>
      touches;
  uint32_t viewport = 0;  // the sun: the grid draws' viewport side P; 0: the map's side
  bool scroll = false;    // the sun: cascades scroll through the grid image (Scroll)
  // The sun: the resolves read the grid in place (SunWindow::in_place): the target is the grid,
  // there is no map written from it.
  bool in_place = false;
  // The sun: each cascade's grid start, kept while the rest of its grid (texel size, depth
  // range, light, anchor) stays as it was, so a full draw after such a change starts the grid
  // at the cascade's first texel (one rectangle, not four).
  std::vector<glm::dvec2> starts;
  std::vector<uint64_t> grid_key;
  // The sun: the map drawn from the grid, a triangle per layer writing each texel's depth (on a
  // GPU; a CPU device copies: there a copy is a memcpy and a draw runs a shader per texel).
  bool window_by_draw = false;
  std::unique_ptr<gpu::PipelineLayout> window_layout;
  std::unique_ptr<gpu::GraphicsPipeline> window_pipeline;
  VkDescriptorSet window_set = VK_NULL_HANDLE;

  // The base image holds the still casters: the sun's grid, a spot or point view's still copy
  // (the cache with moving casters), else the map itself.
  gpu::Image base_image;
  std::string base_name;
  bool grid() const { return viewport != 0; }
  bool has_base() const { return base_image.handle() != VK_NULL_HANDLE; }
  gpu::Image& base() { return has_base() ? base_image : *target; }
  std::string base_label() const { return has_base() ? base_name : image; }
  bool moving = false;  // the scene has moving casters: drawn over the map, not into the base

  // This frame's plan, per layer.
  enum class Base : uint8_t { keep, draw, strips };
  std::vector<Base> base_plan;
  std::vector<std::vector<glm::ivec4>> strips;  // grid rectangles (x0, y0, x1, y1) newly reached
  std::vector<uint8_t> restore;  // the map copied from the base (and the moving drawn over)
  // Without a base (same_layout): per layer, the rectangles (x0, y0, x1, y1) drawn again this
  // frame where a moving caster was or is, and each moving caster where it reaches: its index,
  // its rectangle and the hash of how it is drawn.
  struct Reach {
    size_t caster;
    glm::ivec4 rect;
    uint64_t key;
  };
  std::vector<std::vector<glm::ivec4>> dirty;
  std::vector<std::vector<Reach>> reach;
  // The texels of layer l that bounds b can be drawn into (x0, y0, x1, y1): the sun's in grid
  // texels within the cascade's window, a spot map's or cube face's in its own.
  std::function<glm::ivec4(const PackedFrame&, uint32_t, const scene::Bounds&)> rect;
  // Whether the map is drawn as it is sampled, with no base (the sun read in place, a spot or
  // point view): moving casters are drawn again with the rest where they were and are.
  bool same_layout() const { return in_place || !grid(); }
  // The sun without moving casters: a cascade drawn whole while its window starts on a whole
  // map of the grid (w mod N = 0, as after every new grid) is drawn straight into the map, whose
  // layout is then the grid's (`direct`); the grid layer is left stale (`in_map`) until the
  // cascade scrolls, when the map is first copied back into it (`sync`). A still camera never
  // copies.
  std::vector<uint8_t> direct, sync, in_map;
  std::vector<uint64_t> base_key, map_key;
  // What was drawn of each layer (x kRedrawn* bits; y, z the sun's move in texels), for the
  // lookups' blocks and so the debug view `redrawn`.
  std::vector<glm::uvec4> redrawn;
  std::vector<glm::ivec2> base_window, window;
  std::vector<std::vector<glm::mat4>> models;  // per slot, per draw
  std::vector<scene::Bounds> bounds;           // per draw, this frame
};

constexpr VkImageUsageFlags kMapUsage =
    VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;

// FNV-1a over bytes.
struct Hash {
  uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
  }
  template <class T>
  void add(const T& v) {
    bytes(&v, sizeof(v));
  }
};

template <class T>
std::vector<std::byte> bytes_of(const std::vector<T>& v) {
  const auto b = std::as_bytes(std::span(v));
  return {b.begin(), b.end()};
}

std::unique_ptr<gpu::PipelineLayout> ubo_layout(FrameResources& r);
VkDescriptorSet ubo_set(FrameResources& r, const gpu::PipelineLayout& layout,
                        const gpu::Buffer& ubo);
// The depth-only caster pipelines of a light: opaque casters with no fragment stage, and (when
// the scene has masked materials) alpha-tested casters. Dynamic depth bias on both.
void add_caster_pipelines(FrameResources& r, const std::string& name, const std::string& vertex,
                          const gpu::PipelineLayout& layout,
                          std::unique_ptr<gpu::GraphicsPipeline>& opaque,
                          std::unique_ptr<gpu::GraphicsPipeline>& masked_out, bool depth_clamp);
// The sun's view: n cascades of res^2 drawn through the grid (shadow_sun_view.cpp).
void configure_sun_view(FrameResources& r, ShadowMapPass::View& v, gpu::Image& map, uint32_t n,
                        uint32_t res);

}  // namespace penumbra::render::passes
