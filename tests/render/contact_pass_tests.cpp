// ContactShadowPass on synthetic depth/normal buffers (tests/render/contact_scenes.hpp): the
// push-constant struct against SPIR-V reflection, step_count 0 recording nothing, the R32F depth
// resolve and its bilinear filtering, every scene of issue 6 compared per pixel with the CPU
// reference march (shader_tests/reference/contact_ref.hpp) in both depth conventions, and the
// dual depth read shown to be necessary. Validation is on; any message fails the test.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <contact_scenes.hpp>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <glm/gtc/matrix_transform.hpp>
#include <iostream>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/gpu/resources.hpp>
#include <penumbra/render/contact_shadows.hpp>
#include <penumbra/shader/compiler.hpp>
#include <penumbra/shader/reflection.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <random>
#include <sstream>

namespace penumbra::render {
namespace {

using testing::GpuTest;
using ::testing::HasSubstr;
namespace ref = reference::contact;
using shadow::DepthConvention;
using test::Box;
using test::Plane;
using test::Scene;
using test::View;

// ---- running the pass ----------------------------------------------------------------------

struct Images {
  gpu::Image depth;
  gpu::Image normals;
};

Images upload(gpu::Context& ctx, const ref::Buffers& b) {
  gpu::ImageDesc d;
  d.format = VK_FORMAT_D32_SFLOAT;
  d.width = static_cast<uint32_t>(b.width);
  d.height = static_cast<uint32_t>(b.height);
  Images im{gpu::Image(ctx, d), {}};
  im.depth.upload_floats(b.depth);
  d.format = VK_FORMAT_R32G32B32A32_SFLOAT;
  im.normals = gpu::Image(ctx, d);
  std::vector<glm::vec4> n(b.normals.size());
  for (size_t i = 0; i < n.size(); ++i) n[i] = glm::vec4(b.normals[i], 0.0f);
  im.normals.upload(std::as_bytes(std::span(n)));
  return im;
}

std::vector<float> download_mask(ContactShadowPass& pass) {
  const auto bytes = pass.mask()->download();
  std::vector<float> m(bytes.size());
  for (size_t i = 0; i < m.size(); ++i) m[i] = static_cast<float>(bytes[i]) / 255.0f;
  return m;
}

struct Run {
  std::vector<float> mask;
  ContactShadowGpu params;
};

Run run_pass(gpu::Context& ctx, const ref::Buffers& b, const ContactShadowSettings& settings,
             const ContactShadowFrame& frame, ContactDepthReads reads = ContactDepthReads::dual) {
  ContactShadowPassDesc desc;
  desc.width = static_cast<uint32_t>(b.width);
  desc.height = static_cast<uint32_t>(b.height);
  desc.settings = settings;
  desc.reads = reads;
  ContactShadowPass pass(ctx, desc);
  Images im = upload(ctx, b);
  gpu::submit_one_shot(ctx,
                       [&](VkCommandBuffer cmd) { pass.record(cmd, im.depth, im.normals, frame); });
  return {download_mask(pass), pass.last_params()};
}

ref::Reads to_ref(ContactDepthReads r) {
  switch (r) {
    case ContactDepthReads::bilinear_only:
      return ref::Reads::bilinear_only;
    case ContactDepthReads::nearest_only:
      return ref::Reads::nearest_only;
    default:
      return ref::Reads::dual;
  }
}

// ---- comparing with the reference ----------------------------------------------------------

// An R8_UNORM mask holds round(m * 255) / 255.
constexpr double kMaskTolerance = 0.5 / 255.0 + 1e-3;

struct Comparison {
  int pixels = 0;
  int mismatches = 0;    // gpu outside [mask_lo, mask_hi] by more than kMaskTolerance
  int unexplained = 0;   // mismatches on pixels the reference does not call marginal
  int marginal = 0;      // pixels the reference calls marginal
  int filter_range = 0;  // pixels whose mask the device's bilinear precision leaves open
  int gpu_shadowed = 0, ref_shadowed = 0;  // mask < 0.5
  int partial = 0;                         // ref mask strictly inside (0, 1): edge-faded
  int clamped = 0, clipped = 0, marched = 0;
  // Mismatches by reason (contact_ref.hpp): a tap at a texel edge, a depth at the window's end,
  // a length at a whole pixel; and how many of them straddle a depth discontinuity.
  int at_texel_edge = 0, at_depth_window = 0, at_step_count = 0, at_discontinuity = 0;
  int at_bilinear_weight = 0;
  std::string report;
};

Comparison compare(const std::vector<float>& gpu, const std::vector<ref::PixelResult>& r,
                   int width) {
  Comparison c;
  c.pixels = static_cast<int>(gpu.size());
  std::ostringstream s;
  int listed = 0;
  for (size_t i = 0; i < gpu.size(); ++i) {
    const double want = r[i].mask;
    c.marginal += r[i].marginal;
    c.filter_range += r[i].mask_lo != r[i].mask_hi;
    c.gpu_shadowed += gpu[i] < 0.5f;
    c.ref_shadowed += want < 0.5;
    c.partial += want > 1e-3 && want < 1.0 - 1e-3;
    c.clamped += r[i].ray.steps > 0 && r[i].ray.clamped;
    c.clipped += r[i].ray.steps > 0 && r[i].ray.clipped;
    c.marched += r[i].ray.steps > 0;
    // The reference's mask is an interval where the device may quantise the bilinear weights
    // (contact_ref.hpp): any value in it is right.
    if (gpu[i] < r[i].mask_lo - kMaskTolerance || gpu[i] > r[i].mask_hi + kMaskTolerance) {
      ++c.mismatches;
      if (!r[i].marginal) ++c.unexplained;
      c.at_texel_edge += (r[i].reasons & ref::kTexelEdge) != 0;
      c.at_depth_window += (r[i].reasons & ref::kDepthWindow) != 0;
      c.at_step_count += (r[i].reasons & ref::kStepCount) != 0;
      c.at_discontinuity += (r[i].reasons & ref::kDiscontinuity) != 0;
      c.at_bilinear_weight += (r[i].reasons & ref::kBilinearWeight) != 0;
      if (listed++ < 20) {
        s << "  pixel (" << i % width << ", " << i / width << "): gpu " << gpu[i] << " ref " << want
          << " [" << r[i].mask_lo << ", " << r[i].mask_hi << "]"
          << (r[i].marginal ? " (marginal, reasons " : " (NOT marginal, reasons ") << r[i].reasons
          << ") steps " << r[i].ray.steps << "\n";
      }
    }
  }
  std::ostringstream head;
  head << c.mismatches << " of " << c.pixels << " pixels differ (" << c.unexplained
       << " not marginal; at a texel edge " << c.at_texel_edge << ", at the depth window "
       << c.at_depth_window << ", at a step count " << c.at_step_count << ", at a bilinear weight "
       << c.at_bilinear_weight << "; on a discontinuity " << c.at_discontinuity << "); "
       << c.marginal << " marginal; " << c.filter_range
       << " left open by the filter precision; shadowed gpu " << c.gpu_shadowed << " ref "
       << c.ref_shadowed << "; edge-faded " << c.partial << "; marched " << c.marched
       << ", clamped " << c.clamped << ", clipped " << c.clipped << "\n";
  c.report = head.str() + s.str();
  return c;
}

// The acceptance rule of every scene: no mismatch outside marginal pixels, and at most 0.1% of
// the pixels (at least 2) mismatching at all. A result inside the interval that the device's
// bilinear precision allows (PixelResult::mask_lo, mask_hi) is no mismatch.
void expect_matches_reference(const Comparison& c, const std::string& what) {
  EXPECT_EQ(c.unexplained, 0) << what << ": " << c.report;
  EXPECT_LE(c.mismatches, std::max(2, c.pixels / 1000)) << what << ": " << c.report;
  std::cout << "[ scene    ] " << what << ": " << c.report.substr(0, c.report.find('\n')) << "\n";
}

// ---- the scenes ----------------------------------------------------------------------------

View default_view(DepthConvention depth) {
  View v;
  v.camera.position = {0.0, 1.5, -4.0};
  v.camera.forward = glm::dvec3(0.0, 0.3, 0.0) - v.camera.position;
  v.camera.up = {0.0, 1.0, 0.0};
  v.camera.fov_y = glm::radians(50.0);
  v.camera.aspect = 4.0 / 3.0;
  v.camera.near = 0.1;
  v.camera.far = 100.0;
  v.width = 192;
  v.height = 144;
  v.depth = depth;
  return v;
}

Plane floor_plane() {
  return {{0.0, 0.0, 0.0}, {0.0, 1.0, 0.0}};
}

// The ray these cases were written for (0.5 m, 0.1 m thick), independent of the defaults.
ContactShadowSettings case_settings() {
  ContactShadowSettings s;
  s.max_distance = 0.5f;
  s.thickness = 0.1f;
  return s;
}

struct Case {
  Scene scene;
  View view;
  glm::dvec3 to_light_world{0.0, 1.0, 0.0};
  ContactShadowSettings settings = case_settings();
  uint32_t frame = 0;
};

ContactShadowFrame frame_of(const Case& c) {
  ContactShadowFrame f;
  f.camera = test::contact_camera(c.view);
  f.light_dir_view = to_contact_view(c.view.camera, c.to_light_world);
  f.frame = c.frame;
  return f;
}

// The camera looks along +z from -z; world +x is on the left of the screen.
Case floor_post(DepthConvention depth) {
  Case c;
  c.scene.name = "floor_post";
  c.scene.planes = {floor_plane()};
  c.scene.boxes = {{{-0.06, 0.0, -0.06}, {0.06, 1.2, 0.06}}};
  c.view = default_view(depth);
  c.view.camera.position = {0.0, 1.0, -2.0};
  c.view.camera.forward = glm::dvec3(0.0, 0.3, 0.0) - c.view.camera.position;
  c.to_light_world = test::sun(25.0, 105.0);  // from +x, a little behind the camera
  c.settings.max_distance = 1.0f;
  return c;
}

// A raised platform (x < 0, 0.25 high) whose side wall shadows the lower floor at its foot, and
// whose top edge is seen against the floor far behind it.
Case step_edge(DepthConvention depth) {
  Case c;
  c.scene.name = "step_edge";
  c.scene.planes = {floor_plane()};
  c.scene.boxes = {{{-3.0, 0.0, 0.5}, {0.0, 0.25, 6.0}}};
  c.view = default_view(depth);
  c.view.camera.position = {2.5, 1.5, -1.0};
  c.view.camera.forward = glm::dvec3(0.0, 0.0, 2.5) - c.view.camera.position;
  c.to_light_world = test::sun(30.0, -80.0);  // from -x: over the platform onto the floor
  return c;
}

// The camera looks at the horizon: the upper part of the screen is sky (infinite far plane).
Case sky(DepthConvention depth) {
  Case c;
  c.scene.name = "sky";
  c.scene.planes = {floor_plane()};
  c.scene.boxes = {{{-0.5, 0.0, 2.0}, {0.5, 0.6, 2.4}}, {{1.0, 0.0, 6.0}, {1.3, 2.0, 6.3}}};
  c.view = default_view(depth);
  c.view.camera.position = {0.0, 1.0, -2.0};
  c.view.camera.forward = {0.0, -0.08, 1.0};
  c.view.camera.far = std::numeric_limits<double>::infinity();
  c.to_light_world = test::sun(35.0, -40.0);
  return c;
}

// Boxes lit from -x: the +x faces the camera sees face away from the light.
Case back_facing(DepthConvention depth) {
  Case c;
  c.scene.name = "back_facing";
  c.scene.planes = {floor_plane()};
  c.scene.boxes = {{{-1.2, 0.0, 0.0}, {-0.4, 0.8, 0.8}}, {{0.4, 0.0, -0.5}, {1.2, 0.5, 0.3}}};
  c.view = default_view(depth);
  c.view.camera.position = {3.0, 1.8, -2.5};
  c.view.camera.forward = glm::dvec3(0.0, 0.3, 0.2) - c.view.camera.position;
  c.to_light_world = test::sun(25.0, -100.0);
  return c;
}

// The sun behind the camera: rays head towards the viewer and 3 m of them would cross the
// camera plane; they end on the near plane instead.
Case light_behind_camera(DepthConvention depth) {
  Case c;
  c.scene.name = "light_behind_camera";
  c.scene.planes = {floor_plane()};
  c.scene.boxes = {{{-0.05, 0.0, 0.3}, {0.05, 0.6, 0.4}}, {{0.3, 0.0, -0.3}, {0.5, 0.15, -0.1}}};
  c.view = default_view(depth);
  c.view.camera.position = {0.0, 0.6, -1.0};
  c.view.camera.forward = glm::dvec3(0.0, 0.0, 0.4) - c.view.camera.position;
  c.to_light_world = test::sun(25.0, 170.0);
  c.settings.max_distance = 3.0f;
  return c;
}

// Light from +x: rays run to the left edge of the screen. One post stands just inside the edge
// (its shadow is edge-faded), one just beyond it (its shadow cannot be found on screen).
Case rays_leaving_screen(DepthConvention depth) {
  Case c;
  c.scene.name = "rays_leaving_screen";
  c.scene.planes = {floor_plane()};
  c.scene.boxes = {{{2.75, 0.0, 0.5}, {2.85, 1.5, 0.6}},
                   {{3.4, 0.0, 0.5}, {3.5, 1.5, 0.6}},
                   {{0.6, 0.0, -1.0}, {0.7, 1.0, -0.9}}};
  c.view = default_view(depth);
  c.to_light_world = test::sun(20.0, 95.0);
  c.settings.max_distance = 1.5f;
  c.settings.step_count = 32;
  return c;
}

// The sun 3 degrees above the horizon over low bricks.
Case grazing(DepthConvention depth) {
  Case c;
  c.scene.name = "grazing";
  c.scene.planes = {floor_plane()};
  c.scene.boxes = {{{-0.6, 0.0, 0.0}, {-0.4, 0.1, 0.2}},
                   {{0.3, 0.0, 1.0}, {0.5, 0.1, 1.2}},
                   {{0.8, 0.0, -1.2}, {1.0, 0.1, -1.0}}};
  c.view = default_view(depth);
  c.to_light_world = test::sun(3.0, 70.0);
  return c;
}

// Thin posts 1 m in front of a wall, light from the side: every wall pixel is really lit (the
// posts are out of the rays' reach), but the bilinear read invents a surface between each
// post's silhouette and the wall.
Case silhouettes(DepthConvention depth) {
  Case c;
  c.scene.name = "silhouettes";
  c.scene.planes = {{{0.0, 0.0, 4.0}, {0.0, 0.0, -1.0}}};
  for (int k = -3; k <= 3; ++k) {
    const double x = 0.45 * k;
    c.scene.boxes.push_back({{x - 0.04, -5.0, 2.95}, {x + 0.04, 5.0, 3.0}});
  }
  c.view = default_view(depth);
  c.view.camera.position = {0.0, 0.0, 0.0};
  c.view.camera.forward = {0.0, 0.0, 1.0};
  c.to_light_world = glm::normalize(glm::dvec3(1.0, 0.3, -0.5));
  return c;
}

// An empty floor seen from 0.8 m, the sun 2 degrees high: nothing occludes anything, but the
// nearest read turns the floor into stairs whose risers the grazing rays run into.
Case stairs(DepthConvention depth) {
  Case c;
  c.scene.name = "stairs";
  c.scene.planes = {floor_plane()};
  c.view = default_view(depth);
  c.view.camera.position = {0.0, 0.8, -4.0};
  c.view.camera.forward = glm::dvec3(0.0, 0.0, 0.0) - c.view.camera.position;
  c.to_light_world = test::sun(2.0, 60.0);
  return c;
}

struct Outcome {
  test::Frame frame;
  Run run;
  std::vector<ref::PixelResult> ref;
  Comparison cmp;
  std::vector<bool> truth;  // the ground truth: geometry within max_distance towards the light
};

Outcome evaluate(gpu::Context& ctx, const Case& c,
                 ContactDepthReads reads = ContactDepthReads::dual) {
  Outcome o;
  o.frame = test::render_buffers(c.scene, c.view);
  o.run = run_pass(ctx, o.frame.buffers, c.settings, frame_of(c), reads);
  ref::Params p = test::ref_params(o.run.params);
  // Vulkan lets the device quantise the bilinear weights to subTexelPrecisionBits.
  p.bilinear_weight_error = std::ldexp(1.0, -int(ctx.info().limits.subTexelPrecisionBits));
  o.ref = ref::march(o.frame.buffers, p, to_ref(reads));
  o.cmp = compare(o.run.mask, o.ref, c.view.width);
  o.truth = test::truth_occluded(c.scene, o.frame, c.to_light_world, c.settings.max_distance);
  return o;
}

// With PENUMBRA_CONTACT_DUMP=<dir>, writes <dir>/<name>.ppm: the scene shaded by N.L times the
// mask; red where the mask shadows a pixel the ground truth calls lit, green where the truth
// is occluded and the mask lit. For looking at the results; no assertion reads it.
void dump(const std::string& name, const Outcome& o, glm::dvec3 to_light_view) {
  const char* dir = std::getenv("PENUMBRA_CONTACT_DUMP");
  if (dir == nullptr) return;
  const auto& b = o.frame.buffers;
  std::ofstream f(std::string(dir) + "/" + name + ".ppm", std::ios::binary);
  f << "P6\n" << b.width << " " << b.height << "\n255\n";
  const glm::dvec3 l = glm::normalize(to_light_view);
  const auto byte = [](double v) {
    return static_cast<char>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
  };
  for (size_t i = 0; i < o.run.mask.size(); ++i) {
    double r = 0.55, g = 0.7, bl = 0.95;
    if (!o.frame.sky[i]) {
      const double shade = 0.25 + 0.75 * std::max(glm::dot(glm::dvec3(b.normals[i]), l), 0.0);
      const double m = o.run.mask[i];
      r = g = bl = shade * (0.35 + 0.65 * m);
      if (m < 0.5 && !o.truth[i]) r = 1.0, g *= 0.3, bl *= 0.3;
      if (m >= 0.5 && o.truth[i]) g = 1.0, r *= 0.3, bl *= 0.3;
    }
    f << byte(r) << byte(g) << byte(bl);
  }
}

std::string name_of(DepthConvention d) {
  return d == DepthConvention::reverse_z ? "reverse_z" : "standard";
}

// Pixels the mask darkens (mask < 1 beyond the R8 tolerance) that lie further than `radius`
// pixels from every truly occluded pixel: shadows where there is nothing to cast them.
int stray_shadows(const Outcome& o, int width, int radius) {
  const int height = static_cast<int>(o.run.mask.size()) / width;
  int n = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if (o.run.mask[static_cast<size_t>(y) * width + x] > 1.0 - kMaskTolerance) continue;
      bool near_truth = false;
      for (int dy = -radius; dy <= radius && !near_truth; ++dy) {
        for (int dx = -radius; dx <= radius && !near_truth; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= width || yy >= height) continue;
          near_truth = o.truth[static_cast<size_t>(yy) * width + xx];
        }
      }
      n += !near_truth;
    }
  }
  return n;
}

