// Analytic soft shadows of sphere occluders: the fraction of a sphere light (or of the sun's
// disc) that a sphere hides from a receiver, in closed form. Every function is pure: positions,
// radii and angles come in as arguments. No #version here: include this from a stage file.
//
// Conventions
// - Seen from the receiver, the light is a cap of half-angle a on the unit sphere of directions
//   (a sphere light of radius R at distance D: a = asin(R / D); the sun: half its angular
//   diameter) and the occluder a cap of half-angle b (a sphere of radius r at distance d:
//   asin(r / d); pi/2 for a receiver on or inside it, whose own horizon is then the occluder);
//   g is the angle between their centres.
// - The occlusion is the solid angle of the caps' intersection over the light cap's: the light is
//   sampled uniformly in solid angle, as the reference tracer (src/reference) samples it.
// - Two forms of the intersection. Spherical (a >= kSphereCapPlanarBelow): the great circle
//   through the two boundary crossings splits the lens into one segment of each cap, and a
//   segment is its cap's sector less the isosceles triangle at the cap's centre (spherical
//   excess). Every term is of the order of the segment's own cap, and the crossings' azimuths
//   (acos, the least accurate step on some drivers) enter only to second order. (The textbook
//   closed form sums terms of order pi whose difference is O(a^2): in fp32 on lavapipe it was off
//   by 0.013 at a = 0.1.) Planar (below): the lens of two circles of radii a and b at distance g,
//   scaled by a, also as two segments (half-angles from atan2 of the common chord, a series for
//   thin segments), so that it stays exact to rounding for any b / a; its error is the sphere's
//   curvature, O(a^2), except next to a horizon (b near pi/2), where the occluder's edge is a
//   great circle that the planar form bends with radius b: 0.0007 there at the switch.
// - Several occluders combine as a product of visibilities, 1 - occlusion each: overlapping
//   occluders (in the light's view) over-darken; the reference error says by how much.

#ifndef PENUMBRA_SPHERE_SHADOW_GLSL
#define PENUMBRA_SPHERE_SHADOW_GLSL

#include "penumbra/finite.glsl"

const float kSphereShadowPi = 3.14159265358979;
const float kSphereShadowHalfPi = 1.57079632679490;
// The light half-angle (radians) below which the occlusion uses the planar form (see the header).
const float kSphereCapPlanarBelow = 0.01;

// Returns theta - sin(theta) cos(theta) (the area of a unit circle's segment of half-angle
// theta), by its series below 0.1 where the difference cancels.
float sphere_segment_area(float theta) {
  if (theta < 0.1) {
    float t2 = theta * theta;
    return theta * t2 * (2.0 / 3.0 - t2 * (2.0 / 15.0 - t2 * (4.0 / 315.0)));
  }
  return theta - 0.5 * sin(2.0 * theta);
}

// Returns the fraction of a disc of radius a that a disc of radius b at distance g covers
// (planar), for g in (|a - b|, a + b): two segments cut by the common chord, in units of a.
// g - b is taken before the division: at the smallest lights g / a and b / a are 1e4 and more,
// and their difference would carry the quotients' rounding (a drivers' division may be off by
// 2.5 ULP).
float sphere_planar_lens_fraction(float a, float b, float g) {
  float bu = b / a, gu = g / a;
  // The chord's signed distance from the light disc's centre, towards the other disc.
  float x = (((g - b) / a) * ((g + b) / a) + 1.0) / (2.0 * gu);
  float h = sqrt(max(1.0 - x * x, 0.0));  // half the chord
  float theta_a = atan(h, x);
  float theta_b = atan(h / bu, (gu - x) / bu);
  return (sphere_segment_area(theta_a) + bu * bu * sphere_segment_area(theta_b)) /
         kSphereShadowPi;
}

