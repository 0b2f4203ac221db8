#define GLFW_INCLUDE_VULKAN
#include "ui.hpp"

#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_vulkan.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/check.hpp>
#include <penumbra/scene/params.hpp>
#include <string>
#include <vector>

namespace penumbra::runtime {
namespace {

void check_vk(VkResult r) {
  if (r != VK_SUCCESS) std::fprintf(stderr, "penumbra-view: ImGui Vulkan call: VkResult %d\n", r);
}

float as_float(Session& s, const std::string& key) {
  try {
    return std::stof(s.get(key));
  } catch (const std::exception&) {
    return 0.0f;
  }
}

// Keys that rebuild the renderer apply when the slider is released, not while it is dragged.
bool rebuilds(const scene::Param& p) {
  return p.apply == scene::ParamApply::rebuild;
}

// "pcf_radius##shadows.pcf_radius": the name shown, the key as ImGui's id.
std::string label_of(const scene::Param& p) {
  std::string label(p.name());
  for (char& c : label)
    if (c == '_') c = ' ';
  return label + "##" + std::string(p.key);
}

}  // namespace

std::string ui_version() {
  return std::string("Dear ImGui ") + IMGUI_VERSION;
}

Ui::Ui(gpu::Context& ctx, Window& window) : ctx_(ctx) {
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini in the working directory
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForVulkan(window.handle(), true);  // chains to the window's callbacks

  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 4};
  VkDescriptorPoolCreateInfo pi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pi.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
  pi.maxSets = 4;
  pi.poolSizeCount = 1;
  pi.pPoolSizes = &size;
  gpu::check(vkCreateDescriptorPool(ctx_.device(), &pi, nullptr, &pool_), "vkCreateDescriptorPool");

  ImGui_ImplVulkan_InitInfo info{};
  info.Instance = ctx_.instance();
  info.PhysicalDevice = ctx_.physical_device();
  info.Device = ctx_.device();
  info.QueueFamily = ctx_.info().queue_family;
  info.Queue = ctx_.queue();
  info.DescriptorPool = pool_;
  info.Subpass = 0;
  info.MinImageCount = window.min_image_count();
  info.ImageCount = std::max(window.image_count(), window.min_image_count());
  info.MSAASamples = VK_SAMPLE_COUNT_1_BIT;
  info.CheckVkResultFn = check_vk;
  if (!ImGui_ImplVulkan_Init(&info, window.render_pass())) {
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    vkDestroyDescriptorPool(ctx_.device(), pool_, nullptr);
    throw Error("ImGui_ImplVulkan_Init failed");
  }
  window.submit_now([](VkCommandBuffer cmd) { ImGui_ImplVulkan_CreateFontsTexture(cmd); });
  ImGui_ImplVulkan_DestroyFontUploadObjects();
}

Ui::~Ui() {
  vkDeviceWaitIdle(ctx_.device());
  ImGui_ImplVulkan_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  vkDestroyDescriptorPool(ctx_.device(), pool_, nullptr);
}

void Ui::new_frame() {
  ImGui_ImplVulkan_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
  rendered_ = false;
}

bool Ui::wants_mouse() const {
  return ImGui::GetIO().WantCaptureMouse;
}
bool Ui::wants_keyboard() const {
  return ImGui::GetIO().WantCaptureKeyboard;
}

void Ui::set(Session& session, const std::string& key, const std::string& value) {
  try {
    session.set(key, value);
    last_error_.clear();
    ++changes_;
    std::printf("[ui] %s = %s\n", key.c_str(), value.c_str());
    std::fflush(stdout);
  } catch (const std::exception& e) {
    last_error_ = e.what();
  }
}

