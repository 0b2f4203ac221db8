// penumbra-view's window mode under Xvfb (a GLFW window and a Vulkan swapchain on lavapipe or a
// GPU): it presents frames with the validation layer silent, shows a reload error in the title,
// and falls back to headless without a display. Xvfb is required (CI installs it): when it
// cannot start, the tests fail and say so.
#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <sstream>
#include <map>
#include <thread>

#include "temp_tree.hpp"

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;
using testing::TempTree;

// An Xvfb server on a display it picks itself (-displayfd), stopped by the destructor.
class Xvfb {
 public:
  Xvfb() {
    int fds[2];
    if (pipe(fds) != 0) {
      error_ = "pipe failed";
      return;
    }
    pid_ = fork();
    if (pid_ == 0) {
      close(fds[0]);
      const int null = open("/dev/null", O_WRONLY);
      dup2(null, 1);
      dup2(null, 2);
      const std::string fd = std::to_string(fds[1]);
      execlp("Xvfb", "Xvfb", "-displayfd", fd.c_str(), "-screen", "0", "640x480x24", "-nolisten",
             "tcp", static_cast<char*>(nullptr));
      _exit(127);
    }
    close(fds[1]);
    std::string number;
    pollfd p{fds[0], POLLIN, 0};
    while (poll(&p, 1, 5000) > 0) {
      char c = 0;
      if (read(fds[0], &c, 1) != 1 || c == '\n') break;
      number += c;
    }
    close(fds[0]);
    if (pid_ < 0 || number.empty()) {
      error_ =
          "Xvfb did not start (is the xvfb package installed? .ci/install-deps.sh installs it); "
          "the window tests need it";
    } else {
      display_ = ":" + number;
    }
  }
  ~Xvfb() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
    }
  }
  Xvfb(const Xvfb&) = delete;
  Xvfb& operator=(const Xvfb&) = delete;

  const std::string& display() const { return display_; }
  const std::string& error() const { return error_; }

 private:
  pid_t pid_ = -1;
  std::string display_, error_;
};

struct Result {
  int status = 0;
  std::string output;
};

Result shell(const std::string& cmd) {
  Result r;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return {-1, "popen failed"};
  char buf[512];
  while (fgets(buf, sizeof buf, p)) r.output += buf;
  r.status = pclose(p);
  return r;
}

TEST(WindowMode, PresentsFramesUnderXvfbWithoutValidationMessages) {
  Xvfb x;
  ASSERT_TRUE(x.error().empty()) << x.error();
  // With the parameter panel (when built with Dear ImGui) and without it.
  for (const std::string flags : {"", " --no-ui"}) {
    const Result r =
        shell("env DISPLAY=" + x.display() + " PENUMBRA_VALIDATION=1 " + PENUMBRA_VIEW_EXE +
              " --frames 3 --exit-after-frames --size 160x120" + flags);
    EXPECT_EQ(r.status, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("[window] presented 3 frames (3 rendered) to a 160x120"));
    EXPECT_THAT(r.output, HasSubstr(flags.empty() ? "[window] panel: " : "panel: off"));
    EXPECT_THAT(r.output, HasSubstr("validation:  0 messages"));
    EXPECT_THAT(r.output, Not(HasSubstr("rendering headless")));
  }
}

