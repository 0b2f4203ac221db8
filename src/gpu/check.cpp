#include <penumbra/core/error.hpp>
#include <penumbra/gpu/check.hpp>

namespace penumbra::gpu {

const char* result_name(VkResult result) {
  switch (result) {
#define PENUMBRA_RESULT(name) \
  case name:                  \
    return #name;
    PENUMBRA_RESULT(VK_SUCCESS)
    PENUMBRA_RESULT(VK_NOT_READY)
    PENUMBRA_RESULT(VK_TIMEOUT)
    PENUMBRA_RESULT(VK_INCOMPLETE)
    PENUMBRA_RESULT(VK_ERROR_OUT_OF_HOST_MEMORY)
    PENUMBRA_RESULT(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    PENUMBRA_RESULT(VK_ERROR_INITIALIZATION_FAILED)
    PENUMBRA_RESULT(VK_ERROR_DEVICE_LOST)
    PENUMBRA_RESULT(VK_ERROR_MEMORY_MAP_FAILED)
    PENUMBRA_RESULT(VK_ERROR_LAYER_NOT_PRESENT)
    PENUMBRA_RESULT(VK_ERROR_EXTENSION_NOT_PRESENT)
    PENUMBRA_RESULT(VK_ERROR_FEATURE_NOT_PRESENT)
    PENUMBRA_RESULT(VK_ERROR_INCOMPATIBLE_DRIVER)
    PENUMBRA_RESULT(VK_ERROR_TOO_MANY_OBJECTS)
    PENUMBRA_RESULT(VK_ERROR_FORMAT_NOT_SUPPORTED)
    PENUMBRA_RESULT(VK_ERROR_FRAGMENTED_POOL)
    PENUMBRA_RESULT(VK_ERROR_OUT_OF_POOL_MEMORY)
    PENUMBRA_RESULT(VK_ERROR_SURFACE_LOST_KHR)
    PENUMBRA_RESULT(VK_ERROR_OUT_OF_DATE_KHR)
    PENUMBRA_RESULT(VK_SUBOPTIMAL_KHR)
#undef PENUMBRA_RESULT
    default:
      return "VK_RESULT_UNKNOWN";
  }
}

void check(VkResult result, const char* what) {
  if (result != VK_SUCCESS) {
    throw Error(std::string(what) + " failed: " + result_name(result) + " (" +
                std::to_string(static_cast<int>(result)) + ")");
  }
}

}  // namespace penumbra::gpu
