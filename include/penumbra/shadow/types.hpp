#pragma once

// Plain value types shared by the shadow math: depth convention, camera, lights, bounds.
// Every length is in metres (world units), every angle in radians. World space is right-handed
// with +Y up (the basis code puts its only discontinuity at the horizon, see math.hpp).

#include <cstdint>
#include <glm/glm.hpp>
#include <penumbra/core/depth.hpp>

namespace penumbra::shadow {

// The maximum number of cascades (or clipmap levels) of one directional light.
inline constexpr std::uint32_t kMaxCascades = 8;

// The filters' limits, as pcf.glsl declares them (kPcfMaxRadius, kPcfMaxPoissonTaps): the
// parameter table's ranges and the host's filter arithmetic use these; shader_tests/pcf_tests
// checks them against the GLSL's own constants.
inline constexpr int kPcfMaxRadius = 5;
inline constexpr int kPcfMaxPoissonTaps = 32;

// How a [near, far] range maps to Vulkan's [0, 1] depth (penumbra/core/depth.hpp).
using DepthConvention = penumbra::DepthConvention;

// An axis-aligned box in world space. Valid boxes are finite with min <= max on every axis and
// a positive extent on at least one axis (a flat ground plane is a valid scene).
struct Aabb {
  glm::dvec3 min{0.0};
  glm::dvec3 max{0.0};
};

// The viewing camera. Only position, the two direction vectors and the frustum parameters are
// used; forward and up need not be unit length but must not be parallel.
struct Camera {
  glm::dvec3 position{0.0};
  glm::dvec3 forward{0.0, 0.0, -1.0};
  glm::dvec3 up{0.0, 1.0, 0.0};
  // Full vertical field of view, in (0, pi).
  double fov_y = 1.0471975511965976;  // 60 degrees
  // Width / height, > 0.
  double aspect = 16.0 / 9.0;
  // View distances along forward (view-space depth, positive), 0 < near < far. far may be
  // +infinity (an infinite reverse-Z camera); shadows end at ShadowConfig.max_distance anyway.
  double near = 0.1;
  double far = 1000.0;
};

// A directional light (the sun, a star far away).
struct DirectionalLight {
  // The direction the light travels (from the light into the scene); need not be unit length,
  // must be finite and non-zero. Default: straight down.
  glm::dvec3 direction{0.0, -1.0, 0.0};
  // Angular diameter of the light's disc as seen from the scene, in [0, pi/2). The sun: 0.0093.
  // 0 gives hard shadows (PCSS degenerates to PCF with the minimum filter).
  double angular_diameter = 0.0093;
};

}  // namespace penumbra::shadow