// The panel shows what each shipped scene models, grouped by light (penumbra-view --ui-rows
// prints the rows drawn, group by group): no sun rows without a sun, the spot and point lights'
// own rows, PCSS rows only where a light uses PCSS, clipmap rows only with the clipmap layout.
TEST(WindowMode, ThePanelShowsTheRowsEachShippedSceneModels) {
  Xvfb x;
  ASSERT_TRUE(x.error().empty()) << x.error();
  const auto rows = [&](const std::string& args) {
    const Result r = shell("env DISPLAY=" + x.display() + " PENUMBRA_VALIDATION=1 " +
                           PENUMBRA_VIEW_EXE + " --frames 1 --exit-after-frames --size 96x64 " +
                           "--ui-rows " + args);
    EXPECT_EQ(r.status, 0) << r.output;
    EXPECT_THAT(r.output, HasSubstr("validation:  0 messages"));
    std::map<std::string, std::string> groups;  // "sun" -> " sun.direction sun.color ..."
    std::istringstream lines(r.output);
    for (std::string line; std::getline(lines, line);) {
      if (line.rfind("[ui] rows ", 0) != 0) continue;
      const auto colon = line.find(':');
      groups[line.substr(10, colon - 10)] = line.substr(colon + 1) + " ";
    }
    return groups;
  };
  const auto has = [](const std::map<std::string, std::string>& g, const std::string& group,
                      const std::string& key) {
    const auto it = g.find(group);
    return it != g.end() && it->second.find(" " + key + " ") != std::string::npos;
  };
  const auto anywhere = [](const std::map<std::string, std::string>& g, const std::string& key) {
    for (const auto& [name, keys] : g)
      if (name.rfind("not used", 0) != 0 && keys.find(" " + key + " ") != std::string::npos)
        return true;
    return false;
  };

  const auto indoor = rows("--scene indoor");  // a spot and a point light, no sun
  EXPECT_EQ(indoor.count("sun"), 0u);
  EXPECT_TRUE(has(indoor, "spot[0]", "spot[0].resolution"));
  EXPECT_TRUE(has(indoor, "spot[0]", "spot[0].filter"));
  EXPECT_TRUE(has(indoor, "point[0]", "point[0].radius"));
  EXPECT_FALSE(anywhere(indoor, "shadows.cascades"));
  EXPECT_FALSE(anywhere(indoor, "sun.direction"));

  const auto space = rows("--scene space");  // one fitted point light
  EXPECT_EQ(space.count("sun"), 0u);
  EXPECT_EQ(space.count("spot[0]"), 0u);
  EXPECT_TRUE(has(space, "point[0]", "point[0].fit_to_camera"));

  const auto def = rows("--scene default");  // the sun's cascades
  EXPECT_TRUE(has(def, "sun", "sun.direction"));
  EXPECT_TRUE(has(def, "sun", "shadows.cascades"));
  EXPECT_EQ(def.count("point[0]"), 0u);
  EXPECT_FALSE(anywhere(def, "shadows.clipmap_levels"));
  EXPECT_FALSE(anywhere(def, "shadows.pcss_search_texels"));  // no light uses PCSS
  // The rows follow the scene: the clipmap layout's rows replace the cascades'; PCSS's appear
  // with a light that uses it.
  const auto clip = rows("--scene default --set shadows.layout=clipmap --set shadows.filter=pcss");
  EXPECT_TRUE(has(clip, "sun", "shadows.clipmap_levels"));
  EXPECT_FALSE(anywhere(clip, "shadows.cascades"));
  EXPECT_TRUE(anywhere(clip, "shadows.pcss_search_texels"));

  const auto grazing = rows("--scene grazing");
  EXPECT_TRUE(has(grazing, "sun", "shadows.resolution"));
}

