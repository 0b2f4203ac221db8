// The reference against the GPU: the alpha mask it evaluates is the shaders' mask; with a hard
// light and a fine shadow map it agrees with the rasterizer away from shadow edges; every
// shipped scene meets its accuracy budget and writes its images; bad frames give defined results.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <penumbra/core/error.hpp>
#include <penumbra/reference/frame.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <penumbra/testing/generators.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <penumbra/testing/shader_function.hpp>

namespace penumbra::reference {
namespace {

namespace fs = std::filesystem;
using testing::GpuTest;
using ::testing::HasSubstr;
using ::testing::Not;

class ReferenceGpu : public GpuTest {};

// ---- the mask ---------------------------------------------------------------------------------
// Distance (in pattern cells) from uv * scale to the pattern's nearest edge, in double.
double edge_distance(glm::vec2 uv, scene::MaskPattern pattern, glm::vec2 scale) {
  const double x = double(uv.x) * scale.x, y = double(uv.y) * scale.y;
  const double fx = x - std::floor(x), fy = y - std::floor(y);
  const auto to_int = [](double f) { return std::min(f, 1.0 - f); };
  switch (pattern) {
    case scene::MaskPattern::stripes:
      return std::min(to_int(fx), std::abs(fx - 0.5));
    case scene::MaskPattern::checker:
      return std::min(to_int(fx), to_int(fy));
    case scene::MaskPattern::circles:
      return std::min({std::abs(std::hypot(fx - 0.5, fy - 0.5) - 0.3), to_int(fx), to_int(fy)});
    default:
      return 1.0;
  }
}

TEST_F(ReferenceGpu, TheTracersMaskIsTheShadersMask) {
  testing::ShaderFunction<float(glm::vec2, int32_t, glm::vec2)> mask("penumbra/material.glsl",
                                                                     "procedural_mask");
  testing::Rng rng(0x3A5C);
  const std::vector<glm::vec2> scales{{1, 1}, {16, 1}, {16, 4}, {8, 12}, {400, 1}, {3.3f, 7.1f}};
  std::vector<std::tuple<glm::vec2, int32_t, glm::vec2>> cases;
  for (int i = 0; i < 30000; ++i) {
    const glm::vec2 uv(testing::detail::uniform_scalar(rng, -2.0f, 3.0f),
                       testing::detail::uniform_scalar(rng, -2.0f, 3.0f));
    cases.emplace_back(uv, int32_t(i % 5), scales[size_t(i / 5) % scales.size()]);
  }
  const std::vector<float> got = mask.run(cases);
  size_t compared = 0, near_edge = 0, cut = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [uv, pattern, scale] = cases[i];
    const auto p = static_cast<scene::MaskPattern>(pattern);
    if (edge_distance(uv, p, scale) < 1e-4) {  // float rounding may fall either side
      ++near_edge;
      continue;
    }
    ++compared;
    const float want = scene::procedural_mask(uv, p, scale);
    cut += want == 0.0f;
    ASSERT_EQ(got[i], want) << "uv (" << uv.x << ", " << uv.y << ") pattern " << pattern
                            << " scale (" << scale.x << ", " << scale.y << ")";
  }
  EXPECT_GT(compared, 29000u);
  EXPECT_GT(cut, 5000u);  // both outcomes are exercised
  // The comparison has power: circles of radius 0.31 instead of 0.3 disagree with the shader.
  size_t differ = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto [uv, pattern, scale] = cases[i];
    if (pattern != int32_t(scene::MaskPattern::circles)) continue;
    const glm::vec2 c = uv * scale - glm::floor(uv * scale) - 0.5f;
    differ += (glm::length(c) > 0.31f ? 1.0f : 0.0f) != got[i];
  }
  EXPECT_GT(differ, 50u);
}

