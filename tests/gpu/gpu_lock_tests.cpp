// Tests of the GPU lock (PENUMBRA_GPU_LOCK): two GpuLock objects on one file stand for two
// processes (flock locks belong to an open file, not to a process).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/gpu_lock.hpp>
#include <string>
#include <thread>

namespace penumbra::gpu {
namespace {

namespace fs = std::filesystem;

// A lock file in a folder of this test process's own, removed at exit.
fs::path lock_file(const std::string& name) {
  struct Dir {
    fs::path path = fs::temp_directory_path() /
                    ("penumbra-gpu-lock-" + std::to_string(::getpid()));
    Dir() { fs::create_directories(path); }
    ~Dir() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  };
  static const Dir dir;
  return dir.path / name;
}

TEST(GpuLock, SubmissionsShareTimingExcludes) {
  const auto path = lock_file("share");
  GpuLock a(path), b(path);
  ASSERT_TRUE(a.enabled());
  a.lock_shared();
  EXPECT_TRUE(b.try_lock_shared()) << "two submitting processes must not wait on each other";
  b.unlock_shared();
  EXPECT_FALSE(b.try_lock_exclusive()) << "a timer must wait for a running submission";
  a.unlock_shared();
  ASSERT_TRUE(b.try_lock_exclusive());
  EXPECT_FALSE(a.try_lock_shared()) << "no submission may land inside another's timed frames";
  EXPECT_FALSE(a.try_lock_exclusive());
  b.unlock_exclusive();
  EXPECT_TRUE(a.try_lock_shared());
  a.unlock_shared();
}

TEST(GpuLock, AWaitingTimerKeepsNewSubmissionsOut) {
  const auto path = lock_file("turnstile");
  GpuLock running(path), timer(path), newcomer(path);
  running.lock_shared();
  std::atomic<bool> timed{false};
  std::thread t([&] {
    const ExclusiveGpu alone(timer);
    timed = true;
  });
  // The timer waits behind the running submission; from the moment it waits, a new
  // submission waits too (else a steady stream of submissions would starve it).
  bool kept_out = false;
  for (int i = 0; i < 60000 && !kept_out; ++i) {  // a minute at most on a busy machine
    if (newcomer.try_lock_shared())
      newcomer.unlock_shared();
    else
      kept_out = true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_TRUE(kept_out);
  EXPECT_FALSE(timed.load());
  running.unlock_shared();
  t.join();
  EXPECT_TRUE(timed.load());
  EXPECT_TRUE(newcomer.try_lock_shared());
  newcomer.unlock_shared();
}

TEST(GpuLock, SubmissionsInsideOwnTimedStretchDoNotWait) {
  const auto path = lock_file("nested");
  GpuLock lock(path), other(path);
  {
    const ExclusiveGpu alone(lock);
    const SharedGpu submit(lock);  // the timed frames' own submissions
    EXPECT_FALSE(other.try_lock_shared());
  }
  EXPECT_TRUE(other.try_lock_exclusive());
  other.unlock_exclusive();
  lock.lock_shared();
  EXPECT_THROW(lock.lock_exclusive(), Error) << "a stretch cannot begin inside a submission";
  lock.unlock_shared();
}

TEST(GpuLock, UnsetLocksNothing) {
  GpuLock none{fs::path()};
  EXPECT_FALSE(none.enabled());
  none.lock_exclusive();
  EXPECT_TRUE(none.try_lock_shared());
  none.unlock_shared();
  none.unlock_exclusive();
}

TEST(GpuLock, UnopenableFileIsNamed) {
  try {
    GpuLock bad(fs::path("/nonexistent-penumbra-dir/gpu.lock"));
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("/nonexistent-penumbra-dir/gpu.lock"));
  }
}

}  // namespace
}  // namespace penumbra::gpu
