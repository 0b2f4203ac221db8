#pragma once

// The TOML reading shared by the scene file's parts (scene_file.cpp: the singleton tables and
// the lights; scene_objects.cpp: materials, meshes, objects and scatters): typed, range-checked
// accessors whose errors name the file, line, table and key, with "did you mean" suggestions.
// Internal to penumbra::scene.

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <glm/glm.hpp>
#include <limits>
#include <optional>
#include <penumbra/core/error.hpp>
#include <penumbra/core/text.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace penumbra::scene::file {

namespace fs = std::filesystem;

// ---- small helpers ---------------------------------------------------------------------------

inline std::string format_number(double value) {
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%g", value);
  return buffer;
}

inline std::string describe(const toml::node& node) {
  std::ostringstream out;
  node.visit([&](const auto& v) {
    if constexpr (toml::is_string<decltype(v)>) {
      out << "'" << v.get() << "'";
    } else if constexpr (toml::is_number<decltype(v)>) {
      out << format_number(static_cast<double>(v.get()));
    } else {
      out << v;
    }
  });
  std::string text = out.str();
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  return text;
}

inline std::string type_name(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::string:
      return "a string";
    case toml::node_type::integer:
      return "an integer";
    case toml::node_type::floating_point:
      return "a floating-point number";
    case toml::node_type::boolean:
      return "a boolean";
    case toml::node_type::array:
      return "an array";
    case toml::node_type::table:
      return "a table";
    default:
      return "a date/time";
  }
}

using penumbra::edit_distance;  // penumbra/core/text.hpp

// " (did you mean 'color'?)" for the closest candidate, or "" when none is close.
inline std::string did_you_mean(std::string_view word,
                                const std::vector<std::string_view>& candidates) {
  std::string_view best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  for (std::string_view candidate : candidates) {
    std::size_t distance = edit_distance(word, candidate);
    const bool prefix =
        word.size() >= 3 && (candidate.starts_with(word) || word.starts_with(candidate));
    if (prefix) distance = std::min<std::size_t>(distance, 1);
    if (distance < best_distance) {
      best_distance = distance;
      best = candidate;
    }
  }
  const std::size_t limit = word.size() <= 3 ? 1 : word.size() <= 6 ? 2 : 3;
  if (best.empty() || best_distance > limit) return "";
  return " (did you mean '" + std::string(best) + "'?)";
}

inline std::string join(const std::vector<std::string_view>& words) {
  std::string out;
  for (std::string_view w : words) {
    if (!out.empty()) out += ", ";
    out += w;
  }
  return out;
}

using Range = ParamRange;
using namespace ranges;

template <class E>
using Names = std::vector<std::pair<std::string_view, E>>;

inline const Names<AlphaMode> kAlphaModes{{"opaque", AlphaMode::opaque},
                                          {"masked", AlphaMode::masked}};
inline const Names<MaskPattern> kMasks{{"none", MaskPattern::none},
                                       {"texture", MaskPattern::texture},
                                       {"stripes", MaskPattern::stripes},
                                       {"checker", MaskPattern::checker},
                                       {"circles", MaskPattern::circles}};

template <class E>
inline std::string_view name_of(const Names<E>& names, E value) {
  for (const auto& [name, v] : names) {
    if (v == value) return name;
  }
  return "?";
}

// ---- reading one table -----------------------------------------------------------------------

struct Context {
  std::string file;  // for messages
  fs::path base_dir;
};

class Reader {
 public:
  Reader(const Context& ctx, const toml::table& table, std::string label)
      : ctx_(ctx), table_(table), label_(std::move(label)) {}

  const std::string& label() const { return label_; }
  const toml::table& table() const { return table_; }
  const Context& context() const { return ctx_; }

  std::uint32_t line_of(const toml::node* node) const {
    const toml::node& n = node != nullptr ? *node : static_cast<const toml::node&>(table_);
    return n.source().begin.line;
  }
  // "[sun] intensity" (or just the key at the top level).
  std::string name(std::string_view key) const {
    return label_.empty() ? std::string(key) : label_ + " " + std::string(key);
  }
  [[noreturn]] void fail_at(const toml::node* node, const std::string& text) const {
    throw Error(ctx_.file + ":" + std::to_string(line_of(node)) + ": " + text);
  }
  [[noreturn]] void fail_key(std::string_view key, const std::string& text) const {
    fail_at(table_.get(key), name(key) + ": " + text);
  }
  // "[camera] fov_y = 200 is out of range; must be in (0, 180)".
  [[noreturn]] void fail_range(std::string_view key, const toml::node& node,
                               const std::string& requirement) const {
    fail_at(&node, name(key) + " = " + describe(node) + " is out of range; " + requirement);
  }

  const toml::node* get(std::string_view key) const { return table_.get(key); }
  bool has(std::string_view key) const { return table_.contains(key); }