void Ui::panel(Session& session) {
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(430, 0), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowBgAlpha(0.85f);
  if (ImGui::Begin("penumbra")) {
    const std::string error = session.error_text();
    if (!error.empty()) {
      ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0f, 0.35f, 0.3f, 1.0f));
      ImGui::TextWrapped("reload error:\n%s", error.c_str());
      ImGui::PopStyleColor();
      ImGui::Separator();
    }

    // One widget per settable row of the parameter table (scene/params.hpp): a combo for a
    // choice, a checkbox for a bool, a slider over the row's widget range (or its closed range)
    // for numbers; vectors only in "every parameter" below.
    auto widget = [&](const scene::Param& p) {
      const std::string key(p.key);
      const std::string label = label_of(p);
      const std::string now = session.get(key);
      switch (p.type) {
        case scene::ParamType::choice:
          if (ImGui::BeginCombo(label.c_str(), now.c_str())) {
            for (std::string_view choice : p.choices) {
              const bool selected = now == choice;
              if (ImGui::Selectable(std::string(choice).c_str(), selected) && !selected)
                set(session, key, std::string(choice));
            }
            ImGui::EndCombo();
          }
          break;
        case scene::ParamType::boolean: {
          bool v = now == "true";
          if (ImGui::Checkbox(label.c_str(), &v)) set(session, key, v ? "true" : "false");
          break;
        }
        case scene::ParamType::integer: {
          int v = static_cast<int>(as_float(session, key));
          const bool moved = ImGui::SliderInt(label.c_str(), &v, int(p.range.lo), int(p.range.hi));
          if (rebuilds(p) ? ImGui::IsItemDeactivatedAfterEdit() : moved)
            set(session, key, std::to_string(v));
          break;
        }
        case scene::ParamType::number: {
          const scene::ParamRange r = p.widget.lo < p.widget.hi ? p.widget : p.range;
          if (!std::isfinite(r.lo) || !std::isfinite(r.hi)) break;
          float v = as_float(session, key);
          const bool moved =
              ImGui::SliderFloat(label.c_str(), &v, float(r.lo), float(r.hi), "%.4g");
          if (rebuilds(p) ? ImGui::IsItemDeactivatedAfterEdit() : moved) {
            char text[64];
            std::snprintf(text, sizeof text, "%.9g", static_cast<double>(v));
            set(session, key, text);
          }
          break;
        }
        default:
          break;
      }
    };
    // The rows this scene uses, by table; the others apart, each with the reason it does
    // nothing here (scene::unused_reason), so the panel shows first what the scene models.
    // Labels get 45% of the width, so the longest ("pcss min filter texels") are not cut.
    ImGui::PushItemWidth(ImGui::GetWindowWidth() * 0.5f);
    std::vector<std::pair<const scene::Param*, std::string>> unused;
    for (const char* table : {"render", "shadows", "sun", "contact", "camera"}) {
      std::vector<const scene::Param*> used;
      for (const scene::Param* p : scene::params_of(table)) {
        if (!p->settable()) continue;
        std::string why = scene::unused_reason(session.scene(), *p);
        if (why.empty())
          used.push_back(p);
        else
          unused.emplace_back(p, std::move(why));
      }
      if (used.empty()) continue;
      const bool open = std::string_view(table) != "camera";
      if (!ImGui::CollapsingHeader(table, open ? ImGuiTreeNodeFlags_DefaultOpen : 0)) continue;
      for (const scene::Param* p : used) widget(*p);
    }
    const std::string apart = "not used by this scene (" + std::to_string(unused.size()) + ")";
    if (!unused.empty() && ImGui::CollapsingHeader(apart.c_str())) {
      for (const auto& [p, why] : unused) {
        widget(*p);
        ImGui::SameLine();
        ImGui::TextDisabled("(%s)", why.c_str());
      }
    }
    ImGui::PopItemWidth();
    if (ImGui::CollapsingHeader("every parameter (Enter applies)")) {
      for (const std::string& key : session.keys()) {
        char text[128];
        std::snprintf(text, sizeof text, "%s", session.get(key).c_str());
        if (ImGui::InputText(key.c_str(), text, sizeof text, ImGuiInputTextFlags_EnterReturnsTrue))
          set(session, key, text);
      }
    }
    if (!last_error_.empty()) {
      ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0f, 0.6f, 0.2f, 1.0f));
      ImGui::TextWrapped("%s", last_error_.c_str());
      ImGui::PopStyleColor();
    }
    if (ImGui::CollapsingHeader("GPU time per pass", ImGuiTreeNodeFlags_DefaultOpen)) {
      double total = 0.0;
      for (const auto& t : session.renderer().timings()) {
        ImGui::Text("%-18s %8.3f ms", t.name.c_str(), t.gpu_ms);
        total += t.gpu_ms;
      }
      ImGui::Text("%-18s %8.3f ms", "total", total);
    }
  }
  ImGui::End();
  ImGui::Render();
  rendered_ = true;
}

void Ui::record(VkCommandBuffer cmd) {
  if (!rendered_) ImGui::Render();
  rendered_ = true;
  ImGui_ImplVulkan_RenderDrawData(ImGui::GetDrawData(), cmd);
}

}  // namespace penumbra::runtime
