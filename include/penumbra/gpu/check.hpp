#pragma once

#include <vulkan/vulkan.h>

#include <string>

namespace penumbra::gpu {

// Name of a VkResult ("VK_ERROR_OUT_OF_DEVICE_MEMORY").
const char* result_name(VkResult result);

// Throws penumbra::Error("<what> failed: <VkResult name>") when result is not VK_SUCCESS.
void check(VkResult result, const char* what);

}  // namespace penumbra::gpu
