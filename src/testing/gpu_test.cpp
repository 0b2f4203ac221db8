#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <penumbra/testing/gpu_test.hpp>
#include <string>
#include <vector>

namespace penumbra::testing {
namespace {

std::unique_ptr<gpu::Context>& context_slot() {
  static std::unique_ptr<gpu::Context> ctx;
  return ctx;
}
std::vector<std::function<void()>>& teardown_callbacks() {
  static std::vector<std::function<void()>> callbacks;
  return callbacks;
}
std::mutex& context_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace

void before_shared_context_destroyed(std::function<void()> callback) {
  teardown_callbacks().push_back(std::move(callback));
}

gpu::Context& shared_context() {
  std::lock_guard lock(context_mutex());
  auto& slot = context_slot();
  if (!slot) {
    gpu::ContextOptions options;
    // Always on, except when PENUMBRA_VALIDATION=0 is set explicitly (benchmarks measuring
    // without the layer's overhead). CTest sets PENUMBRA_VALIDATION=1 for every test.
    const char* env = std::getenv("PENUMBRA_VALIDATION");
    options.validation = !(env != nullptr && std::string(env) == "0");
    // Debug printf on with validation, so that a tested function's debugPrintfEXT lines reach
    // ShaderFunction::printed() and failure reports; PENUMBRA_DEBUG_PRINTF=0 turns it off.
    const char* printf_env = std::getenv("PENUMBRA_DEBUG_PRINTF");
    options.debug_printf = !(printf_env != nullptr && std::string(printf_env) == "0");
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
  for (auto& callback : teardown_callbacks()) callback();
  teardown_callbacks().clear();
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
