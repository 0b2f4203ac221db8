#pragma once

// Triangle meshes: the vertex layout the renderer uploads, procedural shapes and file loading.
// Every mesh has counter-clockwise front faces (seen from the side its normals point to), unit
// normals, and texture coordinates in the Vulkan image convention (uv (0, 0) is the top-left texel
// of an image; OBJ and 3DS coordinates are flipped on load). Lengths are metres, +Y is up.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <glm/glm.hpp>
#include <limits>
#include <string>
#include <vector>

namespace penumbra::scene {

// One vertex as the vertex buffer holds it: 32 bytes, tightly packed (position at 0, normal at
// 12, uv at 24).
struct Vertex {
  glm::vec3 position{0.0f};
  glm::vec3 normal{0.0f, 1.0f, 0.0f};
  glm::vec2 uv{0.0f};
};
static_assert(sizeof(Vertex) == 32, "Vertex must be 32 bytes");
static_assert(offsetof(Vertex, position) == 0);
static_assert(offsetof(Vertex, normal) == 12);
static_assert(offsetof(Vertex, uv) == 24);

// An axis-aligned box; default-constructed it is empty (min = +inf, max = -inf), and extending
// an empty box by a point gives that point.
struct Bounds {
  glm::vec3 min{std::numeric_limits<float>::infinity()};
  glm::vec3 max{-std::numeric_limits<float>::infinity()};

  void extend(glm::vec3 point);
  void extend(const Bounds& other);
  // True when no point was added (written NaN-safe: a box with a NaN corner is empty too).
  bool empty() const;
  glm::vec3 center() const { return 0.5f * (min + max); }
  glm::vec3 size() const { return max - min; }
};

// The bounds of `bounds` after `transform` (all eight corners); empty stays empty.
Bounds transform_bounds(const Bounds& bounds, const glm::mat4& transform);

struct Mesh {
  std::string name;
  std::vector<Vertex> vertices;
  std::vector<std::uint32_t> indices;  // triangle list, 3 per triangle, CCW front faces
  Bounds bounds;                       // of the vertex positions, in the mesh's own space
};

// Recomputes mesh.bounds from the vertex positions.
void update_bounds(Mesh& mesh);

// Recomputes the normals from the triangles: smooth across edges whose faces meet at less than
// crease_degrees, hard (split vertices) across sharper edges. Vertices at the same position are
// welded for the purpose, so UV seams stay smooth. Degenerate triangles contribute nothing.
void compute_normals(Mesh& mesh, float crease_degrees = 60.0f);

// Procedural shapes. UVs span [0, 1] per face (plane: over the whole plane).
// A plane at y = 0 centred on the origin, normal +Y; subdivisions >= 1 quads per side.
Mesh make_plane(float size_x, float size_z, std::uint32_t subdivisions = 1);
// A closed box centred on the origin (24 vertices, flat faces).
Mesh make_box(glm::vec3 size);
// A UV sphere centred on the origin; segments >= 3 around, rings >= 2 from pole to pole.
Mesh make_sphere(float radius, std::uint32_t segments = 32, std::uint32_t rings = 16);
// A closed cylinder standing on y = 0 (caps at y = 0 and y = height); segments >= 3.
Mesh make_post(float radius, float height, std::uint32_t segments = 12);
// A chair from six boxes (seat at 0.45 m, backrest, four legs), about 0.46 x 0.95 x 0.46 m,
// standing on y = 0, centred in x and z, the backrest towards -Z.
Mesh make_chair();
// A table from five boxes (top 4 cm thick, four legs), standing on y = 0, centred in x and z.
// size = overall width (x), height (y), depth (z); each > 0.1 m.
Mesh make_table(glm::vec3 size = {1.4f, 0.75f, 0.8f});

// Loads a triangle mesh: Wavefront .obj (tinyobjloader; all shapes merged, polygons
// triangulated, materials ignored) or Autodesk .3ds (the TRIMESH chunks of every object, merged;
// converted from 3DS's Z-up to Y-up). Normals missing from the file are computed (see
// compute_normals); a file whose triangles are wound clockwise is flipped so the result is CCW.
// Throws penumbra::Error naming the file on any problem (missing, unreadable, malformed, empty).
Mesh load_mesh(const std::filesystem::path& file);

}  // namespace penumbra::scene
