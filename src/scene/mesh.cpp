// Bounds, normal generation and the procedural shapes.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <penumbra/core/error.hpp>
#include <penumbra/scene/mesh.hpp>
#include <string>
#include <unordered_map>

#include "mesh_detail.hpp"

namespace penumbra::scene {

void Bounds::extend(glm::vec3 point) {
  min = glm::min(min, point);
  max = glm::max(max, point);
}

void Bounds::extend(const Bounds& other) {
  if (other.empty()) return;
  extend(other.min);
  extend(other.max);
}

bool Bounds::empty() const {
  return !(min.x <= max.x && min.y <= max.y && min.z <= max.z);
}

Bounds transform_bounds(const Bounds& bounds, const glm::mat4& transform) {
  Bounds result;
  if (bounds.empty()) return result;
  for (int corner = 0; corner < 8; ++corner) {
    const glm::vec3 p{(corner & 1) ? bounds.max.x : bounds.min.x,
                      (corner & 2) ? bounds.max.y : bounds.min.y,
                      (corner & 4) ? bounds.max.z : bounds.min.z};
    result.extend(glm::vec3(transform * glm::vec4(p, 1.0f)));
  }
  return result;
}

void update_bounds(Mesh& mesh) {
  mesh.bounds = Bounds{};
  for (const Vertex& v : mesh.vertices) mesh.bounds.extend(v.position);
}

namespace {

struct Vec3Hash {
  std::size_t operator()(const glm::vec3& v) const {
    std::array<std::uint32_t, 3> bits{};
    std::memcpy(bits.data(), &v, sizeof(bits));
    std::size_t h = 1469598103934665603ull;
    for (std::uint32_t b : bits) h = (h ^ b) * 1099511628211ull;
    return h;
  }
};

struct CornerKey {
  std::uint32_t vertex;
  glm::vec3 normal;
  bool operator==(const CornerKey& o) const { return vertex == o.vertex && normal == o.normal; }
};

struct CornerHash {
  std::size_t operator()(const CornerKey& k) const {
    return Vec3Hash{}(k.normal) ^ (std::size_t{k.vertex} * 0x9e3779b97f4a7c15ull);
  }
};

}  // namespace

void compute_normals(Mesh& mesh, float crease_degrees) {
  const std::size_t triangle_count = mesh.indices.size() / 3;
  // Weld by exact position.
  std::unordered_map<glm::vec3, std::uint32_t, Vec3Hash> weld_ids;
  std::vector<std::uint32_t> weld(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const glm::vec3 p = mesh.vertices[i].position + glm::vec3(0.0f);  // -0 -> +0
    const auto [it, inserted] =
        weld_ids.try_emplace(p, static_cast<std::uint32_t>(weld_ids.size()));
    weld[i] = it->second;
  }
  // Unit face normals, and the angle of each triangle corner (the weight of the face's normal
  // at that corner, so the result does not depend on how polygons were triangulated).
  std::vector<glm::vec3> unit_normal(triangle_count);
  std::vector<float> corner_angle(mesh.indices.size(), 0.0f);
  for (std::size_t t = 0; t < triangle_count; ++t) {
    const std::array<glm::vec3, 3> p{mesh.vertices[mesh.indices[3 * t]].position,
                                     mesh.vertices[mesh.indices[3 * t + 1]].position,
                                     mesh.vertices[mesh.indices[3 * t + 2]].position};
    const glm::vec3 n = glm::cross(p[1] - p[0], p[2] - p[0]);
    const float len = glm::length(n);
    if (!(std::isfinite(len) && len > 0.0f)) continue;  // degenerate: contributes nothing
    unit_normal[t] = n / len;
    for (std::size_t k = 0; k < 3; ++k) {
      const glm::vec3 e1 = glm::normalize(p[(k + 1) % 3] - p[k]);
      const glm::vec3 e2 = glm::normalize(p[(k + 2) % 3] - p[k]);
      corner_angle[3 * t + k] = std::acos(std::clamp(glm::dot(e1, e2), -1.0f, 1.0f));
    }
  }
  // Triangle corners around each welded position (CSR).
  std::vector<std::uint32_t> start(weld_ids.size() + 1, 0);
  for (std::uint32_t index : mesh.indices) ++start[weld[index] + 1];
  for (std::size_t i = 1; i < start.size(); ++i) start[i] += start[i - 1];
  std::vector<std::uint32_t> corners(mesh.indices.size());
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (std::size_t i = 0; i < mesh.indices.size(); ++i) {
    corners[fill[weld[mesh.indices[i]]]++] = static_cast<std::uint32_t>(i);
  }
  const float cos_crease = std::cos(glm::radians(crease_degrees));
  std::vector<Vertex> out_vertices;
  out_vertices.reserve(mesh.vertices.size());
  std::unordered_map<CornerKey, std::uint32_t, CornerHash> corner_ids;
  std::vector<std::uint32_t> out_indices(mesh.indices.size());
  for (std::size_t i = 0; i < mesh.indices.size(); ++i) {
    const std::uint32_t vertex = mesh.indices[i];
    const std::size_t face = i / 3;
    const glm::vec3 own = unit_normal[face];
    glm::vec3 sum(0.0f);
    const std::uint32_t w = weld[vertex];
    for (std::uint32_t k = start[w]; k < start[w + 1]; ++k) {
      const std::uint32_t corner = corners[k];
      const glm::vec3 other = unit_normal[corner / 3];
      if (glm::dot(own, other) >= cos_crease) sum += corner_angle[corner] * other;
    }
    glm::vec3 normal = own;
    const float len = glm::length(sum);
    if (std::isfinite(len) && len > 0.0f) normal = sum / len;
    if (glm::dot(normal, normal) == 0.0f) normal = glm::vec3(0.0f, 1.0f, 0.0f);
    const auto [it, inserted] = corner_ids.try_emplace(
        CornerKey{vertex, normal}, static_cast<std::uint32_t>(out_vertices.size()));
    if (inserted) {
      Vertex v = mesh.vertices[vertex];
      v.normal = normal;
      out_vertices.push_back(v);
    }
    out_indices[i] = it->second;
  }
  mesh.vertices = std::move(out_vertices);
  mesh.indices = std::move(out_indices);
}

namespace detail {

void append(Mesh& dst, const Mesh& src, const glm::mat4& transform) {
  const auto base = static_cast<std::uint32_t>(dst.vertices.size());
  const glm::mat3 normal_matrix = glm::transpose(glm::inverse(glm::mat3(transform)));
  for (Vertex v : src.vertices) {
    v.position = glm::vec3(transform * glm::vec4(v.position, 1.0f));
    v.normal = glm::normalize(normal_matrix * v.normal);
    dst.vertices.push_back(v);
  }
  for (std::uint32_t index : src.indices) dst.indices.push_back(base + index);
}

}  // namespace detail

namespace {

void add_triangle(Mesh& mesh, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  mesh.indices.insert(mesh.indices.end(), {a, b, c});
}

std::uint32_t add_vertex(Mesh& mesh, glm::vec3 position, glm::vec3 normal, glm::vec2 uv) {
  mesh.vertices.push_back(Vertex{position, normal, uv});
  return static_cast<std::uint32_t>(mesh.vertices.size() - 1);
}

void require_positive(const char* what, const char* name, float value) {
  if (!(value > 0.0f) || !std::isfinite(value)) {
    throw Error(std::string(what) + ": " + name + " = " + std::to_string(value) +
                " must be finite and > 0");
  }
}

std::string format_number(float value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%g", static_cast<double>(value));
  return buffer;
}

}  // namespace

Mesh make_plane(float size_x, float size_z, std::uint32_t subdivisions) {
  require_positive("make_plane", "size_x", size_x);
  require_positive("make_plane", "size_z", size_z);
  if (subdivisions < 1 || subdivisions > 4096) {
    throw Error("make_plane: subdivisions = " + std::to_string(subdivisions) +
                " must be in [1, 4096]");
  }
  Mesh mesh;
  mesh.name = "plane " + format_number(size_x) + "x" + format_number(size_z);
  const std::uint32_t n = subdivisions;
  for (std::uint32_t j = 0; j <= n; ++j) {
    for (std::uint32_t i = 0; i <= n; ++i) {
      const float u = static_cast<float>(i) / static_cast<float>(n);
      const float v = static_cast<float>(j) / static_cast<float>(n);
      add_vertex(mesh, {(u - 0.5f) * size_x, 0.0f, (v - 0.5f) * size_z}, {0.0f, 1.0f, 0.0f},
                 {u, v});
    }
  }
  for (std::uint32_t j = 0; j < n; ++j) {
    for (std::uint32_t i = 0; i < n; ++i) {
      const std::uint32_t a = j * (n + 1) + i;  // (i, j)
      const std::uint32_t b = a + (n + 1);      // (i, j + 1)
      add_triangle(mesh, a, b, b + 1);
      add_triangle(mesh, a, b + 1, a + 1);
    }
  }
  update_bounds(mesh);
  return mesh;
}

Mesh make_box(glm::vec3 size) {
  require_positive("make_box", "size.x", size.x);
  require_positive("make_box", "size.y", size.y);
  require_positive("make_box", "size.z", size.z);
  Mesh mesh;
  mesh.name =
      "box " + format_number(size.x) + "x" + format_number(size.y) + "x" + format_number(size.z);
  const glm::vec3 half = 0.5f * size;
  // Each face: outward normal n, "up" v on the face; u = v x n, so u x v = n (CCW).
  const std::array<std::pair<glm::vec3, glm::vec3>, 6> faces{{
      {{1, 0, 0}, {0, 1, 0}},
      {{-1, 0, 0}, {0, 1, 0}},
      {{0, 0, 1}, {0, 1, 0}},
      {{0, 0, -1}, {0, 1, 0}},
      {{0, 1, 0}, {0, 0, -1}},
      {{0, -1, 0}, {0, 0, 1}},
  }};
  // The area of face f's pair, and the largest pair (ties: +Z, then +X, then +Y).
  auto pair_area = [&](size_t f) {
    const glm::vec3 across = glm::vec3(1.0f) - glm::abs(faces[f].first);
    return (across.x > 0.0f ? size.x : 1.0f) * (across.y > 0.0f ? size.y : 1.0f) *
           (across.z > 0.0f ? size.z : 1.0f);
  };
  size_t largest = 2;
  for (size_t f : {size_t{0}, size_t{4}})
    if (pair_area(f) > pair_area(largest)) largest = f;
  for (size_t f = 0; f < faces.size(); ++f) {
    const auto& [n, v_axis] = faces[f];
    const glm::vec3 u_axis = glm::cross(v_axis, n);
    const glm::vec3 c = n * half;
    const glm::vec3 u = u_axis * half;  // component-wise: half-extent along u's axis
    const glm::vec3 v = v_axis * half;
    // The uvs are those of the +X, +Z or +Y face (the pair's first) at the same point seen
    // through the box: uv (0, 0) is that face's top-left corner (top = +v). A mask then cuts
    // through the box, its holes in the same place on both faces (from behind, the image is
    // mirrored, as through a window). The faces of a pair smaller than the largest (a panel's
    // thin edges) take the largest pair's uvs instead: the mask is extruded through them, so
    // a picket fence's top shows the pickets' ends, not the whole texture squeezed into 3 cm.
    const size_t ref = pair_area(f) < pair_area(largest) ? largest : (f & ~size_t{1});
    const glm::vec3 ref_n = faces[ref].first, ref_v = faces[ref].second;
    const glm::vec3 ref_u = glm::cross(ref_v, ref_n);
    auto uv = [&](glm::vec3 p) {
      return glm::vec2(0.5f + 0.5f * glm::dot(p, ref_u) / glm::dot(half, glm::abs(ref_u)),
                       0.5f - 0.5f * glm::dot(p, ref_v) / glm::dot(half, glm::abs(ref_v)));
    };
    const std::uint32_t a = add_vertex(mesh, c - u - v, n, uv(c - u - v));
    add_vertex(mesh, c + u - v, n, uv(c + u - v));
    add_vertex(mesh, c + u + v, n, uv(c + u + v));
    add_vertex(mesh, c - u + v, n, uv(c - u + v));
    add_triangle(mesh, a, a + 1, a + 2);
    add_triangle(mesh, a, a + 2, a + 3);
  }
  update_bounds(mesh);
  return mesh;
}

Mesh make_sphere(float radius, std::uint32_t segments, std::uint32_t rings) {
  require_positive("make_sphere", "radius", radius);
  if (segments < 3 || segments > 4096 || rings < 2 || rings > 4096) {
    throw Error("make_sphere: segments = " + std::to_string(segments) + ", rings = " +
                std::to_string(rings) + ": need segments in [3, 4096] and rings in [2, 4096]");
  }
  Mesh mesh;
  mesh.name = "sphere r" + format_number(radius);
  const float pi = glm::pi<float>();
  for (std::uint32_t r = 0; r <= rings; ++r) {
    const float v = static_cast<float>(r) / static_cast<float>(rings);
    const float theta = v * pi;  // 0 at the north pole (+Y)
    for (std::uint32_t s = 0; s <= segments; ++s) {
      const float u = static_cast<float>(s) / static_cast<float>(segments);
      const float phi = u * 2.0f * pi;
      glm::vec3 n{std::sin(theta) * std::sin(phi), std::cos(theta),
                  std::sin(theta) * std::cos(phi)};
      if (r == 0) n = {0.0f, 1.0f, 0.0f};
      if (r == rings) n = {0.0f, -1.0f, 0.0f};
      add_vertex(mesh, radius * n, glm::normalize(n), {u, v});
    }
  }
  const std::uint32_t row = segments + 1;
  for (std::uint32_t r = 0; r < rings; ++r) {
    for (std::uint32_t s = 0; s < segments; ++s) {
      const std::uint32_t a = r * row + s;  // upper ring
      const std::uint32_t b = a + row;      // lower ring
      // Seen from outside, +s runs to the right (counter-clockwise seen from +Y).
      if (r != 0) add_triangle(mesh, a, b, a + 1);
      if (r != rings - 1) add_triangle(mesh, a + 1, b, b + 1);
    }
  }
  update_bounds(mesh);
  return mesh;
}

Mesh make_post(float radius, float height, std::uint32_t segments) {
  require_positive("make_post", "radius", radius);
  require_positive("make_post", "height", height);
  if (segments < 3 || segments > 4096) {
    throw Error("make_post: segments = " + std::to_string(segments) + " must be in [3, 4096]");
  }
  Mesh mesh;
  mesh.name = "post r" + format_number(radius) + " h" + format_number(height);
  const float pi = glm::pi<float>();
  auto ring = [&](std::uint32_t s) {
    const float phi = 2.0f * pi * static_cast<float>(s) / static_cast<float>(segments);
    return glm::vec3(std::sin(phi), 0.0f, std::cos(phi));
  };
  // Side: smooth normals, a seam column duplicated for the uvs.
  for (std::uint32_t s = 0; s <= segments; ++s) {
    const glm::vec3 n = ring(s % segments);
    const float u = static_cast<float>(s) / static_cast<float>(segments);
    add_vertex(mesh, radius * n + glm::vec3(0.0f, height, 0.0f), n, {u, 0.0f});
    add_vertex(mesh, radius * n, n, {u, 1.0f});
  }
  for (std::uint32_t s = 0; s < segments; ++s) {
    const std::uint32_t top = 2 * s;
    const std::uint32_t bottom = top + 1;
    add_triangle(mesh, top, bottom, top + 2);
    add_triangle(mesh, top + 2, bottom, bottom + 2);
  }
  // Caps: fans around a centre vertex.
  for (const bool upper : {true, false}) {
    const glm::vec3 n{0.0f, upper ? 1.0f : -1.0f, 0.0f};
    const float y = upper ? height : 0.0f;
    const std::uint32_t centre = add_vertex(mesh, {0.0f, y, 0.0f}, n, {0.5f, 0.5f});
    for (std::uint32_t s = 0; s < segments; ++s) {
      const glm::vec3 d = ring(s);
      add_vertex(mesh, radius * d + glm::vec3(0.0f, y, 0.0f), n,
                 {0.5f + 0.5f * d.x, 0.5f + 0.5f * d.z});
    }
    for (std::uint32_t s = 0; s < segments; ++s) {
      const std::uint32_t a = centre + 1 + s;
      const std::uint32_t b = centre + 1 + (s + 1) % segments;
      if (upper) {
        add_triangle(mesh, centre, a, b);
      } else {
        add_triangle(mesh, centre, b, a);
      }
    }
  }
  update_bounds(mesh);
  return mesh;
}

namespace {

void add_box(Mesh& mesh, glm::vec3 size, glm::vec3 center) {
  detail::append(mesh, make_box(size), glm::translate(glm::mat4(1.0f), center));
}

}  // namespace

Mesh make_chair() {
  Mesh mesh;
  mesh.name = "chair";
  constexpr float width = 0.46f;  // x and z
  constexpr float seat_height = 0.45f;
  constexpr float seat_thickness = 0.05f;
  constexpr float leg = 0.04f;
  constexpr float back_height = 0.5f;
  constexpr float back_thickness = 0.04f;
  const float leg_offset = 0.5f * (width - leg);
  const float leg_height = seat_height - seat_thickness;
  // Seat.
  add_box(mesh, {width, seat_thickness, width}, {0.0f, seat_height - 0.5f * seat_thickness, 0.0f});
  // Legs.
  for (const float x : {-leg_offset, leg_offset}) {
    for (const float z : {-leg_offset, leg_offset}) {
      add_box(mesh, {leg, leg_height, leg}, {x, 0.5f * leg_height, z});
    }
  }
  // Backrest, on the -Z edge of the seat.
  add_box(mesh, {width, back_height, back_thickness},
          {0.0f, seat_height + 0.5f * back_height, -0.5f * (width - back_thickness)});
  update_bounds(mesh);
  return mesh;
}

Mesh make_table(glm::vec3 size) {
  if (!(size.x > 0.1f && size.y > 0.1f && size.z > 0.1f) || !std::isfinite(size.x) ||
      !std::isfinite(size.y) || !std::isfinite(size.z)) {
    throw Error("make_table: size = [" + format_number(size.x) + ", " + format_number(size.y) +
                ", " + format_number(size.z) + "] must be finite and > 0.1 m on every axis");
  }
  Mesh mesh;
  mesh.name =
      "table " + format_number(size.x) + "x" + format_number(size.y) + "x" + format_number(size.z);
  constexpr float top = 0.04f;
  constexpr float leg = 0.06f;
  constexpr float inset = 0.04f;
  add_box(mesh, {size.x, top, size.z}, {0.0f, size.y - 0.5f * top, 0.0f});
  const float leg_height = size.y - top;
  const float lx = 0.5f * size.x - inset - 0.5f * leg;
  const float lz = 0.5f * size.z - inset - 0.5f * leg;
  for (const float x : {-lx, lx}) {
    for (const float z : {-lz, lz}) {
      add_box(mesh, {leg, leg_height, leg}, {x, 0.5f * leg_height, z});
    }
  }
  update_bounds(mesh);
  return mesh;
}

}  // namespace penumbra::scene
