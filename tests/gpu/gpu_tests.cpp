// Tests of src/gpu: device choice, buffers, depth images and compare samplers, compute and
// graphics pipelines, timestamps, and the validation fixture itself.
#include <gmock/gmock.h>
#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/gpu/resources.hpp>
#include <penumbra/shader/compiler.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <random>
#include <span>

namespace penumbra {
namespace {

using testing::GpuTest;
using ::testing::HasSubstr;

shader::Compiler& compiler() {
  static shader::Compiler c;
  return c;
}

std::vector<uint32_t> compute_spirv(std::string_view source) {
  return compiler().compile_source(source, "gpu_tests.comp", shader::Stage::compute).spirv;
}

TEST_F(GpuTest, ReportNamesDeviceDriverAndApi) {
  const auto& info = ctx().info();
  EXPECT_FALSE(info.name.empty());
  EXPECT_FALSE(info.driver_name.empty());
  EXPECT_GE(info.api_version, VK_API_VERSION_1_3);
  const std::string report = ctx().report();
  EXPECT_THAT(report, HasSubstr(info.name));
  EXPECT_THAT(report, HasSubstr("Vulkan " + gpu::api_version_string(info.api_version)));
  EXPECT_THAT(report, HasSubstr("validation:  on"));
  EXPECT_TRUE(ctx().validation_enabled());
}

TEST_F(GpuTest, UnknownDeviceSelectorListsAvailableDevices) {
  gpu::ContextOptions options;
  options.device = "no-such-device-xyz";
  options.validation = false;
  try {
    gpu::Context c(options);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("no-such-device-xyz"));
    EXPECT_THAT(e.what(), HasSubstr(ctx().info().name));
  }
}

TEST_F(GpuTest, DeviceSelectorByIndexAndName) {
  gpu::ContextOptions by_index;
  by_index.device = std::to_string(ctx().info().index);
  by_index.validation = false;
  gpu::Context a(by_index);
  EXPECT_EQ(a.info().name, ctx().info().name);
  gpu::ContextOptions by_name;
  by_name.device = ctx().info().name.substr(0, 4);
  by_name.validation = false;
  gpu::Context b(by_name);
  EXPECT_THAT(b.info().name, HasSubstr(by_name.device));
}

TEST_F(GpuTest, HostAndDeviceBuffersRoundTrip) {
  std::vector<uint32_t> values(1000);
  for (uint32_t i = 0; i < values.size(); ++i) values[i] = i * 2654435761u;
  for (auto use : {gpu::MemoryUse::host, gpu::MemoryUse::device}) {
    gpu::Buffer b(ctx(), values.size() * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, use);
    b.write_span<uint32_t>(values);
    EXPECT_EQ(b.read_vector<uint32_t>(values.size()), values);
  }
  gpu::Buffer small(ctx(), 16, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  std::vector<uint32_t> too_big(5);
  EXPECT_THROW(small.write_span<uint32_t>(too_big), Error);
}

TEST_F(GpuTest, ComputeRoundTrip) {
  const auto spirv = compute_spirv(R"(#version 460
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer In { float x[]; } in_;
layout(std430, set = 0, binding = 1) writeonly buffer Out { float y[]; } out_;
layout(push_constant) uniform Push { uint count; float scale; } pc;
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= pc.count) return;
  out_.y[i] = in_.x[i] * pc.scale + float(i);
}
)");
  gpu::PipelineLayout layout(ctx(), {{{0}, {1}}}, 8, VK_SHADER_STAGE_COMPUTE_BIT);
  gpu::ComputePipeline pipeline(ctx(), spirv, layout);
  const uint32_t n = 10007;  // not a multiple of the workgroup size: the bounds check matters
  std::vector<float> x(n);
  for (uint32_t i = 0; i < n; ++i) x[i] = static_cast<float>(i) * 0.25f - 100.0f;
  gpu::Buffer in(ctx(), n * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  gpu::Buffer out(ctx(), (n + 64) * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  in.write_span<float>(x);
  std::vector<float> sentinel(n + 64, -12345.0f);
  out.write_span<float>(sentinel);
  gpu::DescriptorPool pool(ctx());
  VkDescriptorSet set = pool.allocate(layout.set_layout(0));
  gpu::DescriptorWriter().buffer(0, in.handle()).buffer(1, out.handle()).update(ctx(), set);
  struct {
    uint32_t count;
    float scale;
  } push{n, 3.0f};
  gpu::submit_one_shot(ctx(), [&](VkCommandBuffer cmd) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.handle());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout.handle(), 0, 1, &set, 0,
                            nullptr);
    vkCmdPushConstants(cmd, layout.handle(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    vkCmdDispatch(cmd, (n + 63) / 64, 1, 1);
  });
  const auto y = out.read_vector<float>(n + 64);
  for (uint32_t i = 0; i < n; ++i) ASSERT_EQ(y[i], x[i] * 3.0f + static_cast<float>(i)) << i;
  for (uint32_t i = n; i < n + 64; ++i)
    ASSERT_EQ(y[i], -12345.0f) << "bounds check broken at " << i;
}

TEST_F(GpuTest, SpecializationConstantsReachTheShader) {
  const auto spirv = compute_spirv(R"(#version 460
layout(local_size_x = 1) in;
layout(constant_id = 0) const int kA = 1;
layout(constant_id = 1) const float kB = 1.0;
layout(std430, binding = 0) buffer Out { float y[]; } out_;
void main() { out_.y[0] = float(kA) * kB; }
)");
  gpu::PipelineLayout layout(ctx(), {{{0}}});
  gpu::Specialization spec;
  spec.set<int32_t>(0, 7).set<float>(1, 1.5f);
  gpu::ComputePipeline pipeline(ctx(), spirv, layout, spec);
  gpu::Buffer out(ctx(), 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  gpu::DescriptorPool pool(ctx());
  VkDescriptorSet set = pool.allocate(layout.set_layout(0));
  gpu::DescriptorWriter().buffer(0, out.handle()).update(ctx(), set);
  gpu::submit_one_shot(ctx(), [&](VkCommandBuffer cmd) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.handle());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout.handle(), 0, 1, &set, 0,
                            nullptr);
    vkCmdDispatch(cmd, 1, 1, 1);
  });
  EXPECT_EQ(out.read_vector<float>(1)[0], 10.5f);
}

