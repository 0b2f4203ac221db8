#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/check.hpp>
#include <penumbra/gpu/context.hpp>
#include <sstream>
#include <vector>

namespace penumbra::gpu {
namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string env_or(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return (v != nullptr && *v != '\0') ? std::string(v) : fallback;
}

VKAPI_ATTR VkBool32 VKAPI_CALL debug_callback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                              VkDebugUtilsMessageTypeFlagsEXT /*types*/,
                                              const VkDebugUtilsMessengerCallbackDataEXT* data,
                                              void* user) {
  auto* sink = static_cast<ValidationSink*>(user);
  ValidationMessage m;
  m.severity = (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) != 0 ? Severity::error
               : (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) != 0
                   ? Severity::warning
               : (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_INFO_BIT_EXT) != 0 ? Severity::info
                                                                                : Severity::verbose;
  m.id = data->pMessageIdName != nullptr ? data->pMessageIdName : "";
  m.message = data->pMessage != nullptr ? data->pMessage : "";
  if (m.id == "UNASSIGNED-DEBUG-PRINTF") {  // a shader's debugPrintfEXT, not a finding
    sink->push_printf(std::move(m.message));
    return VK_FALSE;
  }
  if (m.severity == Severity::warning || m.severity == Severity::error) {
    if (std::getenv("PENUMBRA_VALIDATION_QUIET") == nullptr) {
      std::fprintf(stderr, "%s\n", to_string(m).c_str());
    }
    sink->push(std::move(m));
  }
  return VK_FALSE;
}

bool layer_available(const char* name) {
  uint32_t count = 0;
  vkEnumerateInstanceLayerProperties(&count, nullptr);
  std::vector<VkLayerProperties> layers(count);
  vkEnumerateInstanceLayerProperties(&count, layers.data());
  return std::any_of(layers.begin(), layers.end(), [&](const VkLayerProperties& l) {
    return std::strcmp(l.layerName, name) == 0;
  });
}

struct Candidate {
  VkPhysicalDevice handle;
  DeviceInfo info;
};

DeviceInfo describe(VkPhysicalDevice pd, uint32_t index) {
  VkPhysicalDeviceDriverProperties driver{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
  VkPhysicalDeviceProperties2 props{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &driver};
  vkGetPhysicalDeviceProperties2(pd, &props);
  DeviceInfo info;
  info.index = index;
  info.name = props.properties.deviceName;
  info.driver_name = driver.driverName;
  info.driver_info = driver.driverInfo;
  info.type = props.properties.deviceType;
  info.api_version = props.properties.apiVersion;
  info.driver_version = props.properties.driverVersion;
  info.vendor_id = props.properties.vendorID;
  info.limits = props.properties.limits;
  info.is_cpu = info.type == VK_PHYSICAL_DEVICE_TYPE_CPU;
  VkPhysicalDeviceFeatures features{};
  vkGetPhysicalDeviceFeatures(pd, &features);
  info.depth_clamp = features.depthClamp == VK_TRUE;
  info.image_cube_array = features.imageCubeArray == VK_TRUE;
  info.storage_image_extended_formats = features.shaderStorageImageExtendedFormats == VK_TRUE;
  info.storage_read_without_format = features.shaderStorageImageReadWithoutFormat == VK_TRUE;
  {
    uint32_t n = 0;
    vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, nullptr);
    std::vector<VkExtensionProperties> exts(n);
    vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, exts.data());
    const bool has = std::any_of(exts.begin(), exts.end(), [](const VkExtensionProperties& e) {
      return std::string(e.extensionName) == VK_EXT_ROBUSTNESS_2_EXTENSION_NAME;
    });
    if (has) {
      VkPhysicalDeviceRobustness2FeaturesEXT r2{
          VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ROBUSTNESS_2_FEATURES_EXT};
      VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &r2};
      vkGetPhysicalDeviceFeatures2(pd, &f2);
      info.robustness2 = r2.robustBufferAccess2 == VK_TRUE && r2.robustImageAccess2 == VK_TRUE &&
                         features.robustBufferAccess == VK_TRUE;
    }
  }
  VkFormatProperties fp{};
  vkGetPhysicalDeviceFormatProperties(pd, VK_FORMAT_D32_SFLOAT, &fp);
  info.linear_filter_d32 =
      (fp.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT) != 0;

  uint32_t qcount = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &qcount, nullptr);
  std::vector<VkQueueFamilyProperties> families(qcount);
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &qcount, families.data());
  info.queue_family = UINT32_MAX;
  for (uint32_t i = 0; i < qcount; ++i) {
    const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
    if ((families[i].queueFlags & need) == need) {
      info.queue_family = i;
      info.timestamp_valid_bits = families[i].timestampValidBits;
      break;
    }
  }
  return info;
}

