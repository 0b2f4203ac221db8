// The parameter table as JSON, for tools outside C++ (penumbra-tune reads its search space's
// keys, types, ranges and a scene's values from it: penumbra-view --list-params).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <penumbra/core/json.hpp>
#include <penumbra/scene/filters.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <sstream>

namespace penumbra::scene {
namespace {

// An open-ended bound (infinite) is null.
std::string json_number(double v) {
  return json::number(v, 17);
}
std::string json_string(std::string_view s) {
  return json::string(s);
}

const char* type_name(ParamType t) {
  switch (t) {
    case ParamType::number:
      return "number";
    case ParamType::integer:
      return "integer";
    case ParamType::boolean:
      return "boolean";
    case ParamType::choice:
      return "choice";
    case ParamType::vec3:
      return "vec3";
    case ParamType::direction:
      return "direction";
  }
  return "number";
}

const char* apply_name(ParamApply a) {
  switch (a) {
    case ParamApply::frame:
      return "frame";
    case ParamApply::rebuild:
      return "rebuild";
    case ParamApply::file_only:
      return "file_only";
  }
  return "frame";
}

}  // namespace

std::string params_json(const Scene* scene) {
  std::ostringstream o;
  o << "[";
  bool first = true;
  for (const Param& p : params()) {
    o << (first ? "\n" : ",\n") << " {\"key\": " << json_string(p.key)
      << ", \"type\": " << json_string(type_name(p.type))
      << ", \"apply\": " << json_string(apply_name(p.apply))
      << ", \"range\": {\"lo\": " << json_number(p.range.lo)
      << ", \"hi\": " << json_number(p.range.hi)
      << ", \"lo_open\": " << (p.range.lo_open ? "true" : "false")
      << ", \"hi_open\": " << (p.range.hi_open ? "true" : "false") << "}, \"choices\": [";
    for (size_t i = 0; i < p.choices.size(); ++i) o << (i ? ", " : "") << json_string(p.choices[i]);
    o << "], \"doc\": " << json_string(p.doc) << ", \"default\": " << json_string(default_text(p));
    o << ", \"per_light\": " << (p.per_light() ? "true" : "false");
    // The filters that read a [shadows] key (the filter table's rows).
    std::string readers;
    if (p.table() == "shadows")
      for (const FilterSpec& f : filter_table())
        if (std::find(f.keys.begin(), f.keys.end(), p.name()) != f.keys.end())
          readers += (readers.empty() ? "" : ", ") + json_string(f.name);
    if (!readers.empty()) o << ", \"filters\": [" << readers << "]";
    if (scene) {
      const auto v = p.get ? p.get(*scene) : std::nullopt;
      o << ", \"value\": " << (v ? json_string(format_value(p, *v)) : std::string("null"));
      if (p.per_light()) {  // every light's, by index: spot[i].name
        o << ", \"values\": [";
        for (std::size_t i = 0; i < light_count(*scene, p.table()); ++i)
          o << (i ? ", " : "") << json_string(format_value(p, *p.get_at(*scene, i)));
        o << "]";
      }
    }
    o << "}";
    first = false;
  }
  o << "\n]\n";
  return o.str();
}

}  // namespace penumbra::scene