// The renderer samples mask textures as scene::texture_mask does (bilinear between texel centres,
// repeating): the shipped textures at 30,000 uvs over several repeats. The tolerance is the
// filtering precision Vulkan allows: each bilinear weight may be rounded to subTexelPrecisionBits
// (8 on lavapipe and on NVIDIA), so a coverage may differ by up to 2^-bits per axis.
TEST_F(ReferenceGpu, TheTracersTextureMaskIsTheShadersTextureMask) {
  const fs::path dir = PENUMBRA_SCENE_DIR "/textures";
  const float tolerance =
      2.0f / float(1u << std::min(ctx().info().limits.subTexelPrecisionBits, 16u));
  for (const char* name : {"lattice.png", "picket.png"}) {
    SCOPED_TRACE(name);
    const scene::MaskImage image = scene::load_mask_image(dir / name);
    testing::FloatTextureDesc desc;
    desc.width = image.width;
    desc.height = image.height;
    desc.sampler.filter = VK_FILTER_LINEAR;
    desc.sampler.address = VK_SAMPLER_ADDRESS_MODE_REPEAT;
    std::vector<float> texels;
    for (uint8_t t : image.texels) texels.push_back(float(t) / 255.0f);
    testing::ShaderFunction<float(testing::Sampler2D, glm::vec2, glm::vec2)> mask(
        "penumbra/material.glsl", "texture_mask");
    mask.bind(0, testing::make_float_texture(desc, texels));
    testing::Rng rng(0x7E47);
    const std::vector<glm::vec2> scales{{1, 1}, {16, 1}, {16, 4}, {3.3f, 7.1f}};
    std::vector<std::tuple<glm::vec2, glm::vec2>> cases;
    for (int i = 0; i < 30000; ++i) {
      const glm::vec2 uv(testing::detail::uniform_scalar(rng, -1.0f, 2.0f),
                         testing::detail::uniform_scalar(rng, -1.0f, 2.0f));
      cases.emplace_back(uv, scales[size_t(i) % scales.size()]);
    }
    const std::vector<float> got = mask.run(cases);
    size_t partial = 0;
    float worst = 0.0f;
    for (size_t i = 0; i < cases.size(); ++i) {
      const auto [uv, scale] = cases[i];
      const float want = scene::texture_mask(image, uv, scale);
      partial += want > 0.05f && want < 0.95f;
      worst = std::max(worst, std::abs(got[i] - want));
      ASSERT_NEAR(got[i], want, tolerance)
          << "uv (" << uv.x << ", " << uv.y << ") scale (" << scale.x << ", " << scale.y << ")";
    }
    EXPECT_GT(partial, 1000u);  // the edges, where the filter matters, are exercised
    // The comparison has power: nearest sampling (no filter) disagrees beyond the tolerance.
    size_t differ = 0;
    for (size_t i = 0; i < cases.size(); ++i) {
      const auto [uv, scale] = cases[i];
      const glm::vec2 p = uv * scale;
      const auto x = uint32_t((p.x - std::floor(p.x)) * float(image.width)) % image.width;
      const auto y = uint32_t((p.y - std::floor(p.y)) * float(image.height)) % image.height;
      differ += std::abs(float(image.texels[size_t(y) * image.width + x]) / 255.0f - got[i]) >
                tolerance;
    }
    EXPECT_GT(differ, 500u) << "worst |GPU - C++| " << worst;
  }
}

// ---- geometry agreement -------------------------------------------------------------------------
constexpr const char* kHardSunScene = R"(
name = "hard-sun"
[camera]
position = [0.3, 2.6, 3.6]
target = [-0.2, 0.2, -0.6]
fov_y = 55
near = 0.1
far = 40
[sun]
direction = [-0.4, -1.0, -0.3]
angular_diameter = 0
[shadows]
filter = "hard"
cascades = 1
max_distance = 30
fade_band = 0
resolution = 4096
[contact]
steps = 0
[render]
width = 480
height = 270
[[material]]
name = "grey"
[[object]]
mesh = "plane"
size = [16, 16]
material = "grey"
casts_shadows = false
[[object]]
mesh = "box"
size = [1, 1, 1]
position = [1.5, 0.5, -0.5]
rotation = [0, 25, 0]
material = "grey"
[[object]]
mesh = "sphere"
radius = 0.6
position = [-1.5, 0.8, 0.2]
material = "grey"
[[object]]
mesh = "chair"
position = [0.2, 0, 1.4]
material = "grey"
)";

// Receivers whose reference value is the same over a (2k+1)² window: away from shadow edges.
std::vector<uint8_t> interior(const LightMeasurement& l, uint32_t w, uint32_t h, int k) {
  std::vector<uint8_t> out(l.classes.size(), 0);
  for (int y = k; y < int(h) - k; ++y)
    for (int x = k; x < int(w) - k; ++x) {
      const size_t i = size_t(y) * w + size_t(x);
      if (l.classes[i] != ReceiverClass::lit) continue;
      bool uniform = true;
      for (int dy = -k; dy <= k && uniform; ++dy)
        for (int dx = -k; dx <= k && uniform; ++dx) {
          const size_t j = size_t(y + dy) * w + size_t(x + dx);
          uniform =
              l.classes[j] == ReceiverClass::lit && l.reference.value[j] == l.reference.value[i];
        }
      out[i] = uniform;
    }
  return out;
}

