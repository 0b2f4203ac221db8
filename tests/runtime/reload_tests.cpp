// Hot reload through penumbra-view's session, on a copy of the shader tree, with full frames
// (small): a valid edit changes the image; a broken edit keeps the previous image bit for bit and
// reports the file:line of the error inside the included file; the fix gives the image of a
// cold start; an edit to an included file rebuilds exactly the pipelines that read it; atomic
// rename-saves and deleted-then-recreated files are picked up.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <penumbra/core/error.hpp>
#include <penumbra/scene/filters.hpp>
#include <penumbra/scene/params.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <random>
#include <set>
#include <thread>

#include "session.hpp"
#include "temp_tree.hpp"

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using testing::GpuTest;
using ::testing::HasSubstr;
using testing::TempTree;
using ::testing::UnorderedElementsAreArray;

constexpr uint32_t kWidth = 160, kHeight = 90;
constexpr auto kTimeout = 10000ms;  // a reload compiles on a shared CPU; waits end early

scene::Scene small_scene(std::string_view name) {
  auto s = scene::load_scene(scene::find_scene(name));
  s.render.width = kWidth;
  s.render.height = kHeight;
  s.shadows.resolution = std::min(s.shadows.resolution, 512u);  // fast frames
  for (auto& p : s.points) p.resolution = std::min(p.resolution, 128u);
  for (auto& p : s.spots) p.resolution = std::min(p.resolution, 256u);
  return s;
}

// The first word of each pipeline name ("forward-opaque PENUMBRA_SUN_SHADOWS=1 ..." ->
// "forward-opaque"), sorted.
std::vector<std::string> short_names(const std::vector<std::string>& names) {
  std::vector<std::string> out;
  for (const auto& n : names) out.push_back(n.substr(0, n.find(' ')));
  std::sort(out.begin(), out.end());
  return out;
}

size_t differing_pixels(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  size_t n = 0;
  for (size_t i = 0; i + 3 < std::min(a.size(), b.size()); i += 4)
    n += (a[i] != b[i] || a[i + 1] != b[i + 1] || a[i + 2] != b[i + 2]) ? 1 : 0;
  return n;
}

class ReloadTest : public GpuTest {
 protected:
  std::unique_ptr<runtime::Session> start(
      std::string_view scene = "default",
      std::chrono::milliseconds debounce = runtime::kDefaultDebounce) {
    runtime::SessionOptions o;
    o.shader_dir = tree.shaders();
    o.debounce = debounce;
    o.log = [this](const std::string& line) { log.push_back(line); };
    auto s = std::make_unique<runtime::Session>(ctx(), small_scene(scene), o);
    s->render();
    return s;
  }
  // A renderer built from scratch on the tree as it is now: the cold-start reference.
  std::vector<uint8_t> cold_start(std::string_view scene = "default") {
    render::RendererOptions o;
    o.shader_dir = tree.shaders();
    render::Renderer r(ctx(), small_scene(scene), o);
    r.render(0);
    return r.read_rgba8();
  }
  // A renderer built from scratch for a scene with these keys set (specialize = false: every
  // filter and view compiled, the choice read from the frame): one frame's pixels.
  std::vector<uint8_t> fresh_render(std::string_view scene,
                                    const std::vector<std::pair<std::string, std::string>>& set,
                                    bool specialize = true) {
    scene::Scene sc = small_scene(scene);
    for (const auto& [key, value] : set) scene::set_param(sc, key, value);
    return fresh_render(sc, specialize);
  }
  std::vector<uint8_t> fresh_render(const scene::Scene& sc, bool specialize = true) {
    render::RendererOptions o;
    o.shader_dir = tree.shaders();
    o.specialize = specialize;
    render::Renderer r(ctx(), sc, o);
    r.render(0);
    return r.read_rgba8();
  }
  fs::path shader(const std::string& rel) const {
    return fs::weakly_canonical(tree.shaders() / rel);
  }
  void edit(const std::string& rel, const std::string& from, const std::string& to) {
    testing::write_text(shader(rel), testing::replaced(testing::read_text(shader(rel)), from, to));
  }
  bool logged(const std::string& text) const {
    return std::any_of(log.begin(), log.end(),
                       [&](const std::string& l) { return l.find(text) != std::string::npos; });
  }

  TempTree tree{true};
  std::vector<std::string> log;
};

const std::string kExposure = "vec3 color = texelFetch(hdr, pixel, 0).rgb * frame.ambient.w;";
const std::string kHalfExposure =
    "vec3 color = texelFetch(hdr, pixel, 0).rgb * frame.ambient.w * 0.5;";
// The last step of every PCF filter; "* 0.5 + 0.5" makes every shadow half as dark.
const std::string kSaturate = "return penumbra_is_finite(v) ? clamp(v, 0.0, 1.0) : 1.0;";
const std::string kLighterShadows =
    "return penumbra_is_finite(v) ? clamp(v * 0.5 + 0.5, 0.0, 1.0) : 1.0;";
const std::string kClampRadius = "  return clamp(radius, 0, kPcfMaxRadius);";