std::vector<Candidate> enumerate(VkInstance instance) {
  uint32_t count = 0;
  check(vkEnumeratePhysicalDevices(instance, &count, nullptr), "vkEnumeratePhysicalDevices");
  std::vector<VkPhysicalDevice> devices(count);
  check(vkEnumeratePhysicalDevices(instance, &count, devices.data()), "vkEnumeratePhysicalDevices");
  std::vector<Candidate> out;
  for (uint32_t i = 0; i < count; ++i) out.push_back({devices[i], describe(devices[i], i)});
  return out;
}

std::string describe_line(const DeviceInfo& d) {
  return std::to_string(d.index) + ": " + d.name + " (" + to_string(d.type) + ", " + d.driver_name +
         ")";
}

const Candidate& choose(const std::vector<Candidate>& all, const std::string& selector) {
  auto usable = [](const Candidate& c) { return c.info.queue_family != UINT32_MAX; };
  std::string available;
  for (const auto& c : all) available += "\n  " + describe_line(c.info);
  if (all.empty())
    throw Error("no Vulkan physical device found (is mesa-vulkan-drivers installed?)");

  const std::string sel = lower(selector);
  const Candidate* pick = nullptr;
  if (sel.empty()) {
    for (const auto& c : all)
      if (usable(c) && c.info.type == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU && !pick) pick = &c;
    for (const auto& c : all)
      if (usable(c) && lower(c.info.driver_name).find("llvmpipe") != std::string::npos && !pick)
        pick = &c;
    for (const auto& c : all)
      if (usable(c) && c.info.is_cpu && !pick) pick = &c;
    for (const auto& c : all)
      if (usable(c) && !pick) pick = &c;
  } else if (sel == "lavapipe" || sel == "llvmpipe" || sel == "cpu") {
    for (const auto& c : all)
      if (usable(c) && c.info.is_cpu && !pick) pick = &c;
  } else if (sel == "gpu") {
    for (const auto& c : all)
      if (usable(c) && c.info.type == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU && !pick) pick = &c;
    for (const auto& c : all)
      if (usable(c) && !c.info.is_cpu && !pick) pick = &c;
  } else if (std::all_of(sel.begin(), sel.end(),
                         [](unsigned char ch) { return std::isdigit(ch); })) {
    const unsigned long idx = std::stoul(sel);
    if (idx < all.size() && usable(all[idx])) pick = &all[idx];
  } else {
    for (const auto& c : all)
      if (usable(c) && lower(c.info.name).find(sel) != std::string::npos && !pick) pick = &c;
  }
  if (pick == nullptr) {
    throw Error("PENUMBRA_DEVICE=\"" + selector +
                "\" matches no usable Vulkan device (expected lavapipe, gpu, an index or a name "
                "substring). Available:" +
                available);
  }
  return *pick;
}

}  // namespace

std::string to_string(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return "CPU";
    default:
      return "other";
  }
}

std::string api_version_string(uint32_t v) {
  return std::to_string(VK_API_VERSION_MAJOR(v)) + "." + std::to_string(VK_API_VERSION_MINOR(v)) +
         "." + std::to_string(VK_API_VERSION_PATCH(v));
}

