#include <gtest/gtest.h>

#include <penumbra/testing/gpu_test.hpp>

// main() for Penumbra test binaries: registers the environment that owns the shared GPU context.
int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ::testing::AddGlobalTestEnvironment(new penumbra::testing::GpuEnvironment);
  return RUN_ALL_TESTS();
}
