#pragma once

// Internal helpers of penumbra::shadow: value formatting for error messages and field checks.

#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <penumbra/core/error.hpp>
#include <string>

namespace penumbra::shadow::detail {

// Shortest round-trip text of a double ("0.1", "nan", "inf", "-1e-300").
std::string format(double value);
std::string format(const glm::dvec3& value);

// "<field> = <value>: <requirement>"
[[noreturn]] void fail(const std::string& field, const std::string& value,
                       const std::string& requirement);

inline bool finite(const glm::dvec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// value in [lo, hi] (false for NaN).
inline bool in_range(double value, double lo, double hi) {
  return value >= lo && value <= hi;
}

void check_range(const char* field, double value, double lo, double hi);
void check_range(const char* field, std::uint32_t value, std::uint32_t lo, std::uint32_t hi);
// finite and > 0
void check_positive(const char* field, double value);
void check_finite(const char* field, const glm::dvec3& value);

}  // namespace penumbra::shadow::detail