  // Every key must be one of `allowed`; the first unknown key (by line) is reported, with a
  // suggestion. `explain` may give a more specific message for a known-but-misplaced key.
  template <class Explain>
  void check_keys(const std::vector<std::string_view>& allowed, Explain explain) const {
    const toml::key* worst = nullptr;
    for (const auto& [key, value] : table_) {
      if (std::find(allowed.begin(), allowed.end(), key.str()) != allowed.end()) continue;
      if (worst == nullptr || key.source().begin.line < worst->source().begin.line) worst = &key;
    }
    if (worst == nullptr) return;
    const std::string_view key = worst->str();
    std::string where = label_.empty() ? "at the top level" : "in " + label_;
    std::string text = explain(key);
    if (text.empty()) {
      text = "unknown key '" + std::string(key) + "' " + where + did_you_mean(key, allowed);
    }
    throw Error(ctx_.file + ":" + std::to_string(worst->source().begin.line) + ": " + text);
  }
  void check_keys(const std::vector<std::string_view>& allowed) const {
    check_keys(allowed, [](std::string_view) { return std::string(); });
  }

  std::optional<double> opt_number(std::string_view key, Range range = kAny) const {
    const toml::node* node = get(key);
    if (node == nullptr) return std::nullopt;
    return number_of(key, *node, range, "");
  }
  double number(std::string_view key, double fallback, Range range = kAny) const {
    return opt_number(key, range).value_or(fallback);
  }
  float numberf(std::string_view key, float fallback, Range range = kAny) const {
    return static_cast<float>(number(key, fallback, range));
  }

