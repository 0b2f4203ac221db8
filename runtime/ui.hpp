#pragma once

// penumbra-view's parameter panel: Dear ImGui (Debian's libimgui-dev, its GLFW and Vulkan
// backends) drawn over the presented frame. Every change goes through Session::set, so the
// validation and the rebuilds stay in one place; a rejected value shows its error in the panel.
//
//   runtime::Ui ui(ctx, window);          // after the window; installs ImGui's GLFW callbacks
//   ui.new_frame(); ui.panel(session);    // each frame, before rendering
//   window.present(image, [&](VkCommandBuffer c) { ui.record(c); });

#include <memory>
#include <penumbra/gpu/context.hpp>
#include <string>
#include <vector>

#include "session.hpp"
#include "window.hpp"

namespace penumbra::runtime {

class Ui {
 public:
  // log_rows: print the panel's rows ("[ui] rows sun: sun.direction ...") on the first frame
  // and whenever they change (penumbra-view --ui-rows; the window tests read them).
  Ui(gpu::Context& ctx, Window& window, bool log_rows = false);
  ~Ui();
  Ui(const Ui&) = delete;
  Ui& operator=(const Ui&) = delete;

  void new_frame();
  // Builds the panel: the rows of what the scene models, grouped by light (the sun with its
  // map's rows, each spot and point light, the rows every light shares, contact, render,
  // camera), each with the row's docs line as its tooltip; the rows that do nothing here apart
  // with the reason; every key as text; the per-pass GPU timings and the reload error.
  void panel(Session& session);
  // Records the panel's draws (inside Window's overlay render pass).
  void record(VkCommandBuffer cmd);

  bool wants_mouse() const;
  bool wants_keyboard() const;
  // Parameter changes made through the panel so far.
  uint64_t changes() const { return changes_; }

 private:
  void set(Session& session, const std::string& key, const std::string& value);

  gpu::Context& ctx_;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  std::string last_error_;
  bool log_rows_ = false;
  std::vector<std::string> shown_;  // the rows the panel showed last, group by group
  uint64_t changes_ = 0;
  bool rendered_ = false;
};

// "Dear ImGui <version>", or empty when penumbra-view was built without it.
std::string ui_version();

}  // namespace penumbra::runtime