// Returns the area of the part of a cap of half-angle r (<= pi/2) beyond the great circle through
// two points of its boundary at azimuths +-phi: the sector 2 phi (1 - cos r) less the spherical
// triangle (centre, the two points), whose excess E has tan(E / 2) = u = t sin(2 phi) / (1 + t
// cos(2 phi)), t = tan^2(r / 2) (<= 1, so the denominator stays positive for phi < pi/2 and the
// excess goes negative past it, as the segment grows beyond half the cap). A thin segment of a
// large cap (the occluder's, seen from a receiver close to it) is a small difference of two
// terms of the order of phi, so it is written as
//   [4 phi t / (1 + t) - 2 u] + 2 (u - atan u),
// the first bracket as 2 t ((x - sin x) + t (x cos x - sin x)) / ((1 + t)(1 + t cos x)) with
// x = 2 phi, and each difference by its series where it is small: no term cancels. (Summed
// directly, the atan's rounding alone put lavapipe 0.0012 off at a = 0.01 next to a horizon.)
float sphere_cap_segment_area(float r, float phi) {
  float t = tan(0.5 * r);
  t *= t;
  float x = 2.0 * phi;
  float x2 = x * x;
  float p, q;  // x - sin x, x cos x - sin x
  if (x < 0.2) {
    p = x * x2 * (1.0 / 6.0 - x2 * (1.0 / 120.0 - x2 * (1.0 / 5040.0)));
    q = -x * x2 * (1.0 / 3.0 - x2 * (1.0 / 30.0 - x2 * (1.0 / 840.0)));
  } else {
    p = x - sin(x);
    q = x * cos(x) - sin(x);
  }
  float den = 1.0 + t * cos(x);
  float u = t * sin(x) / den;
  float u2 = u * u;
  float tail = abs(u) < 0.1 ? u * u2 * (1.0 / 3.0 - u2 * (1.0 / 5.0 - u2 * (1.0 / 7.0)))
                            : u - atan(u);  // u - atan(u)
  return 2.0 * t * (p + t * q) / ((1.0 + t) * den) + 2.0 * tail;
}

// Returns the fraction of a light cap of half-angle a hidden by an occluder cap of half-angle b
// whose centre is g away (radians; see the header), in [0, 1]. a = 0 is a point light: 1 when
// its direction is inside the occluder, else 0. NaN inputs are lit (0).
float sphere_cap_occlusion(float a, float b, float g) {
  if (!(b > 0.0) || !(g >= 0.0) || !(a >= 0.0)) return 0.0;
  if (g >= a + b) return 0.0;
  if (!(a > 0.0)) return g < b ? 1.0 : 0.0;
  if (g <= b - a) return 1.0;
  if (g <= a - b) {  // the occluder inside the light: the ratio of the caps' solid angles
    // Small caps by their angles: a driver's sin may be off by an absolute 4e-7 (NVIDIA's
    // was 1% off at a = 1e-4).
    if (a < kSphereCapPlanarBelow) return (b * b) / (a * a);
    float s = sin(0.5 * b) / sin(0.5 * a);
    return s * s;
  }
  if (a < kSphereCapPlanarBelow) return clamp(sphere_planar_lens_fraction(a, b, g), 0.0, 1.0);
  float ca = cos(a), cb = cos(b), cg = cos(g);
  float sa = sin(a), sb = sin(b), sg = sin(g);
  // The crossings' azimuths about each centre (spherical law of cosines). cos b - cos a cos g
  // is a small difference of terms near cos b when the light is small (cos a rounds to 1 below
  // a = 3e-4): it is taken as (cos b - cos g) + cos g (1 - cos a), from half-angle sines.
  float half_a = sin(0.5 * a);
  float cb_minus_ca_cg =
      -2.0 * sin(0.5 * (b - g)) * sin(0.5 * (b + g)) + 2.0 * cg * half_a * half_a;
  float phi_a = acos(clamp(cb_minus_ca_cg / (sa * sg), -1.0, 1.0));
  float phi_b = acos(clamp((ca - cb * cg) / (sb * sg), -1.0, 1.0));
  float fraction = (sphere_cap_segment_area(a, phi_a) + sphere_cap_segment_area(b, phi_b)) /
                   (4.0 * kSphereShadowPi * half_a * half_a);
  return penumbra_is_finite(fraction) ? clamp(fraction, 0.0, 1.0) : 0.0;
}

