#include <cmath>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/check.hpp>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/gpu/gpu_lock.hpp>

namespace penumbra::gpu {

void submit_one_shot(Context& ctx, const std::function<void(VkCommandBuffer)>& record) {
  CommandRecorder recorder(ctx);
  record(recorder.begin());
  recorder.submit_and_wait();
}

void full_barrier(VkCommandBuffer cmd) {
  VkMemoryBarrier2 barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  barrier.srcStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  barrier.srcAccessMask = VK_ACCESS_2_MEMORY_WRITE_BIT;
  barrier.dstStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  barrier.dstAccessMask = VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT;
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.memoryBarrierCount = 1;
  dep.pMemoryBarriers = &barrier;
  vkCmdPipelineBarrier2(cmd, &dep);
}

CommandRecorder::CommandRecorder(Context& ctx) : ctx_(ctx) {
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = ctx.command_pool();
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  check(vkAllocateCommandBuffers(ctx.device(), &ai, &cmd_), "vkAllocateCommandBuffers");
  VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  if (VkResult r = vkCreateFence(ctx.device(), &fi, nullptr, &fence_); r != VK_SUCCESS) {
    vkFreeCommandBuffers(ctx.device(), ctx.command_pool(), 1, &cmd_);
    check(r, "vkCreateFence");
  }
}

CommandRecorder::~CommandRecorder() {
  vkDestroyFence(ctx_.device(), fence_, nullptr);
  vkFreeCommandBuffers(ctx_.device(), ctx_.command_pool(), 1, &cmd_);
}

VkCommandBuffer CommandRecorder::begin() {
  check(vkResetCommandBuffer(cmd_, 0), "vkResetCommandBuffer");
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(cmd_, &bi), "vkBeginCommandBuffer");
  return cmd_;
}

void CommandRecorder::submit_and_wait() {
  submit_and_wait({});
}

void CommandRecorder::submit_and_wait(const std::function<void()>& while_waiting) {
  check(vkEndCommandBuffer(cmd_), "vkEndCommandBuffer");
  VkCommandBufferSubmitInfo cbi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
  cbi.commandBuffer = cmd_;
  VkSubmitInfo2 si{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
  si.commandBufferInfoCount = 1;
  si.pCommandBufferInfos = &cbi;
  check(vkResetFences(ctx_.device(), 1, &fence_), "vkResetFences");
  const SharedGpu shared;  // another process timing its frames waits (PENUMBRA_GPU_LOCK)
  check(vkQueueSubmit2(ctx_.queue(), 1, &si, fence_), "vkQueueSubmit2");
  if (!while_waiting) {
    check(vkWaitForFences(ctx_.device(), 1, &fence_, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    return;
  }
  constexpr uint64_t kPollNs = 2'000'000;
  for (;;) {
    while_waiting();
    const VkResult r = vkWaitForFences(ctx_.device(), 1, &fence_, VK_TRUE, kPollNs);
    if (r == VK_SUCCESS) return;
    if (r != VK_TIMEOUT) check(r, "vkWaitForFences");
  }
}

TimestampPool::TimestampPool(Context& ctx, uint32_t capacity) : ctx_(ctx), capacity_(capacity) {
  if (ctx.info().timestamp_valid_bits == 0) {
    throw Error("device " + ctx.info().name + " has no timestamp support on its queue");
  }
  VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
  qi.queryCount = capacity;
  check(vkCreateQueryPool(ctx.device(), &qi, nullptr, &pool_), "vkCreateQueryPool");
}

TimestampPool::~TimestampPool() {
  vkDestroyQueryPool(ctx_.device(), pool_, nullptr);
}

void TimestampPool::reset(VkCommandBuffer cmd) {
  vkCmdResetQueryPool(cmd, pool_, 0, capacity_);
}

void TimestampPool::write(VkCommandBuffer cmd, uint32_t index, VkPipelineStageFlags2 stage) {
  if (index >= capacity_) {
    throw Error("timestamp index " + std::to_string(index) + " out of range (capacity " +
                std::to_string(capacity_) + ")");
  }
  vkCmdWriteTimestamp2(cmd, stage, pool_, index);
}

std::vector<double> TimestampPool::read_ns(uint32_t count) {
  std::vector<uint64_t> ticks(count);
  check(vkGetQueryPoolResults(ctx_.device(), pool_, 0, count, ticks.size() * sizeof(uint64_t),
                              ticks.data(), sizeof(uint64_t),
                              VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
        "vkGetQueryPoolResults");
  const uint32_t bits = ctx_.info().timestamp_valid_bits;
  const uint64_t mask = bits >= 64 ? ~uint64_t{0} : ((uint64_t{1} << bits) - 1);
  const double period = ctx_.info().limits.timestampPeriod;
  std::vector<double> ns(count);
  for (uint32_t i = 0; i < count; ++i) ns[i] = static_cast<double>(ticks[i] & mask) * period;
  return ns;
}

double TimestampPool::elapsed_ns(uint32_t begin, uint32_t end) {
  const auto ns = read_ns(std::max(begin, end) + 1);
  return ns[end] - ns[begin];
}

}  // namespace penumbra::gpu
