// The shader-tree watcher: writes, atomic rename-saves, deletes and re-creates, new
// subdirectories, editors' temporary files, and the debounce (bursts coalesce into one batch,
// timestamps are when the event happened, poll never blocks).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <penumbra/core/error.hpp>
#include <thread>

#include "temp_tree.hpp"
#include "watcher.hpp"

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using runtime::Clock;
using runtime::FileChange;
using runtime::Watcher;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using testing::TempTree;

constexpr auto kTimeout = 3000ms;  // generous: the machine may be busy; waits end early

std::vector<fs::path> paths(const std::vector<FileChange>& changes) {
  std::vector<fs::path> p;
  for (const auto& c : changes) p.push_back(c.path);
  return p;
}

class WatcherTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(tree.root() / "penumbra");
    testing::write_text(file("penumbra/pcf.glsl"), "float pcf() { return 1.0; }\n");
    testing::write_text(file("render/x.comp"), "");
  }
  fs::path file(const std::string& rel) {
    fs::create_directories((tree.root() / rel).parent_path());
    return tree.root() / rel;
  }
  TempTree tree{false};
};

TEST_F(WatcherTest, WatchesTheRootAndEverySubdirectory) {
  Watcher w({tree.root()});
  EXPECT_THAT(w.directories(),
              ElementsAre(tree.root(), tree.root() / "penumbra", tree.root() / "render"));
}

TEST_F(WatcherTest, AWriteIsReportedOnceAfterTheDebounce) {
  Watcher w({tree.root()});
  const auto before = Clock::now();
  testing::write_text(file("penumbra/pcf.glsl"), "float pcf() { return 0.5; }\n");
  const auto changes = w.wait(kTimeout);
  const auto got = Clock::now();
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].path, file("penumbra/pcf.glsl"));
  EXPECT_TRUE(changes[0].exists);
  EXPECT_GE(changes[0].first_seen, before);
  EXPECT_GE(got - changes[0].last_seen, w.options().debounce) << "handed out before the quiet time";
  EXPECT_TRUE(w.poll().empty()) << "a change is reported once";
}

TEST_F(WatcherTest, EventsAreTimestampedWhenTheyHappenNotWhenPolled) {
  Watcher w({tree.root()});
  const auto before = Clock::now();
  testing::write_text(file("penumbra/pcf.glsl"), "changed\n");
  std::this_thread::sleep_for(400ms);  // a long frame
  const auto polled = Clock::now();
  const auto changes = w.poll_changes();
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_LT(changes[0].first_seen - before, 200ms) << "the event was timestamped late";
  EXPECT_GT(polled - changes[0].first_seen, 200ms);
}

TEST_F(WatcherTest, PollNeverBlocksAndReturnsTheBatchOnceQuiet) {
  runtime::WatcherOptions o;
  o.debounce = 300ms;  // long, so the first poll is surely inside it
  Watcher w({tree.root()}, o);
  testing::write_text(file("penumbra/pcf.glsl"), "changed\n");
  const auto t0 = Clock::now();
  EXPECT_TRUE(w.poll().empty()) << "inside the debounce window";
  EXPECT_LT(Clock::now() - t0, 100ms) << "poll blocked";
  std::vector<fs::path> got;
  const auto deadline = Clock::now() + kTimeout;
  while (got.empty() && Clock::now() < deadline) {
    got = w.poll();
    std::this_thread::sleep_for(2ms);
  }
  EXPECT_THAT(got, ElementsAre(file("penumbra/pcf.glsl")));
  EXPECT_GE(Clock::now() - t0, 250ms) << "handed out before the quiet time";
}

// What a reload compiles while a burst settles: the burst can be looked at before it is handed
// out, and the change count says whether anything changed after the look.
TEST_F(WatcherTest, ABurstCanBeLookedAtBeforeItIsHandedOutAndItsCountTellsALaterChange) {
  runtime::WatcherOptions o;
  o.debounce = 400ms;  // long, so the looks below are surely inside it
  Watcher w({tree.root()}, o);
  std::uint64_t count = 99;
  EXPECT_TRUE(w.pending(&count).empty());
  EXPECT_EQ(count, 0u);
  EXPECT_FALSE(w.wait_pending(20ms)) << "no burst has begun";
  testing::write_text(file("penumbra/pcf.glsl"), "float pcf() { return 0.5; }\n");
  ASSERT_TRUE(w.wait_pending(kTimeout, 2ms));
  std::uint64_t looked = 0;
  const auto look = w.pending(&looked);
  EXPECT_THAT(paths(look), ElementsAre(file("penumbra/pcf.glsl")));
  EXPECT_GT(looked, 0u);
  EXPECT_TRUE(w.pending(nullptr, 10s).empty()) << "a look asks for a quiet burst";
  EXPECT_TRUE(w.poll().empty()) << "looking does not hand the burst out";
  std::uint64_t handed = 0;
  EXPECT_THAT(paths(w.wait(kTimeout, &handed)), ElementsAre(file("penumbra/pcf.glsl")));
  EXPECT_EQ(handed, looked) << "nothing changed after the look";

  // A change after the look: the batch's count is past the look's.
  testing::write_text(file("penumbra/pcf.glsl"), "float pcf() { return 0.25; }\n");
  ASSERT_TRUE(w.wait_pending(kTimeout));
  w.pending(&looked);
  testing::write_text(file("render/x.comp"), "void main() {}\n");
  EXPECT_THAT(paths(w.wait(kTimeout, &handed)),
              ElementsAre(file("penumbra/pcf.glsl"), file("render/x.comp")));
  EXPECT_GT(handed, looked);
  EXPECT_EQ(w.change_count(), handed);
}

