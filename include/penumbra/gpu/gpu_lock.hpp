#pragma once

#include <filesystem>
#include <mutex>

namespace penumbra::gpu {

// One GPU shared by several processes, some of which time their frames (penumbra-tune --jobs):
// a timestamp query measures the GPU's time between two points, and another process's work that
// the GPU runs in between is counted too. PENUMBRA_GPU_LOCK names a lock file: every submission
// (CommandRecorder::submit_and_wait) holds it shared, and a timed stretch (ExclusiveGpu) holds it
// alone, so no other process's work runs between its timestamps. A process waiting to time keeps
// new submissions out while the running ones finish (a second file is the turnstile), so a timer
// never starves. Unset (the default), nothing is locked.
class GpuLock {
 public:
  // The process's lock, from PENUMBRA_GPU_LOCK (read once).
  static GpuLock& process();
  // A lock on `path` and `path`.turnstile; an empty path locks nothing. Throws penumbra::Error
  // naming the file when it cannot be opened.
  explicit GpuLock(const std::filesystem::path& path);
  ~GpuLock();
  GpuLock(const GpuLock&) = delete;
  GpuLock& operator=(const GpuLock&) = delete;

  bool enabled() const { return main_ >= 0; }
  // Shared: for a submission. Inside this process's exclusive stretch it is already held.
  void lock_shared();
  void unlock_shared();
  // Exclusive: waits for every other process's submission to finish and keeps new ones out.
  void lock_exclusive();
  void unlock_exclusive();
  // Without waiting: false when another process holds it (the tests' view of the protocol).
  bool try_lock_shared();
  bool try_lock_exclusive();

 private:
  bool take_shared(bool wait);
  bool take_exclusive(bool wait);

  std::filesystem::path path_;
  int main_ = -1;
  int turnstile_ = -1;
  std::mutex mutex_;
  int shared_ = 0;  // this process's shared holders (threads)
  bool exclusive_ = false;
};

// A timed stretch: the process's lock held exclusively for its lifetime.
class ExclusiveGpu {
 public:
  explicit ExclusiveGpu(GpuLock& lock = GpuLock::process()) : lock_(lock) {
    lock_.lock_exclusive();
  }
  ~ExclusiveGpu() { lock_.unlock_exclusive(); }
  ExclusiveGpu(const ExclusiveGpu&) = delete;
  ExclusiveGpu& operator=(const ExclusiveGpu&) = delete;

 private:
  GpuLock& lock_;
};

// A submission: the process's lock held shared for its lifetime.
class SharedGpu {
 public:
  explicit SharedGpu(GpuLock& lock = GpuLock::process()) : lock_(lock) { lock_.lock_shared(); }
  ~SharedGpu() { lock_.unlock_shared(); }
  SharedGpu(const SharedGpu&) = delete;
  SharedGpu& operator=(const SharedGpu&) = delete;

 private:
  GpuLock& lock_;
};

}  // namespace penumbra::gpu
