// The golden layer without a GPU: 16-bit PNGs, region masks, the region-aware comparison, the
// cases file and the golden files.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <iterator>
#include <penumbra/core/file.hpp>
#include <penumbra/render/renderer.hpp>

#include <cmath>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <penumbra/golden/golden.hpp>
#include <penumbra/scene/scene.hpp>
#include <string>

namespace penumbra::golden {
namespace {
namespace fs = std::filesystem;

fs::path temp_dir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("penumbra-golden-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// ---- PNG ------------------------------------------------------------------------------------
// A write that fails part way (here a file-size limit; a full disk fails the same way) is an
// error naming the file, and the file that was there is left as it was: no truncated PNG.
TEST(AtomicWrite, AFailedWriteIsAnErrorAndLeavesTheOldFileAlone) {
  const fs::path dir = temp_dir("atomic");
  const fs::path png = dir / "lit.png";
  const fs::path csv = dir / "timings.csv";
  write_text(png, "the previous image");
  write_text(csv, "the previous timings");
  // Incompressible pixels: the PNG is ~256 KiB, far past the limit the child sets.
  std::vector<uint8_t> rgba(256 * 256 * 4);
  uint32_t x = 12345;
  for (auto& b : rgba) b = uint8_t((x = x * 1664525u + 1013904223u) >> 24);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    std::signal(SIGXFSZ, SIG_IGN);  // the write fails with EFBIG instead of killing the process
    const rlimit limit{4096, 4096};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    int failures = 0;
    try {
      render::write_png(png, 256, 256, rgba);
    } catch (const Error& e) {
      failures += std::string(e.what()).find(png.string()) != std::string::npos ? 1 : 0;
    }
    try {
      write_file_atomic(csv, std::string(100000, 'x'));
    } catch (const Error& e) {
      failures += std::string(e.what()).find(csv.string()) != std::string::npos ? 1 : 0;
    }
    ::_exit(failures == 2 ? 0 : 1);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "both writes must fail with an error naming the file";
  std::ifstream in_png(png), in_csv(csv);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in_png), {}), "the previous image");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in_csv), {}), "the previous timings");
  size_t leftovers = 0;
  for (const auto& e : fs::directory_iterator(dir)) leftovers += e.path().extension() != ".png" &&
                                                                 e.path().extension() != ".csv";
  EXPECT_EQ(leftovers, 0u) << "no temporary files are left behind";
  // Without the limit, the same writes succeed and replace the files.
  render::write_png(png, 256, 256, rgba);
  EXPECT_GT(fs::file_size(png), 200000u);
  fs::remove_all(dir);
}

TEST(GoldenPng, SixteenBitVisibilityRoundTripsToOneStep) {
  const fs::path d = temp_dir("png");
  std::vector<float> v = {0.0f, 1.0f, 0.5f, 1.0f / 65535.0f, 0.123456f, 2.0f, -1.0f, NAN};
  write_png16(d / "v.png", 4, 2, v);
  uint32_t w = 0, h = 0;
  const auto back = read_png16(d / "v.png", w, h);
  ASSERT_EQ(w, 4u);
  ASSERT_EQ(h, 2u);
  const std::vector<float> want = {0.0f, 1.0f, 0.5f, 1.0f / 65535.0f, 0.123456f, 1.0f, 0.0f, 0.0f};
  for (size_t i = 0; i < want.size(); ++i)
    EXPECT_NEAR(back[i], want[i], 0.5f / 65535.0f) << i;  // clamped, NaN stored as 0
  fs::remove_all(d);
}

TEST(GoldenPng, UnreadableFilesAreErrorsNamingThem) {
  const fs::path d = temp_dir("png-bad");
  uint32_t w = 0, h = 0;
  EXPECT_NE(error_of([&] { read_png16(d / "missing.png", w, h); }).find("missing.png"),
            std::string::npos);
  write_text(d / "text.png", "not a png");
  EXPECT_NE(error_of([&] { read_png_rgba8(d / "text.png", w, h); }).find("text.png"),
            std::string::npos);
  EXPECT_NE(error_of([&] { write_png16(d / "short.png", 4, 4, std::vector<float>(3)); })
                .find("3 values for 4x4"),
            std::string::npos);
  fs::remove_all(d);
}

// ---- regions --------------------------------------------------------------------------------
// A w x h image of receivers on a plane facing the eye at distance 5, with an object at
// distance 2 over columns [ox0, ox1); the light's reference: x < split hidden, else visible.
struct Synthetic {
  reference::Receivers receivers;
  reference::LightMeasurement light;
};