TEST_F(ReloadTest, AValidEditChangesTheImage) {
  auto s = start();
  const auto before = s->pixels();
  edit("render/tonemap.comp", kExposure, kHalfExposure);
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec) << "no reload";
  EXPECT_EQ(short_names(rec->result.rebuilt), std::vector<std::string>{"tonemap"});
  EXPECT_TRUE(rec->result.ok());
  ASSERT_TRUE(rec->latency_ms) << "the frame after the reload measures the latency";
  EXPECT_GT(*rec->latency_ms, 0.0);
  EXPECT_TRUE(logged("[reload] rebuilt: tonemap")) << ::testing::PrintToString(log);
  EXPECT_TRUE(logged("[reload] latency"));
  const auto after = s->pixels();
  EXPECT_GT(differing_pixels(before, after), before.size() / 4 / 2)
      << "half the exposure darkens most pixels";
  EXPECT_EQ(after, cold_start()) << "the reloaded pipeline renders what a fresh one does";
}

// A reload in two steps, the first while the GPU renders a frame (as Session::render does for
// a burst that finishes then): the frame in flight runs the old pipelines, the next the new
// ones; a broken edit keeps them; and when the renderer's programs change between the steps (a
// filter set through scene() swaps the resolve's variant), the finish prepares again.
TEST_F(ReloadTest, AReloadPreparedWhileTheGpuRendersSwapsInAfterTheFrame) {
  render::RendererOptions o;
  o.shader_dir = tree.shaders();
  render::Renderer r(ctx(), small_scene("default"), o);
  r.render(0);
  const auto before = r.read_rgba8();
  const std::vector<fs::path> pcf{shader("penumbra/pcf.glsl")};
  auto prepare_during_frame = [&] {
    std::optional<shader::PreparedReload> prepared;
    std::thread worker;
    int calls = 0;
    r.render(0, [&] {
      if (calls++ == 0) worker = std::thread([&] { prepared = r.prepare_reload(pcf); });
    });
    worker.join();
    EXPECT_GE(calls, 1);
    return prepared;
  };

  edit("penumbra/pcf.glsl", kSaturate, kLighterShadows);
  auto prepared = prepare_during_frame();
  EXPECT_EQ(r.read_rgba8(), before) << "the frame in flight runs the last pipelines";
  ASSERT_TRUE(prepared);
  auto result = r.finish_reload(std::move(*prepared));
  EXPECT_TRUE(result.ok()) << ::testing::PrintToString(result.errors);
  EXPECT_EQ(short_names(result.rebuilt), std::vector<std::string>{"shadow-resolve"});
  r.render(0);
  const auto lighter = r.read_rgba8();
  EXPECT_NE(lighter, before);
  EXPECT_EQ(lighter, cold_start());

  edit("penumbra/pcf.glsl", kLighterShadows, kLighterShadows + " +");  // does not compile
  prepared = prepare_during_frame();
  ASSERT_TRUE(prepared);
  result = r.finish_reload(std::move(*prepared));
  EXPECT_EQ(short_names(result.failed), std::vector<std::string>{"shadow-resolve"});
  r.render(0);
  EXPECT_EQ(r.read_rgba8(), lighter);

  // Mended while the frame runs; then PCF is set and its variant of the resolve replaces the
  // hard one before the finish: the finish compiles for the programs there are now.
  edit("penumbra/pcf.glsl", kLighterShadows + " +", kSaturate);
  prepared = prepare_during_frame();
  ASSERT_TRUE(prepared);
  scene::set_param(r.scene(), "shadows.filter", "pcf");
  r.prepare();
  result = r.finish_reload(std::move(*prepared));
  EXPECT_TRUE(result.ok()) << ::testing::PrintToString(result.errors);
  EXPECT_EQ(short_names(result.rebuilt), std::vector<std::string>{"shadow-resolve"});
  r.render(0);
  EXPECT_EQ(r.read_rgba8(), fresh_render("default", {{"shadows.filter", "pcf"}}));
}

// In a frame loop (the windowed viewer), saves land at any moment of a frame: whether the burst
// is compiled during a frame or between two, the first frame after it renders what a fresh
// renderer of the edited tree renders, and its latency is recorded.
TEST_F(ReloadTest, SavesDuringAFrameLoopReloadWhereverTheyLand) {
  auto s = start();
  std::mt19937 rng(7);
  int during = 0;
  for (int i = 0; i < 4; ++i) {
    const std::string text = testing::replaced(testing::read_text(shader("render/tonemap.comp")),
                                               i % 2 == 0 ? kExposure : kHalfExposure,
                                               i % 2 == 0 ? kHalfExposure : kExposure);
    const size_t before = s->reloads().size();
    std::thread later([&, wait = std::uniform_int_distribution<int>(0, 20)(rng)] {
      std::this_thread::sleep_for(std::chrono::milliseconds(wait));
      testing::write_text(shader("render/tonemap.comp"), text);
    });
    const auto deadline = std::chrono::steady_clock::now() + kTimeout;
    const runtime::ReloadRecord* done = nullptr;
    while (!done && std::chrono::steady_clock::now() < deadline) {
      s->render();
      for (size_t r = before; r < s->reloads().size(); ++r)
        if (s->reloads()[r].latency_ms) done = &s->reloads()[r];
    }
    later.join();
    ASSERT_TRUE(done) << "no reload with a latency after save " << i;
    EXPECT_TRUE(done->result.ok()) << s->error_text();
    during += done->during_frame ? 1 : 0;
    EXPECT_EQ(s->pixels(), cold_start()) << "save " << i;
  }
  std::printf("[          ] %d of 4 saves compiled during a frame\n", during);
}

