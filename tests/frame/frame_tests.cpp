// Full-frame checks: every shipped scene renders headless with zero validation messages into a
// plausible image; the renderer builds only what a scene requires; the frame structs match the
// GLSL blocks.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <functional>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <penumbra/render/frame_types.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/scene/scene.hpp>
#include <penumbra/shader/compiler.hpp>
#include <penumbra/shader/reflection.hpp>
#include <penumbra/testing/gpu_test.hpp>

namespace penumbra {
namespace {

using testing::GpuTest;
using ::testing::HasSubstr;

constexpr uint32_t kWidth = 320, kHeight = 180;

struct ImageStats {
  double mean = 0, stddev = 0;
  size_t distinct_rows = 0;
};

ImageStats stats(const std::vector<uint8_t>& rgba) {
  ImageStats s;
  const size_t n = rgba.size() / 4;
  double sum = 0, sum2 = 0;
  for (size_t i = 0; i < n; ++i) {
    const double l = 0.2126 * rgba[i * 4] + 0.7152 * rgba[i * 4 + 1] + 0.0722 * rgba[i * 4 + 2];
    sum += l;
    sum2 += l * l;
  }
  s.mean = sum / double(n);
  s.stddev = std::sqrt(std::max(0.0, sum2 / double(n) - s.mean * s.mean));
  return s;
}

scene::Scene small(std::string_view name) {
  auto s = scene::load_scene(scene::find_scene(name));
  s.render.width = kWidth;
  s.render.height = kHeight;
  return s;
}

class FrameTest : public GpuTest {};

class ShippedScene : public FrameTest, public ::testing::WithParamInterface<std::string> {};

TEST_P(ShippedScene, RendersAPlausibleImageWithoutValidationMessages) {
  render::Renderer r(ctx(), small(GetParam()));
  r.render(0);
  const auto px = r.read_rgba8();
  ASSERT_EQ(px.size(), size_t{kWidth} * kHeight * 4);
  const auto s = stats(px);
  EXPECT_GT(s.mean, 5.0) << "image is (nearly) black";
  EXPECT_LT(s.mean, 250.0) << "image is (nearly) white";
  EXPECT_GT(s.stddev, 8.0) << "image is (nearly) uniform";
  EXPECT_FALSE(r.timings().empty());
  for (const auto& t : r.timings()) EXPECT_GE(t.gpu_ms, 0.0) << t.name;
  if (const char* dir = std::getenv("PENUMBRA_TEST_OUTPUT")) {
    render::write_png(std::string(dir) + "/" + GetParam() + ".png", kWidth, kHeight, px);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, ShippedScene,
                         ::testing::Values("default", "grazing", "space", "indoor"));

TEST_F(FrameTest, DefaultSceneShadowedFractionInRange) {
  render::Renderer r(ctx(), small("default"));
  r.render(0);
  const auto info = r.read_shadow_info();
  ASSERT_EQ(info.size(), size_t{kWidth} * kHeight * 4);
  size_t geometry = 0, facing = 0, cast = 0, self = 0;
  for (size_t i = 0; i < info.size() / 4; ++i) {
    if (info[i * 4 + 1] < 0.0f) continue;  // sky or beyond the shadow distance
    ++geometry;
    if (info[i * 4 + 2] < 0.0f) {  // faces away from the sun
      ++self;
      continue;
    }
    ++facing;
    if (info[i * 4] < 0.5f) ++cast;
  }
  ASSERT_GT(geometry, size_t{kWidth} * kHeight / 4) << "the camera should see mostly geometry";
  const double cast_fraction = double(cast) / double(facing);
  const double self_fraction = double(self) / double(geometry);
  std::printf("default scene: %.2f%% of sun-facing pixels in cast shadow, %.2f%% self-shadowed\n",
              100 * cast_fraction, 100 * self_fraction);
  // Measured at 320x180: 1.26% cast, 1.56% self (lavapipe and H100 alike). The objects are small in
  // the frame (the 40 m ground fills most of it). Below 0.3% the cast shadows are gone (a lost
  // shadow map, a wrong compare direction or fade); above 5% the ground shows acne or the maps are
  // shifted. Self-shadowing depends only on normals and the sun direction.
  EXPECT_GT(cast_fraction, 0.003);
  EXPECT_LT(cast_fraction, 0.05);
  EXPECT_GT(self_fraction, 0.002);
  EXPECT_LT(self_fraction, 0.05);
}

// shadows.selection = "containment": each receiver takes the finest cascade whose map holds it.
// The cascade view distance selects was fit to hold that receiver, so containment never picks a
// coarser one, and on the default scene it picks a finer one for part of the frame (cascade 0's
// square map reaches past its slice). Mutation: selecting by depth in both renders fails the
// second expectation.
TEST_F(FrameTest, CascadeSelectionByContainmentPicksTheFinestCascadeThatHoldsTheReceiver) {
  render::Renderer r(ctx(), small("default"));  // the selection is a per-frame parameter
  auto cascades = [&](scene::CascadeSelection selection) {
    r.scene().shadows.selection = selection;
    r.render(0);
    const auto info = r.read_shadow_info();
    std::vector<float> c(info.size() / 4);
    for (size_t i = 0; i < c.size(); ++i) c[i] = info[i * 4 + 1];
    return c;
  };
  const auto by_depth = cascades(scene::CascadeSelection::depth);
  const auto by_containment = cascades(scene::CascadeSelection::containment);
  size_t geometry = 0, finer = 0, coarser = 0;
  for (size_t i = 0; i < by_depth.size(); ++i) {
    if (by_depth[i] < 0.0f) continue;  // sky or beyond the shadow distance
    ++geometry;
    ASSERT_GE(by_containment[i], 0.0f) << "pixel " << i << ": no cascade holds it";
    finer += by_containment[i] < by_depth[i];
    coarser += by_containment[i] > by_depth[i];
  }
  ASSERT_GT(geometry, 1000u);
  EXPECT_EQ(coarser, 0u) << "of " << geometry;
  EXPECT_GT(finer, geometry / 20) << "of " << geometry;
}

TEST_F(FrameTest, SunShadowMapsHoldTheCasters) {
  render::Renderer r(ctx(), small("default"));
  r.render(0);
  const auto& s = r.scene();
  size_t busiest = 0;
  for (uint32_t c = 0; c < s.shadows.cascades; ++c) {
    const auto map = r.read_sun_shadow_map(c);
    ASSERT_EQ(map.size(), size_t{s.shadows.resolution} * s.shadows.resolution);
    size_t written = 0;
    for (float d : map) written += d != 0.0f ? 1 : 0;  // reverse-Z clears to 0 (far)
    busiest = std::max(busiest, written);
    // The ground plane does not cast (casts_shadows = false): a full map would mean it does,
    // or that the clear value or depth compare of the pass is wrong.
    EXPECT_LT(written, map.size() / 2) << "cascade " << c;
  }
  // The objects stand 6–10 m from the camera; the cascade covering them holds their depth.
  EXPECT_GT(busiest, size_t{s.shadows.resolution} * s.shadows.resolution / 1000);
}

// The clipmap layout (shadows.layout = clipmap): its levels are squares around the camera's
// position in light space, so turning the camera (same position, another target) leaves every
// level's map bit for bit as it was. Cascades follow the view frustum and change.
TEST_F(FrameTest, ClipmapLevelsDoNotMoveWhenTheCameraTurns) {
  for (const char* layout : {"clipmap", "cascades"}) {
    SCOPED_TRACE(layout);
    scene::Scene s = small("default");
    s.hold_still();  // the ball rolls: held, only the camera turns
    s.shadows.layout =
        std::string(layout) == "clipmap" ? scene::ShadowLayout::clipmap : scene::ShadowLayout::cascades;
    s.shadows.clipmap_levels = 5;
    s.shadows.resolution = 512;
    render::Renderer r(ctx(), s);
    EXPECT_EQ(r.built().has_pass("sun-shadow: 5"), std::string(layout) == "clipmap")
        << r.built().to_string();
    const uint32_t layers = r.scene().requirements().cascades;
    r.render(0);
    std::vector<std::vector<float>> before;
    for (uint32_t l = 0; l < layers; ++l) before.push_back(r.read_sun_shadow_map(l));
    r.scene().camera.target += glm::vec3(1.5f, 0.4f, -0.8f);  // yaw and pitch
    r.render(1);
    size_t changed = 0;
    for (uint32_t l = 0; l < layers; ++l) changed += r.read_sun_shadow_map(l) != before[l];
    if (std::string(layout) == "clipmap") {
      EXPECT_EQ(changed, 0u) << "levels whose map changed";
    } else {
      EXPECT_GT(changed, 0u) << "the cascades follow the view";
    }
  }
}

// A clipmap ends where its coarsest level does, not at a view distance: fade_band (the
// cascades' fade towards max_distance) changes nothing. With the view-distance fade, the
// grazing sun's long shadows were cut off past the last level's radius.
TEST_F(FrameTest, ClipmapShadowsDoNotFadeWithViewDistance) {
  auto visibility = [&](const char* layout, float fade_band) {
    scene::Scene s = small("grazing");
    s.shadows.layout = std::string(layout) == "clipmap" ? scene::ShadowLayout::clipmap
                                                        : scene::ShadowLayout::cascades;
    s.shadows.clipmap_levels = 2;
    s.shadows.max_distance = 20.0f;
    s.shadows.fade_band = fade_band;
    render::Renderer r(ctx(), s);
    r.render(0);
    const auto info = r.read_shadow_info();
    std::vector<float> v;
    for (size_t i = 0; i < info.size(); i += 4) v.push_back(info[i]);
    return v;
  };
  const auto clip = visibility("clipmap", 0.0f);
  EXPECT_EQ(clip, visibility("clipmap", 1.0f));
  EXPECT_NE(visibility("cascades", 0.0f), visibility("cascades", 1.0f));
  // The long shadows reach past the levels' radii (16 m): they are there (1454 pixels here;
  // faded at the last radius, 18 were left).
  size_t shadowed = 0;
  for (float v : clip) shadowed += v < 0.5f;
  EXPECT_GT(shadowed, 1000u);
}

// Shadow maps larger than the device allows (per image, or in all) are refused before anything
// is created, naming the scene key and value, the image and the limit; where the device has the
// room, the same scene builds. Either way no Vulkan call fails and no validation message comes.
TEST_F(FrameTest, ShadowMapsBeyondTheDeviceAreAnErrorNamingTheKey) {
  struct Case {
    std::string key;
    std::function<void(scene::Scene&)> set;
  };
  const std::vector<Case> cases{
      {"shadows.resolution = 16384",
       [](scene::Scene& s) {
         s.shadows.resolution = 16384;
         s.shadows.cascades = 4;
       }},
      {"[[point]] resolution = 8192", [](scene::Scene& s) {
         s.points.resize(2, s.points.empty() ? scene::PointLight{} : s.points[0]);
         for (auto& p : s.points) p.resolution = 8192;
       }}};
  for (const auto& c : cases) {
    scene::Scene s = small(c.key.front() == '[' ? "indoor" : "default");
    c.set(s);
    try {
      render::Renderer r(ctx(), s);
      r.render(0);
      std::printf("[device] %s: built (the device has the room)\n", c.key.c_str());
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr(c.key)) << e.what();
      EXPECT_THAT(e.what(), ::testing::HasSubstr(ctx().info().name));
      EXPECT_THAT(e.what(), ::testing::ContainsRegex("maxResourceSize|device memory|maxArrayLayers|"
                                                     "maxImageDimensionCube|allows for it"));
    }
  }
}

TEST_F(FrameTest, BuildsOnlyWhatTheSceneRequires) {
  {
    render::Renderer r(ctx(), small("default"));
    const auto& b = r.built();
    EXPECT_TRUE(b.has_pass("sun-shadow"));
    EXPECT_TRUE(b.has_pass("shadow-resolve"));
    EXPECT_FALSE(b.has_pass("point-shadow")) << b.to_string();
    EXPECT_FALSE(b.has_pass("spot-shadow")) << b.to_string();
    EXPECT_FALSE(b.has_pass("sphere-shadows")) << b.to_string();
    EXPECT_TRUE(b.has_pipeline("sun-shadow-opaque"));
    EXPECT_TRUE(b.has_pipeline("sun-shadow-masked")) << "the default scene has a masked fence";
    // The frame graph, as the report prints it: the steps in the order their images give.
    std::vector<std::string> steps;
    for (const auto& g : b.graph) steps.push_back(g.substr(0, g.find(':')));
    // The cascades scroll in the map itself, which the resolves read in place: one step.
    std::vector<std::string> expected{"sun-shadow"};
    for (const char* step : {"prepass", "shadow-resolve", "shadow-temporal",
                             "shadow-temporal-history", "contact-resolve", "contact-shadows",
                             "forward", "tonemap", "readback"})
      expected.push_back(step);
    EXPECT_EQ(steps, expected);
    EXPECT_THAT(b.to_string(),
                ::testing::HasSubstr("step      shadow-resolve: reads depth (sampled), normal "
                                     "(sampled), sun-shadow-map (sampled); writes shadow-info "
                                     "(storage write)"));
  }
  {
    render::Renderer r(ctx(), small("space"));
    const auto& b = r.built();
    EXPECT_TRUE(b.has_pass("point-shadow"));
    EXPECT_FALSE(b.has_pass("sun-shadow")) << b.to_string();
    EXPECT_FALSE(b.has_pass("shadow-resolve")) << b.to_string();
    EXPECT_FALSE(b.has_pass("contact-shadows")) << b.to_string();
  }
  {
    render::Renderer r(ctx(), small("indoor"));
    const auto& b = r.built();
    EXPECT_TRUE(b.has_pass("spot-shadow"));
    EXPECT_TRUE(b.has_pass("point-shadow"));
    EXPECT_FALSE(b.has_pass("sun-shadow")) << b.to_string();
  }
  {
    // An analytic sphere: the sphere pass, for the local lights' image only.
    auto s = small("indoor");
    for (auto& i : s.instances)
      if (s.meshes[i.mesh].name.starts_with("sphere")) i.analytic_sphere_radius = 0.15f;
    render::Renderer r(ctx(), s);
    const auto& b = r.built();
    EXPECT_TRUE(b.has_pass("sphere-shadows: compute (1 analytic spheres)")) << b.to_string();
    EXPECT_TRUE(b.has_pipeline("sphere-shadows PENUMBRA_SUN_SHADOWS=0 PENUMBRA_LOCAL_SHADOWS=1 "
                               "PENUMBRA_ANALYTIC_SPHERES=1"))
        << b.to_string();
  }
  {
    auto s = small("default");
    s.shadows.cascades = 1;
    s.contact.step_count = 0;
    for (auto& m : s.materials) {
      m.alpha = scene::AlphaMode::opaque;
      m.mask = scene::MaskPattern::none;
    }
    render::Renderer r(ctx(), s);
    const auto& b = r.built();
    EXPECT_TRUE(b.has_pass("sun-shadow: 1 cascade"));
    EXPECT_FALSE(b.has_pass("contact-shadows")) << b.to_string();
    EXPECT_FALSE(b.has_pipeline("sun-shadow-masked")) << b.to_string();
    bool one_layer = false;
    for (const auto& i : b.images)
      if (i.rfind("sun-shadow-map ", 0) == 0) one_layer = i.find("x1 ") == std::string::npos;
    EXPECT_TRUE(one_layer) << b.to_string();
    r.render(0);
  }
}

// The local resolve's loops over the spot and the point lights are not unrolled
// ([[dont_unroll]]): unrolled, a driver compiles one copy of a light's biases and filter per
// light slot, and a new version of the shader took llvmpipe 500-650 ms to compile instead of
// 200-260 (docs/hot-reload.md). Their SPIR-V loops must carry DontUnroll, and only those two.
TEST_F(FrameTest, LocalResolveLightLoopsAreNotUnrolled) {
  shader::Compiler compiler(shader::CompileOptions{{PENUMBRA_SHADER_DIR}, {}, false});
  const std::filesystem::path file =
      std::filesystem::path(PENUMBRA_SHADER_DIR) / "render/local_shadow_resolve.comp";
  const std::vector<uint32_t> spirv =
      compiler
          .compile_file(file, {}, {{"PENUMBRA_SPOT_SHADOWS", "1"}, {"PENUMBRA_POINT_SHADOWS", "1"}})
          .spirv;
  constexpr uint32_t kOpLoopMerge = 246, kDontUnroll = 0x2;
  int loops = 0, not_unrolled = 0;
  for (size_t i = 5; i < spirv.size();) {  // past the header
    const uint32_t words = spirv[i] >> 16, op = spirv[i] & 0xffffu;
    ASSERT_GT(words, 0u) << "malformed SPIR-V at word " << i;
    if (op == kOpLoopMerge) {
      ++loops;
      if ((spirv[i + 3] & kDontUnroll) != 0) ++not_unrolled;
    }
    i += words;
  }
  EXPECT_GE(loops, 2);
  EXPECT_EQ(not_unrolled, 2) << "of " << loops << " loops";
}

TEST_F(FrameTest, FrameStructsMatchReflection) {
  shader::Compiler compiler(shader::CompileOptions{{PENUMBRA_SHADER_DIR}, {}, false});
  const auto spirv = compiler
                         .compile_source(R"(#version 460
#include "penumbra/frame_types.glsl"
layout(local_size_x = 1) in;
layout(std140, binding = 0) uniform FrameBlock { FrameGpu frame; };
layout(std430, binding = 1) buffer Out { float x; };
layout(push_constant) uniform Push { DrawPush draw; };
void main() { x = frame.viewport.x + draw.albedo.x; }
)",
                                         "frame_layout.comp", shader::Stage::compute)
                         .spirv;
  const auto refl = shader::reflect(spirv);
  const auto* ubo = refl.find_binding("FrameBlock");
  ASSERT_NE(ubo, nullptr);
  ASSERT_TRUE(ubo->block.has_value());
  const auto* f = ubo->block->find("frame");
  ASSERT_NE(f, nullptr);
  auto member = [&](const char* name) -> const shader::BlockMember& {
    for (const auto& m : f->members)
      if (m.name == name) return m;
    throw Error(std::string("no member ") + name);
  };
#define PENUMBRA_CHECK(member_name) \
  EXPECT_EQ(member(#member_name).offset, offsetof(render::FrameGpu, member_name)) << #member_name
  PENUMBRA_CHECK(view);
  PENUMBRA_CHECK(proj);
  PENUMBRA_CHECK(view_proj);
  PENUMBRA_CHECK(inv_view_proj);
  PENUMBRA_CHECK(camera_position);
  PENUMBRA_CHECK(camera_forward);
  PENUMBRA_CHECK(sun_direction);
  PENUMBRA_CHECK(sun_color);
  PENUMBRA_CHECK(ambient);
  PENUMBRA_CHECK(viewport);
  PENUMBRA_CHECK(projection);
  PENUMBRA_CHECK(bias);
  PENUMBRA_CHECK(filter_params);
  PENUMBRA_CHECK(mode);
  PENUMBRA_CHECK(counts);
  PENUMBRA_CHECK(spots);
  PENUMBRA_CHECK(points);
  PENUMBRA_CHECK(pcss);
  PENUMBRA_CHECK(filter_world);
  PENUMBRA_CHECK(evsm);
#undef PENUMBRA_CHECK
  EXPECT_EQ(f->members.size(), 20u) << "a GLSL member without a C++ counterpart";
  EXPECT_EQ(f->size, sizeof(render::FrameGpu));
  EXPECT_EQ(member("spots").array_stride, sizeof(render::LightGpu));
  ASSERT_TRUE(refl.push_constants.has_value());
  const auto* d = refl.push_constants->find("draw");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->size, sizeof(render::DrawPush));
  for (const auto& m : d->members) {
    size_t want = 0;
    if (m.name == "model")
      want = offsetof(render::DrawPush, model);
    else if (m.name == "albedo")
      want = offsetof(render::DrawPush, albedo);
    else if (m.name == "mask")
      want = offsetof(render::DrawPush, mask);
    else if (m.name == "index")
      want = offsetof(render::DrawPush, index);
    else
      ADD_FAILURE() << "DrawPush member " << m.name << " has no C++ counterpart";
    EXPECT_EQ(m.offset, want) << m.name;
  }
}

// The shadow-temporal pass's block, as shadow_temporal.comp declares it.
TEST_F(FrameTest, TemporalBlockMatchesReflection) {
  shader::Compiler compiler(shader::CompileOptions{{PENUMBRA_SHADER_DIR}, {}, false});
  const auto spirv = compiler
                         .compile_source(R"(#version 460
#include "penumbra/frame_types.glsl"
layout(local_size_x = 1) in;
layout(std140, binding = 0) uniform TemporalBlock { TemporalGpu temporal; };
layout(std430, binding = 1) buffer Out { float x; };
void main() { x = temporal.to_previous_view[0].x + temporal.previous_proj[0].x + temporal.params.x; }
)",
                                         "temporal_layout.comp", shader::Stage::compute)
                         .spirv;
  const auto refl = shader::reflect(spirv);
  const auto* ubo = refl.find_binding("TemporalBlock");
  ASSERT_NE(ubo, nullptr);
  ASSERT_TRUE(ubo->block.has_value());
  const auto* t = ubo->block->find("temporal");
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->size, sizeof(render::TemporalGpu));
  ASSERT_EQ(t->members.size(), 3u) << "a GLSL member without a C++ counterpart";
  for (const auto& m : t->members) {
    size_t want = 0;
    if (m.name == "to_previous_view")
      want = offsetof(render::TemporalGpu, to_previous_view);
    else if (m.name == "previous_proj")
      want = offsetof(render::TemporalGpu, previous_proj);
    else if (m.name == "params")
      want = offsetof(render::TemporalGpu, params);
    else
      ADD_FAILURE() << "TemporalGpu member " << m.name << " has no C++ counterpart";
    EXPECT_EQ(m.offset, want) << m.name;
  }
}

TEST_F(FrameTest, SceneFileErrorReachesTheUserWithFileAndLine) {
  const std::string path = ::testing::TempDir() + "/broken_scene.toml";
  std::ofstream(path) << "name = \"broken\"\n[camera]\nposition = [0, 1, 5]\nfov = 60\n";
  const std::string cmd = std::string(PENUMBRA_VIEW_EXE) + " --headless --scene " + path + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string output;
  char buf[512];
  while (fgets(buf, sizeof buf, p)) output += buf;
  const int status = pclose(p);
  EXPECT_NE(status, 0);
  EXPECT_THAT(output, HasSubstr("broken_scene.toml:4"));
  EXPECT_THAT(output, HasSubstr("fov"));
}

}  // namespace
}  // namespace penumbra