Synthetic synthetic(uint32_t w, uint32_t h, uint32_t split, uint32_t ox0, uint32_t ox1) {
  Synthetic s;
  auto& r = s.receivers;
  r.width = w;
  r.height = h;
  r.eye = glm::dvec3(0.0);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const bool object = x >= ox0 && x < ox1;
      const double z = object ? 2.0 : 5.0;
      r.position.push_back(glm::dvec3((double(x) - w / 2.0) * 0.01 * z, double(y) * 0.01 * z, -z));
      r.normal.push_back(glm::dvec3(0, 0, 1));
      r.valid.push_back(1);
      s.light.classes.push_back(reference::ReceiverClass::lit);
      s.light.reference.value.push_back(x < split ? 0.0f : 1.0f);
    }
  return s;
}

TEST(GoldenRegions, UmbraLitPenumbraBandAndSilhouettes) {
  auto s = synthetic(40, 10, 10, 30, 34);
  s.light.reference.value[5 * 40 + 20] = 0.5f;  // one partly visible pixel
  s.light.classes[0] = reference::ReceiverClass::facing_away;
  const auto r = classify_regions(s.receivers, s.light, {});
  auto at = [&](uint32_t x, uint32_t y) { return r[size_t(y) * 40 + x]; };
  EXPECT_EQ(at(0, 0), Region::none);
  EXPECT_EQ(at(3, 5), Region::umbra);
  EXPECT_EQ(at(15, 5), Region::lit);
  // The hard edge between x = 9 and 10 and the band of 1 pixel around it.
  for (uint32_t x : {8u, 9u, 10u, 11u}) EXPECT_EQ(at(x, 5), Region::penumbra) << x;
  EXPECT_EQ(at(7, 5), Region::umbra);
  EXPECT_EQ(at(12, 5), Region::lit);
  // The partly visible pixel and its neighbours.
  for (uint32_t x : {19u, 20u, 21u}) EXPECT_EQ(at(x, 5), Region::penumbra) << x;
  EXPECT_EQ(at(20, 4), Region::penumbra);
  EXPECT_EQ(at(22, 5), Region::lit);
  // The object's depth edges at x = 29 | 30 and 33 | 34, one pixel either side.
  for (uint32_t x : {28u, 29u, 30u, 31u, 32u, 33u, 34u, 35u})
    EXPECT_EQ(at(x, 5), Region::silhouette) << x;
  EXPECT_EQ(at(27, 5), Region::lit);
  EXPECT_EQ(at(36, 5), Region::lit);
}

TEST(GoldenRegions, AGrazingPlaneIsNotASilhouette) {
  // A ground plane seen at a grazing angle: the distance to the eye grows fast from row to row
  // (a quarter from one row to the next at the horizon), but its inverse stays affine.
  const uint32_t w = 8, h = 60;
  Synthetic s;
  auto& r = s.receivers;
  r.width = w;
  r.height = h;
  r.eye = glm::dvec3(0.0, 1.5, 0.0);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      // The view ray of row y hits the ground (height 0) at 1.5 / tan(angle).
      const double angle = 0.002 + 0.004 * double(y);
      const double dist = 1.5 / std::tan(angle);
      r.position.push_back(glm::dvec3(0.01 * double(x) * dist, 0.0, -dist));
      r.normal.push_back(glm::dvec3(0, 1, 0));
      r.valid.push_back(1);
      s.light.classes.push_back(reference::ReceiverClass::lit);
      s.light.reference.value.push_back(1.0f);
    }
  const auto regions = classify_regions(r, s.light, {});
  size_t silhouettes = 0;
  for (auto g : regions) silhouettes += g == Region::silhouette;
  EXPECT_EQ(silhouettes, 0u);
}

// ---- comparison -----------------------------------------------------------------------------
Frame frame_with_regions(uint32_t w, uint32_t h) {
  auto s = synthetic(w, h, w / 4, w - 6, w - 2);
  Frame f;
  f.width = w;
  f.height = h;
  f.lit.assign(size_t(w) * h * 4, 100);
  LightImage l;
  l.light = "sun";
  l.visibility = s.light.reference.value;
  l.regions = classify_regions(s.receivers, s.light, {});
  f.lights.push_back(l);
  return f;
}

Frame without_regions(const Frame& g) {
  Frame a = g;
  for (auto& l : a.lights) l.regions.clear();
  return a;
}

size_t first(const Frame& f, Region r) {
  const auto& g = f.lights[0].regions;
  return size_t(std::find(g.begin(), g.end(), r) - g.begin());
}

TEST(GoldenCompare, TheSameFramePasses) {
  const Frame g = frame_with_regions(64, 32);
  const Comparison c = compare(g, without_regions(g));
  EXPECT_TRUE(c.passed()) << c.summary();
  EXPECT_TRUE(c.failures().empty());
  // Every region of the frame is reported.
  for (const char* region : {"umbra", "lit", "penumbra", "silhouette"})
    EXPECT_NE(c.summary().find(std::string("sun ") + region + ":"), std::string::npos) << region;
}

