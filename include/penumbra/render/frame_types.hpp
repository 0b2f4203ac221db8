#pragma once

// GPU structs of the renderer, declared once here and mirrored in
// shaders/penumbra/frame_types.glsl; tests/render checks every member against SPIR-V reflection.
// Only mat4 / vec4 / uvec4 members, so std140 and std430 agree with the C++ layout.
// Positions are relative to the render origin (the camera), like the shadow structs.

#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <penumbra/scene/scene.hpp>

namespace penumbra::render {

inline constexpr uint32_t kMaxSpotLights = 2;
inline constexpr uint32_t kMaxPointLights = 2;
static_assert(kMaxSpotLights == scene::kMaxSpotLights && kMaxPointLights == scene::kMaxPointLights,
              "the scene reader's light limits are the renderer's");

struct alignas(16) LightGpu {
  glm::vec4 position_range;   // xyz relative to the render origin; w: range (m)
  glm::vec4 direction_cos;    // spot: xyz axis (unit), w: cos(outer); point: 0
  glm::vec4 color_intensity;  // rgb, w: intensity
  // x: cos(inner) (spot), y: shadow map index or -1, z: radius (m), w: the light's own filter
  // (filter_index) or -1 for the scene's
  glm::vec4 params;
};
static_assert(sizeof(LightGpu) == 64);

// The EVSM exponent limits of shaders/penumbra/vsm.glsl (kEvsmMaxExponentFp16 / Fp32).
inline constexpr float kEvsmMaxExponentFp16 = 5.54f;
inline constexpr float kEvsmMaxExponentFp32 = 42.0f;

struct alignas(16) FrameGpu {
  glm::mat4 view;  // (world - origin) -> view
  glm::mat4 proj;  // view -> clip (reverse-Z when counts.y == 1)
  glm::mat4 view_proj;
  glm::mat4 inv_view_proj;    // clip -> (world - origin)
  glm::vec4 camera_position;  // relative to the origin (0 for a camera-centred origin), w = 1
  glm::vec4 camera_forward;   // unit, w = 0
  glm::vec4 sun_direction;    // xyz unit *towards* the sun, w: intensity (0: no sun)
  glm::vec4 sun_color;        // rgb, w: 1 when the sun casts shadows
  glm::vec4 ambient;          // rgb sky ambient, w: exposure
  glm::vec4 viewport;         // width, height, 1 / width, 1 / height
  glm::vec4 projection;       // near, far, tan(fov_y / 2), aspect
  // World-unit biases (shaders/penumbra/bias.glsl): x normal offset (texels at the receiver),
  // y slope bias (texels), z constant bias (metres along the light), w slope bound (texels)
  glm::vec4 bias;
  glm::vec4 filter_params;  // x: PCF radius, y: PCSS tier, z: Poisson taps, w: Poisson radius
  // x: frame index; y: depth convention (1 reverse-Z); z: filter (0 hard, 1 pcf, 2 pcss,
  // 3 poisson, 4 evsm2: the sun only, and only when the moments are built); w: debug view (0 lit, 1 shadow factor, 2 cascades, 3 contact mask, 4 texel
  // density, 5 penumbra)
  glm::uvec4 mode;
  // x: spot lights, y: point lights, z: contact pass (0/1), w: the visibility slot the contact
  // mask darkens (primary_light_slot: 0 sun, 1 + i spot i, 1 + kMaxSpotLights + i point i)
  glm::uvec4 counts;
  LightGpu spots[kMaxSpotLights];
  LightGpu points[kMaxPointLights];
  // x: confidence fraction (blocker-search taps that must hit); y, z, w: the local lights' PCSS
  // search radius, minimum and maximum filter radius (texels)
  glm::vec4 pcss;
  // x: 1 when PCF and Poisson keep their width in world units across cascades
  // (shadows.constant_filter_width), else 0; y: the evsm2 blur radius in texels
  // (shadows.evsm_blur); z, w: 0
  glm::vec4 filter_world;
  // filter = evsm2 (the sun): x the exponent c, clamped for the moment format; y the minimum
  // variance (depth units squared); z light-bleed reduction; w 1 when the moments are fp16
  glm::vec4 evsm;
};

static_assert(offsetof(FrameGpu, view) == 0);
static_assert(offsetof(FrameGpu, proj) == 64);
static_assert(offsetof(FrameGpu, view_proj) == 128);
static_assert(offsetof(FrameGpu, inv_view_proj) == 192);
static_assert(offsetof(FrameGpu, camera_position) == 256);
static_assert(offsetof(FrameGpu, mode) == 400);
static_assert(offsetof(FrameGpu, counts) == 416);
static_assert(offsetof(FrameGpu, spots) == 432);
static_assert(offsetof(FrameGpu, points) == 560);
static_assert(offsetof(FrameGpu, pcss) == 688);
static_assert(offsetof(FrameGpu, filter_world) == 704);
static_assert(offsetof(FrameGpu, evsm) == 720);
static_assert(sizeof(FrameGpu) == 736);

// The shadow-temporal pass's block (shaders/render/shadow_temporal.comp): how this frame's
// pixels find the last frame's.
struct alignas(16) TemporalGpu {
  glm::mat4 to_previous_view;  // this frame's (world - origin) -> the last frame's view space
  glm::mat4 previous_proj;     // the last frame's view -> clip
  // x: the new frame's share (shadows.temporal_weight); y: 1 when the history is usable
  // (0: the first frame, or after a reset); z, w: a reprojected point is on the same surface
  // when the last frame's distance there is within z x its distance + w metres
  glm::vec4 params;
};
static_assert(offsetof(TemporalGpu, previous_proj) == 64);
static_assert(offsetof(TemporalGpu, params) == 128);
static_assert(sizeof(TemporalGpu) == 144);
// TemporalGpu::params.zw: a reprojected point is on the last frame's surface within 2% of its
// distance plus 2 mm (the flicker measure's reprojection uses the same bound).
inline constexpr float kTemporalSurfaceFraction = 0.02f;
inline constexpr float kTemporalSurfaceConstant = 0.002f;

// Push constants of every geometry pass.
struct alignas(16) DrawPush {
  glm::mat4 model;   // object -> (world - origin)
  glm::vec4 albedo;  // rgb, w: 1 opaque / 0 masked
  glm::vec4 mask;    // x: MaskPattern, y: alpha cutoff, zw: mask scale
  // x: cascade layer / cube face / spot index, y: light index, z: 1 when the instance casts
  // shadows (draw_meshes sets it)
  glm::uvec4 index;
};
static_assert(sizeof(DrawPush) == 112);
static_assert(offsetof(DrawPush, albedo) == 64);
static_assert(offsetof(DrawPush, mask) == 80);
static_assert(offsetof(DrawPush, index) == 96);

}  // namespace penumbra::render