// The fraction of the truly occluded pixels whose 3x3 neighbourhood is occluded too (away from
// the shadow's outline, where one pixel of offset decides) that the mask shadows (< 0.5).
double interior_recall(const Outcome& o, int width, int* interior = nullptr) {
  const int height = static_cast<int>(o.run.mask.size()) / width;
  int total = 0, found = 0;
  for (int y = 1; y + 1 < height; ++y) {
    for (int x = 1; x + 1 < width; ++x) {
      bool all = true;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          all = all && o.truth[static_cast<size_t>(y + dy) * width + x + dx];
      if (!all) continue;
      ++total;
      found += o.run.mask[static_cast<size_t>(y) * width + x] < 0.5f;
    }
  }
  if (interior) *interior = total;
  return total > 0 ? double(found) / total : 0.0;
}

int count_false_shadows(const Outcome& o) {
  int n = 0;
  for (size_t i = 0; i < o.run.mask.size(); ++i) n += o.run.mask[i] < 0.5f && !o.truth[i];
  return n;
}

// The same for the reference's mask interval: pixels it shadows (< 0.5) for every bilinear read
// the device's filter precision allows (`surely`, mask_hi) or for some (mask_lo), truly lit.
int count_reference_false_shadows(const Outcome& o, bool surely) {
  int n = 0;
  for (size_t i = 0; i < o.ref.size(); ++i)
    n += (surely ? o.ref[i].mask_hi : o.ref[i].mask_lo) < 0.5 && !o.truth[i];
  return n;
}

