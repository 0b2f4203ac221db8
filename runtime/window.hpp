#pragma once

// penumbra-view's interactive window: GLFW + a Vulkan swapchain that shows the renderer's
// tonemapped image (blitted, scaled to the window), and the camera controls.
//
//   std::string why;
//   auto glfw = runtime::WindowSystem::init(why);       // null (and why) without a display
//   gpu::Context ctx({.instance_extensions = glfw->instance_extensions(),
//                     .device_extensions = {"VK_KHR_swapchain"}});
//   runtime::Window window(ctx, 1280, 720, "penumbra-view");   // throws penumbra::Error
//   while (!window.should_close()) { window.poll(); ...; renderer.render(); window.present(img); }

#include <cstdint>
#include <functional>
#include <memory>
#include <penumbra/gpu/context.hpp>
#include <penumbra/gpu/resources.hpp>
#include <penumbra/scene/scene.hpp>
#include <string>
#include <vector>

struct GLFWwindow;

namespace penumbra::runtime {

// glfwInit / glfwTerminate, and the instance extensions a window surface needs.
class WindowSystem {
 public:
  // Null, with the reason in `why`, when GLFW cannot start (no display) or has no Vulkan.
  static std::unique_ptr<WindowSystem> init(std::string& why);
  ~WindowSystem();
  WindowSystem(const WindowSystem&) = delete;
  WindowSystem& operator=(const WindowSystem&) = delete;
  const std::vector<std::string>& instance_extensions() const { return extensions_; }

 private:
  WindowSystem() = default;
  std::vector<std::string> extensions_;
};

// What the camera controls do with the input of one frame.
//   left drag: orbit around camera.target; right drag: look around (fly);
//   W/A/S/D (+ Q/E down/up, Shift faster): fly; scroll: zoom toward the target.
class CameraControls {
 public:
  // Returns whether the camera changed.
  bool update(GLFWwindow* window, scene::Camera& camera, double dt_seconds, double scroll);
  // Ends a drag (the panel took the mouse): the next update starts from where the cursor is.
  void cancel() { dragging_ = false; }

 private:
  double last_x_ = 0.0, last_y_ = 0.0;
  bool dragging_ = false;
};

class Window {
 public:
  // A window of this size (its framebuffer may differ) and a swapchain on ctx's queue; throws
  // penumbra::Error when the window, surface or swapchain cannot be made or ctx's queue family
  // cannot present to it. ctx must have VK_KHR_swapchain and the WindowSystem's extensions.
  Window(gpu::Context& ctx, uint32_t width, uint32_t height, const std::string& title);
  ~Window();
  Window(const Window&) = delete;
  Window& operator=(const Window&) = delete;

  GLFWwindow* handle() const { return window_; }
  bool should_close() const;
  void close();
  void poll();  // glfwPollEvents
  void set_title(const std::string& title);
  // Scroll since the last call (wheel notches, + away from the user).
  double take_scroll();
  // Keys pressed (not held) since the last call, as GLFW key codes.
  std::vector<int> take_keys();

  // Blits `image` (a 2D color image in TRANSFER_SRC_OPTIMAL whose writes have completed, e.g.
  // Renderer::output_image() after render()) to the next swapchain image, scaled to fill it,
  // presents it and waits for the copy. Recreates the swapchain when it is out of date or the
  // window was resized. Returns false when no frame was presented (minimized, out of date).
  // `overlay`, when given, records draws into a render pass on the swapchain image (after the
  // blit; render_pass(), loads the blitted pixels), e.g. the Dear ImGui panel.
  bool present(const gpu::Image& image,
               const std::function<void(VkCommandBuffer)>& overlay = nullptr);

  // For an overlay renderer: the render pass (one color attachment in the swapchain format,
  // COLOR_ATTACHMENT_OPTIMAL -> PRESENT_SRC), the swapchain's image counts and the command
  // buffer used for one-shot uploads (submit_now).
  VkRenderPass render_pass() const { return render_pass_; }
  uint32_t image_count() const { return static_cast<uint32_t>(images_.size()); }
  uint32_t min_image_count() const { return min_image_count_; }
  // Records `work` into a command buffer, submits it and waits.
  void submit_now(const std::function<void(VkCommandBuffer)>& work);

  uint64_t presented() const { return presented_; }
  uint32_t recreated() const { return recreated_; }
  uint32_t width() const { return extent_.width; }
  uint32_t height() const { return extent_.height; }
  VkFormat format() const { return format_; }

 private:
  void destroy();
  void create_swapchain();
  void destroy_swapchain_objects();
  static void on_scroll(GLFWwindow* w, double dx, double dy);
  static void on_key(GLFWwindow* w, int key, int scancode, int action, int mods);
  static void on_resize(GLFWwindow* w, int width, int height);

  gpu::Context& ctx_;
  GLFWwindow* window_ = nullptr;
  VkSurfaceKHR surface_ = VK_NULL_HANDLE;
  VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
  VkFormat format_ = VK_FORMAT_UNDEFINED;
  VkExtent2D extent_{0, 0};
  std::vector<VkImage> images_;
  std::vector<VkImageView> views_;
  std::vector<VkFramebuffer> framebuffers_;
  VkRenderPass render_pass_ = VK_NULL_HANDLE;
  VkFormat render_pass_format_ = VK_FORMAT_UNDEFINED;
  uint32_t min_image_count_ = 2;
  std::vector<VkSemaphore> rendered_;  // per swapchain image: blit done, may present
  VkSemaphore acquired_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  bool resized_ = false;
  double scroll_ = 0.0;
  std::vector<int> keys_;
  uint64_t presented_ = 0;
  uint32_t recreated_ = 0;
};

}  // namespace penumbra::runtime
