#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <penumbra/gpu/validation.hpp>
#include <string>
#include <vector>

namespace penumbra::gpu {

struct ContextOptions {
  // Which physical device: "lavapipe" (Mesa's CPU driver), "gpu" (first non-CPU device), a
  // decimal index into vkEnumeratePhysicalDevices, or a case-insensitive name substring.
  // Empty: read PENUMBRA_DEVICE; if unset, a discrete GPU when present, else lavapipe.
  std::string device;
  // Khronos validation layer. Unset: on when PENUMBRA_VALIDATION=1.
  std::optional<bool> validation;
  // Print the device report to stderr when the context is created.
  bool print_report = false;
  // Extra instance / device extensions (a window: glfwGetRequiredInstanceExtensions and
  // VK_KHR_swapchain). Context creation fails naming them when one is missing.
  std::vector<std::string> instance_extensions;
  std::vector<std::string> device_extensions;
  // Robust access: VK_EXT_robustness2's robustBufferAccess2 and robustImageAccess2 (with
  // robustBufferAccess), so that out-of-bounds buffer and image accesses read zeros and drop
  // writes the same way on every device. Context creation fails naming what the device lacks.
  // Unset: on when PENUMBRA_ROBUST_ACCESS=1.
  std::optional<bool> robust_access;
  // The validation layer's debug printf (GL_EXT_debug_printf in shaders), verbose, so that each
  // message names the invocation that printed it; the messages go to
  // ValidationSink::take_printf(), not to the validation messages. Needs validation on; ignored
  // without it. Unset: on when PENUMBRA_DEBUG_PRINTF=1.
  std::optional<bool> debug_printf;
};

struct DeviceInfo {
  uint32_t index = 0;  // position in vkEnumeratePhysicalDevices
  std::string name;
  std::string driver_name;  // VkPhysicalDeviceDriverProperties::driverName
  std::string driver_info;
  VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;
  uint32_t api_version = 0;
  uint32_t driver_version = 0;
  uint32_t vendor_id = 0;
  bool is_cpu = false;  // lavapipe or another software rasterizer
  VkPhysicalDeviceLimits limits{};
  uint32_t queue_family = 0;
  uint32_t timestamp_valid_bits = 0;
  bool depth_clamp = false;
  bool image_cube_array = false;  // imageCubeArray: cube-map arrays (enabled when supported)
  bool linear_filter_d32 = false;  // VK_FORMAT_D32_SFLOAT supports linear filtering
  // shaderStorageImageExtendedFormats (rg16f, rg32f storage images; enabled when supported)
  bool storage_image_extended_formats = false;
  // shaderStorageImageReadWithoutFormat: imageLoad of a format-less image (enabled when supported)
  bool storage_read_without_format = false;
  bool robustness2 = false;    // VK_EXT_robustness2 with robustBufferAccess2 and robustImageAccess2
  bool robust_access = false;  // ... and this context enabled them (ContextOptions::robust_access)
};

std::string to_string(VkPhysicalDeviceType type);
std::string api_version_string(uint32_t version);

// Instance, one physical device, one logical device with one graphics+compute queue, a
// command pool, and (optionally) the validation layer with its message sink.
class Context {
 public:
  explicit Context(const ContextOptions& options = {});
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  VkInstance instance() const { return instance_; }
  VkPhysicalDevice physical_device() const { return physical_device_; }
  VkDevice device() const { return device_; }
  VkQueue queue() const { return queue_; }
  VkCommandPool command_pool() const { return command_pool_; }
  const DeviceInfo& info() const { return info_; }
  bool validation_enabled() const { return validation_; }
  // Shader debug printf reaches validation_sink().take_printf() (ContextOptions::debug_printf).
  bool debug_printf_enabled() const { return debug_printf_; }
  // ... and its messages name the invocation that printed (not when VK_LAYER_SETTINGS_PATH
  // pointed the layer at the user's own settings).
  bool debug_printf_verbose() const { return debug_printf_verbose_; }
  ValidationSink& validation_sink() { return sink_; }

  // Multi-line report: device, type, driver, API version, key limits, validation state.
  std::string report() const;

  // Memory type index with the given bits and properties; throws when none matches.
  uint32_t memory_type(uint32_t type_bits, VkMemoryPropertyFlags properties) const;
  bool has_memory_type(uint32_t type_bits, VkMemoryPropertyFlags properties) const;

  // Enumerates the physical devices the loader sees ("index: name (type, driver)").
  static std::string list_devices();

 private:
  void destroy();

  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_device_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  VkCommandPool command_pool_ = VK_NULL_HANDLE;
  VkPhysicalDeviceMemoryProperties memory_{};
  DeviceInfo info_;
  bool validation_ = false;
  bool debug_printf_ = false;
  bool debug_printf_verbose_ = false;
  ValidationSink sink_;
};

// Sets MESA_SHADER_CACHE_DIR to the build tree's cache unless the environment already names one
// (or disables the cache with MESA_SHADER_CACHE_DISABLE=true). Called by Context's constructor.
void configure_mesa_cache();

}  // namespace penumbra::gpu