TEST(GoldenCompare, OneWrongUmbraPixelFailsNamingRegionCountAndWorstPixel) {
  const Frame g = frame_with_regions(64, 32);
  Frame a = without_regions(g);
  const size_t i = first(g, Region::umbra);
  a.lights[0].visibility[i] = 0.4f;
  Tolerances t;
  t.umbra.min_allowed = 0;
  const Comparison c = compare(g, a, t);
  ASSERT_FALSE(c.passed());
  ASSERT_EQ(c.failures().size(), 1u) << c.summary();
  const std::string f = c.failures()[0];
  EXPECT_NE(f.find("sun umbra: 1 of"), std::string::npos) << f;
  EXPECT_NE(f.find("(allowed 0)"), std::string::npos) << f;
  EXPECT_NE(f.find("worst at (" + std::to_string(i % 64) + ", " + std::to_string(i / 64) +
                   "): expected 0.000, actual 0.400"),
            std::string::npos)
      << f;
  // Within the umbra's tolerance (0.02) the same pixel passes, and so does one wrong pixel
  // within the default floor of 2 per region.
  a.lights[0].visibility[i] = 0.015f;
  EXPECT_TRUE(compare(g, a, t).passed());
  a.lights[0].visibility[i] = 0.4f;
  EXPECT_TRUE(compare(g, a).passed());
}

TEST(GoldenCompare, PenumbraBandsAllowTheirFractionAndNoMore) {
  const Frame g = frame_with_regions(200, 400);
  const Tolerances t;
  std::vector<size_t> band;
  for (size_t i = 0; i < g.lights[0].regions.size(); ++i)
    if (g.lights[0].regions[i] == Region::penumbra) band.push_back(i);
  const size_t allowed = t.penumbra.allowed(band.size());
  ASSERT_GT(allowed, t.penumbra.min_allowed);  // the fraction, not the floor
  Frame a = without_regions(g);
  for (size_t k = 0; k < allowed; ++k) a.lights[0].visibility[band[k]] = 0.5f;
  EXPECT_TRUE(compare(g, a, t).passed()) << compare(g, a, t).summary();
  a.lights[0].visibility[band[allowed]] = 0.5f;
  const Comparison c = compare(g, a, t);
  ASSERT_FALSE(c.passed());
  EXPECT_NE(c.failures()[0].find("sun penumbra: " + std::to_string(allowed + 1) + " of"),
            std::string::npos)
      << c.summary();
}

TEST(GoldenCompare, NonFiniteValuesAlwaysFail) {
  const Frame g = frame_with_regions(64, 32);
  Frame a = without_regions(g);
  a.lights[0].visibility[first(g, Region::silhouette)] = NAN;
  const Comparison c = compare(g, a);
  ASSERT_FALSE(c.passed());
  EXPECT_NE(c.failures()[0].find("1 non-finite"), std::string::npos) << c.summary();
}

TEST(GoldenCompare, TheLitFrameIsTightAwayFromEdgesAndLooseAtThem) {
  const Frame g = frame_with_regions(64, 32);
  Frame a = without_regions(g);
  Tolerances t;
  t.frame_tight.allowed_fraction = t.frame_loose.allowed_fraction = 0.0;
  t.frame_tight.min_allowed = t.frame_loose.min_allowed = 0;
  const size_t lit = first(g, Region::lit), edge = first(g, Region::penumbra);
  a.lit[edge * 4] = uint8_t(100 + 25);  // 25 levels at an edge: within the loose 0.1
  a.lit[lit * 4 + 1] = uint8_t(100 + 4);  // 4 levels away from edges: within the tight 4
  EXPECT_TRUE(compare(g, a, t).passed()) << compare(g, a, t).summary();
  a.lit[lit * 4 + 1] = uint8_t(100 + 5);
  const Comparison c = compare(g, a, t);
  ASSERT_FALSE(c.passed());
  EXPECT_NE(c.failures()[0].find("frame away from shadow edges: 1 of"), std::string::npos)
      << c.summary();
}

TEST(GoldenCompare, MissingLightsAndSizesAreFailures) {
  const Frame g = frame_with_regions(64, 32);
  Frame a = without_regions(g);
  a.lights[0].light = "spot0";
  const Comparison c = compare(g, a);
  ASSERT_FALSE(c.passed());
  ASSERT_EQ(c.structural.size(), 2u);
  EXPECT_NE(c.summary().find("light spot0: in the frame but not in the golden"), std::string::npos);
  EXPECT_NE(c.summary().find("light sun: in the golden but not in the frame"), std::string::npos);
  Frame small = frame_with_regions(32, 32);
  EXPECT_NE(compare(g, without_regions(small)).summary().find("size: golden 64x32, frame 32x32"),
            std::string::npos);
}

