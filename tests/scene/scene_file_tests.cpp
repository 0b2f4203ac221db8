// The TOML scene format: values, defaults, derived data and every error message.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>
#include <penumbra/core/error.hpp>
#include <penumbra/scene/filters.hpp>
#include <penumbra/scene/scene.hpp>
#include <string>
#include <vector>

namespace penumbra::scene {
namespace {

// The filter table's names, in its order ("hard, pcf, ...").
std::string filter_list() {
  std::string names;
  for (std::string_view n : filter_names()) names += (names.empty() ? "" : ", ") + std::string(n);
  return names;
}

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

const fs::path kData = fs::path(PENUMBRA_TEST_DATA_DIR) / "scene";
const char* const kFile = "scenes/x.toml";
const std::string kBox = "[[object]]\nmesh = \"box\"\n";

Scene parse(const std::string& text) {
  return parse_scene(text, kFile, kData);
}

std::string error_of(const std::string& text) {
  try {
    parse(text);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// "scenes/x.toml:<line>: " for the first line of `text` containing `marker`.
std::string at(const std::string& text, const std::string& marker) {
  const std::size_t pos = text.find(marker);
  EXPECT_NE(pos, std::string::npos) << marker;
  const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n');
  return std::string(kFile) + ":" + std::to_string(line) + ": ";
}

glm::vec3 apply(const glm::mat4& m, glm::vec3 p) {
  return glm::vec3(m * glm::vec4(p, 1.0f));
}

void expect_near(glm::vec3 a, glm::vec3 b, float tolerance = 1e-5f) {
  EXPECT_NEAR(a.x, b.x, tolerance);
  EXPECT_NEAR(a.y, b.y, tolerance);
  EXPECT_NEAR(a.z, b.z, tolerance);
}

// ---- values and defaults ---------------------------------------------------------------------

TEST(SceneFile, MinimalSceneGetsDefaults) {
  const Scene scene = parse(kBox);
  EXPECT_EQ(scene.name, "x");
  EXPECT_EQ(scene.source, fs::path(kFile));
  EXPECT_FALSE(scene.sun.has_value());
  EXPECT_TRUE(scene.spots.empty());
  EXPECT_TRUE(scene.points.empty());
  ASSERT_EQ(scene.instances.size(), 1u);
  ASSERT_EQ(scene.meshes.size(), 1u);
  ASSERT_EQ(scene.materials.size(), 1u);
  EXPECT_EQ(scene.materials[0].name, "default");
  EXPECT_EQ(scene.materials[0].albedo, glm::vec3(0.8f));
  EXPECT_EQ(scene.meshes[0].bounds.max, glm::vec3(0.5f));
  EXPECT_EQ(scene.camera.fov_y_degrees, 60.0f);
  EXPECT_EQ(scene.shadows.filter, Filter::pcf);
  EXPECT_EQ(scene.shadows.cascades, 4u);
  EXPECT_EQ(scene.contact.step_count, 16u);
  EXPECT_EQ(scene.render.width, 1280u);
  const Scene::Requirements r = scene.requirements();
  EXPECT_FALSE(r.sun_shadows);
  EXPECT_EQ(r.cascades, 0u);
  EXPECT_EQ(r.spot_shadow_maps, 0u);
  EXPECT_EQ(r.point_shadow_cubes, 0u);
  EXPECT_FALSE(r.contact_pass);  // no light to cast contact shadows from
  EXPECT_FALSE(r.masked_materials);
}

TEST(SceneFile, EveryTableIsRead) {
  const Scene scene = parse(R"(
name = "full"
[camera]
position = [0, 3, 8]
target = [0, 0.5, 0]
up = [0, 2, 0]
fov_y = 55
near = 0.2
far = 300
[sun]
direction = [0, -2, 0]
angular_diameter = 1.5
intensity = 4
color = [1, 0.95, 0.9]
shadows = true
[[spot]]
position = [1, 2, 3]
direction = [0, -1, 0]
color = [1, 0, 0]
intensity = 5
outer_angle = 40
inner_angle = 10
range = 15
shadows = false
resolution = 256
[[point]]
position = [0, 5, 0]
color = [0, 1, 0]
intensity = 7
range = 9
shadows = true
resolution = 128
[shadows]
filter = "pcss"
cascades = 3
lambda = 0.5
max_distance = 40
resolution = 1024
fit = "box"
pcf_radius = 2
pcss_quality = "high"
blend_band = 0.2
fade_band = 0.3
normal_offset_texels = 1.0
slope_bias = 1.5
constant_bias = 0.001
reverse_z = false
[contact]
steps = 8
max_distance = 0.5
thickness = 0.1
intensity = 0.7
[render]
width = 640
height = 480
frames = 3
view = "cascades"
exposure = 1.5
[[material]]
name = "fence"
albedo = [0.1, 0.2, 0.3]
alpha = "masked"
mask = "stripes"
mask_scale = [8, 1]
alpha_cutoff = 0.4
[[object]]
mesh = "plane"
size = [40, 30]
subdivisions = 4
casts_shadows = false
[[object]]
mesh = "box"
size = [4, 1, 0.05]
material = "fence"
)");
  EXPECT_EQ(scene.name, "full");
  EXPECT_EQ(scene.camera.position, glm::vec3(0, 3, 8));
  EXPECT_EQ(scene.camera.up, glm::vec3(0, 1, 0));  // normalised
  EXPECT_EQ(scene.camera.fov_y_degrees, 55.0f);
  EXPECT_EQ(scene.camera.near, 0.2f);
  EXPECT_EQ(scene.camera.far, 300.0f);
  ASSERT_TRUE(scene.sun.has_value());
  EXPECT_EQ(scene.sun->direction, glm::vec3(0, -1, 0));
  EXPECT_EQ(scene.sun->angular_diameter_degrees, 1.5f);
  EXPECT_EQ(scene.sun->intensity, 4.0f);
  ASSERT_EQ(scene.spots.size(), 1u);
  EXPECT_EQ(scene.spots[0].outer_degrees, 40.0f);
  EXPECT_EQ(scene.spots[0].inner_degrees, 10.0f);
  EXPECT_EQ(scene.spots[0].range, 15.0f);
  EXPECT_FALSE(scene.spots[0].shadows);
  EXPECT_EQ(scene.spots[0].resolution, 256u);
  ASSERT_EQ(scene.points.size(), 1u);
  EXPECT_EQ(scene.points[0].color, glm::vec3(0, 1, 0));
  EXPECT_EQ(scene.points[0].resolution, 128u);
  EXPECT_EQ(scene.shadows.filter, Filter::pcss);
  EXPECT_EQ(scene.shadows.cascades, 3u);
  EXPECT_EQ(scene.shadows.split_lambda, 0.5f);
  EXPECT_EQ(scene.shadows.max_distance, 40.0f);
  EXPECT_EQ(scene.shadows.resolution, 1024u);
  EXPECT_EQ(scene.shadows.fit, CascadeFit::box);
  EXPECT_EQ(scene.shadows.pcf_radius, 2);
  EXPECT_EQ(scene.shadows.pcss_quality, 2);
  EXPECT_EQ(scene.shadows.blend_band, 0.2f);
  EXPECT_EQ(scene.shadows.fade_band, 0.3f);
  EXPECT_EQ(scene.shadows.normal_offset_texels, 1.0f);
  EXPECT_EQ(scene.shadows.slope_bias, 1.5f);
  EXPECT_EQ(scene.shadows.constant_bias, 0.001f);
  EXPECT_FALSE(scene.shadows.reverse_z);
  EXPECT_EQ(scene.contact.step_count, 8u);
  EXPECT_EQ(scene.contact.intensity, 0.7f);
  EXPECT_EQ(scene.render.width, 640u);
  EXPECT_EQ(scene.render.frames, 3u);
  EXPECT_EQ(scene.render.view, DebugView::cascades);
  EXPECT_EQ(scene.render.exposure, 1.5f);
  ASSERT_EQ(scene.materials.size(), 2u);  // fence + the implicit default
  EXPECT_EQ(scene.materials[0].alpha, AlphaMode::masked);
  EXPECT_EQ(scene.materials[0].mask, MaskPattern::stripes);
  EXPECT_EQ(scene.materials[0].mask_scale, glm::vec2(8, 1));
  EXPECT_EQ(scene.materials[0].alpha_cutoff, 0.4f);
  ASSERT_EQ(scene.instances.size(), 2u);
  EXPECT_FALSE(scene.instances[0].casts_shadows);
  EXPECT_EQ(scene.meshes[scene.instances[0].mesh].vertices.size(), 25u);
  EXPECT_EQ(scene.instances[1].material, 0u);

  const Scene::Requirements r = scene.requirements();
  EXPECT_TRUE(r.sun_shadows);
  EXPECT_EQ(r.cascades, 3u);
  EXPECT_EQ(r.spot_shadow_maps, 0u);  // its shadows are off
  EXPECT_EQ(r.point_shadow_cubes, 1u);
  EXPECT_TRUE(r.contact_pass);
  EXPECT_TRUE(r.masked_materials);

  const Bounds world = scene.world_bounds();
  EXPECT_EQ(world.min, glm::vec3(-20, -0.5f, -15));
  EXPECT_EQ(world.max, glm::vec3(20, 0.5f, 15));
  const Bounds casters = scene.caster_bounds();  // the fence only
  EXPECT_EQ(casters.min, glm::vec3(-2, -0.5f, -0.025f));
  EXPECT_EQ(casters.max, glm::vec3(2, 0.5f, 0.025f));
}

TEST(SceneFile, SunFromElevationAndAzimuth) {
  const Scene scene = parse("[sun]\nelevation = 3\nazimuth = 90\n" + kBox);
  ASSERT_TRUE(scene.sun.has_value());
  // The sun stands in +X, 3 degrees up: its light travels towards -X and slightly down.
  const float e = glm::radians(3.0f);
  expect_near(scene.sun->direction, glm::vec3(-std::cos(e), -std::sin(e), 0.0f));
  const Scene noon = parse("[sun]\nelevation = 90\n" + kBox);
  expect_near(noon.sun->direction, glm::vec3(0, -1, 0));
  const Scene south = parse("[sun]\nelevation = 0\nazimuth = 0\n" + kBox);
  expect_near(south.sun->direction, glm::vec3(0, 0, 1));  // sun at -Z, light travels to +Z
}

TEST(SceneFile, SpotTargetGivesItsDirection) {
  const Scene scene = parse("[[spot]]\nposition = [0, 3, 0]\ntarget = [4, 0, 0]\n" + kBox);
  ASSERT_EQ(scene.spots.size(), 1u);
  expect_near(scene.spots[0].direction, glm::vec3(0.8f, -0.6f, 0.0f));
  EXPECT_EQ(scene.spots[0].inner_degrees, 25.0f);
  const Scene narrow = parse(
      "[[spot]]\nposition = [0, 3, 0]\ndirection = [0, -1, 0]\n"
      "outer_angle = 10\n" +
      kBox);
  EXPECT_EQ(narrow.spots[0].inner_degrees, 10.0f);  // the default inner clamps to outer
}

TEST(SceneFile, LightRadiusDefaultsToAPointAndIsRead) {
  const Scene point = parse("[[spot]]\nposition = [0, 3, 0]\ntarget = [4, 0, 0]\n" + kBox);
  EXPECT_EQ(point.spots[0].radius, 0.0f);
  const Scene area = parse(
      "[[spot]]\nposition = [0, 3, 0]\ntarget = [4, 0, 0]\nradius = 0.25\n"
      "[[point]]\nposition = [1, 2, 0]\nradius = 0.1\n" +
      kBox);
  EXPECT_EQ(area.spots[0].radius, 0.25f);
  EXPECT_EQ(area.points[0].radius, 0.1f);
  const std::string text = "[[point]]\nposition = [1, 2, 0]\nradius = -0.5\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "radius") + "[[point]] #1 radius = -0.5 is out "
                                                             "of range; must be >= 0"));
}

TEST(SceneFile, AnalyticSpheresLeaveTheMapsAndAreListedInWorldSpace) {
  const std::string sun = "[sun]\ndirection = [0, -1, 0]\n";
  const Scene scene = parse(sun +
                            "[[object]]\nmesh = \"sphere\"\nradius = 0.5\nposition = [1, 2, 3]\n"
                            "scale = 3\nanalytic_shadow = true\n"
                            "[[object]]\nmesh = \"sphere\"\nposition = [4, 0, 0]\n" +
                            kBox);
  ASSERT_EQ(scene.instances.size(), 3u);
  EXPECT_EQ(scene.instances[0].analytic_sphere_radius, 0.5f);
  EXPECT_FALSE(scene.instances[0].in_shadow_maps());
  EXPECT_TRUE(scene.instances[0].casts_shadows);  // still a caster (the contact pass, the truth)
  EXPECT_TRUE(scene.instances[1].in_shadow_maps());
  const auto spheres = scene.analytic_spheres();
  ASSERT_EQ(spheres.size(), 1u);
  expect_near(glm::vec3(spheres[0]), glm::vec3(1, 2, 3));
  EXPECT_FLOAT_EQ(spheres[0].w, 1.5f);
  EXPECT_EQ(scene.requirements().analytic_spheres, 1u);
  // Without a shadowed light nothing is built for them.
  const Scene unlit = parse("[[object]]\nmesh = \"sphere\"\nanalytic_shadow = true\n");
  EXPECT_EQ(unlit.requirements().analytic_spheres, 0u);
  // A scatter of spheres: every instance is one, at its own position and scale.
  const Scene field = parse(sun +
                            "[[scatter]]\nmesh = \"sphere\"\ncount = 5\nradius = 10\n"
                            "scale = [1, 2]\nanalytic_shadow = true\n");
  ASSERT_EQ(field.analytic_spheres().size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) {
    expect_near(glm::vec3(field.analytic_spheres()[i]), glm::vec3(field.instances[i].transform[3]));
    // The sphere's default radius (a scatter's `radius` is where it places them) times the scale.
    EXPECT_GE(field.analytic_spheres()[i].w, 0.5f);
    EXPECT_LE(field.analytic_spheres()[i].w, 1.0f);
  }
}

TEST(SceneFile, AnalyticShadowsAreForUniformlyScaledCastingSpheres) {
  const std::string box = "[[object]]\nmesh = \"box\"\nanalytic_shadow = true\n";
  EXPECT_THAT(error_of(box), HasSubstr(at(box, "analytic_shadow") +
                                       "[[object]] #1 analytic_shadow: analytic_shadow = true "
                                       "needs mesh = \"sphere\""));
  const std::string uneven =
      "[[object]]\nmesh = \"sphere\"\nscale = [1, 2, 1]\nanalytic_shadow = true\n";
  EXPECT_THAT(error_of(uneven), HasSubstr(at(uneven, "analytic_shadow") +
                                          "[[object]] #1 analytic_shadow: analytic_shadow = "
                                          "true needs a uniform scale"));
  const std::string hidden =
      "[[object]]\nmesh = \"sphere\"\ncasts_shadows = false\nanalytic_shadow = true\n";
  EXPECT_THAT(error_of(hidden), HasSubstr(at(hidden, "analytic_shadow") +
                                          "[[object]] #1 "
                                          "analytic_shadow: analytic_shadow = true with "
                                          "casts_shadows = false"));
  const std::string many =
      "[[scatter]]\nmesh = \"sphere\"\ncount = 300\nradius = 100\n"
      "analytic_shadow = true\n";
  EXPECT_THAT(error_of(many), HasSubstr(at(many, "analytic_shadow") +
                                        "[[scatter]] #1 analytic_shadow: the scene has 300 "
                                        "analytic spheres; at most 256 are supported"));
}

TEST(SceneFile, ALightsOwnFilterOverridesTheScenes) {
  const Scene scene = parse(
      "[[spot]]\nposition = [0, 3, 0]\ntarget = [4, 0, 0]\nfilter = \"pcss\"\n"
      "[[point]]\nposition = [1, 2, 0]\n" +
      kBox);
  ASSERT_TRUE(scene.spots[0].filter.has_value());
  EXPECT_EQ(*scene.spots[0].filter, Filter::pcss);
  EXPECT_FALSE(scene.points[0].filter.has_value());  // the [shadows] filter applies
  // "inherit" says so explicitly (what set writes back for a light without a filter).
  EXPECT_FALSE(parse("[[point]]\nposition = [1, 2, 0]\nfilter = \"inherit\"\n" + kBox)
                   .points[0]
                   .filter.has_value());
  const std::string text = "[[point]]\nposition = [1, 2, 0]\nfilter = \"pfc\"\n" + kBox;
  const std::string names = "inherit, " + filter_list();
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "filter") +
                                        "[[point]] #1 filter: unknown value 'pfc'; valid values: " +
                                        names + " (did you mean 'pcf'?)"));
  EXPECT_THAT(names, ::testing::StartsWith("inherit, hard, pcf, pcss, poisson, evsm2"));
  // A spot or point light's own evsm2 asks for its own moments, and only those.
  const Scene spot_evsm =
      parse("[[spot]]\nposition = [0, 3, 0]\ntarget = [4, 0, 0]\nfilter = \"evsm2\"\n" + kBox);
  EXPECT_EQ(spot_evsm.spots[0].filter, Filter::evsm2);
  EXPECT_TRUE(spot_evsm.requirements().spot_moments);
  EXPECT_FALSE(spot_evsm.requirements().point_moments);
  const Scene point_evsm = parse("[[point]]\nposition = [1, 2, 0]\nfilter = \"evsm2\"\n" + kBox);
  EXPECT_EQ(point_evsm.points[0].filter, Filter::evsm2);
  EXPECT_TRUE(point_evsm.requirements().point_moments);
  EXPECT_FALSE(point_evsm.requirements().spot_moments);
  EXPECT_FALSE(point_evsm.requirements().sun_moments);
  // Under the sun's evsm2 a light without a filter of its own keeps it unset (pcf is chosen
  // when the frame is packed), and the scene requires the moments only with a shadowed sun.
  const Scene sun = parse(
      "[sun]\ndirection = [0, -1, 0]\n[shadows]\nfilter = \"evsm2\"\n"
      "[[point]]\nposition = [1, 2, 0]\n" +
      kBox);
  EXPECT_FALSE(sun.points[0].filter.has_value());
  EXPECT_TRUE(sun.requirements().sun_moments);
  const Scene no_sun = parse("[shadows]\nfilter = \"evsm2\"\n" + kBox);
  EXPECT_FALSE(no_sun.requirements().sun_moments);
}

