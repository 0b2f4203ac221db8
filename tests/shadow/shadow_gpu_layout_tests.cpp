// The C++ GPU structs (gpu_types.hpp) against SPIR-V reflection of their GLSL mirror
// (shaders/penumbra/shadow_types.glsl), in a std140 uniform block and a std430 storage block:
// every member's offset, size, array stride and matrix stride, and nothing left unchecked.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstddef>
#include <map>
#include <penumbra/shader/compiler.hpp>
#include <penumbra/shader/reflection.hpp>
#include <penumbra/shadow/gpu_types.hpp>
#include <set>
#include <string>
#include <vector>

namespace penumbra::shadow {
namespace {

// The block both buffers declare, as C++ lays it out.
struct alignas(16) Blocks {
  ShadowGpu shadow;
  SpotShadowGpu spot;
  PointShadowGpu point_shadow;
  ShadowDrawGpu draw;
};

constexpr const char* kShader = R"(#version 460
#include <penumbra/shadow_types.glsl>
layout(local_size_x = 1) in;
layout(std140, set = 0, binding = 0) uniform ShadowUbo {
  ShadowGpu shadow;
  SpotShadowGpu spot;
  PointShadowGpu point_shadow;
  ShadowDrawGpu draw;
} ubo;
layout(std430, set = 0, binding = 1) buffer ShadowSsbo {
  ShadowGpu shadow;
  SpotShadowGpu spot;
  PointShadowGpu point_shadow;
  ShadowDrawGpu draw;
} ssbo;
void main() {
  ssbo.shadow = ubo.shadow;
  ssbo.spot = ubo.spot;
  ssbo.point_shadow = ubo.point_shadow;
  ssbo.draw = ubo.draw;
}
)";

struct Expected {
  std::size_t offset = 0;  // relative to the enclosing struct
  std::size_t size = 0;
  std::size_t array_stride = 0;
  std::size_t matrix_stride = 0;
};

constexpr std::size_t kVec4 = sizeof(glm::vec4);
constexpr std::size_t kMat4 = sizeof(glm::mat4);

std::map<std::string, Expected> expected_layout() {
  std::map<std::string, Expected> e;
  e["shadow"] = {offsetof(Blocks, shadow), sizeof(ShadowGpu), 0, 0};
  e["spot"] = {offsetof(Blocks, spot), sizeof(SpotShadowGpu), 0, 0};
  e["point_shadow"] = {offsetof(Blocks, point_shadow), sizeof(PointShadowGpu), 0, 0};
  e["draw"] = {offsetof(Blocks, draw), sizeof(ShadowDrawGpu), 0, 0};
  e["draw.cascades"] = {offsetof(ShadowDrawGpu, cascades), sizeof(ShadowDrawGpu::cascades),
                        sizeof(CascadeDrawGpu), 0};
  e["draw.cascades.to_texels"] = {offsetof(CascadeDrawGpu, to_texels), kMat4, 0, kVec4};
  e["draw.cascades.scale"] = {offsetof(CascadeDrawGpu, scale), kVec4, 0, 0};

  e["shadow.cascades"] = {offsetof(ShadowGpu, cascades), sizeof(ShadowGpu::cascades),
                          sizeof(CascadeGpu), 0};
  e["shadow.cascades.view_proj"] = {offsetof(CascadeGpu, view_proj), kMat4, 0, kVec4};
  e["shadow.cascades.params"] = {offsetof(CascadeGpu, params), kVec4, 0, 0};
  e["shadow.splits"] = {offsetof(ShadowGpu, splits), sizeof(ShadowGpu::splits), kVec4, 0};
  e["shadow.light_dir_angular"] = {offsetof(ShadowGpu, light_dir_angular), kVec4, 0, 0};
  e["shadow.pcss"] = {offsetof(ShadowGpu, pcss), kVec4, 0, 0};
  e["shadow.selection"] = {offsetof(ShadowGpu, selection), kVec4, 0, 0};
  e["shadow.camera_position"] = {offsetof(ShadowGpu, camera_position), kVec4, 0, 0};
  e["shadow.camera_forward"] = {offsetof(ShadowGpu, camera_forward), kVec4, 0, 0};
  e["shadow.counts"] = {offsetof(ShadowGpu, counts), sizeof(glm::uvec4), 0, 0};
  e["shadow.modes"] = {offsetof(ShadowGpu, modes), sizeof(glm::uvec4), 0, 0};
  e["shadow.redrawn"] = {offsetof(ShadowGpu, redrawn), sizeof(ShadowGpu::redrawn),
                         sizeof(glm::uvec4), 0};
  e["shadow.redrawn_rect"] = {offsetof(ShadowGpu, redrawn_rect), sizeof(ShadowGpu::redrawn_rect),
                              sizeof(glm::uvec4), 0};
  e["shadow.window"] = {offsetof(ShadowGpu, window), sizeof(ShadowGpu::window), kVec4, 0};

  e["spot.view_proj"] = {offsetof(SpotShadowGpu, view_proj), kMat4, 0, kVec4};
  e["spot.position_near"] = {offsetof(SpotShadowGpu, position_near), kVec4, 0, 0};
  e["spot.direction_far"] = {offsetof(SpotShadowGpu, direction_far), kVec4, 0, 0};
  e["spot.params"] = {offsetof(SpotShadowGpu, params), kVec4, 0, 0};
  e["spot.info"] = {offsetof(SpotShadowGpu, info), sizeof(glm::uvec4), 0, 0};

  e["point_shadow.face_view_proj"] = {offsetof(PointShadowGpu, face_view_proj),
                                      sizeof(PointShadowGpu::face_view_proj), kMat4, kVec4};
  e["point_shadow.position"] = {offsetof(PointShadowGpu, position), kVec4, 0, 0};
  e["point_shadow.depth_range"] = {offsetof(PointShadowGpu, depth_range), kVec4, 0, 0};
  e["point_shadow.info"] = {offsetof(PointShadowGpu, info), sizeof(glm::uvec4), 0, 0};
  return e;
}

void check_members(const std::vector<shader::BlockMember>& members, const std::string& prefix,
                   const std::map<std::string, Expected>& expected, std::set<std::string>& seen) {
  for (const shader::BlockMember& m : members) {
    const std::string path = prefix.empty() ? m.name : prefix + "." + m.name;
    SCOPED_TRACE(path);
    const auto it = expected.find(path);
    ASSERT_NE(it, expected.end()) << "reflected member without a C++ counterpart";
    seen.insert(path);
    EXPECT_EQ(m.offset, it->second.offset);
    EXPECT_EQ(m.size, it->second.size);
    EXPECT_EQ(m.array_stride, it->second.array_stride);
    EXPECT_EQ(m.matrix_stride, it->second.matrix_stride);
    check_members(m.members, path, expected, seen);
  }
}

class GpuLayout : public testing::TestWithParam<const char*> {};

TEST_P(GpuLayout, MatchesReflection) {
  shader::CompileOptions options;
  options.include_dirs.push_back(PENUMBRA_SHADER_DIR);
  shader::Compiler compiler(options);
  const shader::CompiledShader compiled =
      compiler.compile_source(kShader, "shadow_layout.comp", shader::Stage::compute);
  const shader::Reflection reflection = shader::reflect(compiled.spirv);
  const shader::DescriptorBinding* binding = reflection.find_binding(GetParam());
  ASSERT_NE(binding, nullptr) << shader::to_string(reflection);
  ASSERT_TRUE(binding->block.has_value());
  const shader::Block& block = *binding->block;
  EXPECT_EQ(block.size, sizeof(Blocks));

  const std::map<std::string, Expected> expected = expected_layout();
  std::set<std::string> seen;
  check_members(block.members, "", expected, seen);
  for (const auto& [path, e] : expected) {
    EXPECT_TRUE(seen.count(path)) << path << " not reflected";
  }
  // Array lengths.
  const shader::BlockMember* cascades = block.find("shadow.cascades");
  ASSERT_NE(cascades, nullptr);
  EXPECT_EQ(cascades->array_dims, std::vector<uint32_t>{kMaxCascades});
  const shader::BlockMember* faces = block.find("point_shadow.face_view_proj");
  ASSERT_NE(faces, nullptr);
  EXPECT_EQ(faces->array_dims, std::vector<uint32_t>{6});
  const shader::BlockMember* counts = block.find("shadow.counts");
  ASSERT_NE(counts, nullptr);
  EXPECT_EQ(counts->type, "uvec4");
}

INSTANTIATE_TEST_SUITE_P(Std140AndStd430, GpuLayout, testing::Values("ubo", "ssbo"));

}  // namespace
}  // namespace penumbra::shadow