// A save compiles while its burst settles: the compile begins at the first look at the burst,
// long before a 2 s debounce ends (a margin no busy machine eats), and what is swapped in is
// what a fresh renderer of the edited tree renders.
TEST_F(ReloadTest, ASaveCompilesWhileItsBurstSettles) {
  const std::chrono::milliseconds debounce(2000);
  auto s = start("default", debounce);
  edit("render/tonemap.comp", kExposure, kHalfExposure);
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->result.ok()) << s->error_text();
  EXPECT_TRUE(rec->compiled_early);
  EXPECT_LT(rec->waited_ms, double(debounce.count())) << "the compile began after the debounce";
  EXPECT_EQ(s->pixels(), cold_start());
  // The same with the early compile off: the compile waits for the debounce.
  runtime::SessionOptions o;
  o.shader_dir = tree.shaders();
  o.debounce = debounce;
  o.compile_early = false;
  o.log = [](const std::string&) {};
  runtime::Session late(ctx(), small_scene("default"), o);
  late.render();
  edit("render/tonemap.comp", kHalfExposure, kExposure);
  const auto late_rec = late.wait_reload(kTimeout);
  ASSERT_TRUE(late_rec);
  EXPECT_FALSE(late_rec->compiled_early);
  EXPECT_GE(late_rec->waited_ms, double(debounce.count()) - 1.0);
  EXPECT_EQ(late.pixels(), cold_start());
}

// A renderer rebuilt while an early compile waits for its batch drops that compile (it was made
// by the old renderer): the batch compiles on the new one, and the image is a fresh renderer's
// of the edited tree with the new key.
TEST_F(ReloadTest, ARebuildDropsTheCompileBegunBeforeIt) {
  // A 2 s debounce: the compile begins in the first frame, long before the batch is handed out.
  auto s = start("default", std::chrono::milliseconds(2000));
  edit("render/tonemap.comp", kExposure, kHalfExposure);
  // Frames until the compile has begun (the frame loop looks at the burst while the GPU works).
  const auto deadline = std::chrono::steady_clock::now() + kTimeout;
  while (!s->compiled_early_waiting() && s->reloads().empty() &&
         std::chrono::steady_clock::now() < deadline)
    s->render();
  ASSERT_TRUE(s->reloads().empty()) << "handed out before the test could rebuild";
  ASSERT_TRUE(s->compiled_early_waiting());
  s->set("shadows.cascades", "2");  // a key that rebuilds the renderer
  EXPECT_FALSE(s->compiled_early_waiting());
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->result.ok()) << s->error_text();
  EXPECT_EQ(s->pixels(), fresh_render("default", {{"shadows.cascades", "2"}}));
}

// A change after the early look makes that compile stale: the batch compiles again, so the
// image is the last save's, wherever the second save lands (before the look, during the early
// compile, or after its batch was handed out).
TEST_F(ReloadTest, AChangeAfterTheEarlyLookIsCompiledAgain) {
  auto s = start("default", std::chrono::milliseconds(400));
  int stale = 0;
  for (const int wait_ms : {0, 30, 120}) {
    const std::string half = testing::read_text(shader("render/tonemap.comp"));
    edit("render/tonemap.comp", kExposure, kHalfExposure);
    std::thread second([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(wait_ms));
      // A third exposure, neither the first's nor the second's.
      testing::write_text(shader("render/tonemap.comp"),
                          testing::replaced(half, kExposure,
                                            "vec3 color = texelFetch(hdr, pixel, 0).rgb * "
                                            "frame.ambient.w * 0.25;"));
    });
    const auto rec = s->wait_reload(kTimeout);
    second.join();
    ASSERT_TRUE(rec);
    // Until the watcher has handed out every change: the second save may be a batch of its own.
    while (s->wait_reload(std::chrono::milliseconds(1000))) {
    }
    EXPECT_TRUE(s->errors().empty()) << s->error_text();
    for (const auto& r : s->reloads()) stale += (!r.changed.empty() && !r.compiled_early) ? 1 : 0;
    EXPECT_EQ(s->pixels(), cold_start()) << "second save " << wait_ms << " ms after the first";
    edit("render/tonemap.comp", "frame.ambient.w * 0.25;", "frame.ambient.w;");
    ASSERT_TRUE(s->wait_reload(kTimeout));
    EXPECT_EQ(s->pixels(), cold_start());
  }
  std::printf("[          ] %d reloads compiled again after a stale early compile\n", stale);
}

TEST_F(ReloadTest, AnEditOfALibraryFunctionChangesTheShadows) {
  auto s = start();
  const auto before = s->pixels();
  edit("penumbra/pcf.glsl", kSaturate, kLighterShadows);
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->result.ok());
  const auto after = s->pixels();
  EXPECT_GT(differing_pixels(before, after), 0u);
}

TEST_F(ReloadTest, ABrokenEditKeepsTheImageAndNamesTheIncludedFileAndLine) {
  auto s = start();
  const auto before = s->pixels();
  const std::string text = testing::read_text(shader("penumbra/pcf.glsl"));
  const int line = testing::line_of(text, kClampRadius);
  ASSERT_GT(line, 0);
  edit("penumbra/pcf.glsl", kClampRadius, "  return clamp(radius, 0, kPcfMaxRadius) +;");
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->result.rebuilt.empty());
  EXPECT_EQ(short_names(rec->result.failed), (std::vector<std::string>{"shadow-resolve"}));
  // The error is in pcf.glsl (included by shadow.glsl, included by shadow_resolve.comp), at
  // the line edited — not at a line of the expanded source.
  const std::string where = shader("penumbra/pcf.glsl").string() + ":" + std::to_string(line) + ":";
  EXPECT_THAT(s->error_text(), HasSubstr(where));
  for (const auto& [name, error] : s->errors()) EXPECT_THAT(error, HasSubstr(where)) << name;
  EXPECT_TRUE(logged("[reload] error: " + where)) << ::testing::PrintToString(log);
  s->render();
  EXPECT_EQ(s->pixels(), before) << "the last good pipelines must keep rendering";
}