TEST_F(GpuTest, DepthUploadRoundTripsForEveryKind) {
  struct Case {
    gpu::ImageKind kind;
    uint32_t size, layers;
  };
  for (const Case c :
       {Case{gpu::ImageKind::image_2d, 17, 1}, Case{gpu::ImageKind::image_2d_array, 8, 4},
        Case{gpu::ImageKind::cube, 8, 6}}) {
    gpu::ImageDesc d;
    d.kind = c.kind;
    d.format = VK_FORMAT_D32_SFLOAT;
    d.width = d.height = c.size;
    d.layers = c.layers;
    gpu::Image image(ctx(), d);
    std::vector<float> depth(size_t{c.size} * c.size * c.layers);
    for (size_t i = 0; i < depth.size(); ++i) depth[i] = static_cast<float>(i % 97) / 96.0f;
    image.upload_floats(depth);
    EXPECT_EQ(image.layout(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    const auto bytes = image.download();
    ASSERT_EQ(bytes.size(), depth.size() * 4);
    EXPECT_EQ(std::memcmp(bytes.data(), depth.data(), bytes.size()), 0);
  }
}

// Each generated level is a linear blit of the one above: a bilinear read at the centre of every
// new texel, mapped into the level above (a 2x2 average where the size halves, the middle row
// where 3 rows become 1). The reference computes exactly that, layer by layer, in doubles.
TEST_F(GpuTest, GeneratedMipsAreLinearBlitsOfTheLevelAbove) {
  if (!gpu::mips_supported(ctx(), VK_FORMAT_R32G32_SFLOAT)) {
    GTEST_SKIP() << "rg32f blits with linear filtering are not supported here";
  }
  gpu::ImageDesc d;
  d.kind = gpu::ImageKind::image_2d_array;
  d.format = VK_FORMAT_R32G32_SFLOAT;
  d.width = 8;
  d.height = 6;
  d.layers = 2;
  d.mip_levels = gpu::full_mip_count(d.width, d.height);
  ASSERT_EQ(d.mip_levels, 4u);  // 8x6, 4x3, 2x1, 1x1
  d.usage = VK_IMAGE_USAGE_SAMPLED_BIT;
  gpu::Image image(ctx(), d);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> value(0.0f, 1.0f);
  std::vector<float> level(size_t{d.width} * d.height * d.layers * 2);
  for (float& v : level) v = value(rng);
  image.upload(std::as_bytes(std::span<const float>(level)));
  gpu::submit_one_shot(ctx(), [&](VkCommandBuffer cmd) { image.generate_mips(cmd); });
  EXPECT_EQ(image.layout(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  int w = int(d.width), h = int(d.height);
  for (uint32_t mip = 1; mip < d.mip_levels; ++mip) {
    const int nw = std::max(w / 2, 1), nh = std::max(h / 2, 1);
    std::vector<float> expected(size_t(nw) * nh * d.layers * 2);
    auto at = [&](uint32_t layer, int x, int y, int ch) {
      x = std::clamp(x, 0, w - 1);
      y = std::clamp(y, 0, h - 1);
      return double(level[((size_t(layer) * h + y) * w + x) * 2 + ch]);
    };
    for (uint32_t layer = 0; layer < d.layers; ++layer)
      for (int y = 0; y < nh; ++y)
        for (int x = 0; x < nw; ++x) {
          const double sx = (x + 0.5) * w / nw - 0.5, sy = (y + 0.5) * h / nh - 0.5;
          const int x0 = int(std::floor(sx)), y0 = int(std::floor(sy));
          const double fx = sx - x0, fy = sy - y0;
          for (int ch = 0; ch < 2; ++ch) {
            const double top = at(layer, x0, y0, ch) * (1 - fx) + at(layer, x0 + 1, y0, ch) * fx;
            const double bottom =
                at(layer, x0, y0 + 1, ch) * (1 - fx) + at(layer, x0 + 1, y0 + 1, ch) * fx;
            expected[((size_t(layer) * nh + y) * nw + x) * 2 + ch] =
                float(top * (1 - fy) + bottom * fy);
          }
        }
    const auto bytes = image.download(mip);
    ASSERT_EQ(bytes.size(), expected.size() * sizeof(float)) << "mip " << mip;
    std::vector<float> got(expected.size());
    std::memcpy(got.data(), bytes.data(), bytes.size());
    for (size_t i = 0; i < got.size(); ++i)
      ASSERT_NEAR(got[i], expected[i], 1e-4) << "mip " << mip << ", value " << i;
    level = got;
    w = nw;
    h = nh;
  }
  EXPECT_THROW((void)image.download(d.mip_levels), Error);
}

TEST_F(GpuTest, ImageDescriptionErrorsNameTheProblem) {
  gpu::ImageDesc d;
  d.kind = gpu::ImageKind::cube;
  d.format = VK_FORMAT_D32_SFLOAT;
  d.width = 8;
  d.height = 4;
  d.layers = 6;
  try {
    gpu::Image image(ctx(), d);
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("square"));
  }
  d.height = 8;
  gpu::Image ok(ctx(), d);
  std::vector<float> wrong(10);
  EXPECT_THROW(ok.upload_floats(wrong), Error);
}

// CPU reference of a depth-compare texture read: compare each texel of the footprint with the
// reference, then filter the 0/1 results (Vulkan spec, "Depth Compare Operation" happens before
// filtering). Clamp-to-edge addressing.
bool compare(VkCompareOp op, float ref, float texel) {
  switch (op) {
    case VK_COMPARE_OP_NEVER:
      return false;
    case VK_COMPARE_OP_LESS:
      return ref < texel;
    case VK_COMPARE_OP_EQUAL:
      return ref == texel;
    case VK_COMPARE_OP_LESS_OR_EQUAL:
      return ref <= texel;
    case VK_COMPARE_OP_GREATER:
      return ref > texel;
    case VK_COMPARE_OP_NOT_EQUAL:
      return ref != texel;
    case VK_COMPARE_OP_GREATER_OR_EQUAL:
      return ref >= texel;
    default:
      return true;
  }
}

double reference_compare(const std::vector<float>& depth, int w, int h, int layer, float u, float v,
                         float ref, VkCompareOp op, bool linear) {
  auto texel = [&](int x, int y) {
    x = std::clamp(x, 0, w - 1);
    y = std::clamp(y, 0, h - 1);
    return compare(op, ref, depth[(size_t(layer) * h + y) * w + x]) ? 1.0 : 0.0;
  };
  const double x = double(u) * w, y = double(v) * h;
  if (!linear) return texel(int(std::floor(x)), int(std::floor(y)));
  const double fx = x - 0.5, fy = y - 0.5;
  const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
  const double a = fx - x0, b = fy - y0;
  return (1 - a) * (1 - b) * texel(x0, y0) + a * (1 - b) * texel(x0 + 1, y0) +
         (1 - a) * b * texel(x0, y0 + 1) + a * b * texel(x0 + 1, y0 + 1);
}

// Runs one compare-sampler lookup per case on the GPU: cases are (u, v, layer, ref).
std::vector<float> gpu_compare(gpu::Context& c, const gpu::Image& image, const gpu::Sampler& s,
                               const std::vector<std::array<float, 4>>& cases, bool arrayed) {
  const std::string src = std::string("#version 460\nlayout(local_size_x = 64) in;\n") +
                          (arrayed ? "layout(binding = 0) uniform sampler2DArrayShadow map;\n"
                                   : "layout(binding = 0) uniform sampler2DShadow map;\n") +
                          R"(layout(std430, binding = 1) readonly buffer In { vec4 c[]; } in_;
layout(std430, binding = 2) writeonly buffer Out { float r[]; } out_;
layout(push_constant) uniform Push { uint count; } pc;
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= pc.count) return;
  vec4 q = in_.c[i];
)" +
                          (arrayed ? "  out_.r[i] = texture(map, vec4(q.xy, q.z, q.w));\n}\n"
                                   : "  out_.r[i] = texture(map, vec3(q.xy, q.w));\n}\n");
  const auto spirv = compute_spirv(src);
  gpu::PipelineLayout layout(c,
                             {{{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER},
                               {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
                               {2, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER}}},
                             4, VK_SHADER_STAGE_COMPUTE_BIT);
  gpu::ComputePipeline pipeline(c, spirv, layout);
  const uint32_t n = static_cast<uint32_t>(cases.size());
  gpu::Buffer in(c, n * 16, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  gpu::Buffer out(c, n * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  in.write(std::as_bytes(std::span(cases)));
  gpu::DescriptorPool pool(c);
  VkDescriptorSet set = pool.allocate(layout.set_layout(0));
  gpu::DescriptorWriter()
      .combined_image(0, image.view(), s.handle())
      .buffer(1, in.handle())
      .buffer(2, out.handle())
      .update(c, set);
  gpu::submit_one_shot(c, [&](VkCommandBuffer cmd) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.handle());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout.handle(), 0, 1, &set, 0,
                            nullptr);
    vkCmdPushConstants(cmd, layout.handle(), VK_SHADER_STAGE_COMPUTE_BIT, 0, 4, &n);
    vkCmdDispatch(cmd, (n + 63) / 64, 1, 1);
  });
  return out.read_vector<float>(n);
}

// Every compare op, nearest and linear, 2D and 2D array, against the CPU compare-then-filter
// reference. The linear bound comes from the device's subTexelPrecisionBits: each bilinear weight
// may be quantised by up to 2^-bits, and the filtered 0/1 value moves by at most that much per
// axis, so |gpu - exact| <= 2 * 2^-bits (lavapipe reports 8 bits and is exact; NVIDIA reports 8
// and differs by up to ~0.005).
TEST_F(GpuTest, CompareSamplerMatchesCompareThenFilterReference) {
  const int w = 13, h = 11, layers = 3;
  std::mt19937 rng(1234);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<float> depth(size_t{w} * h * layers);
  for (auto& d : depth) d = unit(rng);
  const double bound =
      2.0 * std::ldexp(1.0, -int(ctx().info().limits.subTexelPrecisionBits)) + 1e-5;

  for (bool arrayed : {false, true}) {
    gpu::ImageDesc d;
    d.kind = arrayed ? gpu::ImageKind::image_2d_array : gpu::ImageKind::image_2d;
    d.format = VK_FORMAT_D32_SFLOAT;
    d.width = w;
    d.height = h;
    d.layers = arrayed ? layers : 1;
    gpu::Image image(ctx(), d);
    image.upload_floats(std::span(depth).first(size_t{w} * h * d.layers));

    std::vector<std::array<float, 4>> cases;
    for (int i = 0; i < 2000; ++i) {
      // Nearest lookups stay 0.1 texel away from texel edges, where the choice of texel is
      // implementation-defined.
      const float tx = std::floor(unit(rng) * w) + 0.1f + 0.8f * unit(rng);
      const float ty = std::floor(unit(rng) * h) + 0.1f + 0.8f * unit(rng);
      const int layer = arrayed ? int(unit(rng) * layers) % layers : 0;
      // Half the references are exact texel values so EQUAL / NOT_EQUAL are exercised.
      float ref = unit(rng);
      if (i % 2 == 0)
        ref = depth[(size_t(layer) * h + std::min(int(ty), h - 1)) * w + std::min(int(tx), w - 1)];
      cases.push_back({tx / w, ty / h, float(layer), ref});
    }
    for (VkFilter filter : {VK_FILTER_NEAREST, VK_FILTER_LINEAR}) {
      for (int op = VK_COMPARE_OP_NEVER; op <= VK_COMPARE_OP_ALWAYS; ++op) {
        gpu::SamplerDesc sd;
        sd.filter = filter;
        sd.compare = true;
        sd.compare_op = static_cast<VkCompareOp>(op);
        gpu::Sampler sampler(ctx(), sd);
        const auto got = gpu_compare(ctx(), image, sampler, cases, arrayed);
        int failures = 0;
        double worst = 0;
        for (size_t i = 0; i < cases.size(); ++i) {
          const auto& q = cases[i];
          const double want = reference_compare(depth, w, h, int(q[2]), q[0], q[1], q[3],
                                                sd.compare_op, filter == VK_FILTER_LINEAR);
          const double err = std::abs(double(got[i]) - want);
          worst = std::max(worst, err);
          const double tol = filter == VK_FILTER_LINEAR ? bound : 0.0;
          if (err > tol && ++failures <= 5) {
            ADD_FAILURE() << (arrayed ? "2D array" : "2D") << " "
                          << (filter == VK_FILTER_LINEAR ? "linear" : "nearest") << " "
                          << gpu::compare_op_name(sd.compare_op) << " case " << i << ": uv=("
                          << q[0] << ", " << q[1] << ") layer " << q[2] << " ref " << q[3]
                          << " got " << got[i] << " want " << want;
          }
        }
        EXPECT_EQ(failures, 0) << "worst error " << worst;
      }
    }
  }
}

TEST_F(GpuTest, CubeDepthCompareHitsTheRightFace) {
  const uint32_t size = 4;
  gpu::ImageDesc d;
  d.kind = gpu::ImageKind::cube;
  d.format = VK_FORMAT_D32_SFLOAT;
  d.width = d.height = size;
  d.layers = 6;
  gpu::Image image(ctx(), d);
  std::vector<float> depth(size * size * 6);
  for (uint32_t f = 0; f < 6; ++f)
    for (uint32_t i = 0; i < size * size; ++i) depth[f * size * size + i] = 0.1f + 0.15f * float(f);
  image.upload_floats(depth);
  gpu::SamplerDesc sd;
  sd.compare = true;
  sd.compare_op = VK_COMPARE_OP_LESS;  // 1 when ref < stored depth
  gpu::Sampler sampler(ctx(), sd);
  const auto spirv = compute_spirv(R"(#version 460
layout(local_size_x = 1) in;
layout(binding = 0) uniform samplerCubeShadow map;
layout(std430, binding = 1) writeonly buffer Out { float r[]; } out_;
const vec3 kDirs[6] = vec3[](vec3(1,0,0), vec3(-1,0,0), vec3(0,1,0), vec3(0,-1,0), vec3(0,0,1), vec3(0,0,-1));
void main() {
  for (int f = 0; f < 6; ++f)
    for (int k = 0; k < 7; ++k)
      out_.r[f * 7 + k] = texture(map, vec4(kDirs[f], 0.05 + 0.15 * float(k)));
}
)");
  gpu::PipelineLayout layout(ctx(), {{{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER}, {1}}});
  gpu::ComputePipeline pipeline(ctx(), spirv, layout);
  gpu::Buffer out(ctx(), 42 * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  gpu::DescriptorPool pool(ctx());
  VkDescriptorSet set = pool.allocate(layout.set_layout(0));
  gpu::DescriptorWriter()
      .combined_image(0, image.view(), sampler.handle())
      .buffer(1, out.handle())
      .update(ctx(), set);
  gpu::submit_one_shot(ctx(), [&](VkCommandBuffer cmd) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.handle());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout.handle(), 0, 1, &set, 0,
                            nullptr);
    vkCmdDispatch(cmd, 1, 1, 1);
  });
  const auto r = out.read_vector<float>(42);
  for (int f = 0; f < 6; ++f)
    for (int k = 0; k < 7; ++k) {
      const float ref = 0.05f + 0.15f * float(k), stored = 0.1f + 0.15f * float(f);
      EXPECT_EQ(r[f * 7 + k], ref < stored ? 1.0f : 0.0f) << "face " << f << " ref " << ref;
    }
}

