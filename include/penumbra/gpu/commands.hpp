#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <functional>
#include <penumbra/gpu/context.hpp>
#include <vector>

namespace penumbra::gpu {

// Records into a fresh primary command buffer, submits it to the context's queue and waits.
void submit_one_shot(Context& ctx, const std::function<void(VkCommandBuffer)>& record);

// A full memory barrier (all commands, all memory) — for tests and one-shot work.
void full_barrier(VkCommandBuffer cmd);

// A reusable primary command buffer and fence: record, submit, wait.
class CommandRecorder {
 public:
  explicit CommandRecorder(Context& ctx);
  ~CommandRecorder();
  CommandRecorder(const CommandRecorder&) = delete;
  CommandRecorder& operator=(const CommandRecorder&) = delete;

  VkCommandBuffer begin();  // resets and begins
  void submit_and_wait();   // ends, submits, waits on the fence
  // The same, calling while_waiting right after the submit and then every couple of
  // milliseconds until the fence signals (work for the CPU while the GPU runs the commands: a
  // hot reload's compile).
  void submit_and_wait(const std::function<void()>& while_waiting);
  VkCommandBuffer handle() const { return cmd_; }

 private:
  Context& ctx_;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
};

// Timestamp queries reported in nanoseconds (timestampPeriod applied, valid bits masked).
class TimestampPool {
 public:
  TimestampPool(Context& ctx, uint32_t capacity);
  ~TimestampPool();
  TimestampPool(const TimestampPool&) = delete;
  TimestampPool& operator=(const TimestampPool&) = delete;

  void reset(VkCommandBuffer cmd);  // resets every query; record before the first write
  void write(VkCommandBuffer cmd, uint32_t index,
             VkPipelineStageFlags2 stage = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT);
  // Raw tick values of queries [0, count) converted to nanoseconds; waits for availability.
  std::vector<double> read_ns(uint32_t count);
  // Nanoseconds between two queries written in the same submission.
  double elapsed_ns(uint32_t begin, uint32_t end);
  uint32_t capacity() const { return capacity_; }

 private:
  Context& ctx_;
  VkQueryPool pool_ = VK_NULL_HANDLE;
  uint32_t capacity_ = 0;
};

}  // namespace penumbra::gpu
