#pragma once

// A recursive file watcher for shader trees (Linux inotify).
//
//   runtime::Watcher w({shader_dir});          // the directory and every subdirectory
//   ...
//   for (const auto& path : w.poll()) ...      // between frames: never blocks
//
// The directories are watched (not the files) for IN_CLOSE_WRITE | IN_MOVED_TO | IN_MOVED_FROM |
// IN_CREATE | IN_DELETE, so an editor's atomic save (write a temporary file, rename it over the
// original) is seen as a change of the original, and a deleted file that is created again is
// seen again. Directories created later are watched as they appear.
//
// A background thread reads the events as they arrive and timestamps them (FileChange's
// first_seen is when the watcher saw the first event of the burst, not when it was polled).
// Bursts are coalesced: a batch is handed out once no event arrived for `debounce` (or once the
// burst has lasted `max_delay`, so a file that is rewritten continuously is still reloaded),
// each path once.
//
// A burst can be looked at before it is handed out (pending()), so a reload may compile while
// the burst settles. Every change the watcher records counts (change_count()): a batch handed
// out with the count a look at it gave holds no change made after that look, so what was read
// after the look is what the batch says.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace penumbra::runtime {

using Clock = std::chrono::steady_clock;

// The default quiet time that ends a burst: 15 ms, from the events of real saves watched on the
// CI machine under load (docs/hot-reload.md). Within one save the events of the file came at
// most 1.2 ms apart (vim's :w with its backup rename, sed -i's rename), and saving three files
// at once (vim's :argdo update, sed -i on three files) took under 5 ms. A burst split anyway is
// only a second reload: the files of a failed batch are passed again with the next.
inline constexpr std::chrono::milliseconds kDefaultDebounce{15};
// How long a burst must be quiet before a reload compiles it while it settles (Session): the
// events of one save, measured as above, came at most 1.2 ms apart, so a look after 2 ms of
// quiet rarely lands inside a save (a look that does only costs that early compile).
inline constexpr std::chrono::milliseconds kEarlyQuiet{2};

struct WatcherOptions {
  std::chrono::milliseconds debounce = kDefaultDebounce;  // quiet time that ends a burst
  std::chrono::milliseconds max_delay{500};  // a burst is handed out after this at the latest
  // Only files whose name ends in one of these are reported ("" or empty list: every file).
  // Editors' temporary and swap files (.swp, ~, 4913) are left out this way.
  std::vector<std::string> extensions{".glsl", ".comp", ".vert", ".frag", ".geom",
                                      ".tesc", ".tese", ".h",    ".inc"};
};

struct FileChange {
  std::filesystem::path path;  // the watched directory's weakly canonical path / name
  bool exists = true;          // false: deleted or renamed away (and not back) when polled
  Clock::time_point first_seen;
  Clock::time_point last_seen;
};

class Watcher {
 public:
  // Throws penumbra::Error naming the directory when a root is not a directory or inotify
  // fails.
  explicit Watcher(const std::vector<std::filesystem::path>& roots, WatcherOptions options = {});
  ~Watcher();
  Watcher(const Watcher&) = delete;
  Watcher& operator=(const Watcher&) = delete;

  // The files of the last finished burst, each once, sorted; empty when no burst is finished.
  // Never blocks.
  std::vector<std::filesystem::path> poll();
  // count: the change count as of the batch (change_count()), when one is handed out.
  std::vector<FileChange> poll_changes(std::uint64_t* count = nullptr);
  // Blocks until a burst is finished (then returns it, as poll_changes) or the timeout passes
  // (then returns an empty list).
  std::vector<FileChange> wait(std::chrono::milliseconds timeout, std::uint64_t* count = nullptr);

  // The burst in progress (or finished and not yet handed out), without taking it: each file
  // once, sorted, with whether it exists now; empty when none, or when its last event is more
  // recent than `quiet`. count: the change count as of this look. Never blocks.
  std::vector<FileChange> pending(std::uint64_t* count = nullptr,
                                  std::chrono::milliseconds quiet = {}) const;
  // Blocks until a burst has begun and been quiet for `quiet` (true) or the timeout passes
  // (false).
  bool wait_pending(std::chrono::milliseconds timeout, std::chrono::milliseconds quiet = {});
  // Changes recorded so far (every event of a reported file, and every file a new directory or
  // an overflow reported): it only grows.
  std::uint64_t change_count() const;

  // Also watches `dir` itself, not its subdirectories: the directory of a file read from outside
  // the roots (the target of a shader that is a symlink to a file elsewhere). Returns true when
  // it was not watched before; throws penumbra::Error naming it when inotify refuses.
  bool watch_directory(const std::filesystem::path& dir);

  // The directories watched now (weakly canonical), sorted.
  std::vector<std::filesystem::path> directories() const;
  // inotify events read so far (all of them, also those filtered out).
  std::uint64_t events_seen() const;
  const WatcherOptions& options() const { return options_; }

 private:
  struct Pending {
    Clock::time_point first, last;
  };
  void add_tree(const std::filesystem::path& dir, bool report_files);
  void add_directory(const std::filesystem::path& dir);
  void thread_main();
  void handle_buffer(const char* data, std::size_t size, Clock::time_point now);
  bool wanted(const std::string& name) const;
  bool ready(Clock::time_point now) const;
  std::vector<FileChange> take();
  std::vector<FileChange> snapshot() const;

  WatcherOptions options_;
  std::vector<std::filesystem::path> roots_;
  int inotify_fd_ = -1;
  int wake_fd_ = -1;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::map<int, std::filesystem::path> directories_;  // watch descriptor -> directory
  std::map<std::filesystem::path, Pending> pending_;
  Clock::time_point burst_first_{}, burst_last_{};
  std::uint64_t events_ = 0;
  std::uint64_t changes_ = 0;
  std::thread thread_;
};

}  // namespace penumbra::runtime