// Edits that compile but change what the pipeline was made for (issue 18's crashes): a storage
// image moved to another set or binding. The reload is refused naming the declaration's
// file:line, nothing crashes, and the last good pipeline keeps rendering the same image; undoing
// the edit reloads cleanly.
TEST_F(ReloadTest, AnEditThatMovesABindingIsRefusedAndTheImageStays) {
  auto s = start();
  const auto before = s->pixels();
  const std::string decl = "layout(set = 0, binding = 6, rgba16f) uniform writeonly image2D";
  const int line = testing::line_of(testing::read_text(shader("render/shadow_resolve.comp")), decl);
  ASSERT_GT(line, 0);
  for (const std::string moved :
       {"layout(set = 1, binding = 6, rgba16f) uniform writeonly image2D",
        "layout(set = 0, binding = 9, rgba16f) uniform writeonly image2D"}) {
    edit("render/shadow_resolve.comp", decl, moved);
    const auto rec = s->wait_reload(kTimeout);
    ASSERT_TRUE(rec) << moved;
    EXPECT_TRUE(rec->result.rebuilt.empty());
    EXPECT_EQ(short_names(rec->result.failed), (std::vector<std::string>{"shadow-resolve"}));
    const std::string where =
        shader("render/shadow_resolve.comp").string() + ":" + std::to_string(line) + ": ";
    EXPECT_THAT(s->error_text(), HasSubstr(where)) << s->error_text();
    EXPECT_THAT(s->error_text(), HasSubstr("is new: the pipeline layout has no such binding"));
    s->render();
    EXPECT_EQ(s->pixels(), before) << moved;
    edit("render/shadow_resolve.comp", moved, decl);
    const auto undo = s->wait_reload(kTimeout);
    ASSERT_TRUE(undo);
    EXPECT_TRUE(undo->result.ok()) << s->error_text();
    EXPECT_EQ(s->pixels(), before);
  }
}

// A member removed from a struct every pass shares: the passes that still compile would read
// the host's FrameGpu at the wrong offsets, so the whole reload is refused (none of the
// pipelines the edit reaches is swapped) and the image does not change.
TEST_F(ReloadTest, RemovingASharedStructMemberSwapsNothing) {
  auto s = start();
  const auto before = s->pixels();
  const size_t reading =
      s->renderer().pipelines_reading(shader("penumbra/frame_types.glsl")).size();
  ASSERT_GT(reading, 3u);
  edit("penumbra/frame_types.glsl", "  vec4 viewport;\n", "");
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->result.rebuilt.empty()) << ::testing::PrintToString(rec->result.rebuilt);
  EXPECT_FALSE(rec->result.failed.empty());
  EXPECT_EQ(rec->result.failed.size() + rec->result.held.size(), reading);
  EXPECT_THAT(s->error_text(), HasSubstr("changes the interface"));
  s->render();
  EXPECT_EQ(s->pixels(), before);
}

// A shader file replaced by a symlink to /dev/zero: the pipelines that read it report an error
// naming it (nothing hangs reading an endless file), the image stays, and putting the file back
// reloads cleanly.
TEST_F(ReloadTest, AFileReplacedByASymlinkToDevZeroIsAnErrorNotAHang) {
  auto s = start();
  const auto before = s->pixels();
  const fs::path noise = shader("penumbra/noise.glsl");
  const std::string good = testing::read_text(noise);
  const fs::path link = noise.parent_path() / ".noise.link";
  fs::create_symlink("/dev/zero", link);
  fs::rename(link, noise);  // an atomic swap, as an editor's save
  const auto rec = s->wait_reload(kTimeout, noise);
  ASSERT_TRUE(rec) << "the change to a file that became a symlink must be seen";
  EXPECT_TRUE(rec->result.rebuilt.empty());
  EXPECT_FALSE(rec->result.failed.empty());
  EXPECT_THAT(s->error_text(),
              HasSubstr("penumbra/noise.glsl) is a character device, not a regular file"))
      << s->error_text();
  s->render();
  EXPECT_EQ(s->pixels(), before);
  fs::remove(noise);
  testing::write_text(noise, good);
  const auto back = s->wait_reload(kTimeout, noise);
  ASSERT_TRUE(back);
  EXPECT_TRUE(back->result.ok()) << s->error_text();
  EXPECT_EQ(s->pixels(), before);
}

