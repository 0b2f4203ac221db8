#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/gpu_lock.hpp>
#include <string>

namespace penumbra::gpu {
namespace {

int open_lock(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
  if (fd < 0)
    throw Error("PENUMBRA_GPU_LOCK: cannot open lock file '" + path.string() +
                "': " + std::strerror(errno));
  return fd;
}

// flock, retried when a signal interrupts the wait; false only for a non-blocking miss.
bool lock(int fd, int op, const std::filesystem::path& path) {
  for (;;) {
    if (::flock(fd, op) == 0) return true;
    if (errno == EINTR) continue;
    if (errno == EWOULDBLOCK && (op & LOCK_NB) != 0) return false;
    throw Error("PENUMBRA_GPU_LOCK: flock on '" + path.string() + "': " + std::strerror(errno));
  }
}

}  // namespace

GpuLock& GpuLock::process() {
  static GpuLock instance([] {
    const char* v = std::getenv("PENUMBRA_GPU_LOCK");
    return std::filesystem::path(v != nullptr ? v : "");
  }());
  return instance;
}

GpuLock::GpuLock(const std::filesystem::path& path) : path_(path) {
  if (path.empty()) return;
  main_ = open_lock(path);
  try {
    turnstile_ = open_lock(path.string() + ".turnstile");
  } catch (...) {
    ::close(main_);
    throw;
  }
}

GpuLock::~GpuLock() {
  if (turnstile_ >= 0) ::close(turnstile_);
  if (main_ >= 0) ::close(main_);
}

void GpuLock::lock_shared() {
  take_shared(true);
}

bool GpuLock::try_lock_shared() {
  return take_shared(false);
}

void GpuLock::unlock_shared() {
  if (!enabled()) return;
  const std::lock_guard<std::mutex> guard(mutex_);
  if (exclusive_ || --shared_ > 0) return;
  lock(main_, LOCK_UN, path_);
}

void GpuLock::lock_exclusive() {
  take_exclusive(true);
}

bool GpuLock::try_lock_exclusive() {
  return take_exclusive(false);
}

void GpuLock::unlock_exclusive() {
  if (!enabled()) return;
  const std::lock_guard<std::mutex> guard(mutex_);
  if (!exclusive_) return;
  lock(main_, LOCK_UN, path_);
  lock(turnstile_, LOCK_UN, path_);
  exclusive_ = false;
}

bool GpuLock::take_shared(bool wait) {
  if (!enabled()) return true;
  const std::lock_guard<std::mutex> guard(mutex_);
  if (exclusive_) return true;  // this process's own timed stretch
  if (shared_ > 0) {            // another thread of this process holds it
    ++shared_;
    return true;
  }
  const int nb = wait ? 0 : LOCK_NB;
  if (!lock(turnstile_, LOCK_EX | nb, path_)) return false;  // behind a process waiting to time
  const bool got = lock(main_, LOCK_SH | nb, path_);
  lock(turnstile_, LOCK_UN, path_);
  if (got) shared_ = 1;
  return got;
}

bool GpuLock::take_exclusive(bool wait) {
  if (!enabled()) return true;
  const std::lock_guard<std::mutex> guard(mutex_);
  if (exclusive_ || shared_ > 0)
    throw Error("PENUMBRA_GPU_LOCK: an exclusive stretch begun while this process holds '" +
                path_.string() + "'");
  const int nb = wait ? 0 : LOCK_NB;
  // New submissions of other processes wait from the turnstile on, until the running ones end.
  if (!lock(turnstile_, LOCK_EX | nb, path_)) return false;
  if (!lock(main_, LOCK_EX | nb, path_)) {
    lock(turnstile_, LOCK_UN, path_);
    return false;
  }
  exclusive_ = true;
  return true;
}

}  // namespace penumbra::gpu
