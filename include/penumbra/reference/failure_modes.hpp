#pragma once

// The ways a shadow map fails, told apart (pure C++ and Embree, no GPU). metrics.hpp's false
// shadow mixes self-shadowing acne with a filter's blur near real shadow edges, and its false
// light mixes light leaking into a shadow with the lit gap between a caster and the shadow it
// casts (peter-panning); the same bias knobs trade the two against each other, so they are
// measured apart here:
//
//   acne        false shadow (V < 1 - t) on receivers the truth lights fully (R = 1) and where
//               no caster lies within the filter's reach: a caster occludes the light's centre
//               neither from the receiver nor from any point of a ring of radius `reach` (the
//               filter's reach in world units at that receiver, in the plane across the light)
//               carried onto the receiver's tangent plane. A fraction of those receivers.
//   contact gap where the truth's shadow touches its caster: receivers in the truth's umbra
//               (R < 0.5) whose distance along the surface from where the caster meets it
//               (blocker distance d along the ray to the light's centre, times the length of
//               that ray's component along the surface: exact for a caster standing on the
//               receiver) is under max_contact_texels texels of the light's map there. The gap
//               is the ones the GPU lights (V >= 0.5) that are connected, through such lit
//               receivers (4-neighbours in the image), to one within seed_texels of the contact;
//               its width is how far from the contact they reach: the 95th percentile of their
//               distances, in texels and in metres (and the largest, apart), and the same
//               across the light, in the map's plane (contact_gap_map_texels).
//               Lit speckles off the contact are not the gap (they are leaks, below).
//   leak        false light (V > R + t) outside the gap on receivers the truth puts in full
//               shadow (R = 0) with the light's centre hidden from every point of the same ring
//               (no shadow edge within the filter's reach): a fraction of the light's lit
//               receivers (as false light is).
//
// Receivers are the GPU's own (the G-buffer), so a contact the camera does not see has no gap
// (NaN), and a caster the camera does not see still counts in the truth.

#include <cstdint>
#include <limits>
#include <penumbra/reference/metrics.hpp>
#include <penumbra/reference/reference.hpp>
#include <span>
#include <string>
#include <vector>

namespace penumbra::reference {

// What the truth says about the casters near each receiver (Tracer::blocked rays to the light's
// centre; the area light's extent is the reference's business).
struct CasterProbe {
  // From the receiver (offset along its normal by ray_offset) to the first caster on the ray to
  // the light's centre, metres; +inf where the centre is visible; NaN where not probed (a
  // receiver not valid, or inside a sphere light).
  std::vector<float> blocker_distance;
  // 1 where a caster occludes the light's centre from the receiver or from any point of the
  // ring of radius reach[i] carried onto its tangent plane (see the top of this file).
  std::vector<uint8_t> caster_in_reach;
  // 1 where the light's centre is visible from the receiver or from any point of that ring.
  std::vector<uint8_t> light_in_reach;
  // The distance along the surface from the receiver to where its blocker meets it (see the
  // contact gap above), metres; +inf without a blocker, NaN where not probed.
  std::vector<float> contact_distance;
  // The cosine between the receiver's normal (turned towards the light) and the ray to the
  // light's centre; NaN where not probed. A distance x along the surface towards the contact is
  // x * light_cosine across the light, in the plane of the light's map.
  std::vector<float> light_cosine;
};

// reach: per receiver, the filter's reach in world units (0 probes the centre ray only; NaN
// or negative is treated as 0). ring: points on the ring (>= 3).
CasterProbe probe_casters(const Tracer& tracer, const Receivers& receivers, const AreaLight& light,
                          std::span<const float> reach, uint32_t ring = 8, uint32_t threads = 0);

struct FailureModeOptions {
  double threshold = 0.1;          // t, as MetricsOptions::threshold
  double max_contact_texels = 64;  // umbra receivers farther from a contact are not its gap
  double seed_texels = 1.0;        // a lit receiver this near a contact starts the gap
};

struct FailureModes {
  uint64_t clear_receivers = 0;  // lit receivers with R = 1 and no caster within reach
  uint64_t acne_receivers = 0;   // of those, with V < 1 - t
  double acne = 0.0;             // acne_receivers / clear_receivers (0 when none)
  uint64_t leak_receivers = 0;
  double leak = 0.0;               // leak_receivers / the light's lit receivers
  uint64_t contact_receivers = 0;  // umbra receivers within max_contact_texels of a contact
  uint64_t gap_receivers = 0;      // of those, the gap's
  // The gap's width from the contact: 0 when the shadow starts at the contact, NaN when no
  // contact is seen (no umbra receiver within max_contact_texels of one).
  double contact_gap_texels = std::numeric_limits<double>::quiet_NaN();
  double contact_gap_world = std::numeric_limits<double>::quiet_NaN();
  double contact_gap_max_texels = std::numeric_limits<double>::quiet_NaN();
  // The same gap as the light's map sees it: the 95th percentile of the gap receivers' distances
  // from the contact projected across the light (along the surface times light_cosine), in
  // texels. A map resolves its shadow's edge to about a texel in its own plane; on a receiver
  // the light grazes, that texel is 1 / light_cosine texels long along the surface.
  double contact_gap_map_texels = std::numeric_limits<double>::quiet_NaN();
  std::string to_json() const;  // the members above as JSON fields (no braces)
};

// Per receiver what failed (for the image and tests).
enum class FailureMode : uint8_t { none = 0, acne = 1, leak = 2, gap = 3 };

// v: the GPU's visibility; reference, classes as compute_metrics takes them; texel_world: per
// receiver, the world size of one texel of this light's map there (NaN where unknown: those
// receivers are left out of the contact gap); image_width: the receivers' rows (0: one row).
// modes (optional) receives each receiver's mode.
FailureModes compute_failure_modes(std::span<const float> v, const Visibility& reference,
                                   std::span<const ReceiverClass> classes, const CasterProbe& probe,
                                   std::span<const float> texel_world, uint32_t image_width,
                                   const FailureModeOptions& options = {},
                                   std::vector<FailureMode>* modes = nullptr);

// Over a grey copy of the frame: acne magenta, leaks red, the contact gap yellow.
std::vector<uint8_t> failure_mode_image(std::span<const FailureMode> modes,
                                        std::span<const uint8_t> frame_rgba);

}  // namespace penumbra::reference