class ContactPassTest : public GpuTest {};

// ---- the parameter block, the pass's objects, the resolve ----------------------------------

struct LayoutExpectation {
  const char* name;
  uint32_t offset, size;
  const char* type;
};

TEST_F(ContactPassTest, PushConstantStructMatchesSpirvReflection) {
  ContactShadowPassDesc desc;
  desc.width = 8;
  desc.height = 8;
  ContactShadowPass pass(ctx(), desc);
  const shader::Reflection r = shader::reflect(pass.march_spirv());
  ASSERT_TRUE(r.push_constants.has_value()) << shader::to_string(r);
  const shader::Block& block = *r.push_constants;
  ASSERT_EQ(block.members.size(), 1u);
  const shader::BlockMember& params = block.members[0];
  EXPECT_EQ(params.name, "params");
  EXPECT_EQ(params.type, "struct ContactShadowGpu");
  EXPECT_EQ(params.offset, 0u);
  EXPECT_EQ(params.size, sizeof(ContactShadowGpu));
  EXPECT_EQ(block.size, sizeof(ContactShadowGpu));
  const LayoutExpectation expected[] = {
      {"light_dir", offsetof(ContactShadowGpu, light_dir), 16, "vec4"},
      {"extent", offsetof(ContactShadowGpu, extent), 8, "vec2"},
      {"tan_half_fov_y", offsetof(ContactShadowGpu, tan_half_fov_y), 4, "float"},
      {"aspect", offsetof(ContactShadowGpu, aspect), 4, "float"},
      {"near_plane", offsetof(ContactShadowGpu, near_plane), 4, "float"},
      {"far_plane", offsetof(ContactShadowGpu, far_plane), 4, "float"},
      {"max_distance", offsetof(ContactShadowGpu, max_distance), 4, "float"},
      {"thickness", offsetof(ContactShadowGpu, thickness), 4, "float"},
      {"depth_bias", offsetof(ContactShadowGpu, depth_bias), 4, "float"},
      {"intensity", offsetof(ContactShadowGpu, intensity), 4, "float"},
      {"step_exponent", offsetof(ContactShadowGpu, step_exponent), 4, "float"},
      {"edge_fade", offsetof(ContactShadowGpu, edge_fade), 4, "float"},
      {"step_count", offsetof(ContactShadowGpu, step_count), 4, "uint"},
      {"frame", offsetof(ContactShadowGpu, frame), 4, "uint"},
      {"reverse_z", offsetof(ContactShadowGpu, reverse_z), 4, "uint"},
      {"caster_mask", offsetof(ContactShadowGpu, caster_mask), 4, "uint"},
  };
  ASSERT_EQ(params.members.size(), std::size(expected)) << shader::to_string(r);
  for (size_t i = 0; i < std::size(expected); ++i) {
    SCOPED_TRACE(expected[i].name);
    EXPECT_EQ(params.members[i].name, expected[i].name);
    EXPECT_EQ(params.members[i].offset, expected[i].offset);
    EXPECT_EQ(params.members[i].size, expected[i].size);
    EXPECT_EQ(params.members[i].type, expected[i].type);
  }
}