TEST(SceneFile, ObjectTransform) {
  const Scene scene = parse(R"(
[[object]]
mesh = "box"
position = [1, 2, 3]
rotation = [0, 90, 0]
scale = [2, 1, 1]
[[object]]
mesh = "box"
rotation = [90, 0, 90]
scale = 3
)");
  ASSERT_EQ(scene.instances.size(), 2u);
  // Scale x by 2, then turn +X into -Z (90 degrees about +Y), then move.
  expect_near(apply(scene.instances[0].transform, glm::vec3(1, 0, 0)), glm::vec3(1, 2, 1));
  expect_near(apply(scene.instances[0].transform, glm::vec3(0, 1, 0)), glm::vec3(1, 3, 3));
  // Rotations apply about x first, then z: +Y -> +Z (about x) -> +Z (about z).
  expect_near(apply(scene.instances[1].transform, glm::vec3(0, 1, 0)), glm::vec3(0, 0, 3));
  // +X -> +X (about x) -> +Y (about z).
  expect_near(apply(scene.instances[1].transform, glm::vec3(1, 0, 0)), glm::vec3(0, 3, 0));
  // Both boxes share one mesh.
  EXPECT_EQ(scene.meshes.size(), 1u);
}

TEST(SceneFile, MeshesAreSharedByParameters) {
  const Scene scene = parse(R"(
[[object]]
mesh = "post"
radius = 0.03
[[object]]
mesh = "post"
radius = 0.03
position = [1, 0, 0]
[[object]]
mesh = "post"
radius = 0.04
[[object]]
mesh = "chair"
[[object]]
mesh = "chair"
[[object]]
mesh = "sphere"
[[object]]
mesh = "table"
)");
  EXPECT_EQ(scene.instances.size(), 7u);
  EXPECT_EQ(scene.meshes.size(), 5u);
  EXPECT_EQ(scene.instances[0].mesh, scene.instances[1].mesh);
  EXPECT_NE(scene.instances[0].mesh, scene.instances[2].mesh);
  EXPECT_EQ(scene.instances[3].mesh, scene.instances[4].mesh);
}