// Interior receivers (away from shadow edges) of a scene's one hard light where the rasterizer
// and the reference agree on lit or shadowed: all of them, and the shadowed ones alone.
struct Agreement {
  size_t n = 0, agree = 0, shadowed = 0, shadowed_agree = 0;
  std::string metrics;
  // Per pixel: interior, and lit (visibility >= 0.5) in the reference and on the GPU.
  std::vector<uint8_t> inner, reference_lit, gpu_lit;
};
Agreement hard_light_agreement(gpu::Context& c, const scene::Scene& s) {
  render::RendererOptions ro;
  ro.visibility_output = true;
  render::Renderer r(c, s, ro);
  r.render(0);
  MeasureOptions mo;
  const FrameMeasurement m = measure_frame(r, mo);
  EXPECT_EQ(m.lights.size(), 1u);
  const LightMeasurement& sun = m.lights.at(0);
  EXPECT_TRUE(sun.area.hard());
  const auto inner = interior(sun, m.width, m.height, 2);
  Agreement a;
  a.metrics = sun.metrics.to_line();
  a.inner = inner;
  for (size_t i = 0; i < inner.size(); ++i) {
    a.reference_lit.push_back(sun.reference.value[i] >= 0.5f);
    a.gpu_lit.push_back(sun.gpu[i] >= 0.5f);
    if (!inner[i]) continue;
    ++a.n;
    const bool same = (sun.gpu[i] >= 0.5f) == (sun.reference.value[i] >= 0.5f);
    a.agree += same;
    if (sun.reference.value[i] < 0.5f) {
      ++a.shadowed;
      a.shadowed_agree += same;
    }
  }
  return a;
}

TEST_F(ReferenceGpu, HardSunAgreesWithTheRasterizerAwayFromShadowEdges) {
  const Agreement a =
      hard_light_agreement(ctx(), scene::parse_scene(kHardSunScene, "hard-sun.toml", "."));
  ASSERT_GT(a.n, 50000u);
  ASSERT_GT(a.shadowed, 800u);  // there are shadows to agree on
  EXPECT_GE(double(a.agree) / double(a.n), 0.995)
      << a.agree << " of " << a.n << " interior receivers agree; metrics: " << a.metrics;
  // The lit majority cannot hide a lost shadow: the umbra agrees on its own.
  EXPECT_GE(double(a.shadowed_agree) / double(a.shadowed), 0.995)
      << a.shadowed_agree << " of " << a.shadowed << " interior shadowed receivers agree";
}

// filter = evsm2 on the sun (the evsm pass's moments, blurred, then the Chebyshev bound) under
// a hard sun: in both moment formats the umbrae survive and the lit ground stays lit away from
// shadow edges. EVSM's failure modes are light bleeding (umbrae lit where a second occluder
// overlaps) and lost contact shadows; the bounds below leave room for neither on this scene.
TEST_F(ReferenceGpu, Evsm2OnTheSunKeepsUmbraeAndLitGroundInBothMomentFormats) {
  for (const char* fp16 : {"false", "true"}) {
    SCOPED_TRACE(std::string("evsm_fp16 = ") + fp16);
    scene::Scene s = scene::parse_scene(kHardSunScene, "hard-sun.toml", ".");
    scene::set_param(s, "shadows.filter", "evsm2");
    scene::set_param(s, "shadows.evsm_fp16", fp16);
    scene::set_param(s, "shadows.resolution", "2048");  // a quarter of the moments to write
    ASSERT_TRUE(s.requirements().sun_moments);
    const Agreement a = hard_light_agreement(ctx(), s);
    ASSERT_GT(a.n, 50000u);
    ASSERT_GT(a.shadowed, 800u);
    EXPECT_GE(double(a.agree) / double(a.n), 0.995)
        << a.agree << " of " << a.n << " interior receivers agree; metrics: " << a.metrics;
    EXPECT_GE(double(a.shadowed_agree) / double(a.shadowed), 0.995)
        << a.shadowed_agree << " of " << a.shadowed << " interior shadowed receivers agree";
    std::printf("evsm_fp16 = %s: %zu of %zu interior agree, %zu of %zu shadowed\n", fp16,
                a.agree, a.n, a.shadowed_agree, a.shadowed);
  }
}