TEST_F(WatcherTest, ABurstOfWritesIsOneBatchWithEachFileOnce) {
  runtime::WatcherOptions o;
  o.debounce = 200ms;  // a busy machine may pause the writer for a while
  Watcher w({tree.root()}, o);
  for (int i = 0; i < 5; ++i) {
    testing::write_text(file("penumbra/pcf.glsl"), "v" + std::to_string(i));
    testing::write_text(file("render/x.comp"), "v" + std::to_string(i));
    std::this_thread::sleep_for(5ms);  // well inside the debounce
  }
  testing::write_text(file("penumbra/noise.glsl"), "new file");
  const auto changes = w.wait(kTimeout);
  EXPECT_THAT(paths(changes), ElementsAre(file("penumbra/noise.glsl"), file("penumbra/pcf.glsl"),
                                          file("render/x.comp")));
  EXPECT_TRUE(w.wait(400ms).empty()) << "the burst was split";
}

TEST_F(WatcherTest, AnAtomicRenameSaveIsSeenAsAChangeOfTheOriginal) {
  Watcher w({tree.root()});
  testing::atomic_save(file("penumbra/pcf.glsl"), "saved by rename\n");
  const auto changes = w.wait(kTimeout);
  ASSERT_THAT(paths(changes), ElementsAre(file("penumbra/pcf.glsl")))
      << "the temporary file must be filtered out, the original reported";
  EXPECT_TRUE(changes[0].exists);
  EXPECT_EQ(testing::read_text(file("penumbra/pcf.glsl")), "saved by rename\n");
}

TEST_F(WatcherTest, ADeletedFileIsReportedAndItsRecreationToo) {
  Watcher w({tree.root()});
  fs::remove(file("penumbra/pcf.glsl"));
  auto changes = w.wait(kTimeout);
  ASSERT_THAT(paths(changes), ElementsAre(file("penumbra/pcf.glsl")));
  EXPECT_FALSE(changes[0].exists);
  testing::write_text(file("penumbra/pcf.glsl"), "back\n");
  changes = w.wait(kTimeout);
  ASSERT_THAT(paths(changes), ElementsAre(file("penumbra/pcf.glsl")));
  EXPECT_TRUE(changes[0].exists);
  // And it keeps working: the directory watch survived.
  testing::write_text(file("penumbra/pcf.glsl"), "again\n");
  EXPECT_THAT(paths(w.wait(kTimeout)), ElementsAre(file("penumbra/pcf.glsl")));
}

TEST_F(WatcherTest, ARenameAwayIsADeletion) {
  Watcher w({tree.root()});
  fs::rename(file("penumbra/pcf.glsl"), tree.root() / "pcf.glsl.bak");
  const auto changes = w.wait(kTimeout);
  ASSERT_THAT(paths(changes), ElementsAre(file("penumbra/pcf.glsl")));
  EXPECT_FALSE(changes[0].exists);
}

TEST_F(WatcherTest, ANewSubdirectoryIsWatchedWithTheFilesWrittenIntoIt) {
  Watcher w({tree.root()});
  fs::create_directories(tree.root() / "extra" / "deeper");
  testing::write_text(tree.root() / "extra" / "deeper" / "a.glsl", "a");
  auto changes = w.wait(kTimeout);
  EXPECT_THAT(paths(changes), ElementsAre(tree.root() / "extra" / "deeper" / "a.glsl"));
  EXPECT_THAT(w.directories(), ::testing::Contains(tree.root() / "extra" / "deeper"));
  testing::write_text(tree.root() / "extra" / "deeper" / "a.glsl", "b");
  EXPECT_THAT(paths(w.wait(kTimeout)), ElementsAre(tree.root() / "extra" / "deeper" / "a.glsl"));
}

TEST_F(WatcherTest, EditorTemporaryFilesAreIgnored) {
  Watcher w({tree.root()});
  testing::write_text(tree.root() / "penumbra" / ".pcf.glsl.swp", "swap");
  testing::write_text(tree.root() / "penumbra" / "pcf.glsl~", "backup");
  testing::write_text(tree.root() / "penumbra" / "4913", "vim probe");
  EXPECT_TRUE(w.wait(200ms).empty());
  EXPECT_GT(w.events_seen(), 0u) << "the events arrived but were filtered";
}

TEST_F(WatcherTest, AContinuouslyRewrittenFileIsStillReportedAfterMaxDelay) {
  runtime::WatcherOptions o;
  o.debounce = 50ms;
  o.max_delay = 200ms;
  Watcher w({tree.root()}, o);
  const auto t0 = Clock::now();
  std::vector<FileChange> changes;
  while (changes.empty() && Clock::now() - t0 < kTimeout) {
    testing::write_text(file("penumbra/pcf.glsl"), "tick");
    std::this_thread::sleep_for(10ms);  // never quiet for 50 ms
    changes = w.poll_changes();
  }
  EXPECT_THAT(paths(changes), ElementsAre(file("penumbra/pcf.glsl")));
  EXPECT_LT(Clock::now() - t0, 1000ms);
}

TEST_F(WatcherTest, ARootThatIsNotADirectoryThrowsNamingIt) {
  try {
    Watcher w({tree.root() / "missing"});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("missing"));
    EXPECT_THAT(e.what(), HasSubstr("not a directory"));
  }
}

}  // namespace
}  // namespace penumbra