TEST(SceneFile, ModelsAreNormalisedByHeightOrSize) {
  const Scene scene = parse(R"(
[[object]]
mesh = "model:bunny"
height = 0.8
position = [1, 0, 0]
[[object]]
mesh = "model:bunny"
size = 2
[[object]]
mesh = "model:asteroid-low.3ds"
)");
  ASSERT_EQ(scene.instances.size(), 3u);
  EXPECT_EQ(scene.meshes.size(), 2u);
  const Mesh& bunny = scene.meshes[scene.instances[0].mesh];
  const Bounds standing = transform_bounds(bunny.bounds, scene.instances[0].transform);
  EXPECT_NEAR(standing.min.y, 0.0f, 1e-5f);
  EXPECT_NEAR(standing.size().y, 0.8f, 1e-5f);
  EXPECT_NEAR(standing.center().x, 1.0f, 1e-5f);
  const Bounds sized = transform_bounds(bunny.bounds, scene.instances[1].transform);
  EXPECT_NEAR(std::max({sized.size().x, sized.size().y, sized.size().z}), 2.0f, 1e-5f);
  expect_near(sized.center(), glm::vec3(0.0f));
  EXPECT_EQ(scene.meshes[scene.instances[2].mesh].name, "asteroid-low");
}

TEST(SceneFile, MeshFilesResolveAgainstTheSceneDirectory) {
  const Scene scene = load_scene(kData / "relative.toml");
  EXPECT_EQ(scene.name, "relative");
  ASSERT_EQ(scene.meshes.size(), 1u);
  EXPECT_EQ(scene.meshes[0].name, "tetra_cw");
  EXPECT_EQ(scene.meshes[0].indices.size(), 12u);
  const Scene absolute =
      parse("[[object]]\nmesh = \"file:" + (kData / "quad.obj").string() + "\"\n");
  EXPECT_EQ(absolute.meshes[0].name, "quad");
}

TEST(SceneFile, MaskTextureAndInferredAlpha) {
  const Scene scene = parse(R"(
[[material]]
name = "tex"
mask_texture = "mask_checker.png"
[[material]]
name = "holes"
mask = "circles"
)" + kBox);
  ASSERT_GE(scene.materials.size(), 2u);
  EXPECT_EQ(scene.materials[0].mask, MaskPattern::texture);
  EXPECT_EQ(scene.materials[0].alpha, AlphaMode::masked);
  EXPECT_TRUE(scene.materials[0].mask_texture.is_absolute());
  EXPECT_EQ(scene.materials[0].mask_texture.filename(), "mask_checker.png");
  EXPECT_EQ(scene.materials[1].alpha, AlphaMode::masked);
  EXPECT_FALSE(scene.requirements().masked_materials);  // no instance uses them
}

