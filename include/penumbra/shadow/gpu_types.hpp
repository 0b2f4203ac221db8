#pragma once

// GPU structs of the shadow system, declared once here and mirrored member for member in
// shaders/penumbra/shadow_types.glsl. Only mat4 / vec4 / uvec4 members (and arrays of them or
// of 16-byte-multiple structs), so the std140 and std430 layouts are identical and equal to the
// C++ layout below; tests/shadow/gpu_layout_tests.cpp checks every offset and size against
// SPIR-V reflection of the GLSL block in both layouts.
//
// All matrices are column-major and take positions *relative to the render origin* passed to
// the pack functions (pack.hpp): clip = view_proj * vec4(p_world - render_origin, 1). With
// camera-relative rendering (render origin = the camera, or any point near it) the float data
// stays precise kilometres from the world origin.

#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <penumbra/shadow/types.hpp>

namespace penumbra::shadow {

// One cascade or clipmap level.
struct alignas(16) CascadeGpu {
  glm::mat4 view_proj;  // (world - render_origin) -> clip; uv = ndc.xy * 0.5 + 0.5
  // x: world size of one texel (normal-offset bias, PCSS filter size in texels)
  // y, z: the depth range [near, far] as distances along the light's travel direction,
  //       measured from the render origin: with s = dot(-light_dir_angular.xyz, p_rel),
  //       standard depth = (s - y) / (z - y), reverse-Z depth = (z - s) / (z - y); a depth
  //       difference times (z - y) is a world distance
  // w: world width of the cascade (resolution * x)
  glm::vec4 params;
};

// Directional light: cascades or clipmap levels plus everything the resolve needs.
struct alignas(16) ShadowGpu {
  CascadeGpu cascades[kMaxCascades];  // [0, counts.x) valid
  // Cascades (counts.w == 0): splits[i / 4][i % 4] = far view distance of cascade i (the
  // view distance is dot(p - camera_position.xyz, camera_forward.xyz)); unused entries repeat
  // the last. Clipmap (counts.w == 1): the light-space radius around the camera that level i
  // is guaranteed to cover.
  glm::vec4 splits[kMaxCascades / 4];
  // xyz: unit direction *towards* the light (= -travel direction); w: angular diameter (rad).
  glm::vec4 light_dir_angular;
  // x: tan(angular diameter / 2) (penumbra width = 2 x * (d_receiver - d_blocker))
  // y: blocker search half-width in texels; z: min filter radius in texels; w: max filter
  // radius in texels.
  glm::vec4 pcss;
  // x: camera near (first split); y: blend fraction; z: max shadow distance; w: fade fraction
  // (shadows fade to lit over [z * (1 - w), z]).
  glm::vec4 selection;
  glm::vec4 camera_position;  // xyz relative to the render origin, w = 1
  glm::vec4 camera_forward;   // xyz unit, w = 0
  // x: cascade/level count; y: DepthConvention (0 standard, 1 reverse-Z); z: resolution;
  // w: ShadowLayout (0 cascades by view distance, 1 clipmap by position).
  glm::uvec4 counts;
  // x: CascadeSelection (0 by view distance, 1 the finest cascade that holds the receiver);
  // y, z, w: 0.
  glm::uvec4 modes;
  // What the renderer's shadow-map cache drew of each cascade this frame, for the debug view
  // `redrawn` (the lookups never read it; 0 elsewhere): x the kRedrawn* bits; y, z the
  // cascade's move across its map since the last frame in texels (two's complement): with
  // kRedrawnStrips, the columns and rows that move brought in are the texels drawn.
  glm::uvec4 redrawn[kMaxCascades];
  // With kRedrawnMoving: the map texels (x0, y0, x1, y1) drawn again where moving casters were
  // or are (the whole cascade when x1 = 0; debug view, as redrawn).
  glm::uvec4 redrawn_rect[kMaxCascades];
  // Where each cascade's map lies on the image the lookups sample: xy the whole-texel offset of
  // its texel 0, z 1 when that image is the renderer's toroidal grid sampled in place (repeat
  // addressing; pcf.glsl's windowed lookups take this as their window), 0 when it is the map.
  glm::vec4 window[kMaxCascades];
};

// ShadowGpu::redrawn, SpotShadowGpu::info.z and PointShadowGpu::info.w (4 bits a face): what
// the shadow-map cache drew into a layer this frame. None: the layer was kept as it was.
inline constexpr std::uint32_t kRedrawnWhole = 1;   // drawn whole
inline constexpr std::uint32_t kRedrawnStrips = 2;  // drawn where it newly reaches (scrolled)
inline constexpr std::uint32_t kRedrawnMoving = 4;  // restored, moving casters drawn over

// What the sun's depth pass draws a cascade with (shaders/render/shadow_depth.vert): positions
// relative to the maps' anchor (not the render origin) go to texels of a grid fixed in light
// space, the same for every placement of the cascade on whole texels; the draw's push constant
// gives the grid texel that lands on window texel 0:
//   t = to_texels * vec4(p - anchor, 1)              (t.xy grid texels, t.z depth)
//   window xy = round(t.xy * 256) / 256 - offset     (exact: 1/256-texel steps, whole offsets)
//   ndc xy = window xy * scale.x - 1                 (scale.x = 2 / P, P a power of two)
// Every step is exact, so a grid texel drawn at the same window position is the same bit for
// bit whenever it is drawn: what lets the shadow-map cache draw a cascade that moved by whole
// texels only where it newly reaches (ShadowMapPass, the sun's grid image).
struct alignas(16) CascadeDrawGpu {
  glm::mat4 to_texels;
  glm::vec4 scale;  // x: 2 / P; y, z, w: 0
};

struct alignas(16) ShadowDrawGpu {
  CascadeDrawGpu cascades[kMaxCascades];
};

struct alignas(16) SpotShadowGpu {
  glm::mat4 view_proj;      // (world - render_origin) -> clip, perspective
  glm::vec4 position_near;  // xyz relative to the render origin; w: near plane
  glm::vec4 direction_far;  // xyz unit direction of the cone axis; w: far plane (range)
  // x: cos(outer angle); y: tan(outer angle) (= NDC 1); z: world texel size at distance 1
  // (2 tan / resolution); w: unused (0)
  glm::vec4 params;
  // x: resolution; y: DepthConvention; z: kRedrawn* bits of this frame (debug view); w: 0
  glm::uvec4 info;
};

struct alignas(16) PointShadowGpu {
  glm::mat4 face_view_proj[6];  // Vulkan cube face order +X, -X, +Y, -Y, +Z, -Z
  glm::vec4 position;           // xyz relative to the render origin, w = 1
  // x: depth_near, y: depth_far, z: 1 / (depth_far - depth_near), w: clip near. Stored depth
  // t = clamp((length(p - position.xyz) - x) * z, 0, 1), 1 - t under reverse-Z.
  glm::vec4 depth_range;
  // x: face mask; y: DepthConvention; z: resolution; w: kRedrawn* bits of this frame, face f
  // at bits 4f..4f+3 (debug view)
  glm::uvec4 info;
};

static_assert(sizeof(glm::mat4) == 64 && sizeof(glm::vec4) == 16 && sizeof(glm::uvec4) == 16);

static_assert(offsetof(CascadeGpu, view_proj) == 0);
static_assert(offsetof(CascadeGpu, params) == 64);
static_assert(sizeof(CascadeGpu) == 80);
static_assert(alignof(CascadeGpu) == 16);

static_assert(offsetof(ShadowGpu, cascades) == 0);
static_assert(offsetof(ShadowGpu, splits) == 640);
static_assert(offsetof(ShadowGpu, light_dir_angular) == 672);
static_assert(offsetof(ShadowGpu, pcss) == 688);
static_assert(offsetof(ShadowGpu, selection) == 704);
static_assert(offsetof(ShadowGpu, camera_position) == 720);
static_assert(offsetof(ShadowGpu, camera_forward) == 736);
static_assert(offsetof(ShadowGpu, counts) == 752);
static_assert(offsetof(ShadowGpu, modes) == 768);
static_assert(offsetof(ShadowGpu, redrawn) == 784);
static_assert(offsetof(ShadowGpu, redrawn_rect) == 912);
static_assert(offsetof(ShadowGpu, window) == 1040);
static_assert(sizeof(ShadowGpu) == 1168);

static_assert(offsetof(SpotShadowGpu, view_proj) == 0);
static_assert(offsetof(SpotShadowGpu, position_near) == 64);
static_assert(offsetof(SpotShadowGpu, direction_far) == 80);
static_assert(offsetof(SpotShadowGpu, params) == 96);
static_assert(offsetof(SpotShadowGpu, info) == 112);
static_assert(sizeof(SpotShadowGpu) == 128);

static_assert(offsetof(PointShadowGpu, face_view_proj) == 0);
static_assert(offsetof(PointShadowGpu, position) == 384);
static_assert(offsetof(PointShadowGpu, depth_range) == 400);
static_assert(offsetof(PointShadowGpu, info) == 416);
static_assert(sizeof(PointShadowGpu) == 432);

}  // namespace penumbra::shadow