TEST_F(GpuTest, GraphicsPipelineWithDynamicRenderingWritesDepthAndColor) {
  const auto vs = compiler()
                      .compile_source(R"(#version 460
const vec2 kPos[3] = vec2[](vec2(-1,-1), vec2(1,-1), vec2(-1,1));
void main() { gl_Position = vec4(kPos[gl_VertexIndex], 0.25, 1.0); }
)",
                                      "tri.vert", shader::Stage::vertex)
                      .spirv;
  const auto fs = compiler()
                      .compile_source(R"(#version 460
layout(location = 0) out vec4 color;
void main() { color = vec4(1.0, 0.5, 0.0, 1.0); }
)",
                                      "tri.frag", shader::Stage::fragment)
                      .spirv;
  const uint32_t size = 32;
  gpu::ImageDesc cd;
  cd.format = VK_FORMAT_R8G8B8A8_UNORM;
  cd.width = cd.height = size;
  cd.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
  gpu::Image color(ctx(), cd);
  gpu::ImageDesc dd = cd;
  dd.format = VK_FORMAT_D32_SFLOAT;
  dd.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
  gpu::Image depth(ctx(), dd);
  gpu::PipelineLayout layout(ctx(), {});
  gpu::GraphicsPipelineDesc desc;
  desc.vertex_spirv = vs;
  desc.fragment_spirv = fs;
  desc.color_formats = {VK_FORMAT_R8G8B8A8_UNORM};
  desc.depth_format = VK_FORMAT_D32_SFLOAT;
  desc.cull = VK_CULL_MODE_NONE;
  gpu::GraphicsPipeline pipeline(ctx(), desc, layout);
  gpu::submit_one_shot(ctx(), [&](VkCommandBuffer cmd) {
    color.transition(cmd, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
    depth.transition(cmd, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
    VkRenderingAttachmentInfo ca{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    ca.imageView = color.view();
    ca.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    ca.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    ca.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    ca.clearValue.color = {{0, 0, 0, 0}};
    VkRenderingAttachmentInfo da{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    da.imageView = depth.view();
    da.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    da.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    da.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    da.clearValue.depthStencil = {0.0f, 0};  // reverse-Z: far is 0
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = {{0, 0}, {size, size}};
    ri.layerCount = 1;
    ri.colorAttachmentCount = 1;
    ri.pColorAttachments = &ca;
    ri.pDepthAttachment = &da;
    vkCmdBeginRendering(cmd, &ri);
    VkViewport vp{0, 0, float(size), float(size), 0, 1};
    VkRect2D sc{{0, 0}, {size, size}};
    vkCmdSetViewport(cmd, 0, 1, &vp);
    vkCmdSetScissor(cmd, 0, 1, &sc);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.handle());
    vkCmdDraw(cmd, 3, 1, 0, 0);
    vkCmdEndRendering(cmd);
  });
  color.assume_layout(VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
  depth.assume_layout(VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
  const auto px = color.download();
  const auto dz = depth.download();
  const float* z = reinterpret_cast<const float*>(dz.data());
  int covered = 0;
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x) {
      const size_t i = y * size + x;
      const bool inside = x + y + 1 < size;  // strictly below the diagonal x + y = size - 1
      const bool outside = x + y > size - 1;
      if (inside) {
        EXPECT_EQ(px[i * 4 + 0], std::byte{255}) << x << "," << y;
        EXPECT_EQ(z[i], 0.25f) << x << "," << y;
        ++covered;
      } else if (outside) {
        EXPECT_EQ(px[i * 4 + 0], std::byte{0}) << x << "," << y;
        EXPECT_EQ(z[i], 0.0f) << x << "," << y;
      }
    }
  EXPECT_EQ(covered, int(size * (size - 1) / 2));
}

TEST_F(GpuTest, TimestampsAreMonotonicAndInNanoseconds) {
  ASSERT_GT(ctx().info().timestamp_valid_bits, 0u);
  const auto spirv = compute_spirv(R"(#version 460
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer B { float v[]; } b;
void main() {
  float x = float(gl_GlobalInvocationID.x);
  for (int i = 0; i < 2000; ++i) x = sin(x) * 1.0001 + 0.5;
  b.v[gl_GlobalInvocationID.x] = x;
}
)");
  gpu::PipelineLayout layout(ctx(), {{{0}}});
  gpu::ComputePipeline pipeline(ctx(), spirv, layout);
  const uint32_t n = 64 * 256;
  gpu::Buffer buf(ctx(), n * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  gpu::DescriptorPool pool(ctx());
  VkDescriptorSet set = pool.allocate(layout.set_layout(0));
  gpu::DescriptorWriter().buffer(0, buf.handle()).update(ctx(), set);
  gpu::TimestampPool ts(ctx(), 3);
  gpu::submit_one_shot(ctx(), [&](VkCommandBuffer cmd) {
    ts.reset(cmd);
    ts.write(cmd, 0, VK_PIPELINE_STAGE_2_TOP_OF_PIPE_BIT);
    ts.write(cmd, 1, VK_PIPELINE_STAGE_2_BOTTOM_OF_PIPE_BIT);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.handle());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout.handle(), 0, 1, &set, 0,
                            nullptr);
    vkCmdDispatch(cmd, n / 64, 1, 1);
    ts.write(cmd, 2, VK_PIPELINE_STAGE_2_BOTTOM_OF_PIPE_BIT);
  });
  const auto ns = ts.read_ns(3);
  EXPECT_LE(ns[0], ns[1]);
  EXPECT_LE(ns[1], ns[2]);
  const double work = ns[2] - ns[0];
  // 32M sin() evaluations take far more than 1 µs on any device and far less than a minute:
  // a unit error (ticks vs ns, a wrong period) would land outside this window.
  EXPECT_GT(work, 1e3);
  EXPECT_LT(work, 60e9);
  EXPECT_THROW(ts.write(VK_NULL_HANDLE, 3), Error);
}

// The fixture's own guarantee: a deliberate misuse produces a validation error, and the check
// the fixture runs turns it into a test failure. The misuse must be harmless to every driver
// (the layer reports it and still calls down): anisotropic filtering without enabling the
// samplerAnisotropy feature is one; a driver simply creates the sampler.
TEST_F(GpuTest, ValidationFixtureCatchesDeliberateMisuse) {
  EXPECT_NONFATAL_FAILURE(
      {
        VkSamplerCreateInfo si{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
        si.magFilter = si.minFilter = VK_FILTER_LINEAR;
        si.anisotropyEnable = VK_TRUE;  // the feature was not enabled on the device
        si.maxAnisotropy = 4.0f;
        si.maxLod = 1.0f;
        VkSampler sampler = VK_NULL_HANDLE;
        vkCreateSampler(testing::shared_context().device(), &si, nullptr, &sampler);
        if (sampler != VK_NULL_HANDLE)
          vkDestroySampler(testing::shared_context().device(), sampler, nullptr);
        testing::fail_on_validation_messages(testing::shared_context());
      },
      "VUID-VkSamplerCreateInfo-anisotropyEnable");
  EXPECT_EQ(ctx().validation_sink().count(), 0u);
}

}  // namespace
}  // namespace penumbra
