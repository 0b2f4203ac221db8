// The frame graph (src/render/graph.hpp): the order it derives from the images each step
// declares, the declarations it refuses when it is built, and the barriers it records.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <graph.hpp>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/commands.hpp>
#include <penumbra/testing/gpu_test.hpp>
#include <string>
#include <vector>

namespace penumbra::render::passes {
namespace {

using penumbra::testing::GpuTest;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

Step step(const std::string& name, std::vector<ImageUse> images) {
  return {name, std::move(images), [](VkCommandBuffer) {}, {}};
}

std::vector<std::string> names(const FrameGraph& g) {
  std::vector<std::string> out;
  for (const Step& s : g.steps()) out.push_back(s.name);
  return out;
}

std::string build_error(std::vector<Step> steps) {
  try {
    FrameGraph g(std::move(steps));
  } catch (const Error& e) {
    return e.what();
  }
  return "(built)";
}

// The images below only give the steps something to point at: ordering and refusals never touch
// the device.
TEST(FrameGraph, OrdersWritersBeforeModifiersBeforeReaders) {
  gpu::Image depth, info, out, other;
  FrameGraph g(
      {step("tonemap", {{"info", &info, Use::sampled}, {"out", &out, Use::storage_write}}),
       step("spheres", {{"depth", &depth, Use::sampled}, {"info", &info, Use::storage_modify}}),
       step("unrelated", {{"other", &other, Use::storage_write}}),
       step("resolve", {{"depth", &depth, Use::sampled}, {"info", &info, Use::storage_write}}),
       step("prepass", {{"depth", &depth, Use::depth_target}})});
  EXPECT_THAT(names(g), ElementsAre("unrelated", "prepass", "resolve", "spheres", "tonemap"));
}

TEST(FrameGraph, KeepsTheGivenOrderWhereTheImagesDoNotDecide) {
  gpu::Image a, b, c;
  FrameGraph g({step("first", {{"a", &a, Use::storage_write}}),
                step("second", {{"b", &b, Use::storage_write}}),
                step("third", {{"a", &a, Use::sampled}, {"c", &c, Use::storage_write}}),
                step("fourth", {{"a", &a, Use::copy_source}})});
  EXPECT_THAT(names(g), ElementsAre("first", "second", "third", "fourth"));
}

TEST(FrameGraph, AReadOfTheLastFrameComesBeforeThisFramesWriter) {
  gpu::Image history, current;
  FrameGraph g({step("keep", {{"current", &current, Use::copy_source},
                              {"history", &history, Use::copy_target}}),
                step("blend", {{"history", &history, Use::sampled, true},
                               {"current", &current, Use::storage_write}})});
  EXPECT_THAT(names(g), ElementsAre("blend", "keep"));
}

TEST(FrameGraph, RefusesAReadOfAnImageNoStepWrites) {
  gpu::Image depth, info;
  const std::string e = build_error(
      {step("resolve", {{"depth", &depth, Use::sampled}, {"info", &info, Use::storage_write}}),
       step("tonemap", {{"info", &info, Use::sampled}})});
  EXPECT_THAT(e, HasSubstr("step 'resolve' reads image 'depth', which no step writes"));
  // The same read is fine once a step writes it, or when the caller wrote it before the graph.
  EXPECT_NO_THROW(FrameGraph({step("resolve", {{"depth", &depth, Use::sampled}})}, {&depth}));
  gpu::Image history;
  EXPECT_THAT(build_error({step("blend", {{"history", &history, Use::sampled, true}})}),
              HasSubstr("reads the last frame's 'history', which no step writes"));
  EXPECT_THAT(build_error({step("spheres", {{"info", &info, Use::storage_modify}})}),
              HasSubstr("step 'spheres' modifies image 'info', which no earlier step writes"));
}

TEST(FrameGraph, RefusesTwoWholeWritersACycleAndDoubleDeclarations) {
  gpu::Image a, b;
  EXPECT_THAT(build_error({step("one", {{"a", &a, Use::storage_write}}),
                           step("two", {{"a", &a, Use::color_target}})}),
              HasSubstr("image 'a' is written whole by both 'one' and 'two'"));
  EXPECT_THAT(build_error({step("one", {{"a", &a, Use::storage_write}, {"b", &b, Use::sampled}}),
                           step("two", {{"b", &b, Use::storage_write}, {"a", &a, Use::sampled}})}),
              HasSubstr("order them in a cycle: 'one', 'two'"));
  EXPECT_THAT(build_error({step("one", {{"a", &a, Use::storage_write}, {"a", &a, Use::sampled}})}),
              HasSubstr("step 'one' declares image 'a' twice"));
  EXPECT_THAT(build_error({step("one", {{"gone", nullptr, Use::storage_write}})}),
              HasSubstr("declares image 'gone' that does not exist"));
  EXPECT_THAT(build_error({step("one", {{"a", &a, Use::storage_write, true}})}),
              HasSubstr("writes 'a' as the last frame's"));
}

class FrameGraphGpu : public GpuTest {};

// A write, two reads in one layout, a read in another layout, a modify: a barrier wherever the
// layout changes or a write comes before, none between the two reads; and the next frame's
// write orders itself after this frame's reads.
TEST_F(FrameGraphGpu, RecordsTheBarriersTheDeclarationsNeed) {
  gpu::ImageDesc d;
  d.format = VK_FORMAT_R8G8B8A8_UNORM;
  d.width = d.height = 4;
  d.usage =
      VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  gpu::Image img(ctx(), d);
  std::vector<std::string> log, marks;
  FrameGraph g({step("write", {{"img", &img, Use::storage_write}}),
                step("read-1", {{"img", &img, Use::sampled}}),
                step("read-2", {{"img", &img, Use::sampled}}),
                step("copy", {{"img", &img, Use::copy_source}})});
  const BarrierLog barrier = [&](const std::string& image, VkImageLayout layout) {
    log.push_back(image + " -> " + layout_name(layout));
  };
  for (int frame = 0; frame < 2; ++frame)
    gpu::submit_one_shot(ctx(), [&](VkCommandBuffer cmd) {
      g.record(
          cmd, [&](const std::string& m) { marks.push_back(m); }, barrier);
    });
  EXPECT_THAT(log, ElementsAre("img -> GENERAL", "img -> SHADER_READ_ONLY", "img -> TRANSFER_SRC",
                               "img -> GENERAL", "img -> SHADER_READ_ONLY", "img -> TRANSFER_SRC"));
  EXPECT_EQ(img.layout(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
  // finish() moves an image on for whoever uses it next.
  log.clear();
  gpu::submit_one_shot(ctx(), [&](VkCommandBuffer cmd) {
    g.finish(cmd, {{"img", &img, Use::sampled}}, barrier);
  });
  EXPECT_THAT(log, ElementsAre("img -> SHADER_READ_ONLY"));

  // A step that modifies in place after a write in the same layout still gets its barrier.
  gpu::Image other(ctx(), d);
  log.clear();
  FrameGraph m({step("write", {{"other", &other, Use::storage_write}}),
                step("modify", {{"other", &other, Use::storage_modify}})});
  gpu::submit_one_shot(ctx(), [&](VkCommandBuffer cmd) { m.record(cmd, {}, barrier); });
  EXPECT_THAT(log, ElementsAre("other -> GENERAL", "other -> GENERAL"));
}

}  // namespace
}  // namespace penumbra::render::passes
