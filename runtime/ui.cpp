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
#include <tuple>
#include <vector>

namespace penumbra::runtime {
namespace {

void check_vk(VkResult r) {
  if (r != VK_SUCCESS) std::fprintf(stderr, "penumbra-view: ImGui Vulkan call: VkResult %d\n", r);
}

float as_float(const std::string& text) {
  try {
    return std::stof(text);
  } catch (const std::exception&) {
    return 0.0f;
  }
}

// Keys that rebuild the renderer apply when the slider is released, not while it is dragged.
bool rebuilds(const scene::Param& p) {
  return p.apply == scene::ParamApply::rebuild;
}

// "normal offset texels##shadows.normal_offset_texels": the name shown, the key (a light's: spot[0].range) as
// ImGui's id.
std::string label_of(const scene::Param& p, const std::string& key) {
  std::string label(p.name());
  for (char& c : label)
    if (c == '_') c = ' ';
  return label + "##" + key;
}

}  // namespace

std::string ui_version() {
  return std::string("Dear ImGui ") + IMGUI_VERSION;
}

Ui::Ui(gpu::Context& ctx, Window& window, bool log_rows) : ctx_(ctx), log_rows_(log_rows) {
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

    truth_table();  // --truth: what each save did, first
    // One widget per settable row of the parameter table (scene/params.hpp): a combo for a
    // choice, a checkbox for a bool, a slider over the row's widget range (or its closed range)
    // for numbers, three drag fields for a vector. `key` is the row's key, or a light's
    // ("spot[0].resolution"); the tooltip is the row's docs line.
    std::vector<std::string> shown;  // this frame's rows, group by group
    auto widget = [&](const scene::Param& p, const std::string& key) {
      const std::string label = label_of(p, key);
      const std::string now = session.get(key);
      bool drawn = true;
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
          int v = static_cast<int>(as_float(now));
          const bool moved = ImGui::SliderInt(label.c_str(), &v, int(p.range.lo), int(p.range.hi));
          if (rebuilds(p) ? ImGui::IsItemDeactivatedAfterEdit() : moved)
            set(session, key, std::to_string(v));
          break;
        }
        case scene::ParamType::number: {
          const scene::ParamRange r = p.widget.lo < p.widget.hi ? p.widget : p.range;
          if (!std::isfinite(r.lo) || !std::isfinite(r.hi)) {
            drawn = false;
            break;
          }
          float v = as_float(now);
          const bool moved =
              ImGui::SliderFloat(label.c_str(), &v, float(r.lo), float(r.hi), "%.4g");
          if (rebuilds(p) ? ImGui::IsItemDeactivatedAfterEdit() : moved) {
            char text[64];
            std::snprintf(text, sizeof text, "%.9g", static_cast<double>(v));
            set(session, key, text);
          }
          break;
        }
        case scene::ParamType::vec3:
        case scene::ParamType::direction: {
          float v[3] = {0.0f, 0.0f, 0.0f};
          std::sscanf(now.c_str(), "%f,%f,%f", &v[0], &v[1], &v[2]);
          const bool moved = ImGui::DragFloat3(label.c_str(), v, 0.02f, 0.0f, 0.0f, "%.3g");
          if (rebuilds(p) ? ImGui::IsItemDeactivatedAfterEdit() : moved) {
            char text[128];
            std::snprintf(text, sizeof text, "%.9g,%.9g,%.9g", double(v[0]), double(v[1]),
                          double(v[2]));
            set(session, key, text);
          }
          break;
        }
      }
      if (!drawn) return;
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", std::string(p.doc).c_str());
      shown.back() += " " + key;
    };
    // What the scene models, grouped by light: the sun (its own rows and its map's), each spot
    // and point light (its own rows), each moving object (its motion, closed), then the rows
    // every shadowed light shares, the contact pass, the image and the camera. Rows that do
    // nothing for this scene (scene::unused_reason) are listed apart, each with the reason.
    ImGui::PushItemWidth(ImGui::GetWindowWidth() * 0.5f);
    const scene::Scene& sc = session.scene();
    std::vector<std::tuple<const scene::Param*, std::string, std::string>> unused;
    struct Group {
      std::string title;
      std::vector<std::pair<const scene::Param*, std::string>> rows;
      bool open = true;
    };
    std::vector<Group> groups;
    const auto add = [&](Group& g, const scene::Param* p, const std::string& key,
                         std::size_t light) {
      if (!p->settable()) return;
      std::string why = scene::unused_reason(sc, *p, light);
      if (why.empty())
        g.rows.emplace_back(p, key);
      else
        unused.emplace_back(p, key, std::move(why));
    };
    Group sun{"sun"}, shared{"shadows (every light)"};
    for (const scene::Param* p : scene::params_of("sun")) add(sun, p, std::string(p->key), 0);
    for (const scene::Param* p : scene::params_of("shadows"))
      add(scene::sun_map_row(*p) ? sun : shared, p, std::string(p->key), 0);
    groups.push_back(std::move(sun));
    for (const char* table : {"spot", "point"}) {
      for (std::size_t i = 0; i < scene::light_count(sc, table); ++i) {
        Group g{std::string(table) + "[" + std::to_string(i) + "]"};
        for (const scene::Param* p : scene::params_of(table)) add(g, p, scene::light_key(*p, i), i);
        groups.push_back(std::move(g));
      }
    }
    // The objects that move, each its own closed group (a still object's motion is set with
    // --set or the console: a scene of 200 asteroids would fill the panel).
    for (std::size_t i = 0; i < scene::light_count(sc, "object"); ++i) {
      if (!sc.instances[i].motion) continue;
      Group g{"object[" + std::to_string(i) + "]", {}, false};
      for (const scene::Param* p : scene::params_of("object"))
        add(g, p, scene::light_key(*p, i), i);
      groups.push_back(std::move(g));
    }
    groups.push_back(std::move(shared));
    for (const char* table : {"contact", "render", "camera"}) {
      Group g{table, {}, std::string_view(table) != "camera"};
      for (const scene::Param* p : scene::params_of(table)) add(g, p, std::string(p->key), 0);
      groups.push_back(std::move(g));
    }
    for (const Group& g : groups) {
      if (g.rows.empty()) continue;
      shown.push_back(g.title + ":");
      if (!ImGui::CollapsingHeader(g.title.c_str(), g.open ? ImGuiTreeNodeFlags_DefaultOpen : 0)) {
        shown.back() += " (closed: " + std::to_string(g.rows.size()) + " rows)";
        continue;
      }
      for (const auto& [p, key] : g.rows) widget(*p, key);
    }
    const std::string apart = "not used by this scene (" + std::to_string(unused.size()) + ")";
    if (!unused.empty()) shown.push_back(apart + ":");
    if (!unused.empty() && ImGui::CollapsingHeader(apart.c_str())) {
      for (const auto& [p, key, why] : unused) {
        widget(*p, key);
        ImGui::SameLine();
        ImGui::TextDisabled("(%s)", why.c_str());
      }
    }
    ImGui::PopItemWidth();
    // The rows shown, once and whenever they change (a rebuilt scene, a header opened).
    if (shown != shown_) {
      shown_ = shown;
      if (log_rows_)
        for (const std::string& line : shown_) std::printf("[ui] rows %s\n", line.c_str());
      std::fflush(stdout);
    }
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