TEST_F(ContactPassTest, StructLayoutIsTheSameUnderStd140AndStd430) {
  shader::CompileOptions options;
  options.include_dirs.push_back(PENUMBRA_SHADER_DIR);
  shader::Compiler compiler(options);
  const auto compiled = compiler.compile_source(R"(#version 460
#include "penumbra/contact_shadows.glsl"
layout(local_size_x = 1) in;
layout(std140, set = 0, binding = 0) uniform Ubo { ContactShadowGpu params; } ubo;
layout(std430, set = 0, binding = 1) buffer Ssbo { ContactShadowGpu params; } ssbo;
void main() { ssbo.params = ubo.params; }
)",
                                                "contact_layout.comp", shader::Stage::compute);
  const shader::Reflection r = shader::reflect(compiled.spirv);
  for (const char* name : {"ubo", "ssbo"}) {
    SCOPED_TRACE(name);
    const shader::DescriptorBinding* b = r.find_binding(name);
    ASSERT_NE(b, nullptr);
    ASSERT_TRUE(b->block.has_value());
    const shader::BlockMember* p = b->block->find("params");
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(p->size, sizeof(ContactShadowGpu));
    for (const char* member : {"light_dir", "extent", "far_plane", "step_count", "caster_mask"}) {
      const shader::BlockMember* m = b->block->find(std::string("params.") + member);
      ASSERT_NE(m, nullptr) << member;
    }
    EXPECT_EQ(b->block->find("params.extent")->offset, offsetof(ContactShadowGpu, extent));
    EXPECT_EQ(b->block->find("params.far_plane")->offset, offsetof(ContactShadowGpu, far_plane));
    EXPECT_EQ(b->block->find("params.step_count")->offset, offsetof(ContactShadowGpu, step_count));
    EXPECT_EQ(b->block->find("params.caster_mask")->offset,
              offsetof(ContactShadowGpu, caster_mask));
  }
}

TEST_F(ContactPassTest, BindingsAndSpecializationConstantsMatchThePipelineLayout) {
  ContactShadowPassDesc desc;
  desc.width = 8;
  desc.height = 8;
  ContactShadowPass pass(ctx(), desc);
  const shader::Reflection march = shader::reflect(pass.march_spirv());
  ASSERT_EQ(march.bindings.size(), 4u) << shader::to_string(march);
  const std::array<std::pair<const char*, shader::DescriptorKind>, 4> want = {{
      {"filtered_depth", shader::DescriptorKind::combined_image_sampler},
      {"scene_depth", shader::DescriptorKind::combined_image_sampler},
      {"scene_normals", shader::DescriptorKind::combined_image_sampler},
      {"contact_mask", shader::DescriptorKind::storage_image},
  }};
  for (uint32_t i = 0; i < 4; ++i) {
    EXPECT_EQ(march.bindings[i].set, 0u);
    EXPECT_EQ(march.bindings[i].binding, i);
    EXPECT_EQ(march.bindings[i].name, want[i].first);
    EXPECT_EQ(march.bindings[i].kind, want[i].second);
  }
  EXPECT_EQ(march.workgroup_size, (std::array<uint32_t, 3>{8, 8, 1}));
  ASSERT_EQ(march.spec_constants.size(), 2u);
  EXPECT_EQ(march.spec_constants[0].id, 0u);
  EXPECT_EQ(march.spec_constants[0].name, "kBilinearRead");
  EXPECT_EQ(march.spec_constants[1].id, 1u);
  EXPECT_EQ(march.spec_constants[1].name, "kNearestRead");

  const shader::Reflection resolve = shader::reflect(pass.resolve_spirv());
  ASSERT_EQ(resolve.bindings.size(), 2u);
  EXPECT_EQ(resolve.bindings[0].kind, shader::DescriptorKind::combined_image_sampler);
  EXPECT_EQ(resolve.bindings[1].kind, shader::DescriptorKind::storage_image);
  EXPECT_FALSE(resolve.push_constants.has_value());
}