// Runs penumbra-view in a window on `x` with `args`, calling step(line) for each line it prints
// (step returns true to stop it with SIGTERM); a guard SIGKILLs it after `limit` seconds.
Result watch_window(const Xvfb& x, const std::string& args,
                    const std::function<bool(const std::string&)>& step, int limit) {
  const std::string cmd = "sh -c 'echo pid $$; exec env DISPLAY=" + x.display() +
                          " PENUMBRA_VALIDATION=1 " + PENUMBRA_VIEW_EXE + " " + args + "' 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (p == nullptr) return {-1, "popen failed"};
  std::atomic<pid_t> pid{-1};
  std::atomic<bool> done{false};
  std::thread guard([&] {  // never hang
    for (int i = 0; i < 10 * limit && !done; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (!done && pid > 0) kill(pid, SIGKILL);
  });
  Result r;
  char buf[1024];
  bool stopped = false;
  while (fgets(buf, sizeof buf, p)) {
    const std::string l = buf;
    r.output += l;
    if (l.rfind("pid ", 0) == 0) pid = static_cast<pid_t>(std::stol(l.substr(4)));
    if (!stopped && step(l)) {
      kill(pid, SIGTERM);
      stopped = true;
    }
  }
  r.status = pclose(p);
  done = true;
  guard.join();
  return r;
}

TEST(WindowMode, ShowsTheReloadErrorInTheTitleUntilItIsFixed) {
  Xvfb x;
  ASSERT_TRUE(x.error().empty()) << x.error();
  TempTree tree(true);
  const fs::path pcf = tree.shaders() / "penumbra" / "pcf.glsl";
  const std::string good = testing::read_text(pcf);
  const std::string line = "  return clamp(radius, 0, kPcfMaxRadius);";
  const auto at = good.find(line);
  ASSERT_NE(at, std::string::npos);
  std::string bad = good;
  bad.replace(at, line.size(), "  return clamp(radius, 0, kPcfMaxRadius)  // no semicolon");

  std::string shown, cleared;
  int stage = 0;  // 0: starting, 1: broken, 2: fixed, 3: stopped
  const Result r = watch_window(
      x, "--shader-dir " + tree.shaders().string() + " --size 160x120",
      [&](const std::string& l) {
        if (stage == 0 && l.find("[window] 160x120, watching") != std::string::npos) {
          testing::atomic_save(pcf, bad);
          stage = 1;
        } else if (stage == 1 && l.find("[window] title shows the reload error") != std::string::npos) {
          shown = l;
          testing::atomic_save(pcf, good);
          stage = 2;
        } else if (stage == 2 && l.find("[window] title clear") != std::string::npos) {
          cleared = l;
          stage = 3;
          return true;
        }
        return false;
      },
      30);
  EXPECT_EQ(stage, 3) << r.output;
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_THAT(shown, HasSubstr("RELOAD ERROR: "));
  EXPECT_THAT(shown, HasSubstr("pcf.glsl:"));
  EXPECT_THAT(cleared, Not(HasSubstr("RELOAD ERROR")));
  EXPECT_THAT(r.output, HasSubstr("validation:  0 messages"));
}

// --truth in the window: the panel's table gets a row per save with the measured deltas, and
// undoing the edit comes back bit-identical to the start. The shader directory is an overlay
// holding only pcf.glsl (the rest comes from the library).
TEST(WindowMode, TheTruthTableGetsARowPerSave) {
  Xvfb x;
  ASSERT_TRUE(x.error().empty()) << x.error();
  TempTree tree(false);
  const fs::path pcf = tree.root() / "overlay" / "penumbra" / "pcf.glsl";
  fs::create_directories(pcf.parent_path());
  const std::string good = testing::read_text(fs::path(PENUMBRA_SHADER_DIR) / "penumbra/pcf.glsl");
  testing::write_text(pcf, good);
  const std::string line = "  return clamp(radius, 0, kPcfMaxRadius);";
  const auto at = good.find(line);
  ASSERT_NE(at, std::string::npos);
  std::string wider = good;
  wider.replace(at, line.size(), "  return clamp(radius + 2, 0, kPcfMaxRadius);");

  int stage = 0;  // 0: tracing, 1: widened, 2: undone, 3: stopped
  std::string widened;
  const Result r = watch_window(
      x,
      "--scene default --set shadows.filter=pcf --size 160x120 --truth --ui-rows --shader-dir " +
          pcf.parent_path().parent_path().string(),
      [&](const std::string& l) {
        if (stage == 0 && l.rfind("[truth] GPU", 0) == 0) {
          testing::atomic_save(pcf, wider);
          stage = 1;
        } else if (stage == 1 && l.rfind("[truth] sun: mean |dV|", 0) == 0) {
          widened = l;
        } else if (stage == 1 && l.rfind("[ui] saves: 1", 0) == 0) {
          testing::atomic_save(pcf, good);
          stage = 2;
        } else if (stage == 2 && l.rfind("[ui] saves: 2", 0) == 0) {
          stage = 3;
          return true;
        }
        return false;
      },
      120);
  EXPECT_EQ(stage, 3) << r.output;
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("over " + fs::weakly_canonical(PENUMBRA_SHADER_DIR).string()));
  EXPECT_THAT(widened, HasSubstr(" -> ")) << r.output;
  EXPECT_THAT(r.output, HasSubstr("[truth] image: changed"));
  EXPECT_THAT(r.output, HasSubstr("image bit-identical to the start")) << r.output;
  EXPECT_THAT(r.output, HasSubstr("validation:  0 messages"));
}

TEST(WindowMode, FallsBackToHeadlessWithoutADisplay) {
  TempTree tree(false);
  const Result r = shell(std::string("env -u DISPLAY -u WAYLAND_DISPLAY ") + PENUMBRA_VIEW_EXE +
                         " --frames 1 --size 64x48 --view lit --out " + tree.root().string());
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("rendering headless: no display"));
  EXPECT_TRUE(fs::exists(tree.root() / "lit.png")) << r.output;
}

}  // namespace
}  // namespace penumbra
