#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <penumbra/shader/compiler.hpp>
#include <penumbra/shader/reflection.hpp>
#include <string>

namespace penumbra::shader {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

fs::path data(const std::string& name) {
  return fs::path(PENUMBRA_TEST_DATA_DIR) / "shader" / name;
}

Reflection reflect_file(const std::string& name) {
  Compiler compiler;
  return reflect(compiler.compile_file(data(name)).spirv);
}

Reflection reflect_source(const std::string& source, Stage stage = Stage::compute) {
  Compiler compiler;
  return reflect(compiler.compile_source(source, "inline", stage).spirv);
}

struct Expected {
  const char* path;
  const char* type;
  uint32_t offset;
  uint32_t size;
  std::vector<uint32_t> dims;
  uint32_t array_stride;
  uint32_t matrix_stride;
};

void expect_members(const Block& block, const std::vector<Expected>& expected) {
  for (const Expected& e : expected) {
    SCOPED_TRACE(std::string(block.type_name) + "." + e.path);
    const BlockMember* m = block.find(e.path);
    ASSERT_NE(m, nullptr);
    EXPECT_EQ(m->type, e.type);
    EXPECT_EQ(m->offset, e.offset);
    EXPECT_EQ(m->size, e.size);
    EXPECT_EQ(m->array_dims, e.dims);
    EXPECT_EQ(m->array_stride, e.array_stride);
    EXPECT_EQ(m->matrix_stride, e.matrix_stride);
  }
}

// Inner { vec3 dir; float weight; }: dir 0 (12 bytes), weight packs into its last 4 bytes at 12,
// size 16, alignment 16 (of the vec3) in both std140 and std430.
// Light { vec3 color; float intensity; Inner inner[2]; mat3 basis; } in both layouts:
// color 0, intensity 12, inner at 16 (stride 16, 32 bytes), basis at 48 (three vec3 columns with
// stride 16 = 48 bytes), size 96, alignment 16.
const std::vector<Expected> kInnerAndLight = {
    {"s.dir", "vec3", 0, 12, {}, 0, 0},
    {"s.weight", "float", 12, 4, {}, 0, 0},
    {"lights.color", "vec3", 0, 12, {}, 0, 0},
    {"lights.intensity", "float", 12, 4, {}, 0, 0},
    {"lights.inner", "struct Inner", 16, 32, {2}, 16, 0},
    {"lights.inner.dir", "vec3", 0, 12, {}, 0, 0},
    {"lights[1].inner[0].weight", "float", 12, 4, {}, 0, 0},
    {"lights.basis", "mat3", 48, 48, {}, 0, 16},
};

TEST(ShaderReflection, Std140UniformBlock) {
  const Reflection r = reflect_file("reflect_layout.comp");
  const DescriptorBinding* b = r.find_binding("params");
  ASSERT_NE(b, nullptr);
  EXPECT_EQ(b, r.find_binding("Params"));
  EXPECT_EQ(b->kind, DescriptorKind::uniform_buffer);
  EXPECT_EQ(b->set, 0u);
  EXPECT_EQ(b->binding, 0u);
  EXPECT_EQ(b->count, 1u);
  EXPECT_EQ(b->name, "params");
  ASSERT_TRUE(b->block);
  const Block& block = *b->block;
  EXPECT_EQ(block.type_name, "Params");
  EXPECT_EQ(block.instance_name, "params");
  // std140 by hand:
  //   vec3 a          offset 0, 12 bytes (align 16)
  //   float b         offset 12 (a scalar fits after a vec3)
  //   mat3 m          align 16 -> 16; 3 columns, stride rounded to vec4 = 16 -> 48 bytes
  //   float f[3]      array element stride rounded up to 16 -> offset 64, 48 bytes
  //   vec3 v[2]       stride 16 -> offset 112, 32 bytes
  //   Inner s         struct align rounded to 16 -> offset 144, 16 bytes
  //   Light lights[2] align 16 -> offset 160, stride 96, 192 bytes
  //   float tail      offset 352
  //   vec2 uv         align 8 -> offset 360, 8 bytes; block size 368
  expect_members(block, {
                            {"a", "vec3", 0, 12, {}, 0, 0},
                            {"b", "float", 12, 4, {}, 0, 0},
                            {"m", "mat3", 16, 48, {}, 0, 16},
                            {"f", "float", 64, 48, {3}, 16, 0},
                            {"v", "vec3", 112, 32, {2}, 16, 0},
                            {"s", "struct Inner", 144, 16, {}, 0, 0},
                            {"lights", "struct Light", 160, 192, {2}, 96, 0},
                            {"tail", "float", 352, 4, {}, 0, 0},
                            {"uv", "vec2", 360, 8, {}, 0, 0},
                        });
  expect_members(block, kInnerAndLight);
  EXPECT_EQ(block.size, 368u);
  ASSERT_EQ(block.members.size(), 9u);
  EXPECT_EQ(block.members[6].members.size(), 4u);
  EXPECT_EQ(block.find("nope"), nullptr);
  EXPECT_EQ(block.find("lights.nope"), nullptr);
}

TEST(ShaderReflection, Std430StorageBlock) {
  const Reflection r = reflect_file("reflect_layout.comp");
  const DescriptorBinding* b = r.find_binding("data");
  ASSERT_NE(b, nullptr);
  EXPECT_EQ(b->kind, DescriptorKind::storage_buffer);
  EXPECT_EQ(b->set, 0u);
  EXPECT_EQ(b->binding, 1u);
  ASSERT_TRUE(b->block);
  const Block& block = *b->block;
  EXPECT_EQ(block.type_name, "Data");
  // std430 by hand:
  //   vec3 a          offset 0, 12 bytes
  //   float b         offset 12
  //   mat3 m          column vec3 aligns to 16 -> offset 16, matrix stride 16, 48 bytes
  //   float f[3]      stride 4 (no rounding in std430) -> offset 64, 12 bytes
  //   vec3 v[2]       76 aligned to 16 -> 80, stride 16, 32 bytes
  //   Inner s         align 16 -> 112, 16 bytes
  //   Light lights[2] align 16 -> 128, stride 96, 192 bytes
  //   float tail      320
  //   vec2 uv         324 aligned to 8 -> 328
  //   float rt[]      336, stride 4, runtime (size 0); block size 336
  expect_members(block, {
                            {"a", "vec3", 0, 12, {}, 0, 0},
                            {"b", "float", 12, 4, {}, 0, 0},
                            {"m", "mat3", 16, 48, {}, 0, 16},
                            {"f", "float", 64, 12, {3}, 4, 0},
                            {"v", "vec3", 80, 32, {2}, 16, 0},
                            {"s", "struct Inner", 112, 16, {}, 0, 0},
                            {"lights", "struct Light", 128, 192, {2}, 96, 0},
                            {"tail", "float", 320, 4, {}, 0, 0},
                            {"uv", "vec2", 328, 8, {}, 0, 0},
                            {"rt", "float", 336, 0, {0}, 4, 0},
                        });
  expect_members(block, kInnerAndLight);
  EXPECT_EQ(block.size, 336u);
}

TEST(ShaderReflection, PushConstants) {
  const Reflection r = reflect_file("reflect_layout.comp");
  ASSERT_TRUE(r.push_constants);
  EXPECT_EQ(r.push_constants->type_name, "Push");
  EXPECT_EQ(r.push_constants->instance_name, "pc");
  // std430: mat4 0 (64 bytes, matrix stride 16), vec4 64, uint 80, float 84; size 88.
  expect_members(*r.push_constants, {
                                        {"view_proj", "mat4", 0, 64, {}, 0, 16},
                                        {"tint", "vec4", 64, 16, {}, 0, 0},
                                        {"count", "uint", 80, 4, {}, 0, 0},
                                        {"bias", "float", 84, 4, {}, 0, 0},
                                    });
  EXPECT_EQ(r.push_constants->size, 88u);
  // Push constants are not descriptors.
  EXPECT_EQ(r.find_binding("pc"), nullptr);
  EXPECT_EQ(r.bindings.size(), 2u);
}

TEST(ShaderReflection, WorkgroupSizeAndSpecConstants) {
  const Reflection r = reflect_file("reflect_layout.comp");
  EXPECT_EQ(r.workgroup_size, (std::array<uint32_t, 3>{8, 4, 2}));
  ASSERT_EQ(r.spec_constants.size(), 3u);
  EXPECT_EQ(r.spec_constants[0].id, 0u);
  EXPECT_EQ(r.spec_constants[0].name, "kTaps");
  EXPECT_EQ(r.spec_constants[0].type, "uint");
  EXPECT_EQ(r.spec_constants[1].id, 3u);
  EXPECT_EQ(r.spec_constants[1].name, "kRadius");
  EXPECT_EQ(r.spec_constants[1].type, "float");
  EXPECT_EQ(r.spec_constants[2].id, 5u);
  EXPECT_EQ(r.spec_constants[2].name, "kReverseZ");
  EXPECT_EQ(r.spec_constants[2].type, "bool");
}

TEST(ShaderReflection, WorkgroupSizeFromSpecConstantUsesDefault) {
  const Reflection r = reflect_source(
      "#version 460\n"
      "layout(local_size_x = 32, local_size_x_id = 4, local_size_y = 2) in;\n"
      "void main() {}\n");
  EXPECT_EQ(r.workgroup_size, (std::array<uint32_t, 3>{32, 2, 1}));
  // The workgroup-size spec constant has no name. (Note: a separate
  // `layout(constant_id = 4) const int k = 32;` would NOT set the default: glslang emits it as a
  // second constant with the same SpecId and leaves the size at local_size_x, 1 by default.)
  ASSERT_EQ(r.spec_constants.size(), 1u);
  EXPECT_EQ(r.spec_constants[0].id, 4u);
  EXPECT_EQ(r.spec_constants[0].type, "uint");
}

TEST(ShaderReflection, MultiDimensionalArraysOutermostFirst) {
  const std::string body =
      " buffer B { float grid[2][3]; vec2 pairs[4]; } b;\n"
      "layout(local_size_x = 1) in;\nvoid main() { b.grid[1][2] = b.pairs[3].y; }\n";
  {
    // std430: float[3] is 12 bytes, so the outer stride is 12 and grid takes 24 bytes;
    // vec2 pairs[4] at 24 (align 8), stride 8, 32 bytes; block 56.
    const Reflection r = reflect_source("#version 460\nlayout(std430, binding = 0)" + body);
    const Block& block = *r.find_binding("b")->block;
    expect_members(block,
                   {{"grid", "float", 0, 24, {2, 3}, 12, 0}, {"pairs", "vec2", 24, 32, {4}, 8, 0}});
    EXPECT_EQ(block.size, 56u);
  }
  {
    // std140: inner float[3] has stride 16 -> 48 bytes, outer stride 48, grid 96 bytes;
    // vec2 pairs[4] stride rounded to 16 -> at 96, 64 bytes; block 160.
    const Reflection r = reflect_source("#version 460\nlayout(std140, binding = 0)" + body);
    const Block& block = *r.find_binding("B")->block;
    expect_members(
        block, {{"grid", "float", 0, 96, {2, 3}, 48, 0}, {"pairs", "vec2", 96, 64, {4}, 16, 0}});
    EXPECT_EQ(block.size, 160u);
  }
}

TEST(ShaderReflection, ImageBindings) {
  const Reflection r = reflect_file("reflect_images.frag");
  struct ExpectedImage {
    const char* name;
    uint32_t set, binding;
    DescriptorKind kind;
    uint32_t count;
    int dim;
    bool arrayed, depth;
  };
  const std::vector<ExpectedImage> expected = {
      {"shadow_map", 1, 0, DescriptorKind::combined_image_sampler, 1, 2, false, true},
      {"cascades", 1, 1, DescriptorKind::combined_image_sampler, 1, 2, true, true},
      {"environment", 1, 2, DescriptorKind::combined_image_sampler, 1, 6, false, false},
      {"point_shadow", 1, 3, DescriptorKind::combined_image_sampler, 1, 6, false, true},
      {"albedo", 1, 4, DescriptorKind::sampled_image, 1, 2, false, false},
      {"linear_sampler", 1, 5, DescriptorKind::sampler, 1, 0, false, false},
      {"textures", 1, 6, DescriptorKind::combined_image_sampler, 4, 2, false, false},
      {"volume", 1, 7, DescriptorKind::combined_image_sampler, 1, 3, false, false},
      {"mask", 2, 0, DescriptorKind::storage_image, 1, 2, false, false},
  };
  ASSERT_EQ(r.bindings.size(), expected.size()) << to_string(r);
  for (size_t i = 0; i < expected.size(); ++i) {
    const ExpectedImage& e = expected[i];
    SCOPED_TRACE(e.name);
    const DescriptorBinding& b = r.bindings[i];  // sorted by (set, binding)
    EXPECT_EQ(b.name, e.name);
    EXPECT_EQ(r.find_binding(e.name), &b);
    EXPECT_EQ(b.set, e.set);
    EXPECT_EQ(b.binding, e.binding);
    EXPECT_EQ(b.kind, e.kind);
    EXPECT_EQ(b.count, e.count);
    EXPECT_EQ(b.image_dim, e.dim);
    EXPECT_EQ(b.image_arrayed, e.arrayed);
    EXPECT_EQ(b.image_depth, e.depth);
    EXPECT_FALSE(b.block);
  }
  EXPECT_FALSE(r.push_constants);
  EXPECT_THAT(r.spec_constants, IsEmpty());
  EXPECT_EQ(r.workgroup_size, (std::array<uint32_t, 3>{1, 1, 1}));
}

TEST(ShaderReflection, DumpMentionsEverything) {
  const std::string dump = to_string(reflect_file("reflect_layout.comp"));
  EXPECT_THAT(dump, HasSubstr("workgroup_size 8 4 2"));
  EXPECT_THAT(dump, HasSubstr("set 0 binding 0: uniform_buffer params"));
  EXPECT_THAT(dump, HasSubstr("struct Light lights[2]  offset=160 size=192 array_stride=96"));
  EXPECT_THAT(dump, HasSubstr("float rt[]  offset=336 size=0 array_stride=4"));
  EXPECT_THAT(dump, HasSubstr("push_constants"));
  EXPECT_THAT(dump, HasSubstr("spec_constant 3: float kRadius"));
}

TEST(ShaderReflection, InvalidSpirvIsAnError) {
  EXPECT_THROW(reflect({1, 2, 3}), penumbra::Error);
  EXPECT_THROW(reflect({}), penumbra::Error);
}

}  // namespace
}  // namespace penumbra::shader