TEST_F(ContactPassTest, StepCountZeroCreatesNothingAndRecordsNoDispatch) {
  ref::Buffers b;
  b.width = 16;
  b.height = 8;
  b.depth.assign(16 * 8, 0.5f);
  b.normals.assign(16 * 8, glm::vec3(0, 0, 1));
  Images im = upload(ctx(), b);
  ContactShadowFrame frame;
  frame.light_dir_view = {0.3, 0.5, 0.8};

  ContactShadowPassDesc desc;
  desc.width = 16;
  desc.height = 8;
  desc.settings.step_count = 0;
  ContactShadowPass pass(ctx(), desc);
  EXPECT_FALSE(pass.enabled());
  EXPECT_EQ(pass.pipeline_count(), 0u);
  EXPECT_EQ(pass.mask(), nullptr);
  EXPECT_EQ(pass.resolved_depth(), nullptr);
  EXPECT_EQ(pass.filtered_sampler(), VK_NULL_HANDLE);
  EXPECT_TRUE(pass.march_spirv().empty());
  gpu::submit_one_shot(ctx(),
                       [&](VkCommandBuffer cmd) { pass.record(cmd, im.depth, im.normals, frame); });
  EXPECT_EQ(pass.dispatch_count(), 0u);
  EXPECT_TRUE(pass.recorded_commands().empty());
  // Nothing touched the inputs either.
  EXPECT_EQ(im.depth.layout(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);

  // Turning it on creates the two pipelines and records resolve + march.
  ContactShadowSettings on;
  pass.set_settings(on);
  EXPECT_EQ(pass.pipeline_count(), 2u);
  gpu::submit_one_shot(ctx(),
                       [&](VkCommandBuffer cmd) { pass.record(cmd, im.depth, im.normals, frame); });
  EXPECT_EQ(pass.dispatch_count(), 2u);
  EXPECT_THAT(pass.recorded_commands(),
              ::testing::ElementsAre(
                  "barrier resolved_depth -> GENERAL", "dispatch depth_resolve 2x1x1",
                  "barrier resolved_depth -> SHADER_READ_ONLY", "barrier mask -> GENERAL",
                  "dispatch contact_shadows 2x1x1", "barrier mask -> SHADER_READ_ONLY"));
  // And off again: the objects go away and the next record is empty.
  ContactShadowSettings off;
  off.step_count = 0;
  pass.set_settings(off);
  EXPECT_EQ(pass.pipeline_count(), 0u);
  gpu::submit_one_shot(ctx(),
                       [&](VkCommandBuffer cmd) { pass.record(cmd, im.depth, im.normals, frame); });
  EXPECT_EQ(pass.dispatch_count(), 2u);
  EXPECT_TRUE(pass.recorded_commands().empty());
}

TEST_F(ContactPassTest, InvalidSettingsAndCamerasNameTheField) {
  const auto message = [](auto&& f) -> std::string {
    try {
      f();
    } catch (const Error& e) {
      return e.what();
    }
    return "(no error)";
  };
  ContactShadowSettings s;
  s.step_count = 65;
  EXPECT_THAT(message([&] { validate(s); }), HasSubstr("ContactShadowSettings.step_count = 65"));
  s = {};
  s.thickness = 0.0f;
  EXPECT_THAT(message([&] { validate(s); }), HasSubstr("ContactShadowSettings.thickness = 0"));
  s = {};
  s.intensity = 1.5f;
  EXPECT_THAT(message([&] { validate(s); }), HasSubstr("intensity = 1.5"));
  s = {};
  s.max_distance = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THAT(message([&] { validate(s); }), HasSubstr("max_distance = nan"));
  s = {};
  s.step_exponent = 0.5f;
  EXPECT_THAT(message([&] { validate(s); }), HasSubstr("step_exponent = 0.5"));
  ContactCamera c;
  c.far = c.near;
  EXPECT_THAT(message([&] { validate(c); }), HasSubstr("ContactCamera.far = 0.1"));
  c = {};
  c.near = 1.0;
  c.far = 1.0 + 1e-12;  // distinct in double, equal in float
  EXPECT_THAT(message([&] { validate(c); }), HasSubstr("also when rounded to float"));
  ContactShadowFrame f;
  f.light_dir_view = glm::dvec3(0.0);
  EXPECT_THAT(message([&] { pack_contact_shadow({}, f, 4, 4); }),
              HasSubstr("ContactShadowFrame.light_dir_view"));
  ContactShadowPassDesc d;
  d.width = 4;
  d.height = 4;
  d.settings.edge_fade = 0.75f;
  EXPECT_THAT(message([&] { ContactShadowPass p(ctx(), d); }), HasSubstr("edge_fade = 0.75"));
}

TEST_F(ContactPassTest, PackedParametersFollowTheCamera) {
  shadow::Camera cam;
  cam.fov_y = glm::radians(60.0);
  cam.aspect = 2.0;
  cam.near = 0.25;
  cam.far = std::numeric_limits<double>::infinity();
  ContactShadowFrame f;
  f.camera = ContactCamera::from(cam, DepthConvention::standard);
  f.light_dir_view = {0.0, 3.0, 4.0};
  f.frame = 9;
  const ContactShadowGpu g = pack_contact_shadow({}, f, 640, 320);
  EXPECT_FLOAT_EQ(g.tan_half_fov_y, static_cast<float>(std::tan(glm::radians(30.0))));
  EXPECT_EQ(g.aspect, 2.0f);
  EXPECT_EQ(g.near_plane, 0.25f);
  EXPECT_EQ(g.far_plane, 0.0f);  // infinite
  EXPECT_EQ(g.reverse_z, 0u);
  EXPECT_EQ(g.light_dir, glm::vec4(0.0f, 0.6f, 0.8f, 0.0f));
  EXPECT_EQ(g.extent, glm::vec2(640.0f, 320.0f));
  EXPECT_EQ(g.frame, 9u);
  const ContactShadowSettings defaults;
  EXPECT_EQ(g.step_count, defaults.step_count);
  EXPECT_EQ(g.max_distance, defaults.max_distance);
  EXPECT_EQ(g.thickness, defaults.thickness);
  EXPECT_EQ(g.intensity, defaults.intensity);
  EXPECT_EQ(g.depth_bias, defaults.depth_bias);
  EXPECT_EQ(g.step_exponent, 2.0f);
  EXPECT_EQ(g.edge_fade, defaults.edge_fade);
}

// The pass's view basis is GLM's lookAt rotation (x right, y up, -z forward), which
// depth.glsl assumes.
TEST_F(ContactPassTest, ViewBasisIsGlmLookAt) {
  shadow::Camera cam;
  cam.position = {1.0, 2.0, 3.0};
  cam.forward = {0.3, -0.4, 1.0};
  cam.up = {0.0, 1.0, 0.0};
  const glm::dmat3 basis = contact_view_basis(cam);
  const glm::dmat4 look = glm::lookAt(cam.position, cam.position + cam.forward, cam.up);
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) EXPECT_NEAR(basis[c][r], look[c][r], 1e-12) << c << "," << r;
  const glm::dvec3 fwd = to_contact_view(cam, cam.forward);
  EXPECT_NEAR(fwd.x, 0.0, 1e-12);
  EXPECT_NEAR(fwd.y, 0.0, 1e-12);
  EXPECT_LT(fwd.z, 0.0);
}

