#pragma once

// A scene becomes one frame's GPU data here, on the CPU and without a device: the camera-
// relative draws, the frame block, the sun's cascades and the spot and point shadow matrices.
// The renderer uploads what pack_frame returns; tests/render/frame_pack_tests.cpp checks it
// without a GPU.

#include <cstdint>
#include <optional>
#include <glm/glm.hpp>
#include <penumbra/render/frame_types.hpp>
#include <penumbra/scene/filters.hpp>
#include <penumbra/scene/scene.hpp>
#include <penumbra/shadow/cascades.hpp>
#include <penumbra/shadow/gpu_types.hpp>
#include <penumbra/shadow/local_lights.hpp>
#include <vector>

namespace penumbra::render {

// What the device and the built passes decide about a frame.
struct FrameCaps {
  bool depth_clamp = true;    // the device clamps depth (shadow pancaking)
  bool contact_pass = false;  // the contact-shadow pass was built
  // Shadow maps actually allocated (the renderer's requirements).
  std::uint32_t spot_shadow_maps = 0;
  std::uint32_t point_shadow_cubes = 0;
  bool sun_shadows = false;
  bool sun_moments = false;  // the evsm pass was built (filter = evsm2 is honoured)
  bool point_moments = false;  // the point cubes' evsm pass was built (a point's own evsm2)
  bool spot_moments = false;   // the spot maps' evsm pass was built (a spot's own evsm2)
  std::uint32_t sun_layers = 8;  // layers of the sun's map (cascades or clipmap levels)
};

// One instance, ready to draw: its mesh and push constants (model relative to the origin).
struct Draw {
  std::uint32_t mesh = 0;
  DrawPush push{};
  bool masked = false;
  bool casts = true;    // a shadow caster (the prepass marks it for the contact pass)
  bool in_maps = true;  // drawn into the shadow maps (not an analytic sphere)
  std::uint32_t mask_texture = 0;  // pushed in index.w: its slot in Scene::mask_images()
  glm::dmat4 world{1.0};  // object -> world, unrebased (the shadow maps rebase it on their own)
  bool moves = false;     // the instance has a Motion (drawn over the maps' still copies)
};

struct PackedFrame {
  glm::dvec3 origin{0.0};  // the render origin (the camera position), in world space
  FrameGpu frame{};
  std::vector<Draw> draws;
  // The sun (valid when FrameCaps::sun_shadows).
  shadow::CascadeSet cascades;
  shadow::ShadowGpu shadow{};
  // kMaxSpotLights / kMaxPointLights entries; the first spot_shadows.size() are used.
  std::vector<shadow::SpotShadow> spot_shadows;
  std::vector<shadow::SpotShadowGpu> spot_gpu;
  std::vector<shadow::PointShadow> point_shadows;
  std::vector<shadow::PointShadowGpu> point_gpu;
  // The analytic spheres (Scene::analytic_spheres), centres relative to the origin; the resolves
  // read them as PENUMBRA_ANALYTIC_SPHERES vec4s.
  std::vector<glm::vec4> analytic_spheres;
};

// The camera of the shadow math (double precision, world space) for an image of width x height,
// at frame `frame` of its walk (scene::Camera::at).
shadow::Camera frame_camera(const scene::Scene& scene, std::uint32_t width, std::uint32_t height,
                            std::uint32_t frame = 0);

// Reverse-Z (or standard) perspective, Vulkan clip z in [0, 1], y flipped so +Y is up on screen.
glm::mat4 camera_projection(const scene::Camera& camera, double aspect, bool reverse_z);

// The light that contact shadows follow: the sun when the scene has one, else its first spot
// light, else its first point light. Returns its visibility slot (0 the sun, 1 + i spot i,
// 1 + kMaxSpotLights + i point i, as the forward pass numbers them), or -1 without any light.
int primary_light_slot(const scene::Scene& scene);

// The shader's filter constant (kFilterHard ...) of a scene filter: scene::filter_index
// (filters.hpp), its row in the filter table.
// The sun's filter as the frame carries it (FrameGpu::mode.z): the scene's, except that a filter
// without its moments (a renderer built for another filter) resolves as its fallback (evsm2:
// pcf).
std::uint32_t sun_filter_index(const scene::Scene& scene, bool sun_moments);
// The filter a spot or point light (`kind`) is resolved with: its own (`own`; one that needs
// moments without them, `moments`, or that its maps cannot take resolves as its fallback), else
// the scene's as the frame carries it (sun_filter_index), or its fallback where the light cannot
// use it.
std::uint32_t local_filter_index(const scene::Scene& scene, std::optional<scene::Filter> own,
                                 scene::LightKind kind, bool moments, bool sun_moments);

// Everything the GPU reads for frame `frame_index` of `scene` at width x height: the camera at
// that frame of its walk; the instances as the scene is posed (Scene::pose).
PackedFrame pack_frame(const scene::Scene& scene, std::uint32_t width, std::uint32_t height,
                       const FrameCaps& caps, std::uint32_t frame_index);

}  // namespace penumbra::render
