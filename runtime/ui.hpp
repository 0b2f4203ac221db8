#pragma once

// penumbra-view's parameter panel: Dear ImGui (Debian's libimgui-dev, its GLFW and Vulkan
// backends) drawn over the presented frame. Every change goes through Session::set, so the
// validation and the rebuilds stay in one place; a rejected value shows its error in the panel.
//
//   runtime::Ui ui(ctx, window);          // after the window; installs ImGui's GLFW callbacks
//   ui.new_frame(); ui.panel(session);    // each frame, before rendering
//   window.present(image, [&](VkCommandBuffer c) { ui.record(c); });

#include <memory>
#include <optional>
#include <penumbra/gpu/context.hpp>
#include <string>
#include <vector>

#include "session.hpp"
#include "truth.hpp"
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

  // penumbra-view --truth: the baseline against the ray-traced truth, and what each save did
  // (GPU ms and each light's errors, before -> after): the panel's table of the last saves.
  void truth_baseline(const TruthSnapshot& baseline);
  void add_save(const std::string& what, const TruthSnapshot& before, const TruthSnapshot& after,
                const TruthSnapshot& start);
  // The light whose error heat map the window shows instead of the frame (the panel's "show"
  // choice, or T); -1: the frame.
  int heat_light() const { return heat_light_; }
  void cycle_heat_light();

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
  struct Save {
    std::string what;
    double ms_before = 0.0, ms_after = 0.0;
    bool noise = true, identical = false;
    bool view_changed = false;  // the camera or a setting changed since the last snapshot
    std::vector<std::pair<TruthLight, TruthLight>> lights;  // before, after
  };
  std::optional<TruthSnapshot> baseline_;  // without pixels and heat maps
  std::vector<Save> saves_;                // the last kMaxSaves, oldest first
  std::vector<std::string> light_names_;
  std::string since_;  // the last save against the start (truth_since)
  int heat_light_ = -1;
  void truth_table();
  std::vector<std::string> shown_;  // the rows the panel showed last, group by group
  uint64_t changes_ = 0;
  bool rendered_ = false;
};

// "Dear ImGui <version>", or empty when penumbra-view was built without it.
std::string ui_version();

}  // namespace penumbra::runtime
