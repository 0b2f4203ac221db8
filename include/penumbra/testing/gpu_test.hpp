#pragma once

#include <gtest/gtest.h>

#include <functional>
#include <penumbra/gpu/context.hpp>

namespace penumbra::testing {

// The one Vulkan context of a test process, created on first use with the Khronos validation
// layer on (unless PENUMBRA_VALIDATION=0 is set explicitly, for benchmarks) and the device
// PENUMBRA_DEVICE picks.
gpu::Context& shared_context();

// Registers a callback run before the shared context is destroyed (to release cached GPU
// objects that belong to its device).
void before_shared_context_destroyed(std::function<void()> callback);

// Takes every validation message collected so far and reports each as a gtest failure.
// Returns how many there were.
size_t fail_on_validation_messages(gpu::Context& ctx);

// Base fixture for GPU tests: any validation warning or error produced while the test ran (or
// left over from before it) fails the test.
class GpuTest : public ::testing::Test {
 protected:
  void TearDown() override { fail_on_validation_messages(ctx()); }
  static gpu::Context& ctx() { return shared_context(); }
};

// Registered by penumbra::testing_main: destroys the shared context after the last test and
// fails the run if the teardown itself produced validation messages.
class GpuEnvironment : public ::testing::Environment {
 public:
  void TearDown() override;
};

}  // namespace penumbra::testing
