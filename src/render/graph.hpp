#pragma once

// The frame graph (internal to penumbra::render). Every pass is a list of steps; each step
// declares the images it reads and writes and how (a sampled read, a storage write, a colour
// target, a copy source, ...). From those declarations alone the graph
//   - orders the steps: a step that writes an image whole comes before the steps that modify it
//     in place, and those before the steps that read it; a step reading the last frame's
//     contents of an image (a history) comes before this frame's writer. Steps the declarations
//     do not order keep the order they were given in;
//   - refuses, when it is built, a step that reads an image no step writes, an image two steps
//     write whole, and a cycle, naming the steps and the image;
//   - records, before each step, the layout change and barrier each image needs: when its
//     layout differs from the one the use needs, when the step writes it, or when a step wrote
//     it since its last barrier.
// No pass moves an image itself. docs/architecture.md shows a frame's graph.

#include <functional>
#include <map>
#include <penumbra/gpu/resources.hpp>
#include <string>
#include <vector>

namespace penumbra::render::passes {

enum class Use {
  sampled,         // read through a sampler (SHADER_READ_ONLY_OPTIMAL)
  storage_write,   // written whole as a storage image (GENERAL)
  storage_modify,  // read and written in place as a storage image (GENERAL)
  color_target,    // written as a colour attachment
  depth_target,    // written as a depth attachment
  depth_modify,    // drawn over as a depth attachment, its contents loaded (modified in place)
  depth_test,      // a read-only depth attachment (DEPTH_READ_ONLY_OPTIMAL)
  copy_source,     // read by a transfer (TRANSFER_SRC_OPTIMAL)
  copy_target,     // written whole by a transfer (TRANSFER_DST_OPTIMAL)
};

VkImageLayout layout_for(Use use);
bool use_reads(Use use);
bool use_writes(Use use);
const char* use_name(Use use);  // "sampled", "storage write", ...

struct ImageUse {
  std::string name;  // the image's name in the build report ("shadow-info")
  gpu::Image* image = nullptr;
  Use use = Use::sampled;
  // A read of what this image held at the end of the last frame (a history a later step of
  // this frame overwrites), not of anything this frame wrote.
  bool last_frame = false;
};

struct Step {
  std::string name;
  std::vector<ImageUse> images;
  std::function<void(VkCommandBuffer)> record;  // the step's commands, without barriers
  std::string mark;                             // the timestamp written after it; empty: none
};

// Told of every barrier the graph records: the image's name and the layout it moves to.
using BarrierLog = std::function<void(const std::string& image, VkImageLayout layout)>;

class FrameGraph {
 public:
  FrameGraph() = default;
  // Orders the steps and checks their declarations (see above); throws penumbra::Error.
  // `inputs`: images the caller wrote before the graph runs (a pass used on its own).
  explicit FrameGraph(std::vector<Step> steps, const std::vector<const gpu::Image*>& inputs = {});

  // Records every step, in order, each after its barriers; `mark` is called with a step's mark
  // after its commands.
  void record(VkCommandBuffer cmd, const std::function<void(const std::string&)>& mark,
              const BarrierLog& log = {});
  // Moves images into the layouts of uses that come after the graph (e.g. what the caller of a
  // pass samples next), with the barriers they need.
  void finish(VkCommandBuffer cmd, const std::vector<ImageUse>& uses, const BarrierLog& log = {});

  const std::vector<Step>& steps() const { return steps_; }
  // One line per step, in order: "shadow-resolve: reads depth (sampled), ...; writes
  // shadow-info (storage write)".
  std::vector<std::string> describe() const;

 private:
  void prepare(VkCommandBuffer cmd, const ImageUse& use, const BarrierLog& log);
  std::vector<Step> steps_;
  // Images written since their last barrier. An image the graph has not seen yet is taken to be
  // visible in the layout it is in (whoever moved it there made its writes visible).
  std::map<const gpu::Image*, bool> dirty_;
};

// "GENERAL", "SHADER_READ_ONLY", ... (for logs).
const char* layout_name(VkImageLayout layout);

}  // namespace penumbra::render::passes
