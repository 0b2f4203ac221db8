// Low-discrepancy samples for the reference: the 2D Sobol (0,2)-sequence with a hash-based
// nested uniform (Owen) scramble per receiver, and the concentric disk map.
#include <bit>
#include <cmath>
#include <numbers>
#include <penumbra/reference/reference.hpp>

#include "hash.hpp"

namespace penumbra::reference {
namespace {

uint32_t reverse_bits(uint32_t x) {
  x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
  x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
  return (x >> 16) | (x << 16);
}

// Sobol dimension 0 (van der Corput in base 2) and dimension 1 (primitive polynomial x + 1:
// direction numbers v_0 = 2^31, v_k = v_{k-1} ^ (v_{k-1} >> 1)), as 32-bit fractions.
uint32_t sobol_dim0(uint32_t i) {
  return reverse_bits(i);
}
uint32_t sobol_dim1(uint32_t i) {
  uint32_t x = 0, v = 1u << 31;
  for (; i != 0; i >>= 1, v ^= v >> 1)
    if (i & 1u) x ^= v;
  return x;
}

// A nested uniform scramble of a 32-bit fraction: a hash of the bit-reversed value in which
// each bit is flipped depending only on the bits above it (the Laine–Karras form), so the
// scrambled sequence keeps the (0,2)-net property of every prefix of 2^k points.
uint32_t owen_scramble(uint32_t x, uint32_t seed) {
  x = reverse_bits(x);
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return reverse_bits(x);
}

}  // namespace

glm::dvec2 sobol_owen(uint32_t i, uint64_t seed) {
  const uint64_t h = detail::mix64(seed);
  const uint32_t s0 = static_cast<uint32_t>(h), s1 = static_cast<uint32_t>(h >> 32);
  constexpr double k = 1.0 / 4294967296.0;
  return {owen_scramble(sobol_dim0(i), s0) * k, owen_scramble(sobol_dim1(i), s1) * k};
}

glm::dvec2 concentric_disk(glm::dvec2 u) {
  const double a = 2.0 * u.x - 1.0, b = 2.0 * u.y - 1.0;
  if (a == 0.0 && b == 0.0) return {0.0, 0.0};
  constexpr double quarter = std::numbers::pi / 4.0;
  double r, phi;
  if (std::abs(a) > std::abs(b)) {
    r = a;
    phi = quarter * (b / a);
  } else {
    r = b;
    phi = 2.0 * quarter - quarter * (a / b);
  }
  return {r * std::cos(phi), r * std::sin(phi)};
}

}  // namespace penumbra::reference
