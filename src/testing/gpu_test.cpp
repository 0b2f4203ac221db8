#include <penumbra/testing/gpu_test.hpp>

#include <cstdio>
#include <memory>
#include <mutex>

namespace penumbra::testing {
namespace {

std::unique_ptr<gpu::Context>& context_slot() {
  static std::unique_ptr<gpu::Context> ctx;
  return ctx;
}
std::mutex& context_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace

gpu::Context& shared_context() {
  std::lock_guard lock(context_mutex());
  auto& slot = context_slot();
  if (!slot) {
    gpu::ContextOptions options;
    options.validation = true;
    slot = std::make_unique<gpu::Context>(options);
    std::fprintf(stderr, "%s", slot->report().c_str());
  }
  return *slot;
}

size_t fail_on_validation_messages(gpu::Context& ctx) {
  const auto messages = ctx.validation_sink().take();
  for (const auto& m : messages) ADD_FAILURE() << gpu::to_string(m);
  return messages.size();
}

void GpuEnvironment::TearDown() {
  std::lock_guard lock(context_mutex());
  auto& slot = context_slot();
  if (!slot) return;
  // Messages produced by destroying the device cannot reach the sink after the instance is
  // gone, but everything up to vkDestroyDevice does.
  auto messages = slot->validation_sink().take();
  slot.reset();
  for (const auto& m : messages) ADD_FAILURE() << "at teardown: " << gpu::to_string(m);
}

}  // namespace penumbra::testing