TEST_F(ContactPassTest, ResolveCopiesTheDepthBitForBit) {
  const int w = 37, h = 23;  // not multiples of the 8x8 workgroup
  ref::Buffers b;
  b.width = w;
  b.height = h;
  std::mt19937 rng(61);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < w * h; ++i) b.depth.push_back(i % 11 == 0 ? 0.0f : u(rng));
  b.normals.assign(static_cast<size_t>(w) * h, glm::vec3(0, 0, 1));
  Images im = upload(ctx(), b);
  ContactShadowPassDesc desc;
  desc.width = w;
  desc.height = h;
  ContactShadowPass pass(ctx(), desc);
  ContactShadowFrame frame;
  gpu::submit_one_shot(ctx(),
                       [&](VkCommandBuffer cmd) { pass.record(cmd, im.depth, im.normals, frame); });
  const auto bytes = pass.resolved_depth()->download();
  ASSERT_EQ(bytes.size(), b.depth.size() * 4);
  EXPECT_EQ(std::memcmp(bytes.data(), b.depth.data(), bytes.size()), 0);
}

// Samples an image at each uv with the given sampler (textureLod, level 0) on the GPU.
std::vector<float> sample(gpu::Context& ctx, const gpu::Image& image, VkSampler sampler,
                          const std::vector<glm::vec2>& uvs) {
  static shader::Compiler compiler;
  const auto spirv = compiler
                         .compile_source(R"(#version 460
layout(local_size_x = 64) in;
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(std430, set = 0, binding = 1) readonly buffer In { vec2 uv[]; } in_;
layout(std430, set = 0, binding = 2) writeonly buffer Out { float v[]; } out_;
layout(push_constant) uniform Push { uint count; } pc;
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= pc.count) return;
  out_.v[i] = textureLod(tex, in_.uv[i], 0.0).r;
}
)",
                                         "contact_sample.comp", shader::Stage::compute)
                         .spirv;
  gpu::PipelineLayout layout(ctx,
                             {{{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER},
                               {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
                               {2, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER}}},
                             4, VK_SHADER_STAGE_COMPUTE_BIT);
  gpu::ComputePipeline pipeline(ctx, spirv, layout);
  const uint32_t n = static_cast<uint32_t>(uvs.size());
  gpu::Buffer in(ctx, n * 8, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  gpu::Buffer out(ctx, n * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  in.write(std::as_bytes(std::span(uvs)));
  gpu::DescriptorPool pool(ctx);
  VkDescriptorSet set = pool.allocate(layout.set_layout(0));
  gpu::DescriptorWriter()
      .combined_image(0, image.view(), sampler)
      .buffer(1, in.handle())
      .buffer(2, out.handle())
      .update(ctx, set);
  gpu::submit_one_shot(ctx, [&](VkCommandBuffer cmd) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.handle());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout.handle(), 0, 1, &set, 0,
                            nullptr);
    vkCmdPushConstants(cmd, layout.handle(), VK_SHADER_STAGE_COMPUTE_BIT, 0, 4, &n);
    vkCmdDispatch(cmd, (n + 63) / 64, 1, 1);
  });
  return out.read_vector<float>(n);
}

// The bilinear read really filters: the pass's sampler on the resolved R32F image returns the
// average of two texels half-way between their centres and of four at a shared corner, and the
// exact bilinear weights at random points (within 2^-subTexelPrecisionBits of the texels'
// range). A nearest sampler at the same points returns single texels: the test can tell.
TEST_F(ContactPassTest, BilinearReadOfTheResolvedDepthReallyFilters) {
  const int w = 16, h = 12;
  const float fw = 16.0f, fh = 12.0f;
  ref::Buffers b;
  b.width = w;
  b.height = h;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.05f, 1.0f);
  for (int i = 0; i < w * h; ++i) b.depth.push_back(u(rng));
  b.normals.assign(static_cast<size_t>(w) * h, glm::vec3(0, 0, 1));
  Images im = upload(ctx(), b);
  ContactShadowPassDesc desc;
  desc.width = w;
  desc.height = h;
  ContactShadowPass pass(ctx(), desc);
  gpu::submit_one_shot(ctx(), [&](VkCommandBuffer cmd) {
    pass.record(cmd, im.depth, im.normals, ContactShadowFrame{});
  });
  ASSERT_EQ(pass.resolved_depth()->layout(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);

  std::vector<glm::vec2> uvs;
  std::vector<float> two, four;
  for (int y = 0; y < h - 1; ++y) {
    for (int x = 0; x < w - 1; ++x) {
      // Half-way between the centres of (x, y) and (x + 1, y): u = (x + 1) / w.
      uvs.push_back({float(x + 1) / fw, (float(y) + 0.5f) / fh});
      two.push_back(0.5f * (b.at(x, y) + b.at(x + 1, y)));
      // The corner shared by four texels.
      uvs.push_back({float(x + 1) / fw, float(y + 1) / fh});
      four.push_back(0.25f * (b.at(x, y) + b.at(x + 1, y) + b.at(x, y + 1) + b.at(x + 1, y + 1)));
    }
  }
  std::uniform_real_distribution<float> uu(0.0f, 1.0f);
  std::vector<glm::vec2> random_uvs(2000);
  for (auto& p : random_uvs) p = {uu(rng), uu(rng)};
  std::vector<glm::vec2> all = uvs;
  all.insert(all.end(), random_uvs.begin(), random_uvs.end());

  const auto filtered = sample(ctx(), *pass.resolved_depth(), pass.filtered_sampler(), all);
  gpu::Sampler nearest(ctx(), gpu::SamplerDesc{});
  const auto unfiltered = sample(ctx(), *pass.resolved_depth(), nearest.handle(), all);

  int differs_from_nearest = 0;
  double max_exact_error = 0.0, max_random_error = 0.0, max_bound = 0.0;
  for (size_t i = 0; i < uvs.size(); ++i) {
    const float want = (i % 2 == 0) ? two[i / 2] : four[i / 2];
    max_exact_error = std::max(max_exact_error, double(std::fabs(filtered[i] - want)));
    differs_from_nearest += std::fabs(unfiltered[i] - want) > 1e-4f;
  }
  const double weight_error = std::ldexp(1.0, -int(ctx().info().limits.subTexelPrecisionBits));
  for (size_t k = 0; k < random_uvs.size(); ++k) {
    double range = 0.0;
    const double want = ref::bilinear(b, glm::dvec2(random_uvs[k]), &range);
    const double err = std::fabs(filtered[uvs.size() + k] - want);
    const double bound = 2.0 * weight_error * range + 1e-6;
    max_random_error = std::max(max_random_error, err);
    max_bound = std::max(max_bound, bound);
    EXPECT_LE(err, bound) << "uv " << random_uvs[k].x << ", " << random_uvs[k].y;
  }
  // Averages of two and four texels are exact in any sub-texel precision (weights 1/2).
  EXPECT_LE(max_exact_error, 1e-6);
  // The nearest sampler misses almost every average: the check above is not vacuous.
  EXPECT_GE(differs_from_nearest, static_cast<int>(uvs.size()) * 9 / 10);
  std::cout << "[ bilinear ] " << uvs.size() << " half-texel averages: max error "
            << max_exact_error << "; " << differs_from_nearest
            << " of them differ from the nearest read; random points: max error "
            << max_random_error << "\n";
}