  std::optional<std::int64_t> opt_integer(std::string_view key, std::int64_t lo,
                                          std::int64_t hi) const {
    const toml::node* node = get(key);
    if (node == nullptr) return std::nullopt;
    const auto* value = node->as_integer();
    if (value == nullptr) {
      fail_at(node, name(key) + ": expected an integer, got " + type_name(*node) + " (" +
                        describe(*node) + ")");
    }
    const std::int64_t v = value->get();
    if (v < lo || v > hi) {
      fail_range(key, *node, "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
    return v;
  }
  std::uint32_t uint(std::string_view key, std::uint32_t fallback, std::int64_t lo,
                     std::int64_t hi) const {
    return static_cast<std::uint32_t>(opt_integer(key, lo, hi).value_or(fallback));
  }

  std::optional<bool> opt_bool(std::string_view key) const {
    const toml::node* node = get(key);
    if (node == nullptr) return std::nullopt;
    const auto* value = node->as_boolean();
    if (value == nullptr) {
      fail_at(node, name(key) + ": expected true or false, got " + type_name(*node) + " (" +
                        describe(*node) + ")");
    }
    return value->get();
  }
  bool boolean(std::string_view key, bool fallback) const {
    return opt_bool(key).value_or(fallback);
  }

  std::optional<std::string> opt_string(std::string_view key) const {
    const toml::node* node = get(key);
    if (node == nullptr) return std::nullopt;
    const auto* value = node->as_string();
    if (value == nullptr) {
      fail_at(node, name(key) + ": expected a string, got " + type_name(*node) + " (" +
                        describe(*node) + ")");
    }
    return value->get();
  }
  std::string required_string(std::string_view key) const {
    std::optional<std::string> s = opt_string(key);
    if (!s) missing(key);
    if (s->empty()) fail_key(key, "must not be empty");
    return *s;
  }

  template <int N>
  std::optional<glm::vec<N, double>> opt_vec(std::string_view key, Range range = kAny) const {
    const toml::node* node = get(key);
    if (node == nullptr) return std::nullopt;
    const auto* array = node->as_array();
    if (array == nullptr) {
      fail_at(node, name(key) + ": expected an array of " + std::to_string(N) + " numbers, got " +
                        type_name(*node) + " (" + describe(*node) + ")");
    }
    if (array->size() != N) {
      fail_at(node, name(key) + " = " + describe(*node) + " has " + std::to_string(array->size()) +
                        " elements; expected " + std::to_string(N));
    }
    glm::vec<N, double> out(0.0);
    for (int i = 0; i < N; ++i) {
      out[i] = number_of(key, *array->get(static_cast<std::size_t>(i)), kAny,
                         " element " + std::to_string(i + 1));
    }
    for (int i = 0; i < N; ++i) {
      if (!range.contains(out[i])) fail_range(key, *node, "every element must be " + range.text());
    }
    return out;
  }
  glm::vec3 vec3(std::string_view key, glm::vec3 fallback, Range range = kAny) const {
    const auto v = opt_vec<3>(key, range);
    return v ? glm::vec3(*v) : fallback;
  }
  glm::vec3 required_vec3(std::string_view key, Range range = kAny) const {
    const auto v = opt_vec<3>(key, range);
    if (!v) missing(key);
    return glm::vec3(*v);
  }
  // A unit direction; zero length is an error.
  std::optional<glm::vec3> opt_direction(std::string_view key) const {
    const auto v = opt_vec<3>(key);
    if (!v) return std::nullopt;
    const double len = glm::length(*v);
    if (!(len > 1e-9) || !std::isfinite(len)) {
      fail_at(get(key), name(key) + " = " + describe(*get(key)) +
                            " has zero length; a direction needs a non-zero vector");
    }
    return glm::vec3(*v / len);
  }

  template <class E>
  std::optional<E> opt_enum(std::string_view key, const Names<E>& names) const {
    const toml::node* node = get(key);
    if (node == nullptr) return std::nullopt;
    std::vector<std::string_view> valid;
    for (const auto& [n, v] : names) valid.push_back(n);
    const auto* value = node->as_string();
    if (value == nullptr) {
      fail_at(node, name(key) + ": expected a string (one of " + join(valid) + "), got " +
                        type_name(*node) + " (" + describe(*node) + ")");
    }
    for (const auto& [n, v] : names) {
      if (n == value->get()) return v;
    }
    fail_at(node, name(key) + ": unknown value '" + value->get() +
                      "'; valid values: " + join(valid) + did_you_mean(value->get(), valid));
  }

  [[noreturn]] void missing(std::string_view key, std::string_view alternative = {}) const {
    fail_at(nullptr, (label_.empty() ? std::string("the scene") : label_) +
                         ": missing required key '" + std::string(key) + "'" +
                         (alternative.empty() ? "" : " (or '" + std::string(alternative) + "')"));
  }

 private:
  double number_of(std::string_view key, const toml::node& node, Range range,
                   const std::string& element) const {
    double v = 0.0;
    if (const auto* i = node.as_integer()) {
      v = static_cast<double>(i->get());
    } else if (const auto* f = node.as_floating_point()) {
      v = f->get();
    } else {
      fail_at(&node, name(key) + element + ": expected a number, got " + type_name(node) + " (" +
                         describe(node) + ")");
    }
    if (!std::isfinite(v)) {
      fail_at(&node, name(key) + element + " = " + describe(node) + " is not finite");
    }
    // The renderer keeps numbers as 32-bit floats: one that overflows, becomes 0 or loses its
    // normal precision there is an error, and the range holds for the value as it is stored.
    const float stored = static_cast<float>(v);
    if (!std::isfinite(stored) ||
        (v != 0.0 && (stored == 0.0f || std::fpclassify(stored) == FP_SUBNORMAL))) {
      fail_at(&node, name(key) + element + " = " + describe(node) +
                         " does not fit a 32-bit float (0, or a magnitude from 1.2e-38 to "
                         "3.4e38)");
    }
    if (!range.contains(v)) fail_range(key, node, "must be " + range.text());
    if (!range.contains(double(stored))) {
      fail_range(key, node,
                 "must be " + range.text() + " (as a 32-bit float it is " +
                     format_number(double(stored)) + ")");
    }
    return v;
  }

  const Context& ctx_;
  const toml::table& table_;
  std::string label_;
};

// A single table ([sun]); nullptr when absent.
inline const toml::table* single_table(const Context& ctx, const toml::table& root,
                                       std::string_view key) {
  const toml::node* node = root.get(key);
  if (node == nullptr) return nullptr;
  if (const auto* table = node->as_table()) return table;
  const std::string hint =
      node->is_array() ? " (write [" + std::string(key) + "], not [[" + std::string(key) + "]])"
                       : "";
  throw Error(ctx.file + ":" + std::to_string(node->source().begin.line) + ": '" +
              std::string(key) + "' must be a table, got " + type_name(*node) + hint);
}

// An array of tables ([[object]]); empty when absent.
inline std::vector<const toml::table*> table_array(const Context& ctx, const toml::table& root,
                                                   std::string_view key) {
  std::vector<const toml::table*> out;
  const toml::node* node = root.get(key);
  if (node == nullptr) return out;
  const auto* array = node->as_array();
  if (array == nullptr) {
    const std::string hint =
        node->is_table() ? " (write [[" + std::string(key) + "]], not [" + std::string(key) + "])"
                         : "";
    throw Error(ctx.file + ":" + std::to_string(node->source().begin.line) + ": '" +
                std::string(key) + "' must be an array of tables, got " + type_name(*node) + hint);
  }
  for (const toml::node& element : *array) {
    const auto* table = element.as_table();
    if (table == nullptr) {
      throw Error(ctx.file + ":" + std::to_string(element.source().begin.line) + ": '" +
                  std::string(key) + "' must be an array of tables ([[" + std::string(key) +
                  "]]), but an element is " + type_name(element));
    }
    out.push_back(table);
  }
  return out;
}

inline std::string indexed_label(std::string_view key, std::size_t index) {
  return "[[" + std::string(key) + "]] #" + std::to_string(index + 1);
}

// The materials, [[object]]s and [[scatter]]s of root (scene_objects.cpp).
void read_geometry(const Context& ctx, const toml::table& root, Scene& scene);

}  // namespace penumbra::scene::file