namespace {
constexpr std::size_t kMaxSaves = 8;

std::string percent(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f", 100.0 * v);
  return b;
}
std::string arrow(const std::string& before, const std::string& after) {
  return before == after ? after : before + " > " + after;
}
std::string gap(double texels) {
  if (!std::isfinite(texels)) return "none";
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", texels);
  return b;
}
}  // namespace

void Ui::truth_baseline(const TruthSnapshot& baseline) {
  baseline_ = baseline;
  baseline_->pixels.clear();
  baseline_->heat.clear();
  light_names_.clear();
  for (const auto& l : baseline.lights) light_names_.push_back(l.name);
}

void Ui::add_save(const std::string& what, const TruthSnapshot& before, const TruthSnapshot& after,
                  const TruthSnapshot& start) {
  since_ = truth_since(start, after).front();
  if (since_.rfind("[truth] ", 0) == 0) since_ = since_.substr(8);
  if (log_rows_) {
    std::printf("[ui] saves: %zu, the last: %s\n", std::min(saves_.size() + 1, kMaxSaves),
                what.c_str());
    std::fflush(stdout);
  }
  Save s;
  s.what = what;
  s.ms_before = before.frame_ms;
  s.ms_after = after.frame_ms;
  s.noise = gpu_change_is_noise(before, after);
  s.identical = before.pixels == after.pixels;
  s.view_changed = !changed_settings(before, after).empty();
  for (const auto& a : after.lights)
    for (const auto& b : before.lights)
      if (a.name == b.name) s.lights.emplace_back(b, a);
  saves_.push_back(std::move(s));
  if (saves_.size() > kMaxSaves) saves_.erase(saves_.begin());
}