TEST(SceneFile, MaskTexturesAreReadAndSharedAndCountedWhenUsed) {
  const std::string text = R"(
[[material]]
name = "a"
mask_texture = "mask_checker.png"
[[material]]
name = "b"
mask_texture = "./mask_checker.png"
mask_scale = [4, 4]
[[material]]
name = "unused"
mask_texture = "mask_checker.png"
[[object]]
mesh = "box"
material = "a"
[[object]]
mesh = "plane"
material = "b"
)";
  const Scene scene = parse(text);
  ASSERT_TRUE(scene.materials[0].mask_image);
  const MaskImage& image = *scene.materials[0].mask_image;
  EXPECT_EQ(image.width, 8u);
  EXPECT_EQ(image.height, 8u);
  ASSERT_EQ(image.texels.size(), 64u);
  // One texture file, one entry, whichever spelling of its path.
  EXPECT_EQ(scene.requirements().mask_textures, 1u);
  EXPECT_EQ(scene.mask_images().size(), 1u);
  EXPECT_EQ(scene.mask_image_index(0), 0);
  EXPECT_EQ(scene.mask_image_index(1), 0);
  EXPECT_TRUE(scene.requirements().masked_materials);
}

TEST(SceneFile, AMaskTextureThatIsNotAPngIsAnErrorNamingKeyAndFile) {
  const std::string text = "[[material]]\nname = \"m\"\nmask_texture = \"quad.obj\"\n" + kBox;
  const std::string e = error_of(text);
  EXPECT_THAT(e, HasSubstr(at(text, "mask_texture")));
  EXPECT_THAT(e, HasSubstr("'quad.obj'"));
  EXPECT_THAT(e, HasSubstr("not a PNG"));
  // A directory is not a texture either.
  const std::string dir = "[[material]]\nname = \"m\"\nmask_texture = \".\"\n" + kBox;
  EXPECT_THAT(error_of(dir), HasSubstr(at(dir, "mask_texture")));
}

TEST(SceneFile, TextureMaskIsBilinearBetweenTexelCentresAndRepeats) {
  MaskImage image;
  image.width = 2;
  image.height = 1;
  image.texels = {0, 255};
  // At texel centres: the texels.
  EXPECT_FLOAT_EQ(texture_mask(image, {0.25f, 0.5f}, {1, 1}), 0.0f);
  EXPECT_FLOAT_EQ(texture_mask(image, {0.75f, 0.5f}, {1, 1}), 1.0f);
  // Halfway between them, and across the wrap (u = 0 lies between texel 1 and texel 0).
  EXPECT_FLOAT_EQ(texture_mask(image, {0.5f, 0.5f}, {1, 1}), 0.5f);
  EXPECT_FLOAT_EQ(texture_mask(image, {0.0f, 0.5f}, {1, 1}), 0.5f);
  EXPECT_FLOAT_EQ(texture_mask(image, {0.125f, 0.5f}, {1, 1}), 0.25f);
  EXPECT_FLOAT_EQ(texture_mask(image, {-0.875f, 0.3f}, {1, 1}), 0.25f);        // repeats
  EXPECT_FLOAT_EQ(texture_mask(image, {0.125f / 4.0f, 0.5f}, {4, 1}), 0.25f);  // scaled
  EXPECT_FLOAT_EQ(texture_mask(image, {NAN, 0.5f}, {1, 1}), 1.0f);
  // A material: the alpha test cuts out below the cutoff.
  Material m;
  m.alpha = AlphaMode::masked;
  m.mask = MaskPattern::texture;
  m.mask_image = std::make_shared<const MaskImage>(image);
  m.alpha_cutoff = 0.5f;
  EXPECT_TRUE(alpha_test_discards(m, {0.3f, 0.5f}));
  EXPECT_FALSE(alpha_test_discards(m, {0.6f, 0.5f}));
}

TEST(SceneFile, ScatterIsDeterministicInsideItsShellAndWithoutOverlaps) {
  const std::string text = R"(
[[object]]
mesh = "plane"
size = [100, 100]
[[object]]
mesh = "sphere"
radius = 3
position = [12, 0, 0]
[[scatter]]
mesh = "model:asteroid-low"
count = 150
seed = 7
center = [0, 1, 0]
radius = 30
inner_radius = 8
flatten = 0.5
size = 1
scale = [0.5, 2]
)";
  const Scene a = parse(text);
  const Scene b = parse(text);
  ASSERT_EQ(a.instances.size(), 152u);
  ASSERT_EQ(b.instances.size(), 152u);
  struct Sphere {
    glm::vec3 centre;
    float radius;
  };
  std::vector<Sphere> spheres;
  for (std::size_t i = 1; i < a.instances.size(); ++i) {
    EXPECT_EQ(a.instances[i].transform, b.instances[i].transform);
    const Bounds bounds =
        transform_bounds(a.meshes[a.instances[i].mesh].bounds, a.instances[i].transform);
    spheres.push_back({bounds.center(), 0.5f * glm::length(bounds.size())});
    if (i < 2) continue;
    // The mesh's bounds centre lands on the sampled position.
    const glm::vec3 offset =
        apply(a.instances[i].transform, a.meshes[a.instances[i].mesh].bounds.center()) -
        glm::vec3(0, 1, 0);
    EXPECT_GE(glm::length(offset), 8.0f - 1e-3f);
    EXPECT_LE(glm::length(glm::vec3(offset.x, offset.y / 0.5f, offset.z)), 30.0f + 1e-3f);
    const glm::vec3 size = bounds.size();
    EXPECT_LE(std::max({size.x, size.y, size.z}), 2.0f * std::sqrt(3.0f) + 1e-3f);
  }
  // Bounding boxes' spheres are loose; the placement used the (tighter) mesh bounds' spheres, so
  // compare with the mesh-bounds radius instead: centres at least the sum of those radii apart.
  std::size_t overlaps = 0;
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    for (std::size_t j = i + 1; j < spheres.size(); ++j) {
      const float tight_i = spheres[i].radius / std::sqrt(3.0f);
      const float tight_j = spheres[j].radius / std::sqrt(3.0f);
      if (glm::length(spheres[i].centre - spheres[j].centre) < tight_i + tight_j) ++overlaps;
    }
  }
  EXPECT_EQ(overlaps, 0u);

  const Scene other = parse(text.substr(0, text.find("seed = 7")) + "seed = 8" +
                            text.substr(text.find("seed = 7") + 8));
  EXPECT_NE(other.instances[5].transform, a.instances[5].transform);
}

// ---- requirements ----------------------------------------------------------------------------

TEST(SceneRequirements, OnlyWhatIsDeclared) {
  const Scene no_contact = parse("[sun]\ndirection = [0, -1, 0]\n[contact]\nsteps = 0\n" + kBox);
  EXPECT_FALSE(no_contact.requirements().contact_pass);
  EXPECT_TRUE(no_contact.requirements().sun_shadows);

  const Scene unshadowed_sun = parse("[sun]\ndirection = [0, -1, 0]\nshadows = false\n" + kBox);
  EXPECT_FALSE(unshadowed_sun.requirements().sun_shadows);
  EXPECT_EQ(unshadowed_sun.requirements().cascades, 0u);
  EXPECT_TRUE(unshadowed_sun.requirements().contact_pass);

  const Scene one_cascade =
      parse("[sun]\ndirection = [0, -1, 0]\n[shadows]\ncascades = 1\n" + kBox);
  EXPECT_EQ(one_cascade.requirements().cascades, 1u);

  const Scene lights = parse(R"(
[[spot]]
position = [0, 3, 0]
direction = [0, -1, 0]
[[spot]]
position = [1, 3, 0]
direction = [0, -1, 0]
shadows = false
[[point]]
position = [0, 2, 0]
shadows = false
[[material]]
name = "grid"
mask = "checker"
)" + kBox + "material = \"grid\"\n");
  const Scene::Requirements r = lights.requirements();
  EXPECT_FALSE(r.sun_shadows);
  EXPECT_EQ(r.spot_shadow_maps, 1u);
  EXPECT_EQ(r.point_shadow_cubes, 0u);
  EXPECT_TRUE(r.contact_pass);
  EXPECT_TRUE(r.masked_materials);
}