// Mesa's shader cache is where MESA_SHADER_CACHE_DIR says (CTest points it into the build tree)
// or Mesa's own default: the library sets nothing of its own.
Context::Context(const ContextOptions& options) {
  validation_ = options.validation.value_or(env_or("PENUMBRA_VALIDATION", "0") == "1");

  uint32_t loader_version = VK_API_VERSION_1_0;
  vkEnumerateInstanceVersion(&loader_version);
  if (loader_version < VK_API_VERSION_1_3) {
    throw Error("the Vulkan loader supports only " + api_version_string(loader_version) +
                "; Penumbra needs 1.3");
  }

  std::vector<const char*> layers;
  std::vector<const char*> extensions;
  if (validation_) {
    if (!layer_available(kValidationLayer)) {
      throw Error(std::string(kValidationLayer) +
                  " was requested but is not installed (apt-get install vulkan-validationlayers)");
    }
    layers.push_back(kValidationLayer);
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  }
  for (const auto& e : options.instance_extensions) extensions.push_back(e.c_str());

  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "penumbra";
  app.pEngineName = "penumbra";
  app.apiVersion = VK_API_VERSION_1_3;

  VkDebugUtilsMessengerCreateInfoEXT messenger_info{
      VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
  messenger_info.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                                   VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  messenger_info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  messenger_info.pfnUserCallback = debug_callback;
  messenger_info.pUserData = &sink_;

  // Debug printf: the layer instruments shaders that print and reports each message (at info
  // severity) with the invocation that printed it (verbose).
  if (validation_) {
    if (options.debug_printf.has_value()) {
      debug_printf_ = *options.debug_printf;
    } else if (const char* env = std::getenv("PENUMBRA_DEBUG_PRINTF")) {
      debug_printf_ = std::string(env) == "1";
    }
  }
  const VkValidationFeatureEnableEXT printf_feature = VK_VALIDATION_FEATURE_ENABLE_DEBUG_PRINTF_EXT;
  VkValidationFeaturesEXT validation_features{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
  if (debug_printf_) {
    messenger_info.messageSeverity |= VK_DEBUG_UTILS_MESSAGE_SEVERITY_INFO_BIT_EXT;
    validation_features.enabledValidationFeatureCount = 1;
    validation_features.pEnabledValidationFeatures = &printf_feature;
    validation_features.pNext = &messenger_info;
  }

  // Verbose printf (each message names its invocation) is a layer setting, read from a settings
  // file at vkCreateInstance: a private one, unless the user points the layer at their own.
  std::filesystem::path settings_dir;
  if (debug_printf_ && std::getenv("VK_LAYER_SETTINGS_PATH") == nullptr) {
    std::string tmpl = (std::filesystem::temp_directory_path() / "penumbra-layer.XXXXXX").string();
    if (mkdtemp(tmpl.data()) != nullptr) {
      settings_dir = tmpl;
      std::ofstream(settings_dir / "vk_layer_settings.txt")
          << "khronos_validation.printf_verbose = true\n"
          // Room for ~25,000 short lines per dispatch (the default, 1 KiB, holds ~25); the layer
          // says when a dispatch printed more.
          << "khronos_validation.printf_buffer_size = 1048576\n";
      setenv("VK_LAYER_SETTINGS_PATH", settings_dir.c_str(), 1);
      debug_printf_verbose_ = true;
    }
  }
  struct RemoveSettings {
    const std::filesystem::path& dir;
    ~RemoveSettings() {
      if (dir.empty()) return;
      unsetenv("VK_LAYER_SETTINGS_PATH");
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  } remove_settings{settings_dir};

  VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  // The messenger also catches create/destroy messages.
  ici.pNext = debug_printf_ ? static_cast<const void*>(&validation_features)
              : validation_ ? static_cast<const void*>(&messenger_info)
                            : nullptr;
  ici.pApplicationInfo = &app;
  ici.enabledLayerCount = static_cast<uint32_t>(layers.size());
  ici.ppEnabledLayerNames = layers.data();
  ici.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  ici.ppEnabledExtensionNames = extensions.data();
  check(vkCreateInstance(&ici, nullptr, &instance_), "vkCreateInstance");

  try {
    if (validation_) {
      auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
          vkGetInstanceProcAddr(instance_, "vkCreateDebugUtilsMessengerEXT"));
      check(create(instance_, &messenger_info, nullptr, &messenger_),
            "vkCreateDebugUtilsMessengerEXT");
    }

    const auto candidates = enumerate(instance_);
    const std::string selector =
        options.device.empty() ? env_or("PENUMBRA_DEVICE", "") : options.device;
    const Candidate& chosen = choose(candidates, selector);
    physical_device_ = chosen.handle;
    info_ = chosen.info;
    if (info_.api_version < VK_API_VERSION_1_3) {
      throw Error("device " + info_.name + " supports Vulkan " +
                  api_version_string(info_.api_version) + "; Penumbra needs 1.3");
    }
    vkGetPhysicalDeviceMemoryProperties(physical_device_, &memory_);

    // Features: ask for what the renderer uses when the device has it.
    VkPhysicalDeviceFeatures supported{};
    vkGetPhysicalDeviceFeatures(physical_device_, &supported);
    VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
    f13.dynamicRendering = VK_TRUE;
    f13.synchronization2 = VK_TRUE;
    VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
    f12.pNext = &f13;
    f12.hostQueryReset = VK_TRUE;
    f12.scalarBlockLayout = VK_FALSE;
    VkPhysicalDeviceFeatures2 features{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &f12};
    features.features.depthClamp = supported.depthClamp;
    features.features.depthBiasClamp = supported.depthBiasClamp;
    features.features.shaderStorageImageWriteWithoutFormat =
        supported.shaderStorageImageWriteWithoutFormat;
    features.features.shaderInt64 = supported.shaderInt64;
    features.features.shaderFloat64 = supported.shaderFloat64;
    features.features.fragmentStoresAndAtomics = supported.fragmentStoresAndAtomics;
    features.features.imageCubeArray = supported.imageCubeArray;
    // Mask textures are an array indexed by a push constant (shaders/render/alpha_mask.glsl).
    features.features.shaderSampledImageArrayDynamicIndexing =
        supported.shaderSampledImageArrayDynamicIndexing;
    // The sun's EVSM moments are rg16f / rg32f storage images (shaders/render/evsm_moments.comp).
    features.features.shaderStorageImageExtendedFormats =
        supported.shaderStorageImageExtendedFormats;
    // Shader-function tests of code that reads a format-less storage image parameter.
    features.features.shaderStorageImageReadWithoutFormat =
        supported.shaderStorageImageReadWithoutFormat;
    std::vector<std::string> extra_extensions;
    VkPhysicalDeviceRobustness2FeaturesEXT r2{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ROBUSTNESS_2_FEATURES_EXT};
    bool robust = false;
    if (options.robust_access.has_value()) {
      robust = *options.robust_access;
    } else if (const char* env = std::getenv("PENUMBRA_ROBUST_ACCESS")) {
      robust = std::string(env) == "1";
    }
    if (robust) {
      if (!info_.robustness2) {
        throw Error("robust access (ContextOptions::robust_access or PENUMBRA_ROBUST_ACCESS=1): "
                    "device " + info_.name + " has no VK_EXT_robustness2 with robustBufferAccess2 "
                    "and robustImageAccess2");
      }
      features.features.robustBufferAccess = VK_TRUE;
      r2.robustBufferAccess2 = VK_TRUE;
      r2.robustImageAccess2 = VK_TRUE;
      r2.pNext = features.pNext;
      features.pNext = &r2;
      extra_extensions.push_back(VK_EXT_ROBUSTNESS_2_EXTENSION_NAME);
      info_.robust_access = true;
    }

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    qci.queueFamilyIndex = info_.queue_family;
    qci.queueCount = 1;
    qci.pQueuePriorities = &priority;
    VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, &features};
    dci.queueCreateInfoCount = 1;
    dci.pQueueCreateInfos = &qci;
    std::vector<const char*> device_extensions;
    for (const auto& e : options.device_extensions) device_extensions.push_back(e.c_str());
    for (const auto& e : extra_extensions) device_extensions.push_back(e.c_str());
    dci.enabledExtensionCount = static_cast<uint32_t>(device_extensions.size());
    dci.ppEnabledExtensionNames = device_extensions.data();
    check(vkCreateDevice(physical_device_, &dci, nullptr, &device_), "vkCreateDevice");
    vkGetDeviceQueue(device_, info_.queue_family, 0, &queue_);

    VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pci.queueFamilyIndex = info_.queue_family;
    check(vkCreateCommandPool(device_, &pci, nullptr, &command_pool_), "vkCreateCommandPool");
  } catch (...) {
    destroy();
    throw;
  }
  if (options.print_report) std::fprintf(stderr, "%s", report().c_str());
}

Context::~Context() {
  destroy();
}

void Context::destroy() {
  if (device_ != VK_NULL_HANDLE) {
    vkDeviceWaitIdle(device_);
    if (command_pool_ != VK_NULL_HANDLE) vkDestroyCommandPool(device_, command_pool_, nullptr);
    vkDestroyDevice(device_, nullptr);
    device_ = VK_NULL_HANDLE;
    command_pool_ = VK_NULL_HANDLE;
  }
  if (messenger_ != VK_NULL_HANDLE) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
    destroy(instance_, messenger_, nullptr);
    messenger_ = VK_NULL_HANDLE;
  }
  if (instance_ != VK_NULL_HANDLE) {
    vkDestroyInstance(instance_, nullptr);
    instance_ = VK_NULL_HANDLE;
  }
}

