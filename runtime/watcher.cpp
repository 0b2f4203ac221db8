#include "watcher.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <sys/inotify.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <penumbra/core/error.hpp>

namespace penumbra::runtime {
namespace fs = std::filesystem;

namespace {

constexpr uint32_t kDirectoryMask =
    IN_CLOSE_WRITE | IN_MOVED_TO | IN_MOVED_FROM | IN_CREATE | IN_DELETE | IN_ONLYDIR;

fs::path canonical_dir(const fs::path& p) {
  std::error_code ec;
  fs::path c = fs::weakly_canonical(fs::absolute(p), ec);
  return ec ? p : c;
}

}  // namespace

Watcher::Watcher(const std::vector<fs::path>& roots, WatcherOptions options)
    : options_(std::move(options)) {
  inotify_fd_ = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
  if (inotify_fd_ < 0) throw Error(std::string("watcher: inotify_init1: ") + std::strerror(errno));
  wake_fd_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd_ < 0) {
    close(inotify_fd_);
    throw Error(std::string("watcher: eventfd: ") + std::strerror(errno));
  }
  try {
    for (const auto& r : roots) {
      std::error_code ec;
      if (!fs::is_directory(r, ec)) throw Error("watcher: " + r.string() + ": not a directory");
      roots_.push_back(canonical_dir(r));
      add_tree(roots_.back(), false);
    }
  } catch (...) {
    close(inotify_fd_);
    close(wake_fd_);
    throw;
  }
  thread_ = std::thread([this] { thread_main(); });
}

Watcher::~Watcher() {
  const uint64_t one = 1;
  [[maybe_unused]] const auto written = write(wake_fd_, &one, sizeof one);  // cannot fail here
  if (thread_.joinable()) thread_.join();
  close(inotify_fd_);
  close(wake_fd_);
}

void Watcher::add_directory(const fs::path& dir) {
  const int wd = inotify_add_watch(inotify_fd_, dir.c_str(), kDirectoryMask);
  if (wd < 0) {
    // A directory that vanished between listing and watching is not an error.
    if (errno == ENOENT || errno == ENOTDIR) return;
    throw Error("watcher: " + dir.string() + ": inotify_add_watch: " + std::strerror(errno));
  }
  directories_[wd] = dir;
}

bool Watcher::watch_directory(const fs::path& dir) {
  const fs::path d = canonical_dir(dir);
  std::lock_guard lock(mutex_);  // the reader thread maps descriptors to directories
  for (const auto& [wd, watched] : directories_)
    if (watched == d) return false;
  const size_t before = directories_.size();
  add_directory(d);
  return directories_.size() > before;
}

// Watches dir and its subdirectories. report_files: the files already in it become pending
// changes (a directory created or moved in after the watch began may hold files written
// before its own watch existed).
void Watcher::add_tree(const fs::path& dir, bool report_files) {
  add_directory(dir);
  std::error_code ec;
  const auto now = Clock::now();
  for (fs::recursive_directory_iterator it(dir, fs::directory_options::skip_permission_denied, ec),
       end;
       !ec && it != end; it.increment(ec)) {
    if (it->is_directory(ec)) {
      add_directory(canonical_dir(it->path()));
    } else if (report_files && wanted(it->path().filename().string())) {
      auto& p = pending_[canonical_dir(it->path().parent_path()) / it->path().filename()];
      if (p.first == Clock::time_point{}) p.first = now;
      p.last = now;
      ++changes_;
    }
  }
}

bool Watcher::wanted(const std::string& name) const {
  if (options_.extensions.empty()) return true;
  return std::any_of(
      options_.extensions.begin(), options_.extensions.end(), [&](const std::string& e) {
        return e.empty() ||
               (name.size() >= e.size() && name.compare(name.size() - e.size(), e.size(), e) == 0);
      });
}

void Watcher::handle_buffer(const char* data, size_t size, Clock::time_point now) {
  const size_t before = pending_.size();
  bool any = false;
  for (size_t off = 0; off + sizeof(inotify_event) <= size;) {
    inotify_event ev;
    std::memcpy(&ev, data + off, sizeof ev);
    const char* name_ptr = data + off + sizeof(inotify_event);
    const std::string name = ev.len ? std::string(name_ptr, strnlen(name_ptr, ev.len)) : "";
    off += sizeof(inotify_event) + ev.len;
    ++events_;
    if (ev.mask & IN_Q_OVERFLOW) {
      // Events were lost: report every file under the roots.
      for (const auto& r : roots_) add_tree(r, true);
      any = true;
      continue;
    }
    if (ev.mask & IN_IGNORED) {
      directories_.erase(ev.wd);
      continue;
    }
    const auto dir = directories_.find(ev.wd);
    if (dir == directories_.end() || name.empty()) continue;
    const fs::path path = dir->second / name;
    if (ev.mask & IN_ISDIR) {
      if (ev.mask & (IN_CREATE | IN_MOVED_TO)) {
        add_tree(path, true);
        any = true;
      }
      continue;  // removed directories drop their watches themselves (IN_IGNORED)
    }
    if (!wanted(name)) continue;
    auto& p = pending_[path];
    if (p.first == Clock::time_point{}) p.first = now;
    p.last = now;
    ++changes_;
    any = true;
  }
  if (any || pending_.size() != before) {
    if (burst_first_ == Clock::time_point{}) burst_first_ = now;
    burst_last_ = now;
  }
}

