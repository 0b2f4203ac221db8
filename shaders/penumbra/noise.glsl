// Noise and sample sets for shadow filtering: interleaved gradient noise (spatial and temporal),
// golden-ratio temporal offsets, 2D rotation, and Vogel (golden-angle spiral) and Poisson disk
// sample sets inside the unit disk. Every function is pure. No #version here: include it from a
// file that has one.

#ifndef PENUMBRA_NOISE_GLSL
#define PENUMBRA_NOISE_GLSL

#include "penumbra/common.glsl"

// Interleaved gradient noise, J. Jimenez, "Next Generation Post Processing in Call of Duty:
// Advanced Warfare", SIGGRAPH 2014 Advances in Real-Time Rendering: the published constants.
const vec3 kIgnMagic = vec3(0.06711056, 0.00583715, 52.9829189);

// Temporal IGN: shift the pixel by 5.588238 pixels per frame on both axes, with the frame index
// taken modulo 64 (A. Wolfe, "Interleaved Gradient Noise: A Different Kind of Low Discrepancy
// Sequence", blog.demofox.org, 2022). Wrapping keeps the shifted pixel small, so the noise is as
// precise at frame 4e9 as at frame 0.
const float kIgnFrameOffset = 5.588238;
const uint kIgnFramePeriod = 64u;

// floor(2^64 * (sqrt(5) - 1) / 2) = 0x9E3779B97F4A7C15, the fractional part of the golden ratio
// in 64-bit fixed point (Knuth's Fibonacci-hashing constant), split into 32-bit halves.
const uint kGoldenRatioFractHi = 0x9E3779B9u;
const uint kGoldenRatioFractLo = 0x7F4A7C15u;

// Interleaved gradient noise at `pixel` (window coordinates, e.g. integer + 0.5 pixel centres):
// fract(52.9829189 * fract(0.06711056 * x + 0.00583715 * y)), in [0, 1) for every finite pixel.
// Evaluated without fused multiply-adds (`precise`), so devices that round to nearest even (IEEE
// 754's default; lavapipe and NVIDIA do) return the same bits. A non-finite pixel gives 0 (where
// the driver keeps NaN semantics, which Vulkan does not require by default).
float interleaved_gradient_noise(vec2 pixel) {
  precise float inner = kIgnMagic.x * pixel.x + kIgnMagic.y * pixel.y;
  precise float outer = kIgnMagic.z * fract(inner);
  // fract(outer) = outer - floor(outer) is exact and < 1 for a finite outer >= 0; the comparison
  // maps NaN (from an infinite pixel) to 0.
  float noise = fract(outer);
  return (noise >= 0.0 && noise < 1.0) ? noise : 0.0;
}

// Interleaved gradient noise at `pixel` shifted by 5.588238 * (frame % 64) pixels on both axes:
// a different low-discrepancy pattern each frame, repeating every 64 frames, in [0, 1).
float interleaved_gradient_noise_temporal(vec2 pixel, uint frame) {
  precise vec2 shifted = pixel + kIgnFrameOffset * float(frame % kIgnFramePeriod);
  return interleaved_gradient_noise(shifted);
}

// fract(frame * (sqrt(5) - 1) / 2): the golden-ratio (additive recurrence) offset of a frame, in
// [0, 1), within 2^-24 of the exact value for every uint frame. Computed in 64-bit fixed point
// with integer arithmetic (float(frame) * 0.618034 would lose all precision past ~2^24 frames);
// the result is truncated to a multiple of 2^-24.
float golden_ratio_offset(uint frame) {
  uint carry = 0u, low = 0u;
  umulExtended(frame, kGoldenRatioFractLo, carry, low);
  // Bits 32..63 of frame * 0x9E3779B97F4A7C15 (mod 2^64): the fraction's top 32 bits.
  uint fraction = frame * kGoldenRatioFractHi + carry;
  return float(fraction >> 8u) * (1.0 / 16777216.0);  // exact: a 24-bit integer times 2^-24
}

// `angle` (radians) reduced to [-pi, pi] (up to float rounding), where GPU sin and cos keep their
// stated precision: Vulkan guarantees an absolute error <= 2^-11 only inside [-pi, pi]. Reduced in
// turns, so it adds about |angle| * 2^-23 of error and never overflows: any finite angle gives a
// finite result (0 once |angle| / (2 pi) > 2^23, where the angle's own ulp reaches a turn); a
// non-finite angle gives NaN.
float wrap_angle(float angle) {
  float turns = angle * kInvTwoPi;
  return kTwoPi * (turns - round(turns));  // the difference is exact
}