std::string Context::report() const {
  std::ostringstream s;
  const auto& l = info_.limits;
  s << "device:      " << info_.name << " (" << to_string(info_.type) << ", index " << info_.index
    << ")\n"
    << "driver:      " << info_.driver_name << " " << info_.driver_info << "\n"
    << "api:         Vulkan " << api_version_string(info_.api_version) << "\n"
    << "validation:  " << (validation_ ? "on (VK_LAYER_KHRONOS_validation)" : "off") << "\n"
    << "timestamps:  period " << l.timestampPeriod << " ns, " << info_.timestamp_valid_bits
    << " valid bits\n"
    << "precision:   subTexel " << l.subTexelPrecisionBits << " bits, mipmap "
    << l.mipmapPrecisionBits << " bits, viewportSubPixel " << l.viewportSubPixelBits << " bits\n"
    << "compute:     max workgroup invocations " << l.maxComputeWorkGroupInvocations
    << ", max group count x " << l.maxComputeWorkGroupCount[0] << "\n"
    << "features:    depthClamp " << (info_.depth_clamp ? "yes" : "no") << ", D32 linear filter "
    << (info_.linear_filter_d32 ? "yes" : "no") << ", storage read without format "
    << (info_.storage_read_without_format ? "yes" : "no") << "\n"
    << "robustness:  "
    << (info_.robust_access ? "on (robustBufferAccess2, robustImageAccess2)"
        : info_.robustness2 ? "off (available: PENUMBRA_ROBUST_ACCESS=1)"
                            : "off (no VK_EXT_robustness2)")
    << "\n";
  const char* cache = std::getenv("MESA_SHADER_CACHE_DIR");
  const char* disabled = std::getenv("MESA_SHADER_CACHE_DISABLE");
  if (info_.is_cpu) {
    s << "mesa cache:  "
      << ((disabled != nullptr && std::string(disabled) == "true")
              ? std::string("disabled")
              : std::string(cache ? cache : "default"))
      << "\n";
  }
  return s.str();
}