// ---- errors ----------------------------------------------------------------------------------

TEST(SceneErrors, UnknownKeyNamesLineTableAndSuggestion) {
  const std::string text =
      "name = \"x\"\n\n[sun]\ndirection = [0, -1, 0]\ncolour = [1, 1, 1]\n" + kBox;
  EXPECT_THAT(error_of(text),
              HasSubstr("scenes/x.toml:5: unknown key 'colour' in [sun] (did you mean 'color'?)"));
}

struct UnknownKeyCase {
  std::string text;
  std::string where;  // "in [sun]"
  std::string key;
};

class UnknownKeys : public ::testing::TestWithParam<UnknownKeyCase> {};

TEST_P(UnknownKeys, AreCaughtAtEveryLevel) {
  const UnknownKeyCase& c = GetParam();
  const std::string message = error_of(c.text);
  EXPECT_THAT(message,
              HasSubstr(at(c.text, c.key + " =") + "unknown key '" + c.key + "' " + c.where));
}

INSTANTIATE_TEST_SUITE_P(
    SceneErrors, UnknownKeys,
    ::testing::Values(
        UnknownKeyCase{"titel = \"x\"\n" + kBox, "at the top level", "titel"},
        UnknownKeyCase{"[camera]\nfov = 40\n" + kBox, "in [camera]", "fov"},
        UnknownKeyCase{"[sun]\ndirection = [0, -1, 0]\nsize = 2\n" + kBox, "in [sun]", "size"},
        UnknownKeyCase{"[[spot]]\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nangle = 3\n" + kBox,
                       "in [[spot]] #1", "angle"},
        UnknownKeyCase{"[[point]]\nposition = [0, 1, 0]\n[[point]]\nposition = [0, 2, 0]\n"
                       "size = 3\n" +
                           kBox,
                       "in [[point]] #2", "size"},
        UnknownKeyCase{"[shadows]\nfilter = \"pcf\"\ncascade = 2\n" + kBox, "in [shadows]",
                       "cascade"},
        UnknownKeyCase{"[contact]\nstep = 2\n" + kBox, "in [contact]", "step"},
        UnknownKeyCase{"[render]\nwidht = 2\n" + kBox, "in [render]", "widht"},
        UnknownKeyCase{"[[material]]\nname = \"a\"\ncolor = [1, 1, 1]\n" + kBox,
                       "in [[material]] #1", "color"},
        UnknownKeyCase{kBox + "positon = [0, 0, 0]\n", "in [[object]] #1", "positon"},
        UnknownKeyCase{"[[scatter]]\nmesh = \"box\"\ncount = 3\nradius = 5\nsede = 3\n",
                       "in [[scatter]] #1", "sede"}));

TEST(SceneErrors, SuggestionsForTypos) {
  EXPECT_THAT(error_of("[camera]\nfov = 40\n" + kBox), HasSubstr("(did you mean 'fov_y'?)"));
  EXPECT_THAT(error_of("[[spots]]\nposition = [0, 1, 0]\n" + kBox),
              HasSubstr("unknown key 'spots' at the top level (did you mean 'spot'?)"));
  EXPECT_THAT(error_of(kBox + "positon = [0, 0, 0]\n"), HasSubstr("(did you mean 'position'?)"));
  EXPECT_THAT(error_of("[render]\nwidht = 2\n" + kBox), HasSubstr("(did you mean 'width'?)"));
  // No suggestion when nothing is close.
  EXPECT_THAT(error_of("[contact]\nbanana = 2\n" + kBox), Not(HasSubstr("did you mean")));
}

TEST(SceneErrors, ShapeKeysOfAnotherMesh) {
  const std::string text = kBox + "radius = 0.5\n";
  EXPECT_THAT(error_of(text),
              HasSubstr(at(text, "radius") + "key 'radius' does not apply to mesh 'box' in "
                                             "[[object]] #1 (mesh 'box' takes: size)"));
  EXPECT_THAT(error_of("[[object]]\nmesh = \"chair\"\nsize = [1, 1, 1]\n"),
              HasSubstr("does not apply to mesh 'chair'"));
  EXPECT_THAT(error_of("[[object]]\nmesh = \"model:bunny\"\nradius = 1\n"),
              HasSubstr("does not apply to a mesh file"));
}

TEST(SceneErrors, WrongTypes) {
  std::string text = "[sun]\ndirection = [0, -1, 0]\nintensity = \"bright\"\n" + kBox;
  EXPECT_THAT(error_of(text),
              HasSubstr(at(text, "intensity") + "[sun] intensity: expected a number, got a string "
                                                "('bright')"));
  text = "[shadows]\ncascades = 2.5\n" + kBox;
  EXPECT_THAT(error_of(text),
              HasSubstr(at(text, "cascades") + "[shadows] cascades: expected an integer, got a "
                                               "floating-point number (2.5)"));
  text = "[sun]\ndirection = [0, -1, 0]\nshadows = 1\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr("[sun] shadows: expected true or false, got an integer"));
  text = "[camera]\nposition = [0, 1]\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "position") +
                                        "[camera] position = [ 0, 1 ] has 2 elements; expected 3"));
  text = "[camera]\nposition = [0, \"one\", 2]\n" + kBox;
  EXPECT_THAT(error_of(text),
              HasSubstr("[camera] position element 2: expected a number, got a string ('one')"));
  text = "[camera]\ntarget = 3\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr("[camera] target: expected an array of 3 numbers, got an "
                                        "integer (3)"));
  text = "[shadows]\nfilter = 2\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr("[shadows] filter: expected a string (one of " +
                                        filter_list() + "), got an integer (2)"));
  text = "[sun]\ndirection = [0, -1, 0]\nintensity = nan\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr("[sun] intensity = nan is not finite"));
}