// Two different depth buffers through one pass: the descriptor sets of each pair are cached
// and the second frame sees its own depth.
TEST_F(ContactPassTest, RecordsAgainWithOtherImages) {
  const Case c = floor_post(DepthConvention::reverse_z);
  const test::Frame f = test::render_buffers(c.scene, c.view);
  ref::Buffers flat = f.buffers;
  Scene empty = c.scene;
  empty.boxes.clear();
  const test::Frame g = test::render_buffers(empty, c.view);
  ContactShadowPassDesc desc;
  desc.width = static_cast<uint32_t>(c.view.width);
  desc.height = static_cast<uint32_t>(c.view.height);
  desc.settings = c.settings;
  ContactShadowPass pass(ctx(), desc);
  Images a = upload(ctx(), f.buffers);
  Images b = upload(ctx(), g.buffers);
  int shadowed[3] = {0, 0, 0};
  Images* order[3] = {&a, &b, &a};
  for (int k = 0; k < 3; ++k) {
    gpu::submit_one_shot(ctx(), [&](VkCommandBuffer cmd) {
      pass.record(cmd, order[k]->depth, order[k]->normals, frame_of(c));
    });
    for (float m : download_mask(pass)) shadowed[k] += m < 0.5f;
  }
  EXPECT_EQ(pass.dispatch_count(), 6u);
  EXPECT_GT(shadowed[0], 50);
  EXPECT_EQ(shadowed[1], 0);  // an empty floor has nothing to cast contact shadows
  EXPECT_EQ(shadowed[2], shadowed[0]);
}

// ---- the scenes against the reference, both depth conventions ------------------------------

class ContactSceneTest : public GpuTest, public ::testing::WithParamInterface<DepthConvention> {
 protected:
  Outcome run(const Case& c, ContactDepthReads reads = ContactDepthReads::dual) {
    Outcome o = evaluate(ctx(), c, reads);
    dump(c.scene.name + "_" + name_of(GetParam()) +
             (reads == ContactDepthReads::dual            ? ""
              : reads == ContactDepthReads::bilinear_only ? "_bilinear_only"
                                                          : "_nearest_only"),
         o, frame_of(c).light_dir_view);
    return o;
  }
  std::string label(const Case& c) const { return c.scene.name + " " + name_of(GetParam()); }
};

TEST_P(ContactSceneTest, FloorWithThinPostShadowsBehindThePostAndNowhereElse) {
  const Case c = floor_post(GetParam());
  const Outcome o = run(c);
  expect_matches_reference(o.cmp, label(c));
  int interior = 0;
  const double recall = interior_recall(o, c.view.width, &interior);
  const int stray = stray_shadows(o, c.view.width, 2);
  std::cout << "[ semantic ] " << label(c) << ": " << interior << " interior shadow pixels, recall "
            << recall << ", " << stray
            << " shadowed pixels further than 2 px from the true shadow\n";
  EXPECT_GT(interior, 100);
  EXPECT_GE(recall, 0.9);
  EXPECT_EQ(stray, 0);
}

TEST_P(ContactSceneTest, StepEdgeShadowsTheFloorAtItsFoot) {
  const Case c = step_edge(GetParam());
  const Outcome o = run(c);
  expect_matches_reference(o.cmp, label(c));
  int interior = 0;
  const double recall = interior_recall(o, c.view.width, &interior);
  const int stray = stray_shadows(o, c.view.width, 2);
  std::cout << "[ semantic ] " << label(c) << ": " << interior << " interior shadow pixels, recall "
            << recall << ", " << stray
            << " shadowed pixels further than 2 px from the true shadow\n";
  EXPECT_GT(interior, 100);
  EXPECT_GE(recall, 0.9);
  EXPECT_EQ(stray, 0);
}

TEST_P(ContactSceneTest, SkyPixelsAreLit) {
  const Case c = sky(GetParam());
  const Outcome o = run(c);
  expect_matches_reference(o.cmp, label(c));
  int sky_pixels = 0, sky_dark = 0;
  for (size_t i = 0; i < o.run.mask.size(); ++i) {
    if (!o.frame.sky[i]) continue;
    ++sky_pixels;
    sky_dark += o.run.mask[i] != 1.0f;
    EXPECT_EQ(o.ref[i].ray.steps, 0u);
  }
  EXPECT_GT(sky_pixels, c.view.width * c.view.height / 4);
  EXPECT_EQ(sky_dark, 0);
  EXPECT_GT(o.cmp.gpu_shadowed, 0);  // the boxes still shadow the floor
  EXPECT_EQ(stray_shadows(o, c.view.width, 2), 0);
}

TEST_P(ContactSceneTest, BackFacingPixelsAreNotMarched) {
  const Case c = back_facing(GetParam());
  const Outcome o = run(c);
  expect_matches_reference(o.cmp, label(c));
  const glm::dvec3 l = glm::normalize(frame_of(c).light_dir_view);
  int back = 0, back_dark = 0;
  for (size_t i = 0; i < o.run.mask.size(); ++i) {
    if (o.frame.sky[i] || glm::dot(glm::dvec3(o.frame.buffers.normals[i]), l) > 0.0) continue;
    ++back;
    back_dark += o.run.mask[i] != 1.0f;
  }
  std::cout << "[ semantic ] " << label(c) << ": " << back << " back-facing pixels, " << back_dark
            << " not 1\n";
  EXPECT_GT(back, 500);
  EXPECT_EQ(back_dark, 0);
  EXPECT_GT(o.cmp.gpu_shadowed, 0);
}