// shadows.evsm_mips: the sun's moments get mips and each pixel reads its footprint in the map
// through them. On this scene a pixel covers one texel near the camera and several further
// away, so the prefiltering must show there, and only there: at shadow edges (softened over the
// footprint). Away from the reference's edges the image must not move (a level picked too
// coarse bleeds light into umbrae and shadow onto lit ground), and mips must not be built when
// the key is off.
TEST_F(ReferenceGpu, Evsm2MipsChangeOnlyShadowEdgesWherePixelsCoverSeveralTexels) {
  auto measure = [&](const char* mips, std::string& report) {
    // A pixel over 1 to 8 texels of the 2048 map.
    std::string text = kHardSunScene;
    const std::string size = "width = 480\nheight = 270";
    text.replace(text.find(size), size.size(), "width = 240\nheight = 135");
    scene::Scene s = scene::parse_scene(text, "hard-sun.toml", ".");
    scene::set_param(s, "shadows.filter", "evsm2");
    scene::set_param(s, "shadows.resolution", "2048");
    scene::set_param(s, "shadows.evsm_mips", mips);
    render::RendererOptions ro;
    ro.visibility_output = true;
    render::Renderer r(ctx(), s, ro);
    report = r.built().to_string();
    r.render(0);
    return measure_frame(r, MeasureOptions{});
  };
  std::string off_report, on_report;
  const FrameMeasurement off = measure("false", off_report);
  const FrameMeasurement on = measure("true", on_report);
  EXPECT_THAT(on_report, HasSubstr("sun-moments 2048x2048 RG16F, 12 mips"));
  EXPECT_THAT(off_report, Not(HasSubstr("mips")));
  ASSERT_EQ(on.lights.size(), 1u);
  const LightMeasurement& a = off.lights[0];
  const LightMeasurement& b = on.lights[0];
  const auto inner = interior(b, on.width, on.height, 2);
  size_t changed = 0, changed_inner = 0, n_inner = 0;
  for (size_t i = 0; i < inner.size(); ++i) {
    if (b.classes[i] != ReceiverClass::lit) continue;
    const bool moved = std::abs(b.gpu[i] - a.gpu[i]) > 2.0f / 255.0f;
    changed += moved;
    n_inner += inner[i];
    changed_inner += moved && inner[i];
  }
  ASSERT_GT(n_inner, 15000u);
  EXPECT_GE(changed, 30u) << "the mips changed too few pixels: is the footprint read at all?";
  EXPECT_LE(double(changed_inner), 0.001 * double(n_inner))
      << changed_inner << " of " << n_inner << " pixels away from shadow edges changed";
  std::printf("evsm_mips: %zu pixels changed, %zu of %zu away from edges; mean |dV| %s -> %s\n",
              changed, changed_inner, n_inner, a.metrics.to_line().c_str(),
              b.metrics.to_line().c_str());
}

// A hard point light over a few casters, every face of its cube in use.
const char* const kHardPointScene = R"(
name = "hard-point"
[camera]
position = [2.6, 2.4, 3.0]
target = [0, 0.3, 0]
fov_y = 60
[[point]]
position = [0.3, 2.6, 0.2]
intensity = 40
range = 20
shadows = true
resolution = 1024
filter = "evsm2"
[contact]
steps = 0
[render]
width = 320
height = 180
[[material]]
name = "grey"
albedo = [0.6, 0.6, 0.6]
[[object]]
mesh = "plane"
size = [14, 14]
material = "grey"
[[object]]
mesh = "box"
size = [0.6, 1.2, 0.6]
position = [1.6, 0.6, 0.4]
material = "grey"
[[object]]
mesh = "sphere"
radius = 0.4
position = [-1.2, 0.8, 1.1]
material = "grey"
[[object]]
mesh = "chair"
position = [0.4, 0, -1.5]
material = "grey"
[[object]]
mesh = "box"
size = [0.3, 0.3, 0.3]
position = [-0.6, 0.15, -0.4]
material = "grey"
)";

// The same lamp as a spot light looking down, its cone over the casters.
std::string hard_spot_scene() {
  std::string s = kHardPointScene;
  const std::string point = "[[point]]\nposition = [0.3, 2.6, 0.2]\n";
  s.replace(s.find(point), point.size(),
            "[[spot]]\nposition = [0.3, 2.6, 0.2]\ntarget = [0.2, 0, 0]\nouter_angle = 60\n");
  return s;
}