TEST_F(ReloadTest, TheFixAfterABrokenEditGivesTheImageOfAColdStart) {
  auto s = start();
  const auto original = s->pixels();
  const std::string good = testing::read_text(shader("penumbra/pcf.glsl"));
  edit("penumbra/pcf.glsl", kClampRadius, "  return clamp(radius, 0, kPcfMaxRadius) +;");
  ASSERT_TRUE(s->wait_reload(kTimeout));
  ASSERT_FALSE(s->errors().empty());
  // The fix also changes what the filter does, so the image to match is a new one.
  testing::write_text(shader("penumbra/pcf.glsl"),
                      testing::replaced(good, kSaturate, kLighterShadows));
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->result.ok()) << s->error_text();
  EXPECT_EQ(short_names(rec->result.rebuilt), (std::vector<std::string>{"shadow-resolve"}));
  EXPECT_TRUE(s->errors().empty()) << "a good edit clears the error: " << s->error_text();
  const auto fixed = s->pixels();
  EXPECT_GT(differing_pixels(original, fixed), 0u);
  EXPECT_EQ(fixed, cold_start()) << "bit-identical to a renderer built on the fixed tree";
}

TEST_F(ReloadTest, FixingAFileThatOnlyTheBrokenSourceIncludesClearsTheError) {
  // The broken edit adds an #include of a new file that has the error; the last good pipeline
  // never read that file, so its fix is matched through the failed batch's files.
  auto s = start();
  testing::write_text(shader("penumbra/exposure.glsl"), "float exposure_scale() { return 0.5 }\n");
  std::string tonemap = testing::read_text(shader("render/tonemap.comp"));
  tonemap = testing::replaced(tonemap, "#include \"penumbra/frame_types.glsl\"",
                              "#include \"penumbra/frame_types.glsl\"\n"
                              "#include \"penumbra/exposure.glsl\"");
  tonemap = testing::replaced(
      tonemap, kExposure,
      "vec3 color = texelFetch(hdr, pixel, 0).rgb * frame.ambient.w * exposure_scale();");
  testing::write_text(shader("render/tonemap.comp"), tonemap);  // one save
  auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_EQ(short_names(rec->result.failed), std::vector<std::string>{"tonemap"});
  EXPECT_THAT(s->error_text(), HasSubstr(shader("penumbra/exposure.glsl").string() + ":1:"));
  testing::write_text(shader("penumbra/exposure.glsl"), "float exposure_scale() { return 0.5; }\n");
  rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_EQ(short_names(rec->result.rebuilt), std::vector<std::string>{"tonemap"});
  EXPECT_TRUE(s->errors().empty()) << s->error_text();
  EXPECT_EQ(s->pixels(), cold_start());
}

// The opaque pipelines compile no alpha test (their draws have no mask, and a discard may cost a
// stage its early depth test): an edit of a mask pattern changes the masked pipelines only, and
// renders what a fresh renderer of the edited tree renders.
TEST_F(ReloadTest, AnEditOfAMaskReachesOnlyTheMaskedPipelines) {
  auto s = start();
  edit("penumbra/material.glsl", "return fract(p.x) < 0.5 ? 1.0 : 0.0;",
       "return fract(p.x) < 0.25 ? 1.0 : 0.0;");
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->result.ok()) << s->error_text();
  EXPECT_EQ(short_names(rec->result.same_spirv),
            (std::vector<std::string>{"forward-opaque", "prepass-opaque"}));
  EXPECT_EQ(s->pixels(), cold_start());
}

struct IncludeCase {
  std::string scene;
  std::string file;
  std::vector<std::string> rebuilt;  // first words of the pipeline names, sorted
};

void PrintTo(const IncludeCase& c, std::ostream* os) {
  *os << c.scene << ": " << c.file;
}

class IncludeEdit : public ReloadTest, public ::testing::WithParamInterface<IncludeCase> {};

TEST_P(IncludeEdit, RebuildsExactlyThePipelinesThatReadTheFile) {
  const auto& c = GetParam();
  auto s = start(c.scene);
  const auto readers = s->renderer().pipelines_reading(shader(c.file));
  EXPECT_EQ(short_names(readers), c.rebuilt) << "the dependency graph changed?";
  const std::string text = testing::read_text(shader(c.file));
  testing::write_text(shader(c.file), text + "\n// edited\n");
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->result.ok()) << s->error_text();
  EXPECT_EQ(short_names(rec->result.rebuilt), c.rebuilt);
  EXPECT_THAT(rec->result.rebuilt, UnorderedElementsAreArray(readers));
}

INSTANTIATE_TEST_SUITE_P(
    Files, IncludeEdit,
    ::testing::Values(
        IncludeCase{"default",
                    "penumbra/material.glsl",
                    {"forward-masked", "forward-opaque", "prepass-masked", "prepass-opaque",
                     "sun-shadow-masked"}},
        // The shadow filters are resolved in compute: lighting does not read them.
        IncludeCase{"default", "penumbra/pcf.glsl", {"shadow-resolve"}},
        IncludeCase{"default", "penumbra/noise.glsl", {"contact-shadows", "shadow-resolve"}},
        IncludeCase{"default", "penumbra/vsm.glsl", {"shadow-resolve"}},
        IncludeCase{"default", "contact_shadows.comp", {"contact-shadows"}},
        IncludeCase{"default", "render/tonemap.comp", {"tonemap"}},
        IncludeCase{"indoor",
                    "penumbra/material.glsl",
                    {"forward-masked", "forward-opaque", "point-shadow-cube", "prepass-masked",
                     "prepass-opaque", "spot-shadow-masked"}},
        // Spot and point lights go through the local resolve: no sun, so no shadow-resolve.
        IncludeCase{"indoor", "penumbra/pcf.glsl", {"local-shadow-resolve"}},
        IncludeCase{"indoor", "penumbra/local_shadow.glsl", {"local-shadow-resolve"}}),
    [](const ::testing::TestParamInfo<IncludeCase>& i) {
      std::string n = i.param.scene + "_" + i.param.file;
      for (char& ch : n)
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
      return n;
    });