bool Context::has_memory_type(uint32_t type_bits, VkMemoryPropertyFlags properties) const {
  for (uint32_t i = 0; i < memory_.memoryTypeCount; ++i) {
    if ((type_bits & (1u << i)) != 0 &&
        (memory_.memoryTypes[i].propertyFlags & properties) == properties)
      return true;
  }
  return false;
}

uint32_t Context::memory_type(uint32_t type_bits, VkMemoryPropertyFlags properties) const {
  for (uint32_t i = 0; i < memory_.memoryTypeCount; ++i) {
    if ((type_bits & (1u << i)) != 0 &&
        (memory_.memoryTypes[i].propertyFlags & properties) == properties)
      return i;
  }
  throw Error("no Vulkan memory type with properties 0x" + std::to_string(properties) +
              " among type bits " + std::to_string(type_bits));
}

std::string Context::list_devices() {
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.apiVersion = VK_API_VERSION_1_3;
  VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &app;
  VkInstance instance = VK_NULL_HANDLE;
  check(vkCreateInstance(&ici, nullptr, &instance), "vkCreateInstance");
  std::string out;
  try {
    for (const auto& c : enumerate(instance)) out += describe_line(c.info) + "\n";
  } catch (...) {
    vkDestroyInstance(instance, nullptr);
    throw;
  }
  vkDestroyInstance(instance, nullptr);
  return out;
}

}  // namespace penumbra::gpu
