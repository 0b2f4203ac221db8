#include <penumbra/gpu/pipeline.hpp>
#include <penumbra/gpu/pipeline_upgrades.hpp>

namespace penumbra::gpu {

namespace {
thread_local PipelineUpgrades* t_current = nullptr;
}

namespace detail {

bool UpgradeJob::alive() {
  std::lock_guard lock(mutex);
  return compute != nullptr || graphics != nullptr;
}

void UpgradeJob::forget() {
  std::lock_guard lock(mutex);
  compute = nullptr;
  graphics = nullptr;
}

bool UpgradeJob::install() {
  std::lock_guard lock(mutex);
  if (made == VK_NULL_HANDLE) return false;
  const VkPipeline p = made;
  made = VK_NULL_HANDLE;
  if (compute) {
    compute->adopt(p);
  } else if (graphics) {
    graphics->adopt(p);
  } else {
    vkDestroyPipeline(device, p, nullptr);
    return false;
  }
  compute = nullptr;  // done: the object no longer needs this job
  graphics = nullptr;
  return true;
}

UpgradeJob::~UpgradeJob() {
  if (made != VK_NULL_HANDLE) vkDestroyPipeline(device, made, nullptr);
}

}  // namespace detail

PipelineUpgrades::Scope::Scope(PipelineUpgrades* upgrades) : previous_(t_current) {
  t_current = upgrades;
}

PipelineUpgrades::Scope::~Scope() {
  t_current = previous_;
}

PipelineUpgrades* PipelineUpgrades::current() {
  return t_current;
}

PipelineUpgrades::~PipelineUpgrades() {
  stop();
}

void PipelineUpgrades::enqueue(std::shared_ptr<detail::UpgradeJob> job) {
  std::lock_guard lock(mutex_);
  if (stopping_) return;  // stopped: the quick pipeline stays
  queue_.push_back(std::move(job));
  if (!thread_.joinable()) thread_ = std::thread([this] { run(); });
  cv_.notify_all();
}

void PipelineUpgrades::run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    cv_.wait(lock, [this] { return stopping_ || (!held_ && !queue_.empty()); });
    if (stopping_) return;
    std::shared_ptr<detail::UpgradeJob> job = std::move(queue_.front());
    queue_.pop_front();
    if (!job->alive()) continue;  // replaced before its turn
    ++running_;
    lock.unlock();
    VkPipeline made = VK_NULL_HANDLE;
    std::string error;
    try {
      made = job->make();
    } catch (const std::exception& e) {
      error = e.what();
    }
    {
      std::lock_guard job_lock(job->mutex);
      job->made = made;
      job->error = std::move(error);
      job->done = true;
    }
    lock.lock();
    --running_;
    made_.push_back(std::move(job));
    cv_.notify_all();
  }
}

PipelineUpgrades::Installed PipelineUpgrades::install_ready() {
  std::vector<std::shared_ptr<detail::UpgradeJob>> made;
  {
    std::lock_guard lock(mutex_);
    made.swap(made_);
  }
  Installed out;
  for (const auto& job : made) {
    if (!job->error.empty()) out.errors.push_back(job->error);
    if (job->install()) ++out.swapped;
  }
  return out;
}

bool PipelineUpgrades::pending() {
  std::lock_guard lock(mutex_);
  if (running_ > 0) return true;
  for (const auto& job : queue_)
    if (job->alive()) return true;
  for (const auto& job : made_)
    if (job->alive()) return true;
  return false;
}

void PipelineUpgrades::wait() {
  std::unique_lock lock(mutex_);
  cv_.wait(lock, [this] {
    if (stopping_ || held_) return true;  // held: nothing would start
    if (running_ > 0) return false;
    for (const auto& job : queue_)
      if (job->alive()) return false;
    return true;
  });
}

void PipelineUpgrades::hold(bool held) {
  std::lock_guard lock(mutex_);
  held_ = held;
  cv_.notify_all();
}

void PipelineUpgrades::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    queue_.clear();
    cv_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
  std::lock_guard lock(mutex_);
  made_.clear();
}

}  // namespace penumbra::gpu