TEST_F(ReloadTest, AnAtomicRenameSaveTriggersTheReload) {
  auto s = start();
  const auto before = s->pixels();
  const auto file = shader("penumbra/pcf.glsl");
  testing::atomic_save(file,
                       testing::replaced(testing::read_text(file), kSaturate, kLighterShadows));
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec) << "the rename over the original was not seen";
  EXPECT_THAT(rec->changed, ::testing::Contains(file));
  EXPECT_EQ(short_names(rec->result.rebuilt), (std::vector<std::string>{"shadow-resolve"}));
  EXPECT_GT(differing_pixels(before, s->pixels()), 0u);
}

TEST_F(ReloadTest, DeletingAndRecreatingAFileWorks) {
  auto s = start();
  const auto before = s->pixels();
  for (const std::string rel : {"penumbra/pcf.glsl", "render/tonemap.comp"}) {
    SCOPED_TRACE(rel);
    const auto file = shader(rel);
    const std::string text = testing::read_text(file);
    fs::remove(file);
    auto rec = s->wait_reload(kTimeout);
    ASSERT_TRUE(rec) << "the deletion was not reported";
    EXPECT_THAT(rec->deleted, ::testing::ElementsAre(file));
    EXPECT_TRUE(rec->result.rebuilt.empty());
    EXPECT_TRUE(logged(rel + " was deleted"));
    s->render();
    EXPECT_EQ(s->pixels(), before) << "the pipelines keep running without their file";
    testing::write_text(file, text);
    rec = s->wait_reload(kTimeout);
    ASSERT_TRUE(rec) << "the recreated file was not reloaded";
    EXPECT_TRUE(rec->result.ok()) << s->error_text();
    EXPECT_FALSE(rec->result.rebuilt.empty());
    EXPECT_EQ(s->pixels(), before);
  }
  // A recreated file with new content is reloaded like any edit.
  const auto file = shader("render/tonemap.comp");
  const std::string text = testing::read_text(file);
  fs::remove(file);
  ASSERT_TRUE(s->wait_reload(kTimeout));
  testing::write_text(file, testing::replaced(text, kExposure, kHalfExposure));
  ASSERT_TRUE(s->wait_reload(kTimeout));
  EXPECT_EQ(s->pixels(), cold_start());
  EXPECT_NE(s->pixels(), before);
}

TEST_F(ReloadTest, AParameterThatChangesWhatIsBuiltRebuildsAndKeepsReloading) {
  auto s = start();
  EXPECT_TRUE(s->renderer().built().has_pass("contact-shadows"));
  s->set("contact.steps", "0");
  EXPECT_FALSE(s->renderer().built().has_pass("contact-shadows"));
  s->set("shadows.filter", "pcss");
  EXPECT_EQ(s->get("shadows.filter"), "pcss");
  // A frame-time key that changes what the scene requires: evsm2 needs the moments pass, and
  // leaving it drops the pass again.
  EXPECT_FALSE(s->renderer().built().has_pass("evsm"));
  s->set("shadows.filter", "evsm2");
  EXPECT_TRUE(s->renderer().built().has_pass("evsm"));
  s->render();
  s->set("shadows.filter", "pcss");
  EXPECT_FALSE(s->renderer().built().has_pass("evsm"));
  EXPECT_THROW(s->set("shadows.pcf_radius", "9"), Error);
  EXPECT_EQ(s->get("shadows.pcf_radius"), "1") << "a bad value leaves the parameter as it was";
  edit("render/tonemap.comp", kExposure, kHalfExposure);
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_EQ(short_names(rec->result.rebuilt), std::vector<std::string>{"tonemap"});
}

// A shader that is a symlink to a file outside the tree (a shared checkout, say): editing the
// target reloads like editing the file itself, and other files next to the target are ignored.
TEST_F(ReloadTest, EditingTheTargetOfASymlinkedShaderReloads) {
  const fs::path outside = tree.root() / "outside";
  fs::create_directories(outside);
  const fs::path target = outside / "tonemap.comp";
  fs::rename(tree.shaders() / "render/tonemap.comp", target);
  fs::create_symlink(target, tree.shaders() / "render/tonemap.comp");
  auto s = start();
  EXPECT_TRUE(logged("[watch] also watching " + outside.string())) << ::testing::PrintToString(log);
  const auto before = s->pixels();
  testing::write_text(outside / "unrelated.glsl", "float unrelated() { return 1.0; }\n");
  EXPECT_FALSE(s->wait_reload(1000ms)) << "a file no pipeline reads";
  testing::write_text(target,
                      testing::replaced(testing::read_text(target), kExposure, kHalfExposure));
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec) << "the target's edit was not seen";
  EXPECT_EQ(short_names(rec->result.rebuilt), std::vector<std::string>{"tonemap"});
  EXPECT_NE(s->pixels(), before);
  EXPECT_EQ(s->pixels(), cold_start());
}

