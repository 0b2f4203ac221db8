#include "detail.hpp"

#include <array>
#include <charconv>

namespace penumbra::shadow::detail {

std::string format(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  std::array<char, 64> buffer{};
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  return std::string(buffer.data(), result.ptr);
}

std::string format(const glm::dvec3& value) {
  return "(" + format(value.x) + ", " + format(value.y) + ", " + format(value.z) + ")";
}

void fail(const std::string& field, const std::string& value, const std::string& requirement) {
  throw Error(field + " = " + value + ": " + requirement);
}

void check_range(const char* field, double value, double lo, double hi) {
  if (!in_range(value, lo, hi)) {
    fail(field, format(value), "must be in [" + format(lo) + ", " + format(hi) + "]");
  }
}

void check_range(const char* field, std::uint32_t value, std::uint32_t lo, std::uint32_t hi) {
  if (value < lo || value > hi) {
    fail(field, std::to_string(value),
         "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
}

void check_positive(const char* field, double value) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    fail(field, format(value), "must be finite and > 0");
  }
}

void check_finite(const char* field, const glm::dvec3& value) {
  if (!finite(value)) fail(field, format(value), "must be finite");
}

}  // namespace penumbra::shadow::detail
