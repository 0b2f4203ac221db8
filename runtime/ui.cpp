#define GLFW_INCLUDE_VULKAN
#include "ui.hpp"

#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_vulkan.h>

#include <algorithm>
#include <cstdio>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/check.hpp>
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

// Parameters that rebuild the renderer: applied when the slider is released, not while dragged.
bool rebuilds(const std::string& key) {
  return key.rfind("contact.", 0) == 0 || key == "shadows.cascades" || key == "shadows.resolution";
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
  ImGui::SetNextWindowSize(ImVec2(340, 0), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowBgAlpha(0.85f);
  if (ImGui::Begin("penumbra")) {
    const std::string error = session.error_text();
    if (!error.empty()) {
      ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0f, 0.35f, 0.3f, 1.0f));
      ImGui::TextWrapped("reload error:\n%s", error.c_str());
      ImGui::PopStyleColor();
      ImGui::Separator();
    }

    // values: what get returns and set takes; labels (optional): what the list shows.
    auto combo = [&](const char* label, const std::string& key,
                     const std::vector<const char*>& values,
                     const std::vector<const char*>& labels = {}) {
      const std::string now = session.get(key);
      const char* shown = now.c_str();
      for (size_t i = 0; i < values.size() && !labels.empty(); ++i)
        if (now == values[i]) shown = labels[i];
      if (ImGui::BeginCombo(label, shown)) {
        for (size_t i = 0; i < values.size(); ++i) {
          const bool selected = now == values[i];
          if (ImGui::Selectable(labels.empty() ? values[i] : labels[i], selected) && !selected)
            set(session, key, values[i]);
        }
        ImGui::EndCombo();
      }
    };
    combo("view", "render.view",
          {"lit", "shadow_factor", "cascades", "contact_mask", "texel_density", "penumbra"});
    combo("filter", "shadows.filter", {"hard", "pcf", "pcss", "poisson"});
    combo("pcss quality", "shadows.pcss_quality", {"0", "1", "2"}, {"low", "medium", "high"});
    combo("cascade fit", "shadows.fit", {"box", "camera_sphere", "slice_sphere"});

    auto slider = [&](const char* label, const std::string& key, float lo, float hi,
                      const char* format = "%.4g") {
      float v = as_float(session, key);
      const bool moved = ImGui::SliderFloat(label, &v, lo, hi, format);
      if (rebuilds(key) ? ImGui::IsItemDeactivatedAfterEdit() : moved) {
        char text[64];
        std::snprintf(text, sizeof text, "%.9g", static_cast<double>(v));
        set(session, key, text);
      }
    };
    auto islider = [&](const char* label, const std::string& key, int lo, int hi) {
      int v = static_cast<int>(as_float(session, key));
      const bool moved = ImGui::SliderInt(label, &v, lo, hi);
      if (rebuilds(key) ? ImGui::IsItemDeactivatedAfterEdit() : moved)
        set(session, key, std::to_string(v));
    };
    if (ImGui::CollapsingHeader("shadows", ImGuiTreeNodeFlags_DefaultOpen)) {
      islider("pcf radius", "shadows.pcf_radius", 0, 8);
      slider("slope bias", "shadows.slope_bias", 0.0f, 8.0f);
      slider("constant bias", "shadows.constant_bias", 0.0f, 0.01f, "%.5f");
      slider("normal offset", "shadows.normal_offset_texels", 0.0f, 4.0f);
      islider("cascades", "shadows.cascades", 1, 4);
      slider("lambda", "shadows.lambda", 0.0f, 1.0f);
      slider("max distance", "shadows.max_distance", 1.0f, 500.0f);
      slider("blend band", "shadows.blend_band", 0.0f, 0.5f);
      slider("fade band", "shadows.fade_band", 0.0f, 1.0f);
      slider("sun diameter", "sun.angular_diameter", 0.0f, 10.0f);
      slider("sun intensity", "sun.intensity", 0.0f, 20.0f);
    }
    if (ImGui::CollapsingHeader("contact shadows", ImGuiTreeNodeFlags_DefaultOpen)) {
      islider("steps", "contact.steps", 0, int(scene::kMaxContactSteps));
      slider("max distance##contact", "contact.max_distance", 0.0f, 2.0f);
      slider("thickness", "contact.thickness", 0.0f, 0.5f);
      slider("intensity", "contact.intensity", 0.0f, 1.0f);
    }
    slider("exposure", "render.exposure", 0.0f, 8.0f);
    if (ImGui::CollapsingHeader("every parameter (Enter applies)")) {
      for (const std::string& key : Session::keys()) {
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
