#pragma once

// The little JSON the tools write by hand (metrics.json, the parameter table, texel rates): a
// string quoted and escaped, and a number that is null where JSON has none (NaN, infinities).

#include <cmath>
#include <cstdio>
#include <string>
#include <string_view>

namespace penumbra::json {

// s in double quotes, '"' and '\' escaped, control characters dropped.
inline std::string string(std::string_view s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    out += c;
  }
  return out + "\"";
}

// v with `digits` significant digits (17 round-trips a double), or null when not finite.
inline std::string number(double v, int digits = 6) {
  if (!std::isfinite(v)) return "null";
  char b[40];
  std::snprintf(b, sizeof b, "%.*g", digits, v);
  return b;
}

}  // namespace penumbra::json