void Ui::cycle_heat_light() {
  heat_light_ = heat_light_ + 1 >= int(light_names_.size()) ? -1 : heat_light_ + 1;
}

void Ui::truth_table() {
  if (!baseline_) return;
  if (!ImGui::CollapsingHeader("against the ray-traced truth", ImGuiTreeNodeFlags_DefaultOpen))
    return;
  const std::string shown =
      heat_light_ < 0 ? std::string("the frame")
                      : "error heat map: " + light_names_[std::size_t(heat_light_)];
  if (ImGui::BeginCombo("show (T)", shown.c_str())) {
    if (ImGui::Selectable("the frame", heat_light_ < 0)) heat_light_ = -1;
    for (std::size_t i = 0; i < light_names_.size(); ++i)
      if (ImGui::Selectable(("error heat map: " + light_names_[i]).c_str(), heat_light_ == int(i)))
        heat_light_ = int(i);
    ImGui::EndCombo();
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("too dark against the truth in blue, too light in red, over a grey frame");
  ImGui::Text("at the start: GPU %.3f ms (spread %.3f)", baseline_->frame_ms,
              baseline_->spread_ms);
  if (saves_.empty()) {
    ImGui::TextDisabled("save a shader: each save's deltas appear here");
    return;
  }
  const ImGuiTableFlags flags = ImGuiTableFlags_Borders | ImGuiTableFlags_RowBg |
                                ImGuiTableFlags_SizingFixedFit | ImGuiTableFlags_ScrollX;
  std::size_t rows = 1;
  for (const Save& save : saves_) rows += save.lights.size();
  const float height = ImGui::GetTextLineHeightWithSpacing() * float(rows + 1) +
                       ImGui::GetStyle().ScrollbarSize;
  if (!ImGui::BeginTable("saves", 8, flags, ImVec2(0, height))) return;
  for (const char* h : {"save", "GPU ms", "light", "mean |dV|", "false light %", "false shadow %",
                        "acne %", "gap texels"})
    ImGui::TableSetupColumn(h);
  ImGui::TableHeadersRow();
  for (auto it = saves_.rbegin(); it != saves_.rend(); ++it) {  // the newest first
    for (std::size_t i = 0; i < it->lights.size(); ++i) {
      const auto& [b, a] = it->lights[i];
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      if (i == 0)
        ImGui::TextUnformatted((it->what + (it->identical ? " (image same)" : "") +
                                (it->view_changed ? " (view changed)" : ""))
                                   .c_str());
      if (i == 0 && it->view_changed && ImGui::IsItemHovered())
        ImGui::SetTooltip("the camera or a setting changed since the last snapshot: these deltas "
                          "compare two views, not only the edit");
      ImGui::TableNextColumn();
      if (i == 0) {
        if (it->noise)
          ImGui::TextDisabled("%.3f (noise)", it->ms_after);
        else
          ImGui::Text("%.3f > %.3f", it->ms_before, it->ms_after);
      }
      char dv[64];
      std::snprintf(dv, sizeof dv, "%.5f (%+.5f)", a.mean_abs, a.mean_abs - b.mean_abs);
      const std::string cells[] = {a.name,
                                   dv,
                                   arrow(percent(b.false_light), percent(a.false_light)),
                                   arrow(percent(b.false_shadow), percent(a.false_shadow)),
                                   arrow(percent(b.acne), percent(a.acne)),
                                   arrow(gap(b.gap_texels), gap(a.gap_texels))};
      for (const std::string& c : cells) {
        ImGui::TableNextColumn();
        ImGui::TextUnformatted(c.c_str());
      }
    }
  }
  ImGui::EndTable();
  ImGui::TextWrapped("%s", since_.c_str());
}

void Ui::record(VkCommandBuffer cmd) {
  if (!rendered_) ImGui::Render();
  rendered_ = true;
  ImGui_ImplVulkan_RenderDrawData(ImGui::GetDrawData(), cmd);
}

}  // namespace penumbra::runtime
