#define GLFW_INCLUDE_VULKAN
#include "window.hpp"

#include <GLFW/glfw3.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/check.hpp>

namespace penumbra::runtime {
namespace {

Window* self(GLFWwindow* w) {
  return static_cast<Window*>(glfwGetWindowUserPointer(w));
}

std::string glfw_error() {
  const char* text = nullptr;
  const int code = glfwGetError(&text);
  return code == GLFW_NO_ERROR ? std::string("no GLFW error")
                               : std::string(text ? text : "unknown GLFW error");
}

}  // namespace

// --- WindowSystem -------------------------------------------------------------------------------

std::unique_ptr<WindowSystem> WindowSystem::init(std::string& why) {
  if (glfwInit() != GLFW_TRUE) {
    why = "glfwInit failed: " + glfw_error();
    return nullptr;
  }
  std::unique_ptr<WindowSystem> ws(new WindowSystem());
  if (glfwVulkanSupported() != GLFW_TRUE) {
    why = "GLFW finds no Vulkan loader";
    return nullptr;
  }
  uint32_t count = 0;
  const char** names = glfwGetRequiredInstanceExtensions(&count);
  if (names == nullptr) {
    why = "GLFW cannot present with Vulkan on this display: " + glfw_error();
    return nullptr;
  }
  for (uint32_t i = 0; i < count; ++i) ws->extensions_.emplace_back(names[i]);
  return ws;
}

WindowSystem::~WindowSystem() {
  glfwTerminate();
}

// --- CameraControls -----------------------------------------------------------------------------

bool CameraControls::update(GLFWwindow* window, scene::Camera& cam, double dt, double scroll) {
  bool changed = false;
  const glm::vec3 up = glm::length(cam.up) > 0.0f ? glm::normalize(cam.up) : glm::vec3(0, 1, 0);
  glm::vec3 offset = cam.position - cam.target;  // target -> eye
  float distance = glm::length(offset);
  if (!(distance > 1e-4f)) return false;

  double x = 0.0, y = 0.0;
  glfwGetCursorPos(window, &x, &y);
  const bool left = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
  const bool right = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
  if ((left || right) && dragging_ && (x != last_x_ || y != last_y_)) {
    const float yaw = static_cast<float>(-(x - last_x_) * 0.005);
    const float pitch = static_cast<float>(-(y - last_y_) * 0.005);
    // Rotates `v` by yaw around `up` and by pitch around the right axis, keeping it off the pole.
    auto rotate = [&](glm::vec3 v, float pitch_sign) {
      const glm::vec3 dir = glm::normalize(v);
      const glm::vec3 right_axis = glm::normalize(glm::cross(dir, up));
      glm::mat4 r = glm::rotate(glm::mat4(1.0f), yaw, up);
      const glm::vec3 pitched =
          glm::vec3(glm::rotate(glm::mat4(1.0f), pitch * pitch_sign, right_axis) * glm::vec4(v, 0));
      const float cos_pole = glm::dot(glm::normalize(pitched), up);
      if (std::abs(cos_pole) < 0.995f) v = pitched;
      return glm::vec3(r * glm::vec4(v, 0.0f));
    };
    if (left) {
      offset = rotate(offset, 1.0f);  // orbit: the eye moves around the target
      cam.position = cam.target + offset;
    } else {
      const glm::vec3 forward = rotate(-offset, -1.0f);  // look: the target moves around the eye
      cam.target = cam.position + forward;
    }
    changed = true;
  }
  dragging_ = left || right;
  last_x_ = x;
  last_y_ = y;

  if (scroll != 0.0) {
    const float factor = static_cast<float>(std::pow(0.9, scroll));
    const float d = std::max(distance * factor, 0.05f);
    cam.position = cam.target + glm::normalize(cam.position - cam.target) * d;
    distance = d;
    changed = true;
  }

  auto held = [&](int key) { return glfwGetKey(window, key) == GLFW_PRESS; };
  glm::vec3 move(0.0f);
  const glm::vec3 forward = glm::normalize(cam.target - cam.position);
  const glm::vec3 right_dir = glm::normalize(glm::cross(forward, up));
  if (held(GLFW_KEY_W)) move += forward;
  if (held(GLFW_KEY_S)) move -= forward;
  if (held(GLFW_KEY_D)) move += right_dir;
  if (held(GLFW_KEY_A)) move -= right_dir;
  if (held(GLFW_KEY_E)) move += up;
  if (held(GLFW_KEY_Q)) move -= up;
  if (glm::length(move) > 0.0f) {
    float speed = std::max(distance, 1.0f) * 0.75f;
    if (held(GLFW_KEY_LEFT_SHIFT) || held(GLFW_KEY_RIGHT_SHIFT)) speed *= 4.0f;
    const glm::vec3 step = glm::normalize(move) * speed * static_cast<float>(std::min(dt, 0.1));
    cam.position += step;
    cam.target += step;
    changed = true;
  }
  return changed;
}

// --- Window -------------------------------------------------------------------------------------

Window::Window(gpu::Context& ctx, uint32_t width, uint32_t height, const std::string& title)
    : ctx_(ctx) {
  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  glfwWindowHint(GLFW_RESIZABLE, GLFW_TRUE);
  window_ = glfwCreateWindow(static_cast<int>(width), static_cast<int>(height), title.c_str(),
                             nullptr, nullptr);
  if (window_ == nullptr) throw Error("glfwCreateWindow failed: " + glfw_error());
  try {
    glfwSetWindowUserPointer(window_, this);
    glfwSetScrollCallback(window_, on_scroll);
    glfwSetKeyCallback(window_, on_key);
    glfwSetFramebufferSizeCallback(window_, on_resize);
    const VkResult r = glfwCreateWindowSurface(ctx_.instance(), window_, nullptr, &surface_);
    if (r != VK_SUCCESS) {
      throw Error("glfwCreateWindowSurface failed (VkResult " + std::to_string(r) +
                  "): " + glfw_error());
    }
    VkBool32 can_present = VK_FALSE;
    gpu::check(vkGetPhysicalDeviceSurfaceSupportKHR(
                   ctx_.physical_device(), ctx_.info().queue_family, surface_, &can_present),
               "vkGetPhysicalDeviceSurfaceSupportKHR");
    if (can_present != VK_TRUE) {
      throw Error("queue family " + std::to_string(ctx_.info().queue_family) + " of " +
                  ctx_.info().name + " cannot present to this window");
    }
    VkSemaphoreCreateInfo sci{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    gpu::check(vkCreateSemaphore(ctx_.device(), &sci, nullptr, &acquired_), "vkCreateSemaphore");
    VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    gpu::check(vkCreateFence(ctx_.device(), &fci, nullptr, &fence_), "vkCreateFence");
    VkCommandBufferAllocateInfo cai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    cai.commandPool = ctx_.command_pool();
    cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cai.commandBufferCount = 1;
    gpu::check(vkAllocateCommandBuffers(ctx_.device(), &cai, &cmd_), "vkAllocateCommandBuffers");
    create_swapchain();
    if (swapchain_ == VK_NULL_HANDLE) throw Error("the window has no area to present to");
  } catch (...) {
    destroy();
    throw;
  }
}

Window::~Window() {
  destroy();
}

void Window::destroy() {
  if (ctx_.device() != VK_NULL_HANDLE) vkDeviceWaitIdle(ctx_.device());
  destroy_swapchain_objects();
  if (swapchain_ != VK_NULL_HANDLE) vkDestroySwapchainKHR(ctx_.device(), swapchain_, nullptr);
  swapchain_ = VK_NULL_HANDLE;
  if (render_pass_ != VK_NULL_HANDLE) vkDestroyRenderPass(ctx_.device(), render_pass_, nullptr);
  render_pass_ = VK_NULL_HANDLE;
  if (cmd_ != VK_NULL_HANDLE) vkFreeCommandBuffers(ctx_.device(), ctx_.command_pool(), 1, &cmd_);
  cmd_ = VK_NULL_HANDLE;
  if (fence_ != VK_NULL_HANDLE) vkDestroyFence(ctx_.device(), fence_, nullptr);
  fence_ = VK_NULL_HANDLE;
  if (acquired_ != VK_NULL_HANDLE) vkDestroySemaphore(ctx_.device(), acquired_, nullptr);
  acquired_ = VK_NULL_HANDLE;
  if (surface_ != VK_NULL_HANDLE) vkDestroySurfaceKHR(ctx_.instance(), surface_, nullptr);
  surface_ = VK_NULL_HANDLE;
  if (window_ != nullptr) glfwDestroyWindow(window_);
  window_ = nullptr;
}

bool Window::should_close() const {
  return glfwWindowShouldClose(window_) == GLFW_TRUE;
}
void Window::close() {
  glfwSetWindowShouldClose(window_, GLFW_TRUE);
}
void Window::poll() {
  glfwPollEvents();
}
void Window::set_title(const std::string& title) {
  glfwSetWindowTitle(window_, title.c_str());
}
double Window::take_scroll() {
  const double s = scroll_;
  scroll_ = 0.0;
  return s;
}
std::vector<int> Window::take_keys() {
  std::vector<int> k;
  k.swap(keys_);
  return k;
}

void Window::on_scroll(GLFWwindow* w, double /*dx*/, double dy) {
  self(w)->scroll_ += dy;
}
void Window::on_key(GLFWwindow* w, int key, int /*scancode*/, int action, int /*mods*/) {
  if (action == GLFW_PRESS) self(w)->keys_.push_back(key);
}
void Window::on_resize(GLFWwindow* w, int /*width*/, int /*height*/) {
  self(w)->resized_ = true;
}

void Window::destroy_swapchain_objects() {
  for (VkSemaphore s : rendered_) vkDestroySemaphore(ctx_.device(), s, nullptr);
  rendered_.clear();
  for (VkFramebuffer f : framebuffers_) vkDestroyFramebuffer(ctx_.device(), f, nullptr);
  framebuffers_.clear();
  for (VkImageView v : views_) vkDestroyImageView(ctx_.device(), v, nullptr);
  views_.clear();
  images_.clear();
}

void Window::create_swapchain() {
  const VkPhysicalDevice pd = ctx_.physical_device();
  VkSurfaceCapabilitiesKHR caps{};
  gpu::check(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(pd, surface_, &caps),
             "vkGetPhysicalDeviceSurfaceCapabilitiesKHR");
  VkExtent2D extent = caps.currentExtent;
  if (extent.width == UINT32_MAX) {
    int w = 0, h = 0;
    glfwGetFramebufferSize(window_, &w, &h);
    extent.width = std::clamp(static_cast<uint32_t>(std::max(w, 0)), caps.minImageExtent.width,
                              caps.maxImageExtent.width);
    extent.height = std::clamp(static_cast<uint32_t>(std::max(h, 0)), caps.minImageExtent.height,
                               caps.maxImageExtent.height);
  }
  resized_ = false;
  if (extent.width == 0 || extent.height == 0) return;  // minimized: keep the old one
  const VkImageUsageFlags usage =
      VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
  if ((caps.supportedUsageFlags & usage) != usage)
    throw Error("the window's swapchain images cannot be transfer destinations and attachments");

  uint32_t count = 0;
  vkGetPhysicalDeviceSurfaceFormatsKHR(pd, surface_, &count, nullptr);
  std::vector<VkSurfaceFormatKHR> formats(count);
  vkGetPhysicalDeviceSurfaceFormatsKHR(pd, surface_, &count, formats.data());
  if (formats.empty()) throw Error("the window's surface reports no formats");
  // The image is already display-encoded (tonemapped RGBA8): a UNORM format shows it as is.
  auto blit_dst = [&](VkFormat f) {
    VkFormatProperties fp{};
    vkGetPhysicalDeviceFormatProperties(pd, f, &fp);
    return (fp.optimalTilingFeatures & VK_FORMAT_FEATURE_BLIT_DST_BIT) != 0;
  };
  VkSurfaceFormatKHR chosen{VK_FORMAT_UNDEFINED, VK_COLOR_SPACE_SRGB_NONLINEAR_KHR};
  for (VkFormat want : {VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_R8G8B8A8_UNORM}) {
    for (const auto& f : formats) {
      if (chosen.format == VK_FORMAT_UNDEFINED && f.format == want &&
          f.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR && blit_dst(f.format))
        chosen = f;
    }
  }
  for (const auto& f : formats)
    if (chosen.format == VK_FORMAT_UNDEFINED && blit_dst(f.format)) chosen = f;
  if (chosen.format == VK_FORMAT_UNDEFINED)
    throw Error("no surface format of the window supports blits");

  VkSwapchainCreateInfoKHR ci{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
  ci.surface = surface_;
  ci.minImageCount = std::max(caps.minImageCount + 1, 2u);
  if (caps.maxImageCount != 0) ci.minImageCount = std::min(ci.minImageCount, caps.maxImageCount);
  min_image_count_ = ci.minImageCount;
  ci.imageFormat = chosen.format;
  ci.imageColorSpace = chosen.colorSpace;
  ci.imageExtent = extent;
  ci.imageArrayLayers = 1;
  ci.imageUsage = usage;
  ci.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  ci.preTransform = (caps.supportedTransforms & VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR) != 0
                        ? VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR
                        : caps.currentTransform;
  ci.compositeAlpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
  for (VkCompositeAlphaFlagBitsKHR a :
       {VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR, VK_COMPOSITE_ALPHA_INHERIT_BIT_KHR,
        VK_COMPOSITE_ALPHA_PRE_MULTIPLIED_BIT_KHR, VK_COMPOSITE_ALPHA_POST_MULTIPLIED_BIT_KHR}) {
    if ((caps.supportedCompositeAlpha & a) != 0) {
      ci.compositeAlpha = a;
      break;
    }
  }
  ci.presentMode = VK_PRESENT_MODE_FIFO_KHR;  // always available
  ci.clipped = VK_TRUE;
  ci.oldSwapchain = swapchain_;

  VkSwapchainKHR fresh = VK_NULL_HANDLE;
  gpu::check(vkCreateSwapchainKHR(ctx_.device(), &ci, nullptr, &fresh), "vkCreateSwapchainKHR");
  if (swapchain_ != VK_NULL_HANDLE) {
    vkDeviceWaitIdle(ctx_.device());
    destroy_swapchain_objects();
    vkDestroySwapchainKHR(ctx_.device(), swapchain_, nullptr);
    ++recreated_;
  }
  swapchain_ = fresh;
  format_ = chosen.format;
  extent_ = extent;
  vkGetSwapchainImagesKHR(ctx_.device(), swapchain_, &count, nullptr);
  images_.resize(count);
  vkGetSwapchainImagesKHR(ctx_.device(), swapchain_, &count, images_.data());
  rendered_.resize(count, VK_NULL_HANDLE);
  VkSemaphoreCreateInfo sci{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
  for (VkSemaphore& s : rendered_)
    gpu::check(vkCreateSemaphore(ctx_.device(), &sci, nullptr, &s), "vkCreateSemaphore");

  if (render_pass_ == VK_NULL_HANDLE) {
    // Loads the blitted image; the overlay draws over it.
    VkAttachmentDescription color{};
    color.format = format_;
    color.samples = VK_SAMPLE_COUNT_1_BIT;
    color.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
    color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    color.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    color.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    color.initialLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    color.finalLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    VkAttachmentReference ref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    VkSubpassDescription sub{};
    sub.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    sub.colorAttachmentCount = 1;
    sub.pColorAttachments = &ref;
    VkSubpassDependency in{};
    in.srcSubpass = VK_SUBPASS_EXTERNAL;
    in.dstSubpass = 0;
    in.srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    in.dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    in.srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    in.dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    VkRenderPassCreateInfo rpi{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
    rpi.attachmentCount = 1;
    rpi.pAttachments = &color;
    rpi.subpassCount = 1;
    rpi.pSubpasses = &sub;
    rpi.dependencyCount = 1;
    rpi.pDependencies = &in;
    gpu::check(vkCreateRenderPass(ctx_.device(), &rpi, nullptr, &render_pass_),
               "vkCreateRenderPass");
  } else if (chosen.format != render_pass_format_) {
    throw Error("the window's surface format changed; restart penumbra-view");
  }
  render_pass_format_ = format_;
  views_.resize(count, VK_NULL_HANDLE);
  framebuffers_.resize(count, VK_NULL_HANDLE);
  for (uint32_t i = 0; i < count; ++i) {
    VkImageViewCreateInfo vi{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vi.image = images_[i];
    vi.viewType = VK_IMAGE_VIEW_TYPE_2D;
    vi.format = format_;
    vi.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    gpu::check(vkCreateImageView(ctx_.device(), &vi, nullptr, &views_[i]), "vkCreateImageView");
    VkFramebufferCreateInfo fi{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
    fi.renderPass = render_pass_;
    fi.attachmentCount = 1;
    fi.pAttachments = &views_[i];
    fi.width = extent_.width;
    fi.height = extent_.height;
    fi.layers = 1;
    gpu::check(vkCreateFramebuffer(ctx_.device(), &fi, nullptr, &framebuffers_[i]),
               "vkCreateFramebuffer");
  }
}

void Window::submit_now(const std::function<void(VkCommandBuffer)>& work) {
  gpu::check(vkResetCommandBuffer(cmd_, 0), "vkResetCommandBuffer");
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  gpu::check(vkBeginCommandBuffer(cmd_, &bi), "vkBeginCommandBuffer");
  work(cmd_);
  gpu::check(vkEndCommandBuffer(cmd_), "vkEndCommandBuffer");
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cmd_;
  gpu::check(vkResetFences(ctx_.device(), 1, &fence_), "vkResetFences");
  gpu::check(vkQueueSubmit(ctx_.queue(), 1, &si, fence_), "vkQueueSubmit");
  gpu::check(vkWaitForFences(ctx_.device(), 1, &fence_, VK_TRUE, UINT64_MAX), "vkWaitForFences");
}

bool Window::present(const gpu::Image& image, const std::function<void(VkCommandBuffer)>& overlay) {
  if (resized_ || swapchain_ == VK_NULL_HANDLE) {
    vkDeviceWaitIdle(ctx_.device());
    create_swapchain();
    if (swapchain_ == VK_NULL_HANDLE || resized_) return false;
  }
  int fb_w = 0, fb_h = 0;
  glfwGetFramebufferSize(window_, &fb_w, &fb_h);
  if (fb_w == 0 || fb_h == 0) return false;  // minimized

  uint32_t index = 0;
  VkResult r = vkAcquireNextImageKHR(ctx_.device(), swapchain_, UINT64_MAX, acquired_,
                                     VK_NULL_HANDLE, &index);
  if (r == VK_ERROR_OUT_OF_DATE_KHR) {
    resized_ = true;  // recreated on the next call; the semaphore was not signaled
    return false;
  }
  if (r != VK_SUBOPTIMAL_KHR) gpu::check(r, "vkAcquireNextImageKHR");

  const gpu::ImageDesc& d = image.desc();
  gpu::check(vkResetCommandBuffer(cmd_, 0), "vkResetCommandBuffer");
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  gpu::check(vkBeginCommandBuffer(cmd_, &bi), "vkBeginCommandBuffer");

  const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  VkImageMemoryBarrier2 to_blit[2]{};
  // The source: written by an earlier submission (already waited for); make it visible.
  to_blit[0].sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2;
  to_blit[0].srcStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  to_blit[0].srcAccessMask = VK_ACCESS_2_MEMORY_WRITE_BIT;
  to_blit[0].dstStageMask = VK_PIPELINE_STAGE_2_BLIT_BIT;
  to_blit[0].dstAccessMask = VK_ACCESS_2_TRANSFER_READ_BIT;
  to_blit[0].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  to_blit[0].newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  to_blit[0].srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  to_blit[0].dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  to_blit[0].image = image.handle();
  to_blit[0].subresourceRange = range;
  // The swapchain image: after the acquire semaphore (waited at the transfer stage).
  to_blit[1] = to_blit[0];
  to_blit[1].srcStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  to_blit[1].srcAccessMask = 0;
  to_blit[1].dstStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  to_blit[1].dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  to_blit[1].oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  to_blit[1].newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  to_blit[1].image = images_[index];
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.imageMemoryBarrierCount = 2;
  dep.pImageMemoryBarriers = to_blit;
  vkCmdPipelineBarrier2(cmd_, &dep);

  VkImageBlit blit{};
  blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  blit.srcOffsets[1] = {static_cast<int32_t>(d.width), static_cast<int32_t>(d.height), 1};
  blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  blit.dstOffsets[1] = {static_cast<int32_t>(extent_.width), static_cast<int32_t>(extent_.height),
                        1};
  vkCmdBlitImage(cmd_, image.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, images_[index],
                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_LINEAR);

  VkImageMemoryBarrier2 after = to_blit[1];
  after.srcStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  after.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  after.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  if (overlay) {  // the render pass takes it on to PRESENT_SRC
    after.dstStageMask = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
    after.dstAccessMask =
        VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
    after.newLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  } else {
    after.dstStageMask = VK_PIPELINE_STAGE_2_NONE;
    after.dstAccessMask = 0;
    after.newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
  }
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &after;
  vkCmdPipelineBarrier2(cmd_, &dep);
  if (overlay) {
    VkRenderPassBeginInfo rb{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
    rb.renderPass = render_pass_;
    rb.framebuffer = framebuffers_[index];
    rb.renderArea.extent = extent_;
    vkCmdBeginRenderPass(cmd_, &rb, VK_SUBPASS_CONTENTS_INLINE);
    overlay(cmd_);
    vkCmdEndRenderPass(cmd_);
  }
  gpu::check(vkEndCommandBuffer(cmd_), "vkEndCommandBuffer");

  const VkPipelineStageFlags wait_stage = VK_PIPELINE_STAGE_TRANSFER_BIT;
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.waitSemaphoreCount = 1;
  si.pWaitSemaphores = &acquired_;
  si.pWaitDstStageMask = &wait_stage;
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cmd_;
  si.signalSemaphoreCount = 1;
  si.pSignalSemaphores = &rendered_[index];
  gpu::check(vkResetFences(ctx_.device(), 1, &fence_), "vkResetFences");
  gpu::check(vkQueueSubmit(ctx_.queue(), 1, &si, fence_), "vkQueueSubmit");

  VkPresentInfoKHR pi{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
  pi.waitSemaphoreCount = 1;
  pi.pWaitSemaphores = &rendered_[index];
  pi.swapchainCount = 1;
  pi.pSwapchains = &swapchain_;
  pi.pImageIndices = &index;
  r = vkQueuePresentKHR(ctx_.queue(), &pi);
  // The next frame overwrites the source image and re-records the command buffer.
  gpu::check(vkWaitForFences(ctx_.device(), 1, &fence_, VK_TRUE, UINT64_MAX), "vkWaitForFences");
  if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR) {
    resized_ = true;
  } else {
    gpu::check(r, "vkQueuePresentKHR");
  }
  ++presented_;
  return true;
}

}  // namespace penumbra::runtime