// A spot or point light's own filter = evsm2 (the spot maps' moments of linear depth; the cubes'
// moments, face by face, sampled across faces) under a hard light: in both moment formats the
// umbrae survive and the lit ground stays lit away from shadow edges, as for the sun. Without
// their own evsm2 (the scene's only), the lights use pcf and no moments are built.
TEST_F(ReferenceGpu, Evsm2OnSpotAndPointLightsKeepsUmbraeAndLitGroundInBothMomentFormats) {
  for (const std::string& text : {std::string(kHardPointScene), hard_spot_scene()})
  for (const char* fp16 : {"false", "true"}) {
    SCOPED_TRACE(std::string("evsm_fp16 = ") + fp16);
    scene::Scene s = scene::parse_scene(text, "hard-light.toml", ".");
    scene::set_param(s, "shadows.evsm_fp16", fp16);
    ASSERT_TRUE(s.requirements().point_moments || s.requirements().spot_moments);
    const Agreement a = hard_light_agreement(ctx(), s);
    ASSERT_GT(a.n, 20000u);
    ASSERT_GT(a.shadowed, 800u);
    EXPECT_GE(double(a.agree) / double(a.n), 0.99)
        << a.agree << " of " << a.n << " interior receivers agree; metrics: " << a.metrics;
    EXPECT_GE(double(a.shadowed_agree) / double(a.shadowed), 0.99)
        << a.shadowed_agree << " of " << a.shadowed << " interior shadowed receivers agree";
    std::printf("evsm_fp16 = %s: %zu of %zu interior agree, %zu of %zu shadowed; %s\n", fp16,
                a.agree, a.n, a.shadowed_agree, a.shadowed, a.metrics.c_str());
  }
  scene::Scene scene_wide = scene::parse_scene(kHardPointScene, "hard-point.toml", ".");
  scene_wide.points[0].filter.reset();
  scene::set_param(scene_wide, "shadows.filter", "evsm2");
  EXPECT_FALSE(scene_wide.requirements().point_moments);
  EXPECT_FALSE(scene_wide.requirements().spot_moments);
}

// A fence masked by a texture (the grazing scene's lattice in 1.5 m tiles), leaning between the
// sun and the ground: the rasterizer's caster pass and the reference's occlusion filter cut the
// same holes. The holes are the receivers the same fence, opaque, shadows in the reference and
// the masked one does not: the rasterizer must light them too.
TEST_F(ReferenceGpu, HardSunThroughATextureMaskedFenceAgreesWithTheRasterizer) {
  const std::string fence = std::string(kHardSunScene) + R"(
[[material]]
name = "lattice"
mask_texture = ")" + PENUMBRA_SCENE_DIR "/textures/lattice.png" + R"("
mask_scale = [2, 1]
[[object]]
mesh = "box"
size = [3, 1.5, 0.02]
position = [0.6, 0.9, 0.4]
rotation = [-35, 160, 0]
material = "lattice"
)";
  const scene::Scene masked = scene::parse_scene(fence, "fence.toml", ".");
  ASSERT_EQ(masked.requirements().mask_textures, 1u);
  const Agreement a = hard_light_agreement(ctx(), masked);
  ASSERT_GT(a.n, 30000u);
  EXPECT_GE(double(a.agree) / double(a.n), 0.995)
      << a.agree << " of " << a.n << " interior receivers agree; metrics: " << a.metrics;
  EXPECT_GE(double(a.shadowed_agree) / double(a.shadowed), 0.99)
      << a.shadowed_agree << " of " << a.shadowed << " interior shadowed receivers agree";
  scene::Scene opaque = masked;
  for (auto& m : opaque.materials) {
    m.alpha = scene::AlphaMode::opaque;
    m.mask = scene::MaskPattern::none;
  }
  const Agreement o = hard_light_agreement(ctx(), opaque);
  size_t holes = 0, holes_lit = 0;
  for (size_t i = 0; i < a.inner.size(); ++i) {
    if (!a.inner[i] || o.reference_lit[i] || !a.reference_lit[i]) continue;
    ++holes;
    holes_lit += a.gpu_lit[i];
  }
  ASSERT_GT(holes, 2000u) << "the fence's holes in the reference";
  EXPECT_GE(double(holes_lit) / double(holes), 0.99)
      << holes_lit << " of " << holes << " receivers seen through the holes are lit on the GPU";
}

// Frame 0 of `s` at width x height against the reference (64 samples, no cache).
FrameMeasurement measure_at(gpu::Context& c, scene::Scene s, uint32_t width, uint32_t height) {
  s.render.width = width;
  s.render.height = height;
  render::RendererOptions ro;
  ro.visibility_output = true;
  render::Renderer r(c, s, ro);
  r.render(0);
  MeasureOptions mo;
  mo.trace.samples = 64;
  return measure_frame(r, mo);
}

// ---- every shipped scene ------------------------------------------------------------------------
class ShippedSceneReference : public ReferenceGpu,
                              public ::testing::WithParamInterface<std::string> {};

