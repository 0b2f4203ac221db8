// The shadow-map cache (shadows.cache) changes no pixel: scripted sequences rendered with the
// cache on and off give the same shadow maps and the same final image, bit for bit, at every
// frame, while the cache draws less. The sequences move the camera, move casters into and out
// of the cascades and a spot cone, move the lights, refit the cascades, change a parameter and
// reload a shader.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <glm/gtc/matrix_inverse.hpp>
#include <penumbra/render/frame_pack.hpp>
#include <penumbra/render/renderer.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/scene/scene.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <string>

#include "../runtime/temp_tree.hpp"

namespace penumbra {
namespace {

using testing::GpuTest;

// A shipped scene, small and held still: the tests give it the motions they script.
scene::Scene small(std::string_view name) {
  auto s = scene::load_scene(scene::find_scene(name));
  s.hold_still();
  s.render.width = 160;
  s.render.height = 90;
  s.shadows.resolution = 256;
  for (auto& p : s.spots) p.resolution = 128;
  for (auto& p : s.points) p.resolution = 64;
  return s;
}

// Gives instance i a motion: a walk by `move` over `frames` frames and a spin.
void make_move(scene::Scene& s, size_t i, glm::vec3 move, uint32_t frames, glm::vec3 spin = {}) {
  scene::Motion m;
  m.base = s.instances.at(i).transform;
  m.move = move;
  m.move_frames = frames;
  m.spin = spin;
  s.instances[i].motion = m;
}

// Reloads the renderer's shader file named `name` (unchanged: its pipelines are rebuilt).
void reload(render::Renderer& r, const std::string& name) {
  for (const auto& f : r.shader_files())
    if (f.filename() == name) {
      const auto result = r.reload({f});
      EXPECT_FALSE(result.rebuilt.empty()) << name;
      return;
    }
  ADD_FAILURE() << "no shader file " << name;
}

// Cascades that scroll through a grid of their own, copied into the map (where EVSM2 moments are
// made from it; forced so every device runs it).
render::RendererOptions scrolling() {
  render::RendererOptions o;
  o.scroll_cascades = render::RendererOptions::Scroll::on;
  o.sun_window = render::RendererOptions::SunWindow::copy;
  return o;
}

// Cascades read in place from their toroidal grid (the default where it can).
render::RendererOptions in_place() {
  render::RendererOptions o = scrolling();
  o.sun_window = render::RendererOptions::SunWindow::in_place;
  return o;
}

// An event applied to both renderers before frame k is rendered.
using Event = std::function<void(render::Renderer&)>;

// How many texels of two maps (4-byte texels) differ, and the first (its texel index).
std::string where(const std::vector<std::byte>& a, const std::vector<std::byte>& b) {
  if (a.size() != b.size()) return "sizes differ";
  size_t n = 0, first = 0;
  for (size_t i = 0; i + 3 < a.size(); i += 4)
    if (std::memcmp(&a[i], &b[i], 4) != 0) {
      if (n++ == 0) first = i / 4;
    }
  std::string rows;
  if (std::getenv("PENUMBRA_CACHE_DEBUG")) {
    for (size_t i = 0, shown = 0; i + 3 < a.size() && shown < 40; i += 4)
      if (std::memcmp(&a[i], &b[i], 4) != 0) {
        float x, y;
        std::memcpy(&x, &a[i], 4);
        std::memcpy(&y, &b[i], 4);
        const size_t t = i / 4;
        rows += " [" + std::to_string(t / 65536) + ":" + std::to_string(t % 256) + "," +
                std::to_string((t / 256) % 256) + " " + std::to_string(x) + " " + std::to_string(y) + "]";
        ++shown;
      }
  }
  return std::to_string(n) + " texels, the first at texel " + std::to_string(first) + rows;
}

struct Totals {
  uint32_t layers = 0, drawn = 0, scrolled = 0, moving = 0;
  uint64_t texels_after_first = 0;  // the texels the cache drew after frame 0
  // The caster triangles drawn after frame 0, with the cache and without.
  uint64_t triangles_after_first = 0, triangles_off_after_first = 0;
};

class ShadowCache : public GpuTest {
 protected:
  // Renders frames 0 .. frames-1 (after `events` at their frame) with the cache on and off and
  // requires the same maps and image at each; returns what the cache drew.
  Totals expect_identical(scene::Scene s, uint32_t frames,
                          const std::map<uint32_t, Event>& events = {},
                          render::RendererOptions options = {}) {
    scene::Scene off_scene = s;
    off_scene.shadows.cache = false;
    s.shadows.cache = true;
    render::Renderer on(ctx(), s, options), off(ctx(), off_scene, options);
    Totals t;
    for (uint32_t k = 0; k < frames; ++k) {
      SCOPED_TRACE("frame " + std::to_string(k));
      if (const auto e = events.find(k); e != events.end()) {
        e->second(on);
        e->second(off);
      }
      on.render(k);
      off.render(k);
      const auto& stats = on.shadow_cache_stats();
      SCOPED_TRACE("drawn " + std::to_string(stats.drawn) + ", scrolled " +
                   std::to_string(stats.scrolled) + ", moving " +
                   std::to_string(stats.moving_drawn) + " of " + std::to_string(stats.layers));
      EXPECT_EQ(off.shadow_cache_stats().drawn, off.shadow_cache_stats().layers);
      t.layers += stats.layers;
      t.drawn += stats.drawn;
      t.scrolled += stats.scrolled;
      t.moving += stats.moving_drawn;
      if (k > 0) {
        t.texels_after_first += stats.texels_drawn;
        t.triangles_after_first += stats.triangles_drawn;
        t.triangles_off_after_first += off.shadow_cache_stats().triangles_drawn;
      }
      const auto maps_on = on.read_shadow_maps(), maps_off = off.read_shadow_maps();
      EXPECT_EQ(maps_on.size(), maps_off.size());
      for (size_t m = 0; m < maps_on.size() && m < maps_off.size(); ++m)
        EXPECT_TRUE(maps_on[m] == maps_off[m])
            << "shadow map " << m << " differs: " << where(maps_on[m], maps_off[m]);
      EXPECT_TRUE(on.read_rgba8() == off.read_rgba8()) << "the image differs";
      if (HasFailure()) break;
    }
    return t;
  }
};

TEST_F(ShadowCache, AStillSceneDrawsItsMapsOnce) {
  scene::Scene s = small("default");
  s.shadows.temporal = false;
  const Totals t = expect_identical(s, 3);
  EXPECT_EQ(t.layers, 9u);
  EXPECT_EQ(t.drawn, 3u);  // the first frame's cascades only
}

// The ground casts too, so every texel of every cascade holds a depth: a texel the cache leaves
// stale differs from its redrawn self.
scene::Scene filled(std::string_view name) {
  scene::Scene s = small(name);
  for (auto& i : s.instances) i.casts_shadows = true;
  return s;
}

// A refit (max_distance) before frame 4, a reload of the depth shader before 6, a parameter
// change (lambda) before 7.
std::map<uint32_t, Event> refit_reload_and_change() {
  return {{4, [](render::Renderer& r) { scene::set_param(r.scene(), "shadows.max_distance", "30"); }},
          {6, [](render::Renderer& r) { reload(r, "shadow_depth.vert"); }},
          {7, [](render::Renderer& r) { scene::set_param(r.scene(), "shadows.lambda", "0.5"); }}};
}

// The default scene filled: the ball rolls 2 m to the right and back, the box turns, the
// camera walks.
scene::Scene rolling_turning_walking() {
  scene::Scene s = filled("default");
  make_move(s, 3, {2.0f, 0.0f, 0.0f}, 3);
  make_move(s, 2, {}, 0, {0.0f, 7.0f, 0.0f});
  s.camera.move = {0.6f, 0.0f, -0.4f};
  s.camera.move_frames = 4;
  return s;
}

TEST_F(ShadowCache, AWalkingCameraAndMovingCastersChangeNoPixel) {
  scene::Scene s = rolling_turning_walking();
  const Totals t = expect_identical(
      s, 9,
      refit_reload_and_change(),
      scrolling());
  EXPECT_GT(t.moving, 0u);
  EXPECT_GT(t.scrolled, 0u);
  EXPECT_LT(t.drawn, t.layers);
}

// Without scrolling (a GPU's default) a cascade that moved is drawn whole into its map, the
// moving casters with the still ones: the same images with the cache on and off.
TEST_F(ShadowCache, WithoutScrollingAMovedCascadeIsDrawnWhole) {
  scene::Scene s = filled("default");
  make_move(s, 3, {2.0f, 0.0f, 0.0f}, 3);
  s.camera.move = {0.6f, 0.0f, -0.4f};
  s.camera.move_frames = 4;
  render::RendererOptions o;
  o.scroll_cascades = render::RendererOptions::Scroll::off;
  const Totals t = expect_identical(s, 6, {}, o);
  EXPECT_EQ(t.scrolled, 0u);
  EXPECT_EQ(t.moving, 0u);
  EXPECT_GT(t.drawn, 3u);
  render::Renderer r(ctx(), s, o), scrolled(ctx(), s, scrolling());
  EXPECT_THAT(r.built().to_string(), ::testing::Not(::testing::HasSubstr("sun-shadow-grid")));
  // The same shadows as the scrolling route's (their grids start elsewhere, so not to the bit):
  // a map laid out as the grid instead of the window would move every shadow.
  for (uint32_t k = 0; k < 4; ++k) {
    r.render(k);
    scrolled.render(k);
  }
  const auto a = r.read_rgba8(), b = scrolled.read_rgba8();
  ASSERT_EQ(a.size(), b.size());
  size_t differ = 0;
  for (size_t i = 0; i < a.size(); i += 4)
    for (size_t c = 0; c < 3; ++c)
      if (std::abs(int(a[i + c]) - int(b[i + c])) > 8) {
        ++differ;
        break;
      }
  EXPECT_LT(differ, a.size() / 4 / 200) << differ << " pixels differ";
}

// Read in place: the resolves sample the toroidal grid through each cascade's window, and no
// map is written from it. Cache on and off, the same grid and image at every frame.
TEST_F(ShadowCache, ReadInPlaceAWalkARefitAReloadAndAParameterChangeNoPixel) {
  scene::Scene s = filled("default");
  s.camera.move = {0.6f, 0.0f, -0.4f};
  s.camera.move_frames = 4;
  const Totals t = expect_identical(
      s, 9,
      refit_reload_and_change(),
      in_place());
  EXPECT_GT(t.scrolled, 0u);
  EXPECT_LT(t.drawn, t.layers);
  render::Renderer r(ctx(), s, in_place());
  const std::string report = r.built().to_string();
  EXPECT_THAT(report, ::testing::HasSubstr("read in place"));
  EXPECT_THAT(report, ::testing::Not(::testing::HasSubstr("sun-shadow-grid")));
  EXPECT_FALSE(r.built().has_pipeline("sun-shadow-window"));
}

// Read in place or from the map the grid's window is copied into: the same cascades texel for
// texel (read_sun_shadow_map unrolls the grid), and the same shadows: the windowed lookups read
// what the map gives, their taps' weights quantised apart (pcf_tests' bound: 2 * 2^-8 a tap).
TEST_F(ShadowCache, ReadInPlaceOrFromTheMapTheSameShadows) {
  for (const char* name : {"default", "grazing"}) {
    SCOPED_TRACE(name);
    scene::Scene s = small(name);
    s.camera.move = {1.5f, 0.0f, -1.0f};
    s.camera.move_frames = 6;
    render::Renderer a(ctx(), s, scrolling()), b(ctx(), s, in_place());
    for (uint32_t k = 0; k < 5; ++k) {
      SCOPED_TRACE("frame " + std::to_string(k));
      a.render(k);
      b.render(k);
      for (uint32_t c = 0; c < s.shadows.cascades; ++c)
        EXPECT_TRUE(a.read_sun_shadow_map(c) == b.read_sun_shadow_map(c)) << "cascade " << c;
      const auto ia = a.read_shadow_info(), ib = b.read_shadow_info();
      ASSERT_EQ(ia.size(), ib.size());
      double worst = 0.0;
      size_t cascade_differs = 0;
      for (size_t i = 0; i < ia.size(); i += 4) {
        worst = std::max(worst, double(std::abs(ia[i] - ib[i])));
        cascade_differs += ia[i + 1] != ib[i + 1] ? 1 : 0;
      }
      EXPECT_LE(worst, 4.0 / 256.0) << "sun visibility";
      EXPECT_EQ(cascade_differs, 0u);
    }
  }
}

// Replaces `from` by `to` in a shader file of the renderer's tree where it is still there (the
// event runs for both renderers, which share the tree), then reloads the file.
Event edit(std::string name, std::string from, std::string to) {
  return [=](render::Renderer& r) {
    for (const auto& f : r.shader_files())
      if (f.filename() == name) {
        std::string text = testing::read_text(f);
        if (const size_t at = text.find(from); at != std::string::npos) {
          text.replace(at, from.size(), to);
          std::ofstream(f) << text;
        }
      }
    reload(r, name);
  };
}

// A reload redraws the maps only where it gives a program that draws them new code. On a copy
// of the shader tree: an edit of a filter (the resolve reads the maps) and a comment in the depth
// shader (the same SPIR-V) redraw no layer, and the renderers with the cache on and off agree at
// every frame; then an edit that moves the depths a map program writes (the sun's, a point
// light's) redraws every layer, or the kept maps would differ from the cache-off renderer's.
TEST_F(ShadowCache, AReloadRedrawsTheMapsOnlyWhenItGivesAProgramThatDrawsThemNewCode) {
  struct Case {
    std::string scene;
    std::vector<Event> keep, redraw;  // one per frame after the first, in this order
  };
  const std::vector<Case> cases{
      {"default",
       {edit("pcf.glsl", "return clamp(radius, 0, kPcfMaxRadius);",
             "return clamp(radius + 1, 0, kPcfMaxRadius);"),
        edit("shadow_depth.vert", "void main() {", "// a comment\nvoid main() {")},
       {edit("shadow_depth.vert", "t.z, 1.0);", "t.z * 0.999, 1.0);")}},
      {"indoor", {}, {edit("point_depth.frag", "1.0 - t : t;", "1.0 - t * 0.999 : t * 0.999;")}}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.scene);
    testing::TempTree tree(true);
    render::RendererOptions o;
    o.shader_dir = tree.shaders();
    std::map<uint32_t, Event> events;
    uint32_t k = 1;
    for (const auto* list : {&c.keep, &c.redraw})
      for (const Event& e : *list) events[k++] = e;
    const Totals t = expect_identical(small(c.scene), k, events, o);
    ASSERT_GT(t.layers, 0u);
    // The first frame's layers, then every layer at each new code of a map program.
    EXPECT_EQ(t.drawn, t.layers / k * (1 + uint32_t(c.redraw.size()))) << "of " << t.layers;
  }
}

// Read in place with moving casters: the grid holds the still casters, the map (in the grid's
// layout) takes the strips it newly drew, and the moving casters over a restored copy where they
// are. Cache on and off, the same maps and image at every frame.
TEST_F(ShadowCache, ReadInPlaceMovingCastersAndAWalkChangeNoPixel) {
  scene::Scene s = rolling_turning_walking();
  const Totals t = expect_identical(
      s, 9,
      {{4, [](render::Renderer& r) { scene::set_param(r.scene(), "shadows.max_distance", "30"); }},
       {6, [](render::Renderer& r) { reload(r, "shadow_depth.vert"); }}},
      in_place());
  EXPECT_GT(t.moving, 0u);
  EXPECT_GT(t.scrolled, 0u);
  render::Renderer r(ctx(), s, in_place());
  const std::string report = r.built().to_string();
  EXPECT_THAT(report, ::testing::HasSubstr("read in place"));
  EXPECT_THAT(report, ::testing::HasSubstr("moving casters drawn again with the rest"));
  EXPECT_THAT(report, ::testing::Not(::testing::HasSubstr("sun-shadow-grid")));
  // A ball rolling far off, in the last cascade only: the nearer ones scroll without a moving
  // caster, their strips alone drawn.
  scene::Scene far = filled("default");
  far.instances.at(3).transform[3] = glm::vec4(-14.0f, 0.5f, -22.0f, 1.0f);
  make_move(far, 3, {3.0f, 0.0f, 0.0f}, 3);
  far.camera.move = {0.6f, 0.0f, -0.4f};
  far.camera.move_frames = 4;
  const Totals f = expect_identical(far, 6, {}, in_place());
  EXPECT_GT(f.moving, 0u);
  EXPECT_GT(f.scrolled, f.moving);
}

// Read in place, a moving caster is drawn again only in the rectangle where it was and is (the
// rest of each cascade kept, the old shadow cleared from the grid), also while the camera walks.
TEST_F(ShadowCache, ReadInPlaceAMovingCasterIsRedrawnOnlyWhereItWasAndIs) {
  for (const float walk : {0.0f, 0.3f}) {
    SCOPED_TRACE("walk " + std::to_string(walk));
    scene::Scene s = filled("default");
    make_move(s, 3, {3.0f, 0.0f, 0.0f}, 3);  // a metre a frame: the old and new balls apart
    // A box sliding unturned: its bounds are its corners, so its rectangle is tight.
    make_move(s, 2, {0.7f, 0.0f, 1.3f}, 5);
    s.camera.move = {walk, 0.0f, -walk};
    s.camera.move_frames = 3;
    s.shadows.temporal = false;
    scene::Scene off = s;
    off.shadows.cache = false;
    const Totals t = expect_identical(s, 7, {}, in_place());
    EXPECT_GT(t.moving, 0u);
    // The texels the cache drew after the first frame, against whole layers.
    const uint64_t whole = 6ull * s.shadows.cascades * s.shadows.resolution * s.shadows.resolution;
    EXPECT_LT(t.texels_after_first, whole / 4) << t.texels_after_first << " of " << whole;
  }
}

// A moving caster's rectangle that cuts through a large mesh (the bunny: 137 clusters of 512
// triangles) draws only the mesh's clusters that can reach it: the same maps as whole meshes
// (the cache off draws each whole from its own indices), for a part of the triangles. At 1024
// texels over 8 m, a cluster's bounds a texel short show.
TEST_F(ShadowCache, ARectangleDrawsOnlyTheClustersOfAMeshThatCanReachIt) {
  scene::Scene s = filled("default");
  s.shadows.resolution = 1024;
  s.shadows.cascades = 1;
  s.shadows.max_distance = 8.0f;
  s.shadows.temporal = false;
  make_move(s, 3, {1.2f, 0.0f, 0.0f}, 4);  // the ball rolls up to the bunny
  const Totals t = expect_identical(s, 5, {}, in_place());
  EXPECT_GT(t.moving, 0u);
  EXPECT_GT(t.triangles_after_first, 0u);
  // 15% of the triangles the cache off draws; the bunny whole in each rectangle it reaches
  // would be 50%.
  EXPECT_LT(t.triangles_after_first * 4, t.triangles_off_after_first)
      << t.triangles_after_first << " of " << t.triangles_off_after_first << " triangles";
}

// Under a sun straight down, an unturned box's square across the light is its footprint: its
// rectangle's last row and column are the texels its edges end in, which it covers where an
// edge passes a texel's centre. The box, unturned, slides by fractions of a texel.
TEST_F(ShadowCache, ARectangleHoldsTheTexelsATightCastersEdgesEndIn) {
  scene::Scene s = filled("default");
  scene::set_param(s, "sun.direction", "0,-1,0");
  s.shadows.temporal = false;
  s.instances.at(2).transform = glm::mat4(1.0f);
  s.instances[2].transform[3] = glm::vec4(2.3f, 0.5f, -0.4f, 1.0f);
  make_move(s, 2, {0.37f, 0.0f, 0.23f}, 7);
  const Totals t = expect_identical(s, 8, {}, in_place());
  EXPECT_GT(t.moving, 0u);
}

// A moving caster that holds still while the cascades scroll across it (the frame index held,
// the camera walked by hand): where a strip newly reaches it, it is drawn there again.
TEST_F(ShadowCache, ReadInPlaceACasterTheCascadesScrollAcrossIsDrawnIntoTheirStrips) {
  for (const float way : {1.0f}) {
    SCOPED_TRACE("way " + std::to_string(way));
    scene::Scene s = filled("default");
    make_move(s, 3, {3.0f, 0.0f, 0.0f}, 3);
    s.shadows.temporal = false;
    // Cascades a few metres across, so their edges pass over the ball as the camera walks.
    scene::set_param(s, "shadows.max_distance", "6");
    scene::Scene off_scene = s;
    off_scene.shadows.cache = false;
    render::Renderer on(ctx(), s, in_place()), off(ctx(), off_scene, in_place());
    for (int step = 0; step < 25; ++step) {
      SCOPED_TRACE("step " + std::to_string(step));
      for (render::Renderer* r : {&on, &off}) {
        r->scene().camera.position += way * glm::vec3(-0.15f, 0.0f, 0.1f);
        r->scene().camera.target += way * glm::vec3(-0.15f, 0.0f, 0.1f);
        r->render(1);
      }
      const auto a = on.read_shadow_maps(), b = off.read_shadow_maps();
      ASSERT_EQ(a.size(), b.size());
      for (size_t m = 0; m < a.size(); ++m) EXPECT_TRUE(a[m] == b[m]) << where(a[m], b[m]);
      if (HasFailure()) break;
    }
  }
}

// Read in place or through the map, with moving casters: the same cascades, to the depths'
// last bits. The two routes draw the moving casters at different window positions (the map's,
// the grid's), and the rasterizer interpolates depth from the window position: the last ULPs
// of a texel may differ (that is why a scrolled copy is no redraw, shadow_maps.cpp); a texel
// drawn by one caster and not the other (a misplaced window) differs by far more.
TEST_F(ShadowCache, ReadInPlaceOrFromTheMapTheSameCascadesWithMovingCasters) {
  scene::Scene s = rolling_turning_walking();
  render::Renderer a(ctx(), s, scrolling()), b(ctx(), s, in_place());
  for (uint32_t k = 0; k < 6; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    a.render(k);
    b.render(k);
    for (uint32_t c = 0; c < s.shadows.cascades; ++c) {
      const auto ma = a.read_sun_shadow_map(c), mb = b.read_sun_shadow_map(c);
      ASSERT_EQ(ma.size(), mb.size());
      double worst = 0.0;
      for (size_t i = 0; i < ma.size(); ++i) worst = std::max(worst, double(std::abs(ma[i] - mb[i])));
      EXPECT_LE(worst, 1e-6) << "cascade " << c;
    }
  }
}

// EVSM2's moments are made through each cascade's window when the cascades are read in place:
// the same moments, so the same visibility and image bit for bit, as from the map the copy route
// writes (with
// and without the moments' mips), and cache on and off the same along a walk past a moving
// caster.
TEST_F(ShadowCache, ReadInPlaceEvsmMomentsAreTheCopiedMapsMoments) {
  for (const bool mips : {false, true}) {
    SCOPED_TRACE(mips ? "evsm_mips" : "no mips");
    scene::Scene s = filled("default");
    scene::set_param(s, "shadows.filter", "evsm2");
    s.shadows.evsm_mips = mips;
    s.shadows.temporal = false;
    make_move(s, 3, {2.0f, 0.0f, 0.0f}, 3);
    s.camera.move = {1.5f, 0.0f, -1.0f};
    s.camera.move_frames = 6;
    render::Renderer copied(ctx(), s, scrolling()), in(ctx(), s, in_place());
    EXPECT_THAT(in.built().to_string(), ::testing::HasSubstr("read in place"));
    EXPECT_THAT(copied.built().to_string(), ::testing::Not(::testing::HasSubstr("read in place")));
    for (uint32_t k = 0; k < 5; ++k) {  // frame 4: cascades 0 and 2 scrolled apart in x and y
      SCOPED_TRACE("frame " + std::to_string(k));
      copied.render(k);
      in.render(k);
      EXPECT_TRUE(copied.read_rgba8() == in.read_rgba8()) << "the image differs";
      EXPECT_TRUE(copied.read_shadow_info() == in.read_shadow_info()) << "the sun's V differs";
    }
    if (mips) continue;  // the mips are made from the moments: the cache's part is the same
    const Totals t = expect_identical(s, 5, {}, in_place());
    EXPECT_GT(t.scrolled, 0u);
    EXPECT_GT(t.moving, 0u);
  }
}

TEST_F(ShadowCache, AWalkDrawsOnlyWhatTheCascadesNewlyReach) {
  scene::Scene s = filled("grazing");
  s.camera.move = {1.5f, 0.0f, -1.0f};
  s.camera.move_frames = 6;
  const Totals t = expect_identical(s, 8, {}, scrolling());
  // After the first frame a cascade is drawn whole only when its depth range steps (every 64
  // texels along the light, which this walk has a part of); otherwise it scrolls.
  EXPECT_GT(t.scrolled, 0u);
  EXPECT_LT(t.drawn, t.layers / 2) << "scrolled " << t.scrolled << " of " << t.layers;
}

TEST_F(ShadowCache, LocalLightsMovingAndCastersCrossingTheirVolumesChangeNoPixel) {
  scene::Scene s = small("indoor");
  ASSERT_FALSE(s.spots.empty());
  ASSERT_FALSE(s.points.empty());
  // Every caster of the room moves through the spot's cone and the point light's range.
  for (size_t i = 0; i < s.instances.size(); ++i)
    if (s.instances[i].in_shadow_maps() && i % 3 == 1)
      make_move(s, i, {1.5f, 0.0f, 0.5f}, 2);
  const Totals t = expect_identical(
      s, 7,
      {{2, [](render::Renderer& r) { r.scene().spots[0].position.x += 0.25f; }},
       {3, [](render::Renderer& r) { r.scene().points[0].position.z -= 0.25f; }},
       {5, [](render::Renderer& r) { scene::set_param(r.scene(), "spot[0].outer_angle", "40"); }}});
  EXPECT_GT(t.moving, 0u);
  EXPECT_LT(t.drawn, t.layers);
}

// A small caster moving under the spot and the point light is drawn again only where it was and
// is in each map and cube face, with everything else there.
TEST_F(ShadowCache, LocalLightsRedrawAMovingCasterOnlyWhereItWasAndIs) {
  scene::Scene s = small("indoor");
  for (auto& p : s.spots) p.resolution = 512;
  for (auto& p : s.points) p.resolution = 256;
  s.shadows.temporal = false;
  // The smallest caster (the bunny on the table), sliding sideways and back.
  const std::vector<scene::Bounds> bounds = s.instance_world_bounds();
  size_t small_one = 0;
  float least = std::numeric_limits<float>::infinity();
  for (size_t i = 0; i < s.instances.size(); ++i) {
    if (!s.instances[i].in_shadow_maps() || bounds[i].empty()) continue;
    const glm::vec3 e = bounds[i].max - bounds[i].min;
    if (e.x * e.y * e.z < least) {
      least = e.x * e.y * e.z;
      small_one = i;
    }
  }
  make_move(s, small_one, {0.5f, 0.0f, 0.3f}, 2);
  const Totals t = expect_identical(s, 7);
  EXPECT_GT(t.moving, 0u);
  // The texels the cache drew after the first frame, against whole maps and faces.
  const uint64_t whole = 6ull * (512ull * 512ull + 6ull * 256ull * 256ull);
  EXPECT_LT(t.texels_after_first, whole / 8) << t.texels_after_first << " of " << whole;
}

// The sun's map copied out of its grid or drawn from it (a GPU's route): the same texels.
TEST_F(ShadowCache, TheSunsMapIsTheSameCopiedOrDrawnFromItsGrid) {
  scene::Scene s = filled("default");
  s.camera.move = {0.6f, 0.0f, -0.4f};
  s.camera.move_frames = 4;
  render::RendererOptions copy = scrolling(), draw = scrolling();
  copy.sun_window = render::RendererOptions::SunWindow::copy;
  draw.sun_window = render::RendererOptions::SunWindow::draw;
  render::Renderer a(ctx(), s, copy), b(ctx(), s, draw);
  EXPECT_TRUE(a.built().has_pipeline("sun-shadow-window") == false);
  EXPECT_TRUE(b.built().has_pipeline("sun-shadow-window"));
  for (uint32_t k = 0; k < 5; ++k) {
    a.render(k);
    b.render(k);
    const auto ma = a.read_shadow_maps(), mb = b.read_shadow_maps();
    ASSERT_EQ(ma.size(), 1u);
    ASSERT_EQ(mb.size(), 1u);
    EXPECT_TRUE(ma[0] == mb[0]) << "frame " << k << ": " << where(ma[0], mb[0]);
    EXPECT_TRUE(a.read_rgba8() == b.read_rgba8()) << "frame " << k;
  }
}

// The pixels of a `redrawn` debug image by colour: red (a layer drawn whole), yellow (a strip a
// scrolled cascade newly reached), cyan (restored, moving casters drawn over), the rest grey.
struct RedrawnPixels {
  size_t whole = 0, strips = 0, moving = 0, other = 0, total = 0;
};
RedrawnPixels classify(const std::vector<uint8_t>& rgba) {
  RedrawnPixels p;
  for (size_t i = 0; i + 3 < rgba.size(); i += 4, ++p.total) {
    const int r = rgba[i], g = rgba[i + 1], b = rgba[i + 2];
    if (r == g && g == b) continue;
    if (r > b + 60 && g < r - 60) ++p.whole;
    else if (r > b + 60 && g > b + 60) ++p.strips;
    else if (b > r + 60 && g > r + 60) ++p.moving;
    else ++p.other;
  }
  return p;
}

// The debug view `redrawn` shows what the cache drew this frame, as its counts say: every
// shadowed pixel red on the first frame, nothing on a still frame, strips along a walk, and
// the local lights' maps restored under moving casters.
TEST_F(ShadowCache, TheRedrawnViewShowsWhatEachFrameDrew) {
  scene::Scene s = filled("default");
  s.render.view = scene::DebugView::redrawn;
  // Selected by containment, a cascade's pixels reach its edges, where the strips it newly
  // reaches lie (by view distance they lie beyond the slice it serves: drawn before they show).
  scene::set_param(s, "shadows.selection", "containment");
  s.camera.move = {3.0f, 0.0f, -1.5f};
  s.camera.move_frames = 10;
  render::Renderer r(ctx(), s, scrolling());
  const uint32_t n = s.shadows.resolution;
  size_t strips = 0;
  for (uint32_t k = 0; k < 6; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    r.render(k);
    const auto& stats = r.shadow_cache_stats();
    const RedrawnPixels p = classify(r.read_rgba8());
    EXPECT_EQ(p.other, 0u);
    EXPECT_EQ(p.moving, 0u);
    if (k == 0) {
      EXPECT_GT(p.whole, p.total / 2);
    }
    if (stats.drawn == 0) {
      EXPECT_EQ(p.whole, 0u);
    }
    if (k == 0) continue;
    // A pixel shown in a strip reads a texel its cascade did not hold in the last frame (its
    // point lay outside the cascade then, give or take the two texels the edges may round by);
    // one shown kept in a cascade that scrolled, a texel it held.
    const render::GBuffer g = r.read_gbuffer();
    const std::vector<float> info = r.read_shadow_info();
    render::FrameCaps caps;
    caps.sun_shadows = true;
    const render::PackedFrame last = render::pack_frame(s, g.width, g.height, caps, k - 1);
    const glm::dmat4 inv = glm::inverse(g.camera.proj * g.camera.view);
    size_t shown = 0, wrong = 0;
    for (uint32_t y = 0; y < g.height; ++y)
      for (uint32_t x = 0; x < g.width; ++x) {
        const size_t i = size_t(y) * g.width + x;
        const int c = int(info[4 * i + 1]), code = int(info[4 * i + 2] + 0.5f);
        if (c < 0 || g.normal_view[i].w == 0.0f || (code != 0 && code != 2)) continue;
        const glm::dvec2 ndc((x + 0.5) / g.width * 2.0 - 1.0, (y + 0.5) / g.height * 2.0 - 1.0);
        const glm::dvec4 h = inv * glm::dvec4(ndc, g.depth[i], 1.0);
        const glm::dvec3 world = g.camera.origin + glm::dvec3(h) / h.w;
        const glm::dvec4 clip = glm::dmat4(last.shadow.cascades[c].view_proj) *
                                glm::dvec4(world - last.origin, 1.0);
        const glm::dvec2 uv = glm::dvec2(clip) / clip.w * 0.5 + 0.5;
        const double e = 2.0 / n;
        const bool held = uv.x >= e && uv.x <= 1 - e && uv.y >= e && uv.y <= 1 - e;
        const bool near = uv.x >= -e && uv.x <= 1 + e && uv.y >= -e && uv.y <= 1 + e;
        if (code == 2) {
          ++shown;
          wrong += held ? 1 : 0;
        } else if (!near) {
          ++wrong;
        }
      }
    EXPECT_EQ(wrong, 0u) << "of " << shown << " strip pixels";
    if (stats.scrolled == 0) {
      EXPECT_EQ(shown, 0u);
    }
    strips += shown;
  }
  EXPECT_GT(strips, 100u);
  // A still camera: the second frame draws nothing.
  s.camera.move_frames = 0;
  s.camera.move = {};
  render::Renderer still(ctx(), s, scrolling());
  still.render(0);
  still.render(1);
  EXPECT_EQ(still.shadow_cache_stats().drawn + still.shadow_cache_stats().scrolled, 0u);
  const RedrawnPixels p = classify(still.read_rgba8());
  EXPECT_EQ(p.whole + p.strips + p.moving + p.other, 0u);

  scene::Scene room = small("indoor");
  room.render.view = scene::DebugView::redrawn;
  for (size_t i = 0; i < room.instances.size(); ++i)
    if (room.instances[i].in_shadow_maps() && i % 3 == 1) make_move(room, i, {1.5f, 0.0f, 0.5f}, 2);
  render::Renderer moving(ctx(), room);
  for (uint32_t k = 0; k < 3; ++k) moving.render(k);
  EXPECT_GT(moving.shadow_cache_stats().moving_drawn, 0u);
  const RedrawnPixels m = classify(moving.read_rgba8());
  EXPECT_GT(m.moving, m.total / 2);  // a spot map or cube face is marked whole
  EXPECT_EQ(m.whole + m.strips + m.other, 0u);

  // The sun read in place marks the rectangle a ball rolling past was and is drawn in again.
  scene::Scene ball = small("default");
  ball.render.view = scene::DebugView::redrawn;
  make_move(ball, 3, {2.0f, 0.0f, 0.0f}, 3);
  render::Renderer sun(ctx(), ball, in_place());
  for (uint32_t k = 0; k < 2; ++k) sun.render(k);
  const RedrawnPixels b = classify(sun.read_rgba8());
  EXPECT_GT(b.moving, 20u);
  EXPECT_LT(b.moving, b.total / 8);
  EXPECT_EQ(b.whole + b.strips + b.other, 0u);
}

TEST_F(ShadowCache, TheBuildReportNamesTheCacheAndItsMemory) {
  scene::Scene s = small("indoor");
  make_move(s, 1, {1.0f, 0.0f, 0.0f}, 5);
  render::Renderer r(ctx(), s);
  EXPECT_TRUE(r.built().has_pass("shadow-map cache: on"));
  const std::string report = r.built().to_string();
  // Moving casters need no copies: they are drawn again with the rest where they were and are.
  EXPECT_THAT(report, ::testing::HasSubstr("moving casters drawn again with the rest"));
  EXPECT_THAT(report, ::testing::HasSubstr("(0 MiB beside the maps)"));
  EXPECT_THAT(report, ::testing::Not(::testing::HasSubstr("-still")));
  // The sun's grid, where a CPU device copies its cascades out of it.
  scene::Scene d = small("default");
  render::Renderer sun(ctx(), d, scrolling());
  EXPECT_THAT(sun.built().to_string(), ::testing::HasSubstr("sun-shadow-grid 256x256x3"));
}

}  // namespace
}  // namespace penumbra