// The sun resolve is specialized per frame by its filter and by whether the penumbra view is on
// (a pipeline per set of values, made when a frame first needs it). A filter or view changed
// between frames must render what a renderer built for it renders, and after a reload the
// variants made from the old code must go: switching back to one renders the new code.
TEST_F(ReloadTest, SpecializedVariantsFollowTheFrameAndAReload) {
  auto s = start();
  auto fresh = [&](const std::string& filter, const std::string& view) {
    scene::Scene sc = small_scene("default");
    scene::set_param(sc, "shadows.filter", filter);
    scene::set_param(sc, "render.view", view);
    render::RendererOptions o;
    o.shader_dir = tree.shaders();
    render::Renderer r(ctx(), sc, o);
    r.render(0);
    return r.read_rgba8();
  };
  for (const auto& [filter, view] : std::vector<std::pair<std::string, std::string>>{
           {"pcf", "lit"}, {"pcss", "lit"}, {"pcss", "penumbra"}, {"poisson", "lit"}}) {
    s->set("shadows.filter", filter);
    s->set("render.view", view);
    s->render();
    EXPECT_EQ(s->pixels(), fresh(filter, view)) << filter << ", " << view;
  }
  s->set("shadows.filter", "pcf");
  s->set("render.view", "lit");
  s->render();
  const auto pcf_before = s->pixels();
  s->set("shadows.filter", "hard");
  s->render();
  edit("penumbra/pcf.glsl", kSaturate, kLighterShadows);
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->result.ok()) << s->error_text();
  EXPECT_EQ(s->pixels(), fresh("hard", "lit"));
  s->set("shadows.filter", "pcf");  // made before the edit: must be made again
  s->render();
  EXPECT_NE(s->pixels(), pcf_before);
  EXPECT_EQ(s->pixels(), fresh("pcf", "lit"));
}

// The resolves compile only the filters the scene's lights use (shadow_filter.glsl's
// PENUMBRA_FILTERS_2D and _CUBE). On the default scene (hard), an edit of EVSM2's code changes no
// SPIR-V, so no pipeline is made for it. A filter set between frames compiles the resolve again,
// through Session::set and through a renderer's own scene(); a filter whose file does not
// compile leaves the key, the pipelines and the image as they were, and names the file.
TEST_F(ReloadTest, TheResolvesCompileOnlyTheFiltersTheSceneUses) {
  auto s = start();
  const auto hard = s->pixels();
  edit("penumbra/vsm.glsl", "float lod = log2(max(texels, 1e-8));",
       "float lod = log2(max(texels, 1e-7));");
  auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->result.ok()) << s->error_text();
  EXPECT_EQ(short_names(rec->result.rebuilt), std::vector<std::string>{"shadow-resolve"});
  EXPECT_EQ(short_names(rec->result.same_spirv), std::vector<std::string>{"shadow-resolve"})
      << "the default scene's resolve holds no EVSM2 code";
  EXPECT_EQ(s->pixels(), hard);

  // The penumbra view's PCSS estimate is not compiled while the view is off: an edit of it
  // changes no SPIR-V. The view compiles it, with the edit, and shows what the unspecialized
  // resolve shows.
  edit("penumbra/pcss.glsl",
       "  return pcss_penumbra_width(d, params.tan_half_angle) / params.texel_world_size;",
       "  return 2.0 * pcss_penumbra_width(d, params.tan_half_angle) / params.texel_world_size;");
  rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->result.ok()) << s->error_text();
  EXPECT_EQ(short_names(rec->result.same_spirv), std::vector<std::string>{"shadow-resolve"})
      << "the default scene's resolve holds no penumbra view";
  s->set("render.view", "penumbra");
  s->render();
  EXPECT_EQ(s->pixels(), fresh_render("default", {{"render.view", "penumbra"}}, false));
  s->set("render.view", "lit");
  s->render();
  EXPECT_EQ(s->pixels(), hard);

  // pcss.glsl broken: the reload fails, and so does asking for PCSS.
  const std::string taps =
      "  int search_taps = pcss_search_tap_count(tier);\n  float search_radius";
  const std::string text = testing::read_text(shader("penumbra/pcss.glsl"));
  const int line = testing::line_of(text, "  int search_taps = pcss_search_tap_count(tier);");
  edit("penumbra/pcss.glsl", taps,
       "  int search_taps = pcss_search_tap_count(tier) +;\n  float search_radius");
  rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_FALSE(rec->result.ok());
  try {
    s->set("shadows.filter", "pcss");
    ADD_FAILURE() << "a filter whose file does not compile was set";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("pcss.glsl:" + std::to_string(line))) << e.what();
  }
  EXPECT_EQ(s->get("shadows.filter"), "hard");
  s->render();
  EXPECT_EQ(s->pixels(), hard);

  // Mended: PCSS compiles, and renders what a renderer built for it does.
  edit("penumbra/pcss.glsl", "  int search_taps = pcss_search_tap_count(tier) +;\n",
       "  int search_taps = pcss_search_tap_count(tier);\n");
  rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->result.ok()) << s->error_text();
  s->set("shadows.filter", "pcss");
  s->render();
  scene::Scene pcss = small_scene("default");
  scene::set_param(pcss, "shadows.filter", "pcss");
  render::RendererOptions o;
  o.shader_dir = tree.shaders();
  render::Renderer fresh(ctx(), pcss, o);
  fresh.render(0);
  EXPECT_EQ(s->pixels(), fresh.read_rgba8());
  EXPECT_NE(s->pixels(), hard);

  // A renderer's own scene(): the next frame compiles the filter it names.
  render::Renderer r(ctx(), small_scene("default"), o);
  r.render(0);
  EXPECT_EQ(r.read_rgba8(), hard);
  scene::set_param(r.scene(), "shadows.filter", "pcss");
  r.render(0);
  EXPECT_EQ(r.read_rgba8(), fresh.read_rgba8());
}