// Every shipped scene at its defaults, measured at 640x360 (a quarter of the 1280x720 that
// docs/accuracy.md reports; the metrics agree within 0.2 percentage points between the two
// sizes) against the reference, and held to the accuracy budget of issue 13:
// - soft lights: mean |dV| <= 0.02; hard lights: misclassified <= 0.5% of the receivers;
// - false light <= 1% and false shadow <= 1% (t = 0.1);
// - no lost shadows: of the receivers the reference finds in umbra (R < 0.5), at least 90% are
//   shadowed (V < 0.5) on the GPU. Before the world-unit biases the indoor spot light kept 18%
//   of its umbra, the space point light 66%.
// The bounds sit 1.5-10x above the measured values (docs/accuracy.md lists them): far enough for
// the different rounding of another driver, near enough that a lost shadow (the indoor spot's
// 7.9% false light before the fix) or acne fails. The reference traces from the smooth surface
// the interpolated normals describe (Terminator::smooth), as the shading and the shadow maps
// assume; with flat triangles the space scene's low-poly asteroids shadow their own facets at
// the terminator (3.4% false light), which no shadow map reproduces.
TEST_P(ShippedSceneReference, MeetsTheAccuracyBudgetAndWritesTheImages) {
  scene::Scene s = scene::load_scene(scene::find_scene(GetParam()));
  const FrameMeasurement m = measure_at(ctx(), s, 640, 360);
  ASSERT_FALSE(m.lights.empty());
  const AccuracyBudget b;  // the library's: penumbra-golden holds goldens to the same budget
  uint64_t receivers = 0;
  for (const auto& l : m.lights) {
    SCOPED_TRACE(l.light.name() + ": " + l.metrics.to_line());
    receivers += l.metrics.receivers;
    for (double x : {l.metrics.mean_abs, l.metrics.rmse, l.metrics.p99_abs, l.metrics.false_light,
                     l.metrics.false_shadow})
      EXPECT_TRUE(std::isfinite(x) && x >= 0.0 && x <= 1.0) << x;
    EXPECT_EQ(std::isfinite(l.metrics.misclassified), l.area.hard());
    size_t umbra = 0;
    const double kept = umbra_kept(l, &umbra);
    ASSERT_GT(umbra, 100u) << "no shadow to keep";
    std::printf("%s %s: %s, umbra kept %.3f\n", GetParam().c_str(), l.light.name().c_str(),
                l.metrics.to_line().c_str(), kept);
    for (const auto& v : budget_violations(l, b)) ADD_FAILURE() << "over budget: " << v;
  }
  EXPECT_GT(receivers, 10000u);
  const fs::path dir = fs::temp_directory_path() /
                       ("penumbra-reference-" + GetParam() + "-" + std::to_string(::getpid()));
  const auto files = write_measurement(m, dir, "\"scene\": \"" + GetParam() + "\"");
  EXPECT_EQ(files.size(), 2u + 3u * m.lights.size());
  for (const auto& f : files) EXPECT_GT(fs::file_size(f), 100u) << f;
  fs::remove_all(dir);
}

// Every kernel size: the widest PCF (radius 5, 11 x 11 taps) must not shadow its own receivers.
// The normal offset grows with the filter's reach (filter_normal_offset_texels); before, a
// radius of 3 put 15% of the indoor spot's lit receivers and 29% of the space star's in false
// shadow. What remains at radius 5 is the blur of a hard light's edges, which errs to both sides
// about equally (1280x720: false shadow 0.6-2.6%, false light 0.9-2.0%); the bound is 2x the
// largest.
TEST_P(ShippedSceneReference, TheWidestPcfKernelDoesNotShadowItsOwnReceivers) {
  scene::Scene s = scene::load_scene(scene::find_scene(GetParam()));
  s.shadows.filter = scene::Filter::pcf;
  s.shadows.pcf_radius = 5;
  for (auto& spot : s.spots) spot.filter.reset();
  for (auto& point : s.points) point.filter.reset();
  const FrameMeasurement m = measure_at(ctx(), s, 640, 360);
  ASSERT_FALSE(m.lights.empty());
  for (const auto& l : m.lights) {
    SCOPED_TRACE(l.light.name() + ": " + l.metrics.to_line());
    EXPECT_LE(l.metrics.false_shadow, 0.05);
    EXPECT_LE(l.metrics.false_light, 0.05);
  }
}