TEST_P(ContactSceneTest, LightBehindTheCameraEndsRaysOnTheNearPlane) {
  const Case c = light_behind_camera(GetParam());
  const Outcome o = run(c);
  expect_matches_reference(o.cmp, label(c));
  EXPECT_GT(o.cmp.clamped, c.view.width * c.view.height / 2) << o.cmp.report;
  int interior = 0;
  const double recall = interior_recall(o, c.view.width, &interior);
  std::cout << "[ semantic ] " << label(c) << ": " << o.cmp.clamped << " rays clamped, " << interior
            << " interior shadow pixels, recall " << recall << "\n";
  EXPECT_GE(recall, 0.9);
  EXPECT_EQ(stray_shadows(o, c.view.width, 2), 0);
}

TEST_P(ContactSceneTest, RaysLeavingTheScreenStopAtItsEdgeAndFade) {
  const Case c = rays_leaving_screen(GetParam());
  const Outcome o = run(c);
  expect_matches_reference(o.cmp, label(c));
  EXPECT_GT(o.cmp.clipped, 1000) << o.cmp.report;
  // Occluders within edge_fade of the border give fractional masks.
  int faded = 0;
  for (float m : o.run.mask) faded += m > 0.02f && m < 0.98f;
  // The post beyond the screen edge really shadows floor the camera sees; screen space cannot
  // know: those pixels stay lit (the truth-but-lit count below).
  int missed = 0;
  for (size_t i = 0; i < o.run.mask.size(); ++i) missed += o.truth[i] && o.run.mask[i] == 1.0f;
  std::cout << "[ semantic ] " << label(c) << ": " << o.cmp.clipped << " rays clipped, " << faded
            << " edge-faded pixels, " << missed << " truly occluded pixels left lit\n";
  EXPECT_GT(faded, 10);
  EXPECT_GT(missed, 50);
  EXPECT_EQ(stray_shadows(o, c.view.width, 2), 0);
}

TEST_P(ContactSceneTest, GrazingLight) {
  const Case c = grazing(GetParam());
  const Outcome o = run(c);
  expect_matches_reference(o.cmp, label(c));
  const int stray = stray_shadows(o, c.view.width, 3);
  std::cout << "[ semantic ] " << label(c) << ": " << o.cmp.gpu_shadowed << " shadowed, "
            << count_false_shadows(o) << " of them truly lit, " << stray
            << " further than 3 px from the true shadow\n";
  EXPECT_GT(o.cmp.gpu_shadowed, 100);
  EXPECT_EQ(stray, 0);
}

// The noise moves with the frame (golden-ratio offset): frame 7 matches the reference too and
// differs from frame 0 at some shadow edges.
TEST_P(ContactSceneTest, OtherFramesMatchTheReference) {
  Case c = step_edge(GetParam());
  const Outcome first = run(c);
  c.frame = 7;
  const Outcome later = run(c);
  expect_matches_reference(later.cmp, label(c) + " frame 7");
  EXPECT_EQ(later.run.params.frame, 7u);
  int changed = 0;
  for (size_t i = 0; i < first.run.mask.size(); ++i)
    changed += first.run.mask[i] != later.run.mask[i];
  EXPECT_GT(changed, 0);
}

// ---- the dual read -------------------------------------------------------------------------

// Without the nearest read, the bilinear read's invented surfaces between each post's
// silhouette and the wall behind it shadow the wall beside every post; the dual read (and the
// reference) leaves the wall lit.
TEST_P(ContactSceneTest, BilinearReadAloneCastsFalseShadowsAtSilhouettes) {
  const Case c = silhouettes(GetParam());
  const Outcome dual = run(c);
  const Outcome bilinear = run(c, ContactDepthReads::bilinear_only);
  expect_matches_reference(dual.cmp, label(c) + " dual");
  expect_matches_reference(bilinear.cmp, label(c) + " bilinear only (its own reference)");
  int differ = 0;
  for (size_t i = 0; i < dual.run.mask.size(); ++i)
    differ += std::fabs(dual.run.mask[i] - bilinear.run.mask[i]) > kMaskTolerance;
  const int false_dual = count_false_shadows(dual), false_bilinear = count_false_shadows(bilinear);
  // Not an accident of this device's filter: the false shadows the reference casts for every
  // bilinear read the filter precision allows (mask_hi < 0.5), and those the dual read could
  // cast for some (mask_lo < 0.5).
  const int sure_false_bilinear = count_reference_false_shadows(bilinear, true);
  const int possible_false_dual = count_reference_false_shadows(dual, false);
  std::cout << "[ dual     ] " << label(c) << ": false shadows dual " << false_dual
            << ", bilinear only " << false_bilinear << "; " << differ
            << " pixels differ; for any allowed bilinear read: bilinear only at least "
            << sure_false_bilinear << ", dual at most " << possible_false_dual << "\n";
  EXPECT_EQ(false_dual, 0);
  EXPECT_GT(false_bilinear, 500);
  EXPECT_GT(differ, 500);
  EXPECT_GT(sure_false_bilinear, 500);
  EXPECT_EQ(possible_false_dual, 0);
}

// Without the bilinear read, the nearest read's stairs on an empty floor shadow it under
// grazing light; the dual read leaves it lit.
TEST_P(ContactSceneTest, NearestReadAloneCastsStairStepsUnderGrazingLight) {
  const Case c = stairs(GetParam());
  const Outcome dual = run(c);
  const Outcome nearest = run(c, ContactDepthReads::nearest_only);
  expect_matches_reference(dual.cmp, label(c) + " dual");
  int differ = 0;
  for (size_t i = 0; i < dual.run.mask.size(); ++i)
    differ += std::fabs(dual.run.mask[i] - nearest.run.mask[i]) > kMaskTolerance;
  const int false_dual = count_false_shadows(dual), false_nearest = count_false_shadows(nearest);
  // On any device's filter precision (see the silhouettes above).
  const int sure_false_nearest = count_reference_false_shadows(nearest, true);
  const int possible_false_dual = count_reference_false_shadows(dual, false);
  std::cout << "[ dual     ] " << label(c) << ": false shadows dual " << false_dual
            << ", nearest only " << false_nearest << "; " << differ << " pixels differ; "
            << "nearest only vs its own reference: " << nearest.cmp.mismatches << " mismatches ("
            << nearest.cmp.unexplained << " not marginal); for any allowed bilinear read: "
            << "nearest only at least " << sure_false_nearest << ", dual at most "
            << possible_false_dual << "\n";
  EXPECT_EQ(false_dual, 0);
  EXPECT_GT(false_nearest, 1000);
  EXPECT_GT(differ, 1000);
  EXPECT_GT(sure_false_nearest, 1000);
  EXPECT_EQ(possible_false_dual, 0);
  // The single-read variant matches its own reference only up to marginal taps: on stairs,
  // many taps land on the riser's edge.
  EXPECT_EQ(nearest.cmp.unexplained, 0) << nearest.cmp.report;
}

INSTANTIATE_TEST_SUITE_P(BothDepthConventions, ContactSceneTest,
                         ::testing::Values(DepthConvention::reverse_z, DepthConvention::standard),
                         [](const auto& param_info) { return name_of(param_info.param); });

}  // namespace
}  // namespace penumbra::render
