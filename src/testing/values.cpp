#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <penumbra/testing/values.hpp>
#include <system_error>

namespace penumbra::testing {
namespace {

template <class F>
void append_decimal(std::string& out, F value, int precision) {
  char buf[64];
  const auto result =
      std::to_chars(buf, buf + sizeof(buf), value, std::chars_format::general, precision);
  out.append(buf, result.ptr);
}

// "0x1.555556p-2", "-0x1p+0", "0x0p+0".
template <class F>
void append_hex(std::string& out, F value) {
  char buf[64];
  const auto result = std::to_chars(buf, buf + sizeof(buf), value, std::chars_format::hex);
  std::string_view text(buf, static_cast<std::size_t>(result.ptr - buf));
  if (!text.empty() && text.front() == '-') {
    out += "-0x";
    text.remove_prefix(1);
  } else {
    out += "0x";
  }
  out += text;
}

template <class F, class Bits>
void append_floating(std::string& out, F value, int precision, bool with_hex) {
  if (std::isnan(value)) {
    out += std::signbit(value) ? "-nan" : "nan";
    if (with_hex) {
      char buf[40];
      std::snprintf(buf, sizeof(buf), " (bits 0x%0*llx)", static_cast<int>(2 * sizeof(Bits)),
                    static_cast<unsigned long long>(std::bit_cast<Bits>(value)));
      out += buf;
    }
    return;
  }
  if (std::isinf(value)) {
    out += value < 0 ? "-inf" : "inf";
    return;
  }
  append_decimal(out, value, precision);
  if (with_hex) {
    out += " (";
    // Through double, so float denormals come out normalized: 0x1p-149, not 0x0.000002p-126.
    append_hex(out, static_cast<double>(value));
    out += ')';
  }
}

}  // namespace

std::string format_scalar(const Scalar& s, bool with_hex) {
  std::string out;
  switch (s.kind) {
    case Scalar::Kind::f32:
      append_floating<float, std::uint32_t>(out, s.f, 9, with_hex);
      break;
    case Scalar::Kind::f64:
      append_floating<double, std::uint64_t>(out, s.d, 17, with_hex);
      break;
    case Scalar::Kind::i32:
      out = std::to_string(s.i);
      break;
    case Scalar::Kind::u32:
      out = std::to_string(s.u);
      break;
    case Scalar::Kind::boolean:
      out = s.b ? "true" : "false";
      break;
  }
  return out;
}

namespace detail {

std::string index_segment(std::size_t index) {
  return "[" + std::to_string(index) + "]";
}

std::string tuple_segment(std::size_t index) {
  return "#" + std::to_string(index);
}

std::string matrix_segment(int column, int row) {
  return "c" + std::to_string(column) + ".r" + std::to_string(row);
}

}  // namespace detail
}  // namespace penumbra::testing