// PCF's outer taps are bilinear compares that read a texel beyond the kernel's radius, and the
// normal offset must cover it: without that texel, PCF radius 1 put a moire of acne over the
// indoor ceiling the point light grazes (320x180: false shadow 2.68%, mean |dV| 0.0085; with
// it 0.61% and 0.0036). The bounds are the accuracy budget's 1% and half the defect's error.
TEST_F(ReferenceGpu, PcfOnAPointLightDoesNotShadowTheCeilingItGrazes) {
  scene::Scene s = scene::load_scene(scene::find_scene("indoor"));
  scene::set_param(s, "shadows.filter", "pcf");
  scene::set_param(s, "shadows.pcf_radius", "1");
  const FrameMeasurement m = measure_at(ctx(), s, 320, 180);
  bool found = false;
  for (const auto& l : m.lights) {
    if (l.light.name() != "point0") continue;
    found = true;
    SCOPED_TRACE(l.metrics.to_line());
    EXPECT_LE(l.metrics.false_shadow, 0.01);
    EXPECT_LE(l.metrics.mean_abs, 0.006);
  }
  EXPECT_TRUE(found) << "the indoor scene's point light";
}

// Analytic sphere shadows (tests/data/scene/orrery.toml): a star 1.5 m in radius and three
// spheres whose penumbrae span metres. In closed form the shadows follow the reference; drawn into
// the cube map and filtered with PCSS, the penumbrae beyond the filter's bounds come out hard
// (960x540: mean |dV| 0.0027 against 0.071). The sun's form over the same spheres under a 4-degree
// sun, against its cascades with PCSS. Without the sphere pass the spheres cast nothing (320x180:
// mean |dV| 0.12, false light 26%); with the spheres also drawn into the maps the error is the
// maps' (0.058).
TEST_F(ReferenceGpu, AnalyticSphereShadowsFollowTheReferenceUnderLargeLights) {
  scene::Scene analytic =
      scene::load_scene(fs::path(PENUMBRA_TEST_DATA_DIR) / "scene" / "orrery.toml");
  ASSERT_EQ(analytic.requirements().analytic_spheres, 3u);
  scene::Scene sun = analytic;
  sun.points.clear();
  sun.sun = scene::Sun{};
  sun.sun->direction = glm::normalize(glm::vec3(-0.25f, -0.3f, -1.0f));
  sun.sun->angular_diameter_degrees = 4.0f;
  sun.shadows.filter = scene::Filter::pcss;
  for (const scene::Scene& s : {analytic, sun}) {
    scene::Scene mapped = s;
    for (auto& i : mapped.instances) i.analytic_sphere_radius = 0.0f;
    const FrameMeasurement a = measure_at(ctx(), s, 320, 180);
    const FrameMeasurement m = measure_at(ctx(), mapped, 320, 180);
    ASSERT_EQ(a.lights.size(), 1u);
    ASSERT_EQ(m.lights.size(), 1u);
    const Metrics& am = a.lights[0].metrics;
    SCOPED_TRACE("analytic " + am.to_line() + "\nmapped   " + m.lights[0].metrics.to_line());
    EXPECT_GT(am.receivers, 40000u);
    // Measured 0.0051 (point) and 0.0002 (sun); most of the point light's is the reference's
    // own noise at 64 rays over a frame that is mostly penumbra (0.0027 at 256 rays, 960x540).
    EXPECT_LE(am.mean_abs, 0.008);
    EXPECT_LE(am.false_light, 0.01);
    EXPECT_LE(am.false_shadow, 0.01);
    EXPECT_LT(am.mean_abs, 0.5 * m.lights[0].metrics.mean_abs);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, ShippedSceneReference,
                         ::testing::ValuesIn(scene::shipped_scenes()));

// Standard depth at near 1e-4 / far 1e6 stores the default scene's receivers a centimetre or so
// from their surfaces (a float step of depth near 1 is about 1.5 cm at 5 m). Reconstructed as
// stored, a receiver inside its caster is shadowed by the caster itself: the reference reported
// 2.2% false light at 1280x720, salt and pepper over every object (2.45% here without the fix).
// It moves G-buffer receivers onto the surface along their view ray, within the depth's rounding
// (Receivers::depth_tolerance): 0.27% (reverse-Z at the same planes: 0.26%). What the GPU itself
// loses to that depth is measured, not hidden: 0.54% false shadow against 0.23% with reverse-Z.
TEST_F(ReferenceGpu, ReceiversTheDepthBufferPutInsideTheirCasterAreMovedOntoIt) {
  scene::Scene s = scene::load_scene(scene::find_scene("default"));
  s.camera.near = 1e-4f;
  s.camera.far = 1e6f;
  s.shadows.reverse_z = false;
  s.render.width = 640;
  s.render.height = 360;
  render::RendererOptions ro;
  ro.visibility_output = true;
  render::Renderer r(ctx(), s, ro);
  r.render(0);
  FrameMeasurement m;
  // Both terminator models: with flat triangles nothing else (the ray skipping its own
  // triangle) hides a receiver inside its caster.
  for (const Terminator t : {Terminator::smooth, Terminator::geometric}) {
    MeasureOptions mo;
    mo.trace.samples = 64;
    mo.trace.terminator = t;
    m = measure_frame(r, mo);
    ASSERT_EQ(m.lights.size(), 1u);
    const Metrics& sun = m.lights[0].metrics;
    EXPECT_LE(sun.false_light, 0.01) << sun.to_line();
    EXPECT_LE(sun.false_shadow, 0.01) << sun.to_line();
  }
  size_t widened = 0;
  for (size_t i = 0; i < m.receivers.size(); ++i)
    widened += m.receivers.valid[i] && m.receivers.depth_tolerance[i] > 0.005f;
  EXPECT_GT(widened, m.receivers.size() / 4) << "the depth's rounding exceeds 5 mm on most objects";
}

// ---- bad input ----------------------------------------------------------------------------------
// The sun straight up, below the horizon, reaches the undersides through the non-casting
// ground. The contact march must not take that ground for an occluder (the prepass marks casters
// in the normals' alpha): it did, and dithered 13.6% of the lit receivers into false shadow at
// 1280x720 (0.08% with the mask). At this test's 320x180: 4.4% without the mask, 0.07% with it.
// The false shadow the contact pass adds is measured against the same frame without the pass:
// the shadow map itself leaves some on these head-on lit, curved undersides (6.1% of 1354
// receivers with the scene's 0.25-texel normal offset, 0% at 0.75, where instead 75% of them
// are falsely lit), and that is the normal offset's trade, not the contact march's.
TEST_F(ReferenceGpu, ContactShadowsIgnoreSurfacesThatCastNoShadow) {
  scene::Scene s = scene::load_scene(scene::find_scene("default"));
  s.sun->direction = glm::vec3(0.0f, 1.0f, 0.0f);
  ASSERT_GT(s.contact.step_count, 0u);
  const FrameMeasurement with = measure_at(ctx(), s, 320, 180);
  s.contact.step_count = 0;
  const FrameMeasurement without = measure_at(ctx(), s, 320, 180);
  ASSERT_EQ(with.lights.size(), 1u);
  ASSERT_EQ(without.lights.size(), 1u);
  const Metrics& sun = with.lights[0].metrics;
  ASSERT_GT(sun.receivers, 1000u) << "the undersides the sun reaches";
  EXPECT_LE(sun.false_shadow - without.lights[0].metrics.false_shadow, 0.01)
      << "with the contact pass: " << sun.to_line()
      << "\nwithout: " << without.lights[0].metrics.to_line();
}

TEST_F(ReferenceGpu, WithoutTheVisibilityOutputMeasuringIsAClearError) {
  scene::Scene s = scene::parse_scene(kHardSunScene, "hard-sun.toml", ".");
  render::Renderer r(ctx(), s);
  r.render(0);
  try {
    measure_frame(r, {});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("visibility_output"), std::string::npos) << e.what();
  }
  render::RendererOptions ro;
  ro.visibility_output = true;
  render::Renderer with(ctx(), s, ro);
  with.render(0);
  MeasureOptions mo;
  mo.lights = {"spot0"};
  try {
    measure_frame(with, mo);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("spot0"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("sun"), std::string::npos) << e.what();
  }
}