// v rotated counterclockwise by `angle` radians (x towards y).
vec2 rotate2(vec2 v, float angle) {
  float a = wrap_angle(angle);
  float c = cos(a);
  float s = sin(a);
  return vec2(c * v.x - s * v.y, s * v.x + c * v.y);
}

// v rotated counterclockwise by the angle whose cosine and sine are cos_sin.x and cos_sin.y: for
// loops that rotate many samples by one angle (compute vec2(cos(a), sin(a)) once).
vec2 rotate2_cos_sin(vec2 v, vec2 cos_sin) {
  return vec2(cos_sin.x * v.x - cos_sin.y * v.y, cos_sin.y * v.x + cos_sin.x * v.y);
}

// Sample `index` of a `count`-sample Vogel disk (golden-angle spiral): radius
// sqrt((index + 0.5) / count) < 1 (for count <= 2^23, where index + 0.5 is exact), angle
// index * pi * (3 - sqrt(5)) + rotation (radians). The index is clamped to [0, count - 1]; a count
// below 1 counts as 1.
vec2 vogel_disk_sample(int index, int count, float rotation) {
  int n = max(count, 1);
  int i = clamp(index, 0, n - 1);
  float radius = sqrt((float(i) + 0.5) / float(n));
  // i * golden angle = i * 2 pi * (1 - 1 / phi) == -2 pi * fract(i / phi) (mod 2 pi), and
  // golden_ratio_offset gives that fraction to 2^-24 for any index; the sum is reduced in turns.
  float turns = rotation * kInvTwoPi - golden_ratio_offset(uint(i));
  float angle = kTwoPi * (turns - round(turns));
  return radius * vec2(cos(angle), sin(angle));
}

// 32 points inside the unit disk with pairwise distance >= 0.31 (every point's length <= 1 - 1e-6).
// Generated offline by dart throwing: candidates uniform in [-1, 1]^2 from std::mt19937_64 with
// seed 348 (53-bit doubles: (u >> 11) * 2^-53 * 2 - 1 for x, then y), kept when inside the disk
// of radius 1 - 1e-6 and at least 0.31 + 1e-6 from every kept point, until 32 are kept;
// shader_tests/reference/noise_ref.hpp regenerates it (the tests check it matches). The set is in
// the order the darts landed; the first k entries are also a Poisson set with the same distance.
// clang-format off
const vec2 kPoissonDisk32[32] = vec2[32](
    vec2(-0.24324891, -0.5163638),
    vec2(0.217527896, 0.689635873),
    vec2(-0.454413712, 0.72038722),
    vec2(0.333574951, 0.106647551),
    vec2(0.915057182, -0.354866892),
    vec2(-0.358326197, -0.0368152447),
    vec2(-0.109739028, 0.161311343),
    vec2(0.207713291, -0.702049851),
    vec2(-0.743448973, 0.0943602324),
    vec2(0.941336095, 0.16235292),
    vec2(-0.80586046, -0.514257431),
    vec2(0.286584169, -0.396102011),
    vec2(0.718796253, -0.626525819),
    vec2(0.657977343, 0.72714597),
    vec2(0.598174572, -0.27687645),
    vec2(-0.562808752, 0.366837054),
    vec2(-0.223786533, 0.948261619),
    vec2(-0.17955327, 0.480840653),
    vec2(-0.299204677, -0.841353416),
    vec2(0.480153412, 0.390349209),
    vec2(-0.0301271882, -0.241787255),
    vec2(-0.94953078, -0.177124977),
    vec2(0.816645801, 0.457128048),
    vec2(-0.755800605, 0.628118455),
    vec2(0.489437848, -0.846900642),
    vec2(0.145499542, 0.372368544),
    vec2(-0.514725387, -0.326057822),
    vec2(0.642498195, 0.0301346593),
    vec2(0.0132346051, -0.960135996),
    vec2(-0.618964851, -0.785061777),
    vec2(0.10317158, 0.981111228),
    vec2(-0.924469173, 0.351849943)
);
// clang-format on

// Entry `index` of kPoissonDisk32 (the index is taken modulo 32).
vec2 poisson_disk_sample(int index) {
  return kPoissonDisk32[index & 31];
}

// Entry `index` of kPoissonDisk32 (modulo 32) rotated counterclockwise by `angle` radians.
vec2 rotated_poisson_sample(int index, float angle) {
  return rotate2(kPoissonDisk32[index & 31], angle);
}

#endif  // PENUMBRA_NOISE_GLSL