TEST(SceneErrors, ValuesOutOfRange) {
  std::string text = "[camera]\nfov_y = 200\n" + kBox;
  EXPECT_THAT(
      error_of(text),
      HasSubstr(at(text, "fov_y") + "[camera] fov_y = 200 is out of range; must be in (0, 180)"));
  EXPECT_THAT(error_of("[camera]\nfov_y = 0\n" + kBox), HasSubstr("fov_y = 0 is out of range"));
  text = "[shadows]\ncascades = 5\n" + kBox;
  EXPECT_THAT(error_of(text),
              HasSubstr(at(text, "cascades") + "[shadows] cascades = 5 is out of range; must be in "
                                               "[1, 4]"));
  EXPECT_THAT(error_of("[shadows]\ncascades = 0\n" + kBox),
              HasSubstr("cascades = 0 is out of range"));
  text = "[[object]]\nmesh = \"box\"\nsize = [1, -2, 1]\n";
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "size") +
                                        "[[object]] #1 size = [ 1, -2, 1 ] is out of range; every "
                                        "element must be > 0"));
  text = "[[object]]\nmesh = \"sphere\"\nradius = -1\n";
  EXPECT_THAT(error_of(text), HasSubstr("[[object]] #1 radius = -1 is out of range; must be > 0"));
  // The contact pass marches at most 64 steps: the file says so, not the renderer later.
  text = "[contact]\nsteps = 100\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "steps") + "[contact] steps = 100 is out of "
                                                            "range; must be in [0, 64]"));
  EXPECT_EQ(parse("[contact]\nsteps = 64\n" + kBox).contact.step_count, 64u);
  // near and far out of order: at near's line, naming far's; a near beyond the default far
  // (1e38) at near's line, not far's; a far under the default near at far's.
  text = "[camera]\nnear = 1\nfar = 0.5\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "near") +
                                        "[camera] near = 1 must be less than far = 0.5 (line 3)"));
  text = "[camera]\nnear = 1e38\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "near") + "[camera] near = 1e+38 must be less "
                                                           "than far = 500 (the default)"));
  text = "[camera]\nfar = 0.01\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "far") + "[camera] far = 0.01 must be greater "
                                                          "than near = 0.1 (the default)"));
  text =
      "[[spot]]\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nouter_angle = 20\n"
      "inner_angle = 30\n" +
      kBox;
  EXPECT_THAT(error_of(text),
              HasSubstr(at(text, "inner_angle") + "[[spot]] #1 inner_angle = 30 must not exceed "
                                                  "outer_angle = 20"));
  EXPECT_THAT(error_of("[shadows]\nresolution = 8\n" + kBox),
              HasSubstr("resolution = 8 is out of range; must be in [16, 16384]"));
  EXPECT_THAT(error_of("[[material]]\nname = \"m\"\nalbedo = [1.5, 0, 0]\n" + kBox),
              HasSubstr("albedo = [ 1.5, 0, 0 ] is out of range; every element must be in [0, 1]"));
  EXPECT_THAT(error_of(kBox + "scale = 0\n"), HasSubstr("scale = 0 is out of range; must be > 0"));
  EXPECT_THAT(error_of("[camera]\nposition = [1, 2, 3]\ntarget = [1, 2, 3]\n" + kBox),
              HasSubstr("the camera's target equals its position"));
  EXPECT_THAT(error_of("[camera]\nposition = [0, 5, 0]\ntarget = [0, 0, 0]\n" + kBox),
              HasSubstr("[camera] up is parallel to the view direction"));
}

// vogel takes 2D maps only: a point light's own vogel is refused at its line; the sun and a
// spot light take it.
TEST(SceneErrors, AVogelFilterOnAPointLightIsRefused) {
  const std::string text = "[[point]]\nposition = [1, 2, 0]\nfilter = \"vogel\"\n" + kBox;
  EXPECT_THAT(error_of(text),
              HasSubstr(at(text, "filter") + "[[point]] #1 filter = 'vogel' does not take a point "
                                             "light's cube maps (a point light takes hard, pcf, "
                                             "pcss, poisson, evsm2)"));
  const Scene ok = parse("[shadows]\nfilter = \"vogel\"\n[[spot]]\nposition = [0, 3, 0]\n"
                         "target = [4, 0, 0]\nfilter = \"vogel\"\n" + kBox);
  EXPECT_EQ(ok.shadows.filter, Filter::vogel);
  EXPECT_EQ(ok.spots[0].filter, Filter::vogel);
}

TEST(SceneErrors, UnknownEnumValuesListTheValidOnes) {
  const std::string text = "[shadows]\nfilter = \"pfc\"\n" + kBox;
  EXPECT_THAT(error_of(text),
              HasSubstr(at(text, "filter") + "[shadows] filter: unknown value 'pfc'; valid values: " +
                        filter_list() + " (did you mean 'pcf'?)"));
  EXPECT_THAT(error_of("[shadows]\nfit = \"sphere\"\n" + kBox),
              HasSubstr("valid values: box, camera_sphere, slice_sphere"));
  EXPECT_THAT(error_of("[render]\nview = \"depth\"\n" + kBox),
              HasSubstr("valid values: lit, shadow_factor, cascades, contact_mask, texel_density, "
                        "penumbra"));
  EXPECT_THAT(error_of("[shadows]\npcss_quality = \"ultra\"\n" + kBox),
              HasSubstr("valid values: low, medium, high"));
  EXPECT_THAT(error_of("[shadows]\npcss_quality = 3\n" + kBox),
              HasSubstr("pcss_quality = 3 is out of range; must be in [0, 2]"));
  EXPECT_THAT(error_of("[[object]]\nmesh = \"bxo\"\n"),
              HasSubstr("[[object]] #1 mesh: unknown mesh 'bxo'; valid: plane, box, sphere, post, "
                        "chair, table, model:<name>, file:<path> (did you mean 'box'?)"));
}

TEST(SceneErrors, ZeroLengthDirections) {
  std::string text = "[sun]\ndirection = [0, 0, 0]\n" + kBox;
  EXPECT_THAT(error_of(text),
              HasSubstr(at(text, "direction") + "[sun] direction = [ 0, 0, 0 ] has zero length"));
  text = "[[spot]]\nposition = [0, 1, 0]\ndirection = [0, 0, 0]\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "direction =") + "[[spot]] #1 direction"));
  EXPECT_THAT(error_of("[[spot]]\nposition = [0, 1, 0]\ntarget = [0, 1, 0]\n" + kBox),
              HasSubstr("[[spot]] #1 target: equals the light's position"));
  EXPECT_THAT(error_of("[camera]\nup = [0, 0, 0]\n" + kBox), HasSubstr("[camera] up"));
}

TEST(SceneErrors, MissingMeshFileNamesThePath) {
  const std::string text = "\n\n" + kBox + "[[object]]\nmesh = \"file:meshes/foo.obj\"\n";
  const fs::path resolved = fs::absolute(kData / "meshes/foo.obj").lexically_normal();
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "file:meshes") +
                                        "[[object]] #2 mesh: mesh file "
                                        "'meshes/foo.obj' not found (resolved to " +
                                        resolved.string() + ")"));
  EXPECT_THAT(error_of("[[object]]\nmesh = \"model:bunnny\"\n"),
              HasSubstr("model 'bunnny' not found in /usr/share/glmark2/models; available: "));
  EXPECT_THAT(error_of("[[object]]\nmesh = \"model:bunnny\"\n"),
              HasSubstr("(did you mean 'bunny'?)"));
  EXPECT_THAT(error_of("[[material]]\nname = \"m\"\nmask_texture = \"nope.png\"\n" + kBox),
              HasSubstr("texture file 'nope.png' not found (resolved to "));
}

// Paths that exist but are no regular file, or hold a NUL byte, say so at the key's line (they
// were "not found", or the OS cut the path at the NUL and opened another file).
TEST(SceneErrors, FilePathsThatAreNoFileOrHoldANulSaySo) {
  std::string text = "[[object]]\nmesh = \"file:/dev/zero\"\n";
  EXPECT_THAT(error_of(text),
              HasSubstr(at(text, "file:") + "[[object]] #1 mesh: mesh file '/dev/zero' is a "
                                            "character device, not a regular file"));
  text = "[[object]]\nmesh = \"file:.\"\n";  // the scene's own folder
  EXPECT_THAT(error_of(text), HasSubstr("mesh file '.' is a directory, not a file"));
  text = "[[object]]\nmesh = \"file:tri.obj\\u0000.3ds\"\n";
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "file:") +
                                        "[[object]] #1 mesh: mesh file 'tri.obj\\0.3ds' contains a "
                                        "NUL byte (at 7); a path cannot"));
  text = "[[material]]\nname = \"m\"\nmask_texture = \"/dev/zero\"\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "mask_texture") +
                                        "[[material]] #1 mask_texture: texture file '/dev/zero' "
                                        "is a character device, not a regular file"));
  text = "[[material]]\nname = \"m\"\nmask_texture = \"a.png\\u0000b\"\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr("texture file 'a.png\\0b' contains a NUL byte (at 5)"));
  // Scene files themselves.
  try {
    load_scene("/dev/null");
    ADD_FAILURE() << "/dev/null loaded as a scene";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("scene file '/dev/null' is a character device, not a "
                                    "regular file"));
  }
  try {
    load_scene(kData);
    ADD_FAILURE() << "a directory loaded as a scene";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("is a directory, not a file"));
  }
}

