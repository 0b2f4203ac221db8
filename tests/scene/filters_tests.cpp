// The shadow filters' table (penumbra/scene/filters.hpp): its rows against scene::Filter, the
// parameter table and the light kinds.

#include <gtest/gtest.h>

#include <penumbra/scene/filters.hpp>
#include <penumbra/scene/params.hpp>
#include <set>
#include <string>

namespace penumbra::scene {
namespace {

TEST(FilterTable, RowIIsFilterIAndNamesAreUnique) {
  std::set<std::string_view> names, constants;
  const auto table = filter_table();
  for (std::size_t i = 0; i < table.size(); ++i) {
    SCOPED_TRACE(std::string(table[i].name));
    EXPECT_EQ(std::size_t(table[i].filter), i);
    EXPECT_EQ(filter_index(table[i].filter), i);
    EXPECT_TRUE(names.insert(table[i].name).second);
    EXPECT_TRUE(constants.insert(table[i].constant).second);
    EXPECT_TRUE(table[i].fetches_per_pixel && table[i].reach_texels);
    EXPECT_FALSE(table[i].doc.empty());
    EXPECT_TRUE(table[i].maps || table[i].cubes) << "a filter no light can use";
  }
}

// What a light falls back to must work for every light without moments of its own.
TEST(FilterTable, FallbacksWorkForEveryLightWithoutMoments) {
  for (const FilterSpec& f : filter_table()) {
    SCOPED_TRACE(std::string(f.name));
    const bool needs = f.moments || !f.maps || !f.cubes;
    EXPECT_EQ(f.fallback.has_value(), needs) << "a filter some light cannot use needs a fallback";
    if (!f.fallback) continue;
    const FilterSpec& b = filter_spec(*f.fallback);
    EXPECT_FALSE(b.moments);
    EXPECT_TRUE(b.maps && b.cubes);
  }
}

// The parameter table's choices are the filter table's names, and every key a filter reads is a
// [shadows] row.
TEST(FilterTable, TheParameterTableReadsIt) {
  const Param* sun = find_param("shadows.filter");
  ASSERT_NE(sun, nullptr);
  EXPECT_EQ(sun->choices, filter_names());
  const Param* spot = find_param("spot.filter");
  ASSERT_NE(spot, nullptr);
  ASSERT_EQ(spot->choices.size(), filter_names().size() + 1);
  EXPECT_EQ(spot->choices[0], "inherit");
  for (const FilterSpec& f : filter_table())
    for (std::string_view key : f.keys)
      EXPECT_NE(find_param("shadows." + std::string(key)), nullptr) << f.name << ": " << key;
}

TEST(FilterTable, GlslConstantsAreTheRowIndices) {
  const std::string glsl = filters_glsl();
  for (std::size_t i = 0; i < filter_table().size(); ++i)
    EXPECT_NE(glsl.find("const uint " + std::string(filter_table()[i].constant) + " = " +
                        std::to_string(i) + "u;"),
              std::string::npos)
        << glsl;
  EXPECT_NE(glsl.find("const uint kFilterCount = " + std::to_string(filter_table().size()) + "u;"),
            std::string::npos);
}

}  // namespace
}  // namespace penumbra::scene
