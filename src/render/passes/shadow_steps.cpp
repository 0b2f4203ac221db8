// The shadow-map pass's steps: the grid or still copies, the maps drawn from them, the
// moving casters over them (shadow_maps.cpp).
#include "shadow_view.hpp"

namespace penumbra::render::passes {

std::vector<Step> ShadowMapPass::steps(FrameResources& r) {
  std::vector<Step> out;
  for (View& v : views_) {
    // Draws `which` casters into layer l of `target`: the whole layer (cleared first when
    // `clear`), or, with `rects` (layer texels, each with the grid offset of its draw), only
    // those rectangles, cleared first; the rest of the layer is kept. A caster whose bounds
    // cannot reach a rectangle is skipped.
    struct Area {
      VkRect2D rect;
      glm::ivec2 offset;           // the grid texel at layer texel 0 of the draw
      glm::ivec2 grid_lo, grid_hi;  // the rectangle in grid texels
    };
    const auto draw = [this, &r, &v](VkCommandBuffer cmd, gpu::Image& target, uint32_t l,
                                     Casters which, const std::vector<Area>& areas, bool clear) {
      const gpu::GraphicsPipeline* masked = v.caster_bias ? v.masked.get() : v.opaque.get();
      const uint32_t side = target.desc().width;
      // Depth only, stored; loaded unless the whole layer is cleared.
      VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
      depth.imageView = target.layer_view(l);
      depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
      depth.loadOp = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
      depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
      depth.clearValue.depthStencil = {r.reverse_z ? 0.0f : 1.0f, 0};
      VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
      info.renderArea = {{0, 0}, {side, side}};
      info.layerCount = 1;
      info.pDepthAttachment = &depth;
      vkCmdBeginRendering(cmd, &info);
      const float vp_side = float(v.grid() ? v.viewport : side);
      const VkViewport vp{0, 0, vp_side, vp_side, 0, 1};
      vkCmdSetViewport(cmd, 0, 1, &vp);
      if (!clear) {
        std::vector<VkClearRect> clears;
        for (const Area& a : areas) clears.push_back({a.rect, 0, 1});
        VkClearAttachment wipe{VK_IMAGE_ASPECT_DEPTH_BIT, 0, {}};
        wipe.clearValue.depthStencil = {r.reverse_z ? 0.0f : 1.0f, 0};
        if (!clears.empty() && which != Casters::moving)
          vkCmdClearAttachments(cmd, 1, &wipe, uint32_t(clears.size()), clears.data());
      }
      if (!v.draws || v.draws(r.packed, l)) {
        if (v.caster_bias) vkCmdSetDepthBias(cmd, 0.0f, 0.0f, (r.reverse_z ? -1.0f : 1.0f) * 1.0f);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, v.layout->handle(), 0, 1,
                                &v.set, 0, nullptr);
        const std::vector<glm::mat4>& models = v.models[v.slot(l)];
        CasterParts parts;
        parts.take.resize(models.size());
        parts.ranges.resize(models.size());
        for (const Area& a : areas) {
          vkCmdSetScissor(cmd, 0, 1, &a.rect);
          // A caster is drawn where its bounds can reach the rectangle; with the cache, a mesh
          // of several clusters only in those whose own bounds can (in as few ranges as they
          // make). Without the cache, whole meshes from their own indices: the reference the
          // cache's tests compare with.
          const auto reaches = [&](const scene::Bounds& b) {
            if (!v.touches(r.packed, l, a.grid_lo, a.grid_hi, b)) return false;
            if (!v.rect) return true;
            const glm::ivec4 t = v.rect(r.packed, l, b);
            return t.x < a.grid_hi.x && t.z > a.grid_lo.x && t.y < a.grid_hi.y &&
                   t.w > a.grid_lo.y;
          };
          for (size_t i = 0; i < models.size(); ++i) {
            std::vector<IndexRange>& ranges = parts.ranges[i];
            ranges.clear();
            parts.take[i] = reaches(v.bounds[i]) ? 1 : 0;
            const std::vector<scene::Bounds>& cb = cluster_bounds_[i];
            if (!parts.take[i] || cb.empty()) continue;
            const std::vector<Cluster>& clusters = r.meshes[r.packed.draws[i].mesh].clusters;
            for (size_t c = 0; c < cb.size(); ++c) {
              if (!reaches(cb[c])) continue;
              const Cluster& k = clusters[c];
              if (!ranges.empty() && ranges.back().first + ranges.back().count == k.first_index)
                ranges.back().count += k.index_count;
              else
                ranges.push_back({k.first_index, k.index_count});
            }
            parts.take[i] = ranges.empty() ? 0 : 1;
          }
          glm::uvec4 index = v.index(l);
          if (v.grid()) index.y = uint32_t(a.offset.x) | (uint32_t(a.offset.y) << 16);
          stats_.triangles_drawn +=
              draw_casters(cmd, r, *v.layout, v.opaque->handle(),
                           masked ? masked->handle() : VK_NULL_HANDLE, index, models, which,
                           &parts) /
              3;
        }
      }
      vkCmdEndRendering(cmd);
    };
    // A grid rectangle [lo, hi) as the areas of the grid image it lies in: split where it wraps
    // (grid texel g at layer texel g mod n), each drawn with the offset that puts it there.
    const auto wrapped = [&v](glm::ivec2 lo, glm::ivec2 hi) {
      const int n = int(v.target->desc().width);
      std::vector<Area> areas;
      for (int ky = lo.y / n; ky * n < hi.y; ++ky)
        for (int kx = lo.x / n; kx * n < hi.x; ++kx) {
          const glm::ivec2 k0(kx * n, ky * n);
          const glm::ivec2 a = glm::max(lo, k0), b = glm::min(hi, k0 + n);
          if (a.x >= b.x || a.y >= b.y) continue;
          areas.push_back({{{a.x - k0.x, a.y - k0.y}, {uint32_t(b.x - a.x), uint32_t(b.y - a.y)}},
                           k0, a, b});
        }
      return areas;
    };
    // The whole layer of the map itself (its own window) or of a spot or point base.
    const auto whole = [&v](uint32_t l) {
      const uint32_t n = v.target->desc().width;
      const glm::ivec2 w = v.window.empty() ? glm::ivec2(0) : v.window[l];
      return std::vector<Area>{{{{0, 0}, {n, n}}, w, w, w + glm::ivec2(int(n))}};
    };
    gpu::Image& base = v.base();
    const std::string base_label = v.base_label();
    const bool separate = v.has_base();
    if (v.scroll && separate) {
      // A cascade drawn straight into the map and now scrolling: the map (last frame's, laid
      // out as the grid) copied back into the grid first.
      out.push_back({v.name + "-sync",
                     {{v.image, v.target, Use::copy_source, true},
                      {base_label, &base, Use::copy_target}},
                     [&v, &base](VkCommandBuffer cmd) {
                       std::vector<VkImageCopy> regions;
                       const gpu::ImageDesc& d = v.target->desc();
                       for (uint32_t l = 0; l < v.sync.size(); ++l) {
                         if (!v.sync[l]) continue;
                         VkImageCopy c{};
                         c.srcSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, l, 1};
                         c.dstSubresource = c.srcSubresource;
                         c.extent = {d.width, d.height, 1};
                         regions.push_back(c);
                       }
                       if (!regions.empty())
                         vkCmdCopyImage(cmd, v.target->handle(),
                                        VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, base.handle(),
                                        VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                        uint32_t(regions.size()), regions.data());
                     },
                     {}});
    }
    // The base: layers drawn whole, and the strips a cascade newly reaches. A map the frame's
    // only step writes is declared its target, whatever of it the cache keeps (its layout is
    // kept with its texels: Image::transition).
    Step base_step{separate ? v.name + (v.scroll ? "-grid" : "-still") : v.name,
                   {{base_label, &base,
                     v.scroll && separate ? Use::depth_modify : Use::depth_target}},
                   {},
                   separate ? std::string() : v.name};
    base_step.record = [&v, &base, draw, wrapped, whole](VkCommandBuffer cmd) {
      // The still casters into a base of their own; into the map itself, every caster.
      const Casters which = v.moving && v.has_base() ? Casters::still : Casters::all;
      const int n = int(v.target->desc().width);
      for (uint32_t l = 0; l < v.base_plan.size(); ++l) {
        if (v.base_plan[l] == View::Base::draw) {
          draw(cmd, base, l, which,
               v.grid() ? wrapped(v.window[l], v.window[l] + glm::ivec2(n)) : whole(l), true);
          continue;
        }
        // The strips a cascade newly reaches, and where moving casters were or are.
        std::vector<glm::ivec4> rects;
        if (v.base_plan[l] == View::Base::strips) rects = v.strips[l];
        if (!v.dirty.empty()) rects.insert(rects.end(), v.dirty[l].begin(), v.dirty[l].end());
        std::vector<Area> areas;
        for (const glm::ivec4& s : rects)
          for (const Area& a : wrapped(glm::ivec2(s.x, s.y), glm::ivec2(s.z, s.w)))
            areas.push_back(a);
        if (!areas.empty()) draw(cmd, base, l, which, areas, false);
      }
    };
    out.push_back(std::move(base_step));
    if (!separate) continue;
    // The map: the sun's window drawn out of its grid (a triangle per layer writing each
    // texel's stored depth: a depth-image copy costs several times more on some GPUs), a spot
    // or point map copied from its still copy; then the moving casters drawn over it.
    if (v.window_by_draw) {
      out.push_back({v.name + "-window",
                     {{base_label, &base, Use::sampled}, {v.image, v.target, Use::depth_target}},
                     [&v](VkCommandBuffer cmd) {
                       const int n = int(v.target->desc().width);
                       for (uint32_t l = 0; l < v.restore.size(); ++l) {
                         if (!v.restore[l]) continue;
                         VkRenderingAttachmentInfo depth{
                             VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
                         depth.imageView = v.target->layer_view(l);
                         depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
                         depth.loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
                         depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
                         VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
                         info.renderArea = {{0, 0}, {uint32_t(n), uint32_t(n)}};
                         info.layerCount = 1;
                         info.pDepthAttachment = &depth;
                         vkCmdBeginRendering(cmd, &info);
                         const VkViewport vp{0, 0, float(n), float(n), 0, 1};
                         vkCmdSetViewport(cmd, 0, 1, &vp);
                         vkCmdSetScissor(cmd, 0, 1, &info.renderArea);
                         vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS,
                                           v.window_pipeline->handle());
                         vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS,
                                                 v.window_layout->handle(), 0, 1, &v.window_set,
                                                 0, nullptr);
                         const glm::ivec4 push(int(l), v.window[l].x % n, v.window[l].y % n, n);
                         vkCmdPushConstants(cmd, v.window_layout->handle(),
                                            VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push), &push);
                         vkCmdDraw(cmd, 3, 1, 0, 0);
                         vkCmdEndRendering(cmd);
                       }
                     },
                     {}});
    } else {
      // A copy: the grid's window in up to four parts (it wraps), a still copy whole.
      out.push_back({v.name + "-copy",
                     {{base_label, &base, Use::copy_source}, {v.image, v.target, Use::copy_target}},
                     [&v, &base, wrapped](VkCommandBuffer cmd) {
                       std::vector<VkImageCopy> regions;
                       const int n = int(v.target->desc().width);
                       for (uint32_t l = 0; l < v.restore.size(); ++l) {
                         if (!v.restore[l]) continue;
                         const glm::ivec2 w = v.grid() ? v.window[l] : glm::ivec2(0);
                         // Read in place, the map keeps the grid's layout: the window whole,
                         // or the strips the grid newly drew, each where it lies.
                         for (const Area& a : wrapped(w, w + glm::ivec2(n))) {
                           VkImageCopy c{};
                           c.srcSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, l, 1};
                           c.dstSubresource = c.srcSubresource;
                           c.srcOffset = {a.rect.offset.x, a.rect.offset.y, 0};
                           c.dstOffset = {a.grid_lo.x - w.x, a.grid_lo.y - w.y, 0};
                           c.extent = {a.rect.extent.width, a.rect.extent.height, 1};
                           regions.push_back(c);
                         }
                       }
                       if (!regions.empty())
                         vkCmdCopyImage(cmd, base.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                                        v.target->handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                        uint32_t(regions.size()), regions.data());
                     },
                     v.moving || v.grid() ? std::string() : v.name});
    }
    if (v.scroll && !v.moving) {
      // Cascades drawn whole straight into the map (their window on a whole map of the grid).
      Step direct{v.name, {{v.image, v.target, Use::depth_modify}}, {}, v.name};
      direct.record = [&v, draw, whole](VkCommandBuffer cmd) {
        for (uint32_t l = 0; l < v.direct.size(); ++l)
          if (v.direct[l]) draw(cmd, *v.target, l, Casters::all, whole(l), true);
      };
      out.push_back(std::move(direct));
    }
    if (!v.moving) continue;
    Step step{v.name, {{v.image, v.target, Use::depth_modify}}, {}, v.name};
    step.record = [&v, draw, whole](VkCommandBuffer cmd) {
      for (uint32_t l = 0; l < v.restore.size(); ++l)
        if (v.restore[l]) draw(cmd, *v.target, l, Casters::moving, whole(l), false);
    };
    out.push_back(std::move(step));
  }
  return out;
}

}  // namespace penumbra::render::passes