TEST(SceneErrors, BrokenMeshFileNamesSceneLineAndFile) {
  // A file that exists but is not a mesh: the scene's line and the mesh file's own error.
  const std::string text = "[[object]]\nmesh = \"file:mask_checker.png\"\n";
  const std::string message = error_of(text);
  EXPECT_THAT(message, HasSubstr(at(text, "file:") + "[[object]] #1 mesh: mesh file '"));
  EXPECT_THAT(message, HasSubstr("unsupported format '.png'"));
}

TEST(SceneErrors, Materials) {
  std::string text = "[[material]]\nname = \"ground\"\n" + kBox + "material = \"grund\"\n";
  EXPECT_THAT(error_of(text),
              HasSubstr(at(text, "grund") + "[[object]] #1 material: unknown material 'grund' (did "
                                            "you mean 'ground'?); defined: ground"));
  EXPECT_EQ(parse(kBox + "material = \"default\"\n").materials.at(0).name, "default");
  EXPECT_THAT(error_of(kBox + "material = \"stone\"\n"),
              HasSubstr("unknown material 'stone'; no [[material]] is defined"));
  text = "[[material]]\nname = \"a\"\n[[material]]\nname = \"a\"\n" + kBox;
  EXPECT_THAT(error_of(text), HasSubstr("scenes/x.toml:4: [[material]] #2 name: material 'a' is "
                                        "already defined at line 2"));
  EXPECT_THAT(error_of("[[material]]\nname = \"a\"\nalpha = \"masked\"\n" + kBox),
              HasSubstr("alpha = 'masked' needs a mask"));
  EXPECT_THAT(
      error_of("[[material]]\nname = \"a\"\nalpha = \"opaque\"\nmask = \"checker\"\n" + kBox),
      HasSubstr("[[material]] #1 mask: a mask has no effect on an opaque material"));
  EXPECT_THAT(error_of("[[material]]\nname = \"a\"\nmask = \"texture\"\n" + kBox),
              HasSubstr("mask = 'texture' needs a mask_texture file"));
  EXPECT_THAT(error_of("[[material]]\nalbedo = [1, 1, 1]\n" + kBox),
              HasSubstr("scenes/x.toml:1: [[material]] #1: missing required key 'name'"));
  EXPECT_THAT(error_of("[[material]]\nname = \"a\"\nalpha_cutoff = 1\n" + kBox),
              HasSubstr("alpha_cutoff = 1 is out of range; must be in (0, 1)"));
}

TEST(SceneErrors, TomlSyntaxErrorHasItsLine) {
  const std::string text = "name = \"x\"\n[camera]\nposition = [0, 1, 2\nfov_y = 3\n";
  const std::string message = error_of(text);
  EXPECT_THAT(message, HasSubstr("scenes/x.toml:4: TOML syntax error"));
  EXPECT_THAT(error_of("a = 1\na = 2\n"), HasSubstr("scenes/x.toml:2: TOML syntax error"));
}

TEST(SceneErrors, Structure) {
  EXPECT_THAT(error_of("[[sun]]\ndirection = [0, -1, 0]\n" + kBox),
              HasSubstr("scenes/x.toml:1: 'sun' must be a table, got an array (write [sun], not "
                        "[[sun]])"));
  EXPECT_THAT(error_of("[object]\nmesh = \"box\"\n"),
              HasSubstr("scenes/x.toml:1: 'object' must be an array of tables, got a table "
                        "(write [[object]], not [object])"));
  EXPECT_THAT(error_of("camera = 3\n" + kBox), HasSubstr("'camera' must be a table"));
  EXPECT_THAT(error_of("name = \"empty\"\n"),
              HasSubstr("scenes/x.toml: the scene has no geometry; add an [[object]] or a "
                        "[[scatter]]"));
  EXPECT_THAT(error_of("[[object]]\nposition = [0, 0, 0]\n"),
              HasSubstr("scenes/x.toml:1: [[object]] #1: missing required key 'mesh'"));
  EXPECT_THAT(error_of("[[spot]]\ndirection = [0, -1, 0]\n" + kBox),
              HasSubstr("[[spot]] #1: missing required key 'position'"));
  EXPECT_THAT(error_of("[[spot]]\nposition = [0, 1, 0]\n" + kBox),
              HasSubstr("[[spot]] #1: missing required key 'direction' (or 'target')"));
  EXPECT_THAT(error_of("[sun]\nintensity = 2\n" + kBox),
              HasSubstr("[sun]: missing required key 'direction' (or 'elevation')"));
  EXPECT_THAT(error_of("[sun]\ndirection = [0, -1, 0]\nelevation = 3\n" + kBox),
              HasSubstr("give either 'direction' or 'elevation' and 'azimuth', not both"));
  EXPECT_THAT(error_of("[[scatter]]\nmesh = \"box\"\nradius = 3\n"),
              HasSubstr("[[scatter]] #1: missing required key 'count'"));
  EXPECT_THAT(error_of("[[scatter]]\nmesh = \"box\"\ncount = 3\nradius = 3\ninner_radius = 4\n"),
              HasSubstr("[[scatter]] #1 inner_radius = 4 must be less than radius = 3"));
  EXPECT_THAT(error_of("[[scatter]]\nmesh = \"box\"\ncount = 3\nradius = 3\nscale = [2, 1]\n"),
              HasSubstr("[[scatter]] #1 scale = [ 2, 1 ] must be [min, max] with min <= max"));
  EXPECT_THAT(error_of("[[object]]\nmesh = \"model:bunny\"\nheight = 1\nsize = 1\n"),
              HasSubstr("give either 'size' or 'height', not both"));
}

TEST(SceneErrors, LoadSceneMissingFile) {
  try {
    load_scene(kData / "does_not_exist.toml");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("does_not_exist.toml' not found"));
  }
}

TEST(FindScene, NamesAndPaths) {
  const fs::path found = find_scene("default");
  EXPECT_EQ(found, fs::path(PENUMBRA_SCENE_DIR) / "default.toml");
  EXPECT_TRUE(fs::exists(found));
  EXPECT_EQ(find_scene("some/dir/x.toml"), fs::path("some/dir/x.toml"));
  EXPECT_EQ(find_scene("x.toml"), fs::path("x.toml"));
  try {
    find_scene("defualt");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("scene 'defualt' not found"));
    EXPECT_THAT(e.what(), HasSubstr("shipped scenes: default, grazing, indoor, space"));
  }
}

TEST(ToString, NamesRoundTrip) {
  EXPECT_EQ(to_string(Filter::poisson), "poisson");
  EXPECT_EQ(to_string(CascadeFit::camera_sphere), "camera_sphere");
  EXPECT_EQ(to_string(DebugView::texel_density), "texel_density");
  EXPECT_EQ(to_string(AlphaMode::masked), "masked");
  EXPECT_EQ(to_string(MaskPattern::circles), "circles");
}

// A third spot or point light would be ignored by the renderer: it is an error at its table.
TEST(SceneFile, MoreLocalLightsThanTheRendererShadesIsAnErrorAtTheExtraOne) {
  const std::string spot = "[[spot]]\nposition = [0, 3, 0]\ndirection = [0, -1, 0]\n";
  const std::string three_spots = kBox + spot + spot + "# the third\n" + spot;
  const std::string e = error_of(three_spots);
  EXPECT_THAT(e, HasSubstr("scenes/x.toml:10: [[spot]] #3: "));  // after "# the third"
  EXPECT_THAT(e, HasSubstr("at most 2 spot lights"));
  const std::string point = "[[point]]\nposition = [0, 2, 0]\n";
  EXPECT_THAT(error_of(kBox + point + point + point), HasSubstr("at most 2 point lights"));
  EXPECT_EQ(error_of(kBox + spot + spot + point + point), "(no error)");
}

