#pragma once
// Quick pipelines now, optimized ones a little later: what a hot reload shows first.
//
// Creating a pipeline is most of a reload's cost on a GPU driver (an NVIDIA H100 takes 130-190 ms
// for the sun's shadow resolve). While a PipelineUpgrades::Scope lives on a thread, the compute
// and graphics pipelines made there are created with VK_PIPELINE_CREATE_DISABLE_OPTIMIZATION_BIT,
// which lets the driver skip its optimizations, and each is queued to be made again without the
// flag on a background thread. install_ready() swaps the optimized pipelines made so far into
// their objects (ComputePipeline::handle() then returns the optimized one); a pipeline object
// destroyed before its optimized twin is made (a newer reload replaced it) drops the twin.
//
// The background thread reads only what each job copied when its pipeline was made (the SPIR-V,
// the specialization, the create info) and the pipeline layout it was made with: stop() must run
// before those layouts are destroyed (the renderer stops it first thing in its destructor).
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <penumbra/gpu/context.hpp>
#include <string>
#include <thread>
#include <vector>

namespace penumbra::gpu {

class ComputePipeline;
class GraphicsPipeline;

namespace detail {
// One optimized pipeline to make, and the quick pipeline object it replaces.
struct UpgradeJob {
  std::function<VkPipeline()> make;  // reads only its copies (and the layout)
  VkDevice device = VK_NULL_HANDLE;
  std::mutex mutex;  // guards the targets and made
  ComputePipeline* compute = nullptr;    // null once that object is destroyed
  GraphicsPipeline* graphics = nullptr;  // (one of the two is set)
  VkPipeline made = VK_NULL_HANDLE;
  std::string error;
  bool done = false;

  bool alive();
  void forget();            // the target is being destroyed
  bool install();           // swaps `made` into the target (or destroys it); true when swapped
  ~UpgradeJob();
};
}  // namespace detail

class PipelineUpgrades {
 public:
  PipelineUpgrades() = default;
  ~PipelineUpgrades();
  PipelineUpgrades(const PipelineUpgrades&) = delete;
  PipelineUpgrades& operator=(const PipelineUpgrades&) = delete;

  // While it lives, pipelines made on this thread are made quickly and queued on `upgrades`
  // (null: made as usual). Scopes nest; each thread has its own.
  class Scope {
   public:
    explicit Scope(PipelineUpgrades* upgrades);
    ~Scope();
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    PipelineUpgrades* previous_;
  };
  // The queue the pipelines made on this thread go to (null: none, they are made optimized).
  static PipelineUpgrades* current();

  // Called by the pipelines (any thread).
  void enqueue(std::shared_ptr<detail::UpgradeJob> job);

  struct Installed {
    size_t swapped = 0;               // optimized pipelines now in use
    std::vector<std::string> errors;  // optimized builds that failed (the quick one stays)
  };
  // Swaps in every optimized pipeline made so far. Call where no pending command buffer uses the
  // quick ones (the renderer: at the start of a frame, its last frame waited for).
  Installed install_ready();
  // Jobs queued, being made, or made and not yet installed (their targets alive).
  bool pending();
  // Blocks until every queued job is made (they still need install_ready()); returns at once
  // while held.
  void wait();
  // Tests: while held, the background thread starts no job.
  void hold(bool held);
  // Finishes the job being made, drops the rest and joins the thread. Idempotent.
  void stop();

 private:
  void run();
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::shared_ptr<detail::UpgradeJob>> queue_;
  std::vector<std::shared_ptr<detail::UpgradeJob>> made_;
  size_t running_ = 0;
  bool held_ = false, stopping_ = false;
  std::thread thread_;
};

}  // namespace penumbra::gpu
