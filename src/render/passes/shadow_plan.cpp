// The shadow-map pass's plan of a frame: each layer's keys, and whether its base is kept,
// drawn whole or drawn in the strips a scrolled cascade newly reaches (shadow_maps.cpp).
#include <algorithm>
#include <cstdlib>

#include "shadow_view.hpp"

namespace penumbra::render::passes {

namespace {

// The smallest rectangle (x0, y0, x1, y1) holding both (an empty one, x0 >= x1 or y0 >= y1,
// holds nothing), and the common part of two.
glm::ivec4 unite(glm::ivec4 a, glm::ivec4 b) {
  const bool a_empty = a.x >= a.z || a.y >= a.w, b_empty = b.x >= b.z || b.y >= b.w;
  if (a_empty) return b;
  if (b_empty) return a;
  return glm::ivec4(glm::min(glm::ivec2(a), glm::ivec2(b)),
                    glm::max(glm::ivec2(a.z, a.w), glm::ivec2(b.z, b.w)));
}
glm::ivec4 intersect(glm::ivec4 a, glm::ivec4 b) {
  const glm::ivec2 lo = glm::max(glm::ivec2(a), glm::ivec2(b));
  const glm::ivec2 hi = glm::max(lo, glm::min(glm::ivec2(a.z, a.w), glm::ivec2(b.z, b.w)));
  return glm::ivec4(lo, hi);
}

// The grid rectangles (x0, y0, x1, y1) a window [to, to + n) covers that [from, from + n) did not.
std::vector<glm::ivec4> newly_covered(glm::ivec2 from, glm::ivec2 to, int n) {
  std::vector<glm::ivec4> out;
  const glm::ivec2 m = to - from;
  if (m.x > 0) out.emplace_back(from.x + n, to.y, to.x + n, to.y + n);
  if (m.x < 0) out.emplace_back(to.x, to.y, from.x, to.y + n);
  if (m.y > 0) out.emplace_back(to.x, from.y + n, to.x + n, to.y + n);
  if (m.y < 0) out.emplace_back(to.x, to.y, to.x + n, from.y);
  return out;
}

}  // namespace

void ShadowMapPass::prepare(FrameResources& r) {
  const PackedFrame& f = r.packed;
  stats_ = {};
  // Each caster's bounds this frame (the draws are the scene's instances, in order).
  const std::vector<scene::Bounds> bounds = r.scene.instance_world_bounds();
  // Each caster's clusters' bounds, shared by every view (none without the cache: whole meshes).
  cluster_bounds_.assign(f.draws.size(), {});
  for (size_t i = 0; cache_ && i < f.draws.size() && i < r.scene.instances.size(); ++i) {
    const std::vector<Cluster>& clusters = r.meshes[f.draws[i].mesh].clusters;
    if (clusters.size() < 2 || !f.draws[i].in_maps) continue;
    for (const Cluster& c : clusters)
      cluster_bounds_[i].push_back(
          scene::transform_bounds(c.bounds, r.scene.instances[i].transform));
  }
  for (View& v : views_) {
    View::Packed packed = v.pack(f);
    v.draw_ubo.write(std::span(packed.bytes));
    v.window = std::move(packed.windows);
    v.bounds = bounds;
    v.models.assign(packed.anchors.size(), {});
    for (size_t s = 0; s < packed.anchors.size(); ++s) {
      v.models[s].resize(f.draws.size());
      for (size_t i = 0; i < f.draws.size(); ++i) {
        glm::dmat4 m = f.draws[i].world;
        m[3] -= glm::dvec4(packed.anchors[s], 0.0);
        v.models[s][i] = glm::mat4(m);
      }
    }
    const uint32_t layers = v.layers(f);
    const int side = int(v.target->desc().width);
    const uint64_t texels = uint64_t(side) * uint64_t(side);
    v.base_key.resize(layers, 0);
    v.map_key.resize(layers, 0);
    v.base_window.resize(layers, glm::ivec2(0));
    v.base_plan.assign(layers, View::Base::draw);
    v.strips.assign(layers, {});
    v.restore.assign(layers, v.has_base() ? 1 : 0);
    v.direct.assign(layers, 0);
    v.sync.assign(layers, 0);
    v.in_map.resize(layers, 0);
    v.redrawn.assign(layers, glm::uvec4(0));
    v.dirty.assign(layers, {});
    v.reach.resize(layers);
    stats_.layers += layers;
    for (uint32_t l = 0; l < layers; ++l) {
      // The base's key: what its texels depend on besides the window: the grid or matrices, the
      // still casters with their transforms (as drawn) and materials, the pipelines.
      Hash common;
      common.add(generation_);
      common.add(r.reverse_z);
      const auto [offset, size] = v.span(l);
      common.bytes(packed.bytes.data() + offset, size);
      common.add(!v.draws || v.draws(f, l));
      Hash base = common, moving = common;
      // The moving casters are drawn into the map through its window, unless it keeps the
      // base's layout.
      if (!v.same_layout()) moving.add(v.window[l]);
      bool any_moving = false;
      std::vector<View::Reach> reach;  // where the moving casters reach (same layout)
      const std::vector<glm::mat4>& models = v.models[v.slot(l)];
      for (size_t i = 0; i < f.draws.size(); ++i) {
        const Draw& d = f.draws[i];
        if (!d.in_maps) continue;
        const bool moves = v.moving && d.moves;
        // A moving caster counts where its bounds reach the layer this frame.
        if (moves &&
            !v.touches(f, l, v.window[l], v.window[l] + glm::ivec2(side), bounds[i]))
          continue;
        any_moving = any_moving || moves;
        Hash caster;
        caster.add(i);
        caster.add(models[i]);
        caster.add(d.mesh);
        caster.add(d.masked);
        caster.add(d.push.mask);
        caster.add(d.mask_texture);
        if (moves && v.same_layout()) reach.push_back({i, v.rect(f, l, bounds[i]), caster.h});
        (moves ? moving : base).add(caster.h);
      }
      View::Base plan = View::Base::draw;
      const glm::ivec2 move = v.window[l] - v.base_window[l];
      if (cache_ && base.h == v.base_key[l]) {
        const bool near = std::abs(move.x) < side && std::abs(move.y) < side;
        plan = move == glm::ivec2(0) ? View::Base::keep
               : near && v.scroll    ? View::Base::strips
                                     : View::Base::draw;
      }
      v.base_plan[l] = plan;
      if (plan == View::Base::draw) v.redrawn[l].x = shadow::kRedrawnWhole;
      if (plan == View::Base::strips)
        v.redrawn[l] = glm::uvec4(shadow::kRedrawnStrips, uint32_t(move.x), uint32_t(move.y), 0);
      if (plan == View::Base::strips) v.strips[l] = newly_covered(v.base_window[l], v.window[l], side);
      v.base_key[l] = base.h;
      v.base_window[l] = v.window[l];
      if (plan == View::Base::draw) {
        ++stats_.drawn;
        stats_.texels_drawn += texels;
      } else if (plan == View::Base::strips) {
        ++stats_.scrolled;
        stats_.texels_drawn +=
            texels - uint64_t(side - std::abs(move.x)) * uint64_t(side - std::abs(move.y));
      }
      if (v.scroll && !v.moving && !v.in_place) {
        const bool aligned = v.window[l].x % side == 0 && v.window[l].y % side == 0;
        if (plan == View::Base::draw && aligned) {
          v.direct[l] = 1;
          v.in_map[l] = 1;
          v.base_plan[l] = View::Base::keep;
          v.restore[l] = 0;
          v.map_key[l] = 0;
          continue;
        }
        if (plan == View::Base::strips && v.in_map[l]) v.sync[l] = 1;
        if (plan != View::Base::keep) v.in_map[l] = 0;
        if (v.in_map[l]) {  // kept, and the map holds it
          v.restore[l] = 0;
          continue;
        }
      }
      Hash full = moving;
      full.add(base.h);
      if (v.same_layout()) {
        // No base: what changed is drawn again in the map where it lies: the whole layer, the
        // strips the cascade newly reaches, and for each moving caster drawn otherwise than last
        // frame (or come, or gone) the rectangle where it was (in what is still the window) and
        // is, every caster that reaches it drawn there (a held caster a scroll reaches into is
        // drawn with the rest in its strips).
        const glm::ivec4 window(v.window[l], v.window[l] + glm::ivec2(side));
        std::vector<View::Reach> was = std::move(v.reach[l]);
        v.reach[l] = reach;
        if (cache_ && plan != View::Base::draw && full.h != v.map_key[l]) {
          const auto redraw = [&](glm::ivec4 d) {
            if (d.x >= d.z || d.y >= d.w) return;
            v.dirty[l].push_back(d);
            stats_.texels_drawn += uint64_t(d.z - d.x) * uint64_t(d.w - d.y);
          };
          for (const View::Reach& now : reach) {
            const auto before = std::find_if(was.begin(), was.end(), [&](const View::Reach& w) {
              return w.caster == now.caster;
            });
            if (before == was.end()) {
              redraw(unite(intersect(before->rect, window), now.rect));
            } else {
              if (before->key != now.key) redraw(unite(intersect(before->rect, window), now.rect));
              was.erase(before);
            }
          }
          for (const View::Reach& gone : was) redraw(intersect(gone.rect, window));
          if (!v.dirty[l].empty()) {
            v.redrawn[l].x |= shadow::kRedrawnMoving;
            ++stats_.moving_drawn;
          }
        }
        v.map_key[l] = full.h;
        continue;
      }
      if (!v.has_base()) continue;
      const bool changed = full.h != v.map_key[l] || plan != View::Base::keep;
      v.map_key[l] = full.h;
      v.restore[l] = !cache_ || changed ? 1 : 0;
      if (v.restore[l] && any_moving) {
        v.redrawn[l].x |= shadow::kRedrawnMoving;
        ++stats_.moving_drawn;
        stats_.texels_drawn += texels;
      }
    }
  }
  // The lookups' blocks, with what was drawn of each layer (the debug view `redrawn`).
  for (const View& v : views_) {
    if (v.target == &sun_map) {
      shadow::ShadowGpu sun = f.shadow;
      for (size_t c = 0; c < v.redrawn.size() && c < shadow::kMaxCascades; ++c) {
        sun.redrawn[c] = v.redrawn[c];
        // The rectangle in map texels (the grid's less the window, within it).
        if (c < v.dirty.size() && !v.dirty[c].empty()) {
          glm::ivec4 all = v.dirty[c][0];
          for (const glm::ivec4& d : v.dirty[c]) all = unite(all, d);
          const glm::ivec2 w = v.window[c];
          sun.redrawn_rect[c] = glm::uvec4(all - glm::ivec4(w, w));
        }
        if (v.in_place) sun.window[c] = glm::vec4(glm::vec2(sun_offset(uint32_t(c))), 1.0f, 0.0f);
      }
      sun_ubo.write(std::as_bytes(std::span(&sun, 1)));
    } else if (v.target == &spot_maps) {
      std::vector<shadow::SpotShadowGpu> spots = f.spot_gpu;
      for (size_t i = 0; i < v.redrawn.size() && i < spots.size(); ++i)
        spots[i].info.z = v.redrawn[i].x;
      spot_ubo.write(std::as_bytes(std::span(spots)));
    } else if (v.target == &point_cubes) {
      std::vector<shadow::PointShadowGpu> points = f.point_gpu;
      for (size_t l = 0; l < v.redrawn.size() && l / 6 < points.size(); ++l)
        points[l / 6].info.w |= v.redrawn[l].x << (4 * (l % 6));
      point_ubo.write(std::as_bytes(std::span(points)));
    }
  }
}

}  // namespace penumbra::render::passes
