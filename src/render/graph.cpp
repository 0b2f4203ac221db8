// The frame graph: steps ordered and their barriers derived from the images they declare
// (graph.hpp).

#include "graph.hpp"

#include <algorithm>
#include <penumbra/core/error.hpp>
#include <set>

namespace penumbra::render::passes {

VkImageLayout layout_for(Use use) {
  switch (use) {
    case Use::sampled:
      return VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    case Use::storage_write:
    case Use::storage_modify:
      return VK_IMAGE_LAYOUT_GENERAL;
    case Use::color_target:
      return VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    case Use::depth_target:
    case Use::depth_modify:
      return VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    case Use::depth_test:
      return VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL;
    case Use::copy_source:
      return VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    case Use::copy_target:
      return VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  }
  return VK_IMAGE_LAYOUT_GENERAL;
}

bool use_reads(Use use) {
  return use == Use::sampled || use == Use::storage_modify || use == Use::depth_test ||
         use == Use::copy_source || use == Use::depth_modify;
}

bool use_writes(Use use) {
  return !use_reads(use) || use == Use::storage_modify || use == Use::depth_modify;
}

const char* use_name(Use use) {
  switch (use) {
    case Use::sampled:
      return "sampled";
    case Use::storage_write:
      return "storage write";
    case Use::storage_modify:
      return "storage read-write";
    case Use::color_target:
      return "colour target";
    case Use::depth_target:
      return "depth target";
    case Use::depth_modify:
      return "depth target, loaded";
    case Use::depth_test:
      return "depth test";
    case Use::copy_source:
      return "copy source";
    case Use::copy_target:
      return "copy target";
  }
  return "?";
}

const char* layout_name(VkImageLayout layout) {
  switch (layout) {
    case VK_IMAGE_LAYOUT_GENERAL:
      return "GENERAL";
    case VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL:
      return "SHADER_READ_ONLY";
    case VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL:
      return "COLOR_ATTACHMENT";
    case VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL:
      return "DEPTH_ATTACHMENT";
    case VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL:
      return "DEPTH_READ_ONLY";
    case VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL:
      return "TRANSFER_SRC";
    case VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL:
      return "TRANSFER_DST";
    default:
      return "OTHER";
  }
}

namespace {

// Whether the use writes the image whole (its earlier contents do not matter).
bool produces(Use use) {
  return use_writes(use) && !use_reads(use);
}

std::string quoted(const std::string& s) {
  return "'" + s + "'";
}

// The dependencies the declarations imply: edges[a] holds the steps that must come after a.
std::vector<std::set<size_t>> dependencies(const std::vector<Step>& steps,
                                           const std::vector<const gpu::Image*>& inputs) {
  struct Uses {
    std::string name;
    std::vector<size_t> producers, modifiers, readers, last_frame;
  };
  std::map<const gpu::Image*, Uses> images;
  std::vector<const gpu::Image*> order;  // first declaration order, for stable messages
  for (size_t s = 0; s < steps.size(); ++s) {
    std::set<const gpu::Image*> seen;
    for (const ImageUse& u : steps[s].images) {
      if (!u.image)
        throw Error("frame graph: step " + quoted(steps[s].name) + " declares image " +
                    quoted(u.name) + " that does not exist");
      if (!seen.insert(u.image).second)
        throw Error("frame graph: step " + quoted(steps[s].name) + " declares image " +
                    quoted(u.name) + " twice; one step uses an image one way");
      auto [it, fresh] = images.try_emplace(u.image);
      if (fresh) {
        it->second.name = u.name;
        order.push_back(u.image);
      }
      Uses& i = it->second;
      if (u.last_frame) {
        if (use_writes(u.use))
          throw Error("frame graph: step " + quoted(steps[s].name) + " writes " + quoted(u.name) +
                      " as the last frame's; only reads can be of it");
        i.last_frame.push_back(s);
      } else if (produces(u.use)) {
        i.producers.push_back(s);
      } else if (u.use == Use::storage_modify || u.use == Use::depth_modify) {
        i.modifiers.push_back(s);
      } else {
        i.readers.push_back(s);
      }
    }
  }
  std::vector<std::set<size_t>> after(steps.size());
  auto edge = [&](size_t a, size_t b) {
    if (a != b) after[a].insert(b);
  };
  for (const gpu::Image* image : order) {
    const Uses& i = images.at(image);
    if (i.producers.size() > 1)
      throw Error("frame graph: image " + quoted(i.name) + " is written whole by both " +
                  quoted(steps[i.producers[0]].name) + " and " +
                  quoted(steps[i.producers[1]].name) +
                  "; the later one must declare it read-write, or write an image of its own");
    const bool input = std::find(inputs.begin(), inputs.end(), image) != inputs.end();
    const bool written = input || !i.producers.empty() || !i.modifiers.empty();
    for (size_t s : i.modifiers)
      if (i.producers.empty() && !input)
        throw Error("frame graph: step " + quoted(steps[s].name) + " modifies image " +
                    quoted(i.name) + ", which no earlier step writes");
    for (size_t s : i.readers)
      if (!written)
        throw Error("frame graph: step " + quoted(steps[s].name) + " reads image " +
                    quoted(i.name) + ", which no step writes");
    for (size_t s : i.last_frame)
      if (!written)
        throw Error("frame graph: step " + quoted(steps[s].name) + " reads the last frame's " +
                    quoted(i.name) + ", which no step writes");
    // producer -> modifiers (in the order given) -> readers; last-frame readers before all.
    std::vector<size_t> chain = i.producers;
    chain.insert(chain.end(), i.modifiers.begin(), i.modifiers.end());
    for (size_t k = 1; k < chain.size(); ++k) edge(chain[k - 1], chain[k]);
    if (!chain.empty())
      for (size_t r : i.readers) edge(chain.back(), r);
    for (size_t l : i.last_frame)
      for (size_t w : chain) edge(l, w);
  }
  return after;
}

}  // namespace

FrameGraph::FrameGraph(std::vector<Step> steps, const std::vector<const gpu::Image*>& inputs) {
  const auto after = dependencies(steps, inputs);
  std::vector<size_t> waiting(steps.size(), 0);
  for (const auto& next : after)
    for (size_t b : next) ++waiting[b];
  // Kahn's order, taking the first ready step in the order given.
  std::set<size_t> ready;
  for (size_t s = 0; s < steps.size(); ++s)
    if (waiting[s] == 0) ready.insert(s);
  std::vector<size_t> order;
  while (!ready.empty()) {
    const size_t s = *ready.begin();
    ready.erase(ready.begin());
    order.push_back(s);
    for (size_t b : after[s])
      if (--waiting[b] == 0) ready.insert(b);
  }
  if (order.size() != steps.size()) {
    std::string cycle;
    for (size_t s = 0; s < steps.size(); ++s)
      if (waiting[s] > 0) cycle += (cycle.empty() ? "" : ", ") + quoted(steps[s].name);
    throw Error("frame graph: the images these steps declare order them in a cycle: " + cycle);
  }
  for (size_t s : order) steps_.push_back(std::move(steps[s]));
}

void FrameGraph::prepare(VkCommandBuffer cmd, const ImageUse& use, const BarrierLog& log) {
  gpu::Image& image = *use.image;
  const VkImageLayout layout = layout_for(use.use);
  bool& dirty = dirty_[&image];
  if (image.layout() != layout || dirty || use_writes(use.use)) {
    image.transition(cmd, layout);
    if (log) log(use.name, layout);
  }
  dirty = use_writes(use.use);
}

void FrameGraph::record(VkCommandBuffer cmd, const std::function<void(const std::string&)>& mark,
                        const BarrierLog& log) {
  for (Step& step : steps_) {
    for (const ImageUse& use : step.images) prepare(cmd, use, log);
    step.record(cmd);
    if (!step.mark.empty() && mark) mark(step.mark);
  }
}

void FrameGraph::finish(VkCommandBuffer cmd, const std::vector<ImageUse>& uses,
                        const BarrierLog& log) {
  for (const ImageUse& use : uses) prepare(cmd, use, log);
}

std::vector<std::string> FrameGraph::describe() const {
  std::vector<std::string> lines;
  for (const Step& step : steps_) {
    std::string reads, writes;
    for (const ImageUse& u : step.images) {
      std::string& list = use_writes(u.use) ? writes : reads;
      list += (list.empty() ? "" : ", ") + u.name + " (" + use_name(u.use) +
              (u.last_frame ? ", the last frame's" : "") + ")";
    }
    std::string line = step.name + ":";
    if (!reads.empty()) line += " reads " + reads;
    if (!writes.empty()) line += std::string(reads.empty() ? "" : ";") + " writes " + writes;
    lines.push_back(line);
  }
  return lines;
}

}  // namespace penumbra::render::passes