// Inside a box the rasterizer culls the box's faces (back faces) and sees the scene beyond;
// the tracer keeps the box as a (two-sided) caster. The result is defined: finite metrics,
// visibility in [0, 1] at every receiver, and the box's shadow where its rays cross it.
TEST_F(ReferenceGpu, ACameraInsideGeometryGivesADefinedMeasurement) {
  std::string text = kHardSunScene;
  text += R"(
[[object]]
mesh = "box"
size = [3, 3, 3]
position = [0.3, 2.6, 3.6]
material = "grey"
)";
  const scene::Scene s = scene::parse_scene(text, "inside.toml", ".");
  render::RendererOptions ro;
  ro.visibility_output = true;
  render::Renderer r(ctx(), s, ro);
  r.render(0);
  const FrameMeasurement m = measure_frame(r, {});
  ASSERT_EQ(m.lights.size(), 1u);
  const auto& sun = m.lights[0];
  EXPECT_GT(sun.metrics.receivers, 1000u);
  for (size_t i = 0; i < sun.classes.size(); ++i)
    if (sun.classes[i] != ReceiverClass::none) {
      ASSERT_GE(sun.reference.value[i], 0.0f) << i;
      ASSERT_LE(sun.reference.value[i], 1.0f) << i;
    }
  EXPECT_TRUE(std::isfinite(sun.metrics.mean_abs));
  EXPECT_TRUE(std::isfinite(sun.metrics.misclassified));
}

}  // namespace
}  // namespace penumbra::reference