void Watcher::thread_main() {
  alignas(inotify_event) char buffer[64 * 1024];
  pollfd fds[2] = {{inotify_fd_, POLLIN, 0}, {wake_fd_, POLLIN, 0}};
  for (;;) {
    const int n = ::poll(fds, 2, -1);
    if (n < 0) {
      if (errno == EINTR) continue;
      return;
    }
    if (fds[1].revents) return;
    if (!(fds[0].revents & POLLIN)) continue;
    const auto len = read(inotify_fd_, buffer, sizeof buffer);
    const auto now = Clock::now();
    if (len <= 0) continue;
    {
      std::lock_guard lock(mutex_);
      handle_buffer(buffer, static_cast<size_t>(len), now);
    }
    cv_.notify_all();
  }
}

bool Watcher::ready(Clock::time_point now) const {
  if (pending_.empty()) return false;
  return now - burst_last_ >= options_.debounce || now - burst_first_ >= options_.max_delay;
}

std::vector<FileChange> Watcher::snapshot() const {
  std::vector<FileChange> out;
  out.reserve(pending_.size());
  for (const auto& [path, p] : pending_) {
    std::error_code ec;
    out.push_back({path, fs::exists(path, ec), p.first, p.last});
  }
  return out;
}

std::vector<FileChange> Watcher::take() {
  std::vector<FileChange> out = snapshot();
  pending_.clear();
  burst_first_ = burst_last_ = Clock::time_point{};
  return out;
}

std::vector<FileChange> Watcher::poll_changes(std::uint64_t* count) {
  std::lock_guard lock(mutex_);
  if (!ready(Clock::now())) return {};
  if (count) *count = changes_;
  return take();
}

std::vector<FileChange> Watcher::pending(std::uint64_t* count,
                                         std::chrono::milliseconds quiet) const {
  std::lock_guard lock(mutex_);
  if (count) *count = changes_;
  if (pending_.empty() || Clock::now() - burst_last_ < quiet) return {};
  return snapshot();
}

bool Watcher::wait_pending(std::chrono::milliseconds timeout, std::chrono::milliseconds quiet) {
  const auto deadline = Clock::now() + timeout;
  std::unique_lock lock(mutex_);
  for (;;) {
    const auto now = Clock::now();
    if (!pending_.empty() && now - burst_last_ >= quiet) return true;
    if (now >= deadline) return false;
    // An event wakes this; a burst in progress wakes it when its quiet time is over.
    cv_.wait_until(lock, pending_.empty() ? deadline : std::min(deadline, burst_last_ + quiet));
  }
}

std::uint64_t Watcher::change_count() const {
  std::lock_guard lock(mutex_);
  return changes_;
}

std::vector<fs::path> Watcher::poll() {
  std::vector<fs::path> out;
  for (auto& c : poll_changes()) out.push_back(std::move(c.path));
  return out;
}

std::vector<FileChange> Watcher::wait(std::chrono::milliseconds timeout, std::uint64_t* count) {
  const auto deadline = Clock::now() + timeout;
  std::unique_lock lock(mutex_);
  for (;;) {
    const auto now = Clock::now();
    if (ready(now)) {
      if (count) *count = changes_;
      return take();
    }
    if (now >= deadline) return {};
    // Wake at the end of the debounce window of a burst in progress, or at the deadline.
    auto until = deadline;
    if (!pending_.empty()) {
      until = std::min({until, burst_last_ + options_.debounce, burst_first_ + options_.max_delay});
    }
    cv_.wait_until(lock, until);
  }
}

std::vector<fs::path> Watcher::directories() const {
  std::lock_guard lock(mutex_);
  std::vector<fs::path> out;
  for (const auto& [wd, d] : directories_) out.push_back(d);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::uint64_t Watcher::events_seen() const {
  std::lock_guard lock(mutex_);
  return events_;
}

}  // namespace penumbra::runtime