// ---- cases ----------------------------------------------------------------------------------
TEST(GoldenCases, TheShippedCasesLoadAndNameScenesThatExist) {
  const auto cases = load_cases(golden_root() / "cases.toml");
  ASSERT_GE(cases.size(), 5u);
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    if (c.scene.find(".toml") == std::string::npos) {
      EXPECT_NO_THROW(scene::find_scene(c.scene));
    }
    EXPECT_GE(c.width, 16u);
  }
}

TEST(GoldenCases, BadEntriesNameTheFileLineAndKey) {
  const fs::path d = temp_dir("cases");
  const fs::path f = d / "cases.toml";
  write_text(f, "[[case]]\nname = \"a\"\nscene = \"default\"\nsize = [480, 270]\nsets = []\n");
  EXPECT_NE(error_of([&] { load_cases(f); }).find("cases.toml:5: unknown key 'sets' in [[case]]"),
            std::string::npos)
      << error_of([&] { load_cases(f); });
  write_text(f, "[[case]]\nname = \"a\"\nscene = \"default\"\nsize = [480, 0]\n");
  EXPECT_NE(error_of([&] { load_cases(f); }).find("cases.toml:4: 'size' must be a number in [16"),
            std::string::npos)
      << error_of([&] { load_cases(f); });
  write_text(f, "[[case]]\nname = \"a\"\nscene = \"x\"\n[[case]]\nname = \"a\"\nscene = \"y\"\n");
  EXPECT_NE(error_of([&] { load_cases(f); }).find("cases.toml:5: a second case named 'a'"),
            std::string::npos)
      << error_of([&] { load_cases(f); });
  write_text(f, "[[case]]\nname = \"a\"\nscene = \"x\"\nset = [\"novalue\"]\n");
  EXPECT_NE(error_of([&] { load_cases(f); }).find("cases.toml:4:"), std::string::npos);
  write_text(f, "[[case]]\nname = \"a\"\nscene = \"x\"\nbudget = { false_lite = 0.1 }\n");
  EXPECT_NE(error_of([&] { load_cases(f); }).find("unknown budget key 'false_lite'"),
            std::string::npos);
  fs::remove_all(d);
}

// ---- golden files ---------------------------------------------------------------------------
TEST(GoldenFiles, RoundTripAndStaleLightsAreRemoved) {
  const fs::path d = temp_dir("files");
  Golden g;
  g.case_name = "synthetic";
  g.device_class = "lavapipe";
  g.device = "test";
  g.frame = frame_with_regions(64, 32);
  reference::Metrics m;
  m.mean_abs = 0.0125;
  m.false_light = 0.003;
  g.frame.lights[0].metrics = m;
  LightImage spot = g.frame.lights[0];
  spot.light = "spot0";
  g.frame.lights.push_back(spot);
  write_golden(d, g);
  g.frame.lights.pop_back();  // the scene lost its spot light
  write_golden(d, g);
  EXPECT_FALSE(fs::exists(d / "visibility-spot0.png"));
  EXPECT_FALSE(fs::exists(d / "regions-spot0.png"));
  const auto back = load_golden(d);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->device, "test");
  ASSERT_EQ(back->frame.lights.size(), 1u);
  EXPECT_EQ(back->frame.lights[0].regions, g.frame.lights[0].regions);
  ASSERT_TRUE(back->frame.lights[0].metrics);
  EXPECT_DOUBLE_EQ(back->frame.lights[0].metrics->mean_abs, 0.0125);
  EXPECT_TRUE(compare(back->frame, without_regions(g.frame)).passed());
  EXPECT_FALSE(load_golden(d / "nothing-here"));
  fs::remove_all(d);
}

TEST(GoldenFiles, ARegionImageWithAnUnknownLevelIsAnErrorNamingThePixel) {
  const fs::path d = temp_dir("files-bad");
  Golden g;
  g.case_name = "synthetic";
  g.frame = frame_with_regions(16, 8);
  write_golden(d, g);
  std::vector<float> codes(16 * 8, 1.0f);
  codes[3 * 16 + 5] = 100.0f / 255.0f;
  write_png16(d / "regions-sun.png", 16, 8, codes);
  const std::string e = error_of([&] { load_golden(d); });
  EXPECT_NE(e.find("regions-sun.png: pixel (5, 3) has grey level 100"), std::string::npos) << e;
  fs::remove_all(d);
}

}  // namespace
}  // namespace penumbra::golden
