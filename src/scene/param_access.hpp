#pragma once
// The parameter table's accessors (src/scene/param_table.cpp's rows): a row reads and writes a
// field of Scene through these, typed by the field's own type. Private to src/scene.

#include <cstdio>
#include <optional>
#include <penumbra/core/error.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <string>
#include <type_traits>

namespace penumbra::scene::detail {

using namespace ranges;

// The panel's slider range of a row.
constexpr ParamRange slider(double lo, double hi) {
  return closed(lo, hi);
}

inline std::string number_text(double v) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%g", v);
  return buffer;
}

// ---- field accessors: the value types of ParamValue from the fields' own types ------------

template <class T>
ParamValue to_value(const T& v) {
  if constexpr (std::is_same_v<T, bool>) {
    return v;
  } else if constexpr (std::is_enum_v<T>) {
    return static_cast<std::int64_t>(v);
  } else if constexpr (std::is_integral_v<T>) {
    return static_cast<std::int64_t>(v);
  } else if constexpr (std::is_floating_point_v<T>) {
    return static_cast<double>(v);
  } else {
    return glm::dvec3(v);
  }
}

template <class T>
T from_value(const ParamValue& v) {
  if constexpr (std::is_same_v<T, bool>) {
    return std::get<bool>(v);
  } else if constexpr (std::is_enum_v<T> || std::is_integral_v<T>) {
    return static_cast<T>(std::get<std::int64_t>(v));
  } else if constexpr (std::is_floating_point_v<T>) {
    return static_cast<T>(std::get<double>(v));
  } else {
    return T(std::get<glm::dvec3>(v));
  }
}

struct Access {
  std::optional<ParamValue> (*get)(const Scene&);
  void (*set)(Scene&, const ParamValue&);
};

// A field of one of Scene's always-present tables.
template <auto Table, auto Field>
Access field() {
  return {[](const Scene& s) -> std::optional<ParamValue> { return to_value((s.*Table).*Field); },
          [](Scene& s, const ParamValue& v) {
            auto& f = (s.*Table).*Field;
            f = from_value<std::remove_cvref_t<decltype(f)>>(v);
          }};
}

// A field of the optional [sun].
template <auto Field>
Access sun_field() {
  return {[](const Scene& s) -> std::optional<ParamValue> {
            if (!s.sun) return std::nullopt;
            return to_value((*s.sun).*Field);
          },
          [](Scene& s, const ParamValue& v) {
            if (!s.sun) throw Error("the scene '" + s.name + "' has no [sun]");
            auto& f = (*s.sun).*Field;
            f = from_value<std::remove_cvref_t<decltype(f)>>(v);
          }};
}

// A field of every light of one kind ([[spot]] or [[point]]: Scene::spots or Scene::points);
// get and set are the first light's.
struct IndexedAccess {
  std::optional<ParamValue> (*get_at)(const Scene&, std::size_t) = nullptr;
  void (*set_at)(Scene&, std::size_t, const ParamValue&) = nullptr;
  std::optional<ParamValue> (*get)(const Scene&) = nullptr;
  void (*set)(Scene&, const ParamValue&) = nullptr;
};

template <auto List>
auto& light_at(Scene& s, std::size_t i) {
  auto& list = s.*List;
  if (i >= list.size()) {
    const std::string kind =
        std::is_same_v<std::remove_cvref_t<decltype(list)>, std::vector<SpotLight>> ? "spot"
                                                                                     : "point";
    throw Error("the scene '" + s.name + "' has " + std::to_string(list.size()) + " " + kind +
                " light" + (list.size() == 1 ? "" : "s") + ": no " + kind + "[" +
                std::to_string(i) + "]");
  }
  return list[i];
}

template <auto List, auto Field>
std::optional<ParamValue> light_get(const Scene& s, std::size_t i) {
  if (i >= (s.*List).size()) return std::nullopt;
  return to_value((s.*List)[i].*Field);
}
template <auto List, auto Field>
void light_set(Scene& s, std::size_t i, const ParamValue& v) {
  auto& f = light_at<List>(s, i).*Field;
  f = from_value<std::remove_cvref_t<decltype(f)>>(v);
}

// A light's own filter: choice 0 ("inherit") is none, [shadows] filter's; i is Filter(i - 1).
template <auto List>
std::optional<ParamValue> filter_get(const Scene& s, std::size_t i) {
  if (i >= (s.*List).size()) return std::nullopt;
  const std::optional<Filter>& f = (s.*List)[i].filter;
  return f ? std::int64_t(*f) + 1 : std::int64_t(0);
}
template <auto List>
void filter_set(Scene& s, std::size_t i, const ParamValue& v) {
  const std::int64_t choice = std::get<std::int64_t>(v);
  light_at<List>(s, i).filter =
      choice == 0 ? std::nullopt : std::optional<Filter>(Filter(choice - 1));
}

template <auto GetAt>
std::optional<ParamValue> first_get(const Scene& s) {
  return GetAt(s, 0);
}
template <auto SetAt>
void first_set(Scene& s, const ParamValue& v) {
  SetAt(s, 0, v);
}

template <auto GetAt, auto SetAt>
IndexedAccess indexed() {
  return {GetAt, SetAt, first_get<GetAt>, first_set<SetAt>};
}
template <auto List, auto Field>
IndexedAccess light_field() {
  return indexed<light_get<List, Field>, light_set<List, Field>>();
}
template <auto List>
IndexedAccess light_filter() {
  return indexed<filter_get<List>, filter_set<List>>();
}

// Object i's motion (Scene::instances; an object that does not move reads as moving by 0). Set
// on a still object, it gives it a Motion from where it is.
template <auto Field>
std::optional<ParamValue> motion_get(const Scene& s, std::size_t i) {
  if (i >= s.instances.size()) return std::nullopt;
  return to_value(s.instances[i].motion.value_or(Motion{}).*Field);
}
template <auto Field>
void motion_set(Scene& s, std::size_t i, const ParamValue& v) {
  if (i >= s.instances.size())
    throw Error("the scene '" + s.name + "' has " + std::to_string(s.instances.size()) +
                " object" + (s.instances.size() == 1 ? "" : "s") + ": no object[" +
                std::to_string(i) + "]");
  Instance& instance = s.instances[i];
  if (!instance.motion) {
    Motion m;
    m.base = instance.transform;
    instance.motion = m;
  }
  auto& f = (*instance.motion).*Field;
  f = from_value<std::remove_cvref_t<decltype(f)>>(v);
}
template <auto Field>
IndexedAccess motion_field() {
  return indexed<motion_get<Field>, motion_set<Field>>();
}

// Object i's motion against the rest of the scene, as text ("" when it holds): its move within
// the still objects' bounds grown by its size, no spin on an analytic sphere (scene_objects.cpp;
// the scene file and set_param both check them).
std::string motion_bounds_violation(const Scene& scene, std::size_t i);
std::string motion_spin_violation(const Scene& scene, std::size_t i);

}  // namespace penumbra::scene::detail
