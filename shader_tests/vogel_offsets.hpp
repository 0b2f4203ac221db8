#pragma once

// Unit-disk offsets of Vogel tap sets (count, rotation), read back from noise.glsl (tested
// there), so that a filter's reference checks the search and the filtering, not the spiral.
// Shared by the PCSS tests (pcss_tests.cpp, local_shadow_tests.cpp).

#include <cstdint>
#include <glm/glm.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <tuple>
#include <utility>
#include <vector>

inline std::vector<std::vector<glm::dvec2>> vogel_offsets(
    const std::vector<std::pair<int, float>>& sets) {
  penumbra::testing::ShaderFunction<glm::vec2(int32_t, int32_t, float)> f("penumbra/noise.glsl",
                                                                          "vogel_disk_sample");
  std::vector<std::tuple<int32_t, int32_t, float>> in;
  for (auto [n, rot] : sets)
    for (int i = 0; i < n; ++i) in.emplace_back(i, n, rot);
  const auto got = f.run(in);
  std::vector<std::vector<glm::dvec2>> out;
  size_t k = 0;
  for (auto [n, rot] : sets) {
    out.emplace_back();
    for (int i = 0; i < n; ++i) out.back().push_back(glm::dvec2(got[k++]));
  }
  return out;
}