// The scene's name is the output directory under out/: a path, an empty or a very long name is
// refused at its line.
TEST(SceneFile, ANameThatIsAPathIsRefused) {
  for (const std::string& bad : std::vector<std::string>{"../../../x", "/tmp/abs", "a/b", "",
                                                         ".hidden", std::string(5000, 'n')}) {
    const std::string text = "name = \"" + bad + "\"\n" + kBox;
    const std::string e = error_of(text);
    EXPECT_THAT(e, HasSubstr("scenes/x.toml:1: ")) << bad;
    EXPECT_THAT(e,
                ::testing::AnyOf(HasSubstr("must be a plain name"), HasSubstr("must not be empty")))
        << bad;
    EXPECT_LT(e.size(), 400u) << "a long name is cut in the message";
  }
  EXPECT_EQ(parse("name = \"indoor-2.b_x\"\n" + kBox).name, "indoor-2.b_x");
}

// Scatters that could not finish: a count past the scene's instance budget is an error at its
// line; a dense field (3,999 boxes in a 1 cm ball, where no instance finds a free spot) is
// placed with bounded work instead of trying every pair 64 times.
TEST(SceneFile, ScatterCountsAreBoundedAndADenseFieldStillLoads) {
  const std::string big = kBox + "[[scatter]]\nmesh = \"box\"\ncount = 100000\nradius = 10\n";
  EXPECT_THAT(error_of(big), HasSubstr(at(big, "count = 100000") + "[[scatter]] #1 count"));
  std::string many = kBox;
  for (int i = 0; i < 3; ++i) many += "[[scatter]]\nmesh = \"box\"\ncount = 9000\nradius = 10\n";
  const std::string e = error_of(many);
  EXPECT_THAT(e, HasSubstr("would make 27001; a scene has at most 20000")) << e;
  const Scene dense = parse(kBox + "[[scatter]]\nmesh = \"box\"\ncount = 3999\nradius = 0.01\n");
  EXPECT_EQ(dense.instances.size(), 4000u);
}

}  // namespace
}  // namespace penumbra::scene

namespace penumbra::scene {
namespace {

// [tune] (penumbra-tune's budget): read and checked like any table; the renderer ignores it.
TEST(SceneErrors, TuneBudgetIsCheckedAtItsLines) {
  EXPECT_NO_THROW(parse(kBox + "[tune]\ndevice = \"NVIDIA H200\"\nbudget_ms = 2.3\n"
                               "max_flicker = 0.005\nmax_acne = 0.001\n"));
  std::string text = kBox + "[tune]\nbudget_mss = 2\n";
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "budget_mss") + "unknown key 'budget_mss' in "
                                                                  "[tune] (did you mean "
                                                                  "'budget_ms'?)"));
  text = kBox + "[tune]\nbudget_ms = -1\n";
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "budget_ms") + "[tune] budget_ms = -1 is out "
                                                                 "of range"));
  text = kBox + "[tune]\nmax_gap = -0.5\n";
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "max_gap") + "[tune] max_gap = -0.5"));
  text = kBox + "[tune]\ndevice = \"x\"\n";
  EXPECT_THAT(error_of(text), HasSubstr("[tune] names no budget: give budget_ms or a max_*"));
}

TEST(SceneFile, ObjectsMoveAndSpinOverFrames) {
  const std::string ground = "[[object]]\nmesh = \"plane\"\nsize = [40, 40]\n";
  const Scene s = parse(ground +
                        "[[object]]\nmesh = \"box\"\nposition = [1, 0.5, 0]\n"
                        "move = [2, 0, -1]\nmove_frames = 4\nspin = [0, 90, 0]\n");
  const Instance& box = s.instances.at(1);
  ASSERT_TRUE(box.motion.has_value());
  EXPECT_TRUE(s.has_motion());
  EXPECT_FALSE(s.instances[0].motion.has_value());
  const auto at = [&](uint32_t k) { return glm::vec3(box.motion->transform_at(k)[3]); };
  // There and back: exact at the ends, halfway at move_frames / 2.
  EXPECT_EQ(at(0), glm::vec3(1, 0.5f, 0));
  EXPECT_EQ(at(4), glm::vec3(3, 0.5f, -1));
  EXPECT_EQ(at(8), glm::vec3(1, 0.5f, 0));
  EXPECT_EQ(at(2), glm::vec3(2, 0.5f, -0.5f));
  // 90 degrees a frame about y: the box's x axis turns to -z.
  const glm::mat4 one = box.motion->transform_at(1);
  EXPECT_NEAR(one[0].z, -1.0f, 1e-6f);
  EXPECT_NEAR(one[0].x, 0.0f, 1e-6f);
  // Pose sets the transform; the bounds over the motion hold every frame's.
  Scene posed = s;
  posed.pose(4);
  EXPECT_EQ(glm::vec3(posed.instances[1].transform[3]), glm::vec3(3, 0.5f, -1));
  const Bounds all = s.motion_bounds(box);
  for (uint32_t k = 0; k < 16; ++k) {
    const Bounds b = transform_bounds(s.meshes[box.mesh].bounds, box.motion->transform_at(k));
    EXPECT_TRUE(glm::all(glm::greaterThanEqual(b.min, all.min)) &&
                glm::all(glm::lessThanEqual(b.max, all.max)))
        << "frame " << k;
  }
}

TEST(SceneFile, TheCameraWalksThereAndBack) {
  const Scene s = parse(kBox + "[camera]\nposition = [0, 2, 6]\ntarget = [0, 0, 0]\n"
                               "move = [1, 0, 0]\nmove_frames = 10\n");
  EXPECT_EQ(s.camera.position_at(0), glm::vec3(0, 2, 6));
  EXPECT_EQ(s.camera.position_at(10), glm::vec3(1, 2, 6));
  EXPECT_EQ(s.camera.target_at(10), glm::vec3(1, 0, 0));
  EXPECT_EQ(s.camera.position_at(20), glm::vec3(0, 2, 6));
  EXPECT_TRUE(s.has_motion());
}

TEST(SceneFile, BadMotionIsAnErrorAtItsLine) {
  const std::string ground = "[[object]]\nmesh = \"plane\"\nsize = [40, 40]\n";
  const std::string box = ground + "[[object]]\nmesh = \"box\"\n";
  std::string text = box + "move = [1, 0, 0]\n";
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "move =") + "[[object]] #2 move: needs move_frames"));
  text = box + "move_frames = 3\n";
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "move_frames") + "[[object]] #2 move_frames: applies to a move"));
  text = box + "move = [1, 0, 0]\nmove_frames = -1\n";
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "move_frames") + "[[object]] #2 move_frames = -1 is out of range"));
  // 0 frames, as for the camera's walk: the object stays put.
  const Scene held = parse(box + "move = [1, 0, 0]\nmove_frames = 0\n");
  EXPECT_EQ(held.instances[1].motion->transform_at(7), held.instances[1].motion->base);
  text = box + "move = [nan, 0, 0]\nmove_frames = 2\n";
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "move =")));
  EXPECT_THAT(error_of(text), HasSubstr("not finite"));
  // Out of the still objects' bounds (the 40 m ground, grown by the box's 1 m).
  text = box + "move = [0, 0, 500]\nmove_frames = 2\n";
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "move =") + "[[object]] #2 move: the object's move takes it to [0, 0, 500]"));
  EXPECT_THAT(error_of(text), HasSubstr("outside the still objects' bounds"));
  text = ground + "[[object]]\nmesh = \"sphere\"\nanalytic_shadow = true\nspin = [0, 5, 0]\n";
  EXPECT_THAT(error_of(text), HasSubstr(at(text, "spin") + "[[object]] #2 spin: an analytic sphere"));
}

}  // namespace
}  // namespace penumbra::scene