// Returns asin(x) for x in [0, 1], by its series below 0.01 (a driver's asin, like its sin, may
// be off by an absolute 4e-7, which is a percent of a small light's half-angle).
float sphere_shadow_asin(float x) {
  return x < 0.01 ? x * (1.0 + x * x * (1.0 / 6.0 + x * x * (3.0 / 40.0))) : asin(x);
}

// Returns the angle between two non-zero vectors, accurate at 0 and pi alike.
float sphere_shadow_angle(vec3 u, vec3 v) {
  vec3 un = normalize(u), vn = normalize(v);
  return 2.0 * atan(length(un - vn), length(un + vn));
}

// Returns the occluder cap's half-angle of a sphere of radius r at distance d: pi/2 on or inside
// it (a receiver on the sphere itself: its tangent plane is the horizon).
float sphere_occluder_half_angle(float r, float d) {
  return d > r ? sphere_shadow_asin(r / d) : kSphereShadowHalfPi;
}

// Whether the caps of half-angles a and b (sines sa, sb; cosines ca, cb) whose centres are
// cos_g apart surely miss each other: cos g below cos(a + b) by more than fp32 can blur (the
// margin keeps tiny caps, where cos(a + b) rounds to 1, on the exact path). Square roots and
// products only: most receivers see no sphere near the light, and this spares them the trig.
bool sphere_caps_surely_apart(float sa, float sb, float cos_g) {
  float ca = sqrt(max(1.0 - sa * sa, 0.0));
  float cb = sqrt(max(1.0 - sb * sb, 0.0));
  return cos_g < ca * cb - sa * sb - 1e-5;
}

// Returns the fraction of a sphere light (centre light_center, radius light_radius >= 0; 0 is a
// point light) that the sphere `sphere` (xyz centre, w radius) hides from the receiver p, in
// [0, 1]. An occluder wholly beyond the light's centre hides nothing; a receiver at the
// occluder's centre is hidden.
float sphere_light_occlusion(vec3 p, vec3 light_center, float light_radius, vec4 sphere) {
  vec3 to_light = light_center - p;
  vec3 to_occluder = sphere.xyz - p;
  float dl = length(to_light);
  float d = length(to_occluder);
  if (!(sphere.w > 0.0) || !(dl > 0.0)) return 0.0;
  if (d - sphere.w >= dl) return 0.0;
  if (!(d > 0.0)) return 1.0;
  float sa = min(max(light_radius, 0.0) / dl, 1.0);
  if (sphere_caps_surely_apart(sa, min(sphere.w / d, 1.0), dot(to_light, to_occluder) / (dl * d)))
    return 0.0;
  float a = sphere_shadow_asin(sa);
  return sphere_cap_occlusion(a, sphere_occluder_half_angle(sphere.w, d),
                              sphere_shadow_angle(to_light, to_occluder));
}

// The same for the sun: to_sun the unit direction towards it, angular_radius half its angular
// diameter (radians; 0: hard).
float sun_sphere_occlusion(vec3 p, vec3 to_sun, float angular_radius, vec4 sphere) {
  vec3 to_occluder = sphere.xyz - p;
  float d = length(to_occluder);
  if (!(sphere.w > 0.0)) return 0.0;
  if (!(d > 0.0)) return 1.0;
  float a = max(angular_radius, 0.0);
  if (sphere_caps_surely_apart(sin(min(a, kSphereShadowHalfPi)), min(sphere.w / d, 1.0),
                               dot(to_sun, to_occluder) / d))
    return 0.0;
  return sphere_cap_occlusion(a, sphere_occluder_half_angle(sphere.w, d),
                              sphere_shadow_angle(to_sun, to_occluder));
}

#endif  // PENUMBRA_SPHERE_SHADOW_GLSL