// With PCF the sun resolve compiles the Poisson disk that constant width turns it into only
// while shadows.constant_filter_width is on: an edit of the disk alone does not change the PCF
// resolve's SPIR-V, and turning constant width on compiles the disk (with the edit) and renders
// what the unspecialized resolve does.
TEST_F(ReloadTest, ThePcfResolveCompilesThePoissonDiskOnlyWithConstantWidth) {
  auto s = start();
  s->set("shadows.filter", "pcf");
  s->render();
  const auto pcf = s->pixels();
  const std::string taps =
      "pcf_poisson_offset(i, cos_sin, radius, texel_size);\n    sum += texture(map, vec4(";
  edit("penumbra/pcf.glsl", taps,
       "pcf_poisson_offset(i, cos_sin, radius * 1.5, texel_size);\n    sum += texture(map, vec4(");
  auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_TRUE(rec->result.ok()) << s->error_text();
  EXPECT_EQ(short_names(rec->result.same_spirv), std::vector<std::string>{"shadow-resolve"})
      << "the PCF resolve without constant width holds no Poisson disk";
  s->render();
  EXPECT_EQ(s->pixels(), pcf);

  s->set("shadows.constant_filter_width", "true");
  s->render();
  EXPECT_EQ(
      s->pixels(),
      fresh_render("default",
                   {{"shadows.filter", "pcf"}, {"shadows.constant_filter_width", "true"}}, false));
  EXPECT_NE(s->pixels(), pcf);
}

// Specialization must not change a pixel: for every filter (the scene's, which the local lights
// without their own follow), lights with their own filters, the debug views that change what
// the resolves compute, and each way of choosing the sun's cascade (by view depth, by
// containment, a clipmap's levels), the specialized renderer renders what the unspecialized one
// does (every filter and selection compiled, the choice read from the frame).
TEST_F(ReloadTest, SpecializedResolvesRenderWhatTheUnspecializedOnesDo) {
  struct Case {
    std::string scene, filter, view;
    std::optional<scene::Filter> spot, point;  // the lights' own filters
    std::vector<std::pair<std::string, std::string>> set = {};  // more parameters
  };
  std::vector<Case> cases{
      {"default", "hard", "lit", {}, {}},
      {"default", "pcf", "penumbra", {}, {}},
      {"default", "pcss", "lit", {}, {}},
      {"default", "poisson", "shadow_factor", {}, {}},
      {"indoor", "pcf", "lit", {}, {}},
      {"indoor", "pcss", "penumbra", {}, {}},
      {"indoor", "poisson", "lit", {}, {}},
      {"indoor", "hard", "lit", scene::Filter::pcss, scene::Filter::poisson},
      {"indoor", "pcf", "lit", scene::Filter::evsm2, scene::Filter::evsm2},
      {"default", "pcf", "lit", {}, {}, {{"shadows.selection", "containment"}}},
      {"default", "pcf", "lit", {}, {}, {{"shadows.constant_filter_width", "true"}}},
      {"default", "hard", "cascades", {}, {}, {{"shadows.layout", "clipmap"}}},
      {"default", "hard", "redrawn", {}, {}, {{"shadows.cache", "true"}}}};
  // Every other filter of the table, on the sun and on the local lights.
  for (const scene::FilterSpec& f : scene::filter_table()) {
    const bool listed = std::any_of(cases.begin(), cases.end(),
                                    [&](const Case& c) { return c.filter == f.name; });
    if (listed || f.moments) continue;  // evsm2: its moments are a build of their own
    cases.push_back({"default", std::string(f.name), "lit", {}, {}});
    cases.push_back({"indoor", std::string(f.name), "lit", {}, {}});
  }
  for (const Case& c : cases) {
    scene::Scene sc = small_scene(c.scene);
    scene::set_param(sc, "shadows.filter", c.filter);
    scene::set_param(sc, "render.view", c.view);
    for (auto& l : sc.spots) l.filter = c.spot;
    for (auto& l : sc.points) l.filter = c.point;
    for (const auto& [key, value] : c.set) scene::set_param(sc, key, value);
    EXPECT_EQ(fresh_render(sc, true), fresh_render(sc, false))
        << c.scene << ", " << c.filter << ", " << c.view;
  }
}

// The renderer names the constants it specializes; a shader that renames one is refused at the
// reload, naming the program and the constant, and the last good pipeline keeps rendering.
TEST_F(ReloadTest, ARenamedSpecializationConstantIsRefused) {
  auto s = start();
  const auto before = s->pixels();
  std::string text = testing::read_text(shader("render/shadow_resolve.comp"));
  for (size_t at = text.find("kPenumbraView"); at != std::string::npos;
       at = text.find("kPenumbraView", at + 1))
    text.replace(at, 13, "kPenumbraMode");
  testing::write_text(shader("render/shadow_resolve.comp"), text);
  const auto rec = s->wait_reload(kTimeout);
  ASSERT_TRUE(rec);
  EXPECT_EQ(short_names(rec->result.failed), (std::vector<std::string>{"shadow-resolve"}));
  EXPECT_THAT(s->error_text(),
              HasSubstr("program 'shadow-resolve': the renderer specializes constant_id 1 as "
                        "'kPenumbraView', but the shader calls it 'kPenumbraMode'"));
  s->render();
  EXPECT_EQ(s->pixels(), before);
}

}  // namespace
}  // namespace penumbra
