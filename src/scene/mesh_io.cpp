// Mesh files: Wavefront OBJ through tinyobjloader, Autodesk 3DS through a small chunk reader.

#include <tiny_obj_loader.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <penumbra/core/error.hpp>
#include <penumbra/scene/mesh.hpp>
#include <string>
#include <unordered_map>
#include <vector>

namespace penumbra::scene {
namespace {

namespace fs = std::filesystem;

[[noreturn]] void fail(const fs::path& file, const std::string& what) {
  throw Error("mesh file '" + file.string() + "': " + what);
}

// +1: the triangles' winding agrees with the reference (outward for a closed mesh, or the
// file's normals); -1: clearly opposite; values in between: mixed or undecidable (flat meshes).
double winding_score(const Mesh& mesh, bool by_normals) {
  const glm::dvec3 centre = glm::dvec3(mesh.bounds.center());
  double signed_sum = 0.0;
  double abs_sum = 0.0;
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const Vertex& a = mesh.vertices[mesh.indices[t]];
    const Vertex& b = mesh.vertices[mesh.indices[t + 1]];
    const Vertex& c = mesh.vertices[mesh.indices[t + 2]];
    const glm::dvec3 pa = glm::dvec3(a.position) - centre;
    const glm::dvec3 pb = glm::dvec3(b.position) - centre;
    const glm::dvec3 pc = glm::dvec3(c.position) - centre;
    double term = 0.0;
    if (by_normals) {
      term = glm::dot(glm::cross(pb - pa, pc - pa), glm::dvec3(a.normal + b.normal + c.normal));
    } else {
      term = glm::dot(pa, glm::cross(pb, pc));  // 6 x the signed tetrahedron volume
    }
    if (std::isfinite(term)) {
      signed_sum += term;
      abs_sum += std::abs(term);
    }
  }
  return abs_sum > 0.0 ? signed_sum / abs_sum : 0.0;
}

void flip_winding(Mesh& mesh) {
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    std::swap(mesh.indices[t + 1], mesh.indices[t + 2]);
  }
}

// Makes the winding CCW (flipping a clearly clockwise mesh) and the normals unit; computes the
// normals when the file had none.
void finish_mesh(Mesh& mesh, const fs::path& file, bool has_normals) {
  if (mesh.indices.empty()) fail(file, "contains no triangles");
  // Every vertex, not only the bounds: min/max may skip a NaN.
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const glm::vec3 p = mesh.vertices[i].position;
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      fail(file, "vertex " + std::to_string(i) + " has a non-finite position (" +
                     std::to_string(p.x) + ", " + std::to_string(p.y) + ", " +
                     std::to_string(p.z) + ")");
    }
  }
  update_bounds(mesh);
  if (mesh.bounds.empty() ||
      !std::isfinite(mesh.bounds.min.x + mesh.bounds.min.y + mesh.bounds.min.z + mesh.bounds.max.x +
                     mesh.bounds.max.y + mesh.bounds.max.z)) {
    fail(file, "has non-finite vertex positions");
  }
  constexpr double kClearlyReversed = -0.25;
  if (winding_score(mesh, has_normals) < kClearlyReversed) flip_winding(mesh);
  if (has_normals) {
    for (Vertex& v : mesh.vertices) v.normal = glm::normalize(v.normal);
  } else {
    compute_normals(mesh);
  }
}

// A mesh file's bytes: a regular file (not a FIFO, a device or a directory) of at most
// kMaxMeshFileBytes, read whole.
constexpr std::uintmax_t kMaxMeshFileBytes = std::uintmax_t(1) << 30;

std::string read_mesh_file(const fs::path& file) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) fail(file, "is not a regular file");
  const std::uintmax_t size = fs::file_size(file, ec);
  if (ec) fail(file, "cannot be read: " + ec.message());
  if (size > kMaxMeshFileBytes) {
    fail(file, "is " + std::to_string(size >> 20) + " MiB; mesh files are at most " +
                   std::to_string(kMaxMeshFileBytes >> 20) + " MiB");
  }
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(file, "cannot be opened");
  std::string bytes(size, '\0');
  in.read(bytes.data(), std::streamsize(size));
  if (in.gcount() != std::streamsize(size)) fail(file, "read error");
  return bytes;
}

// ---- OBJ -------------------------------------------------------------------------------------

struct ObjKey {
  int vertex, normal, texcoord;
  bool operator==(const ObjKey&) const = default;
};

struct ObjKeyHash {
  std::size_t operator()(const ObjKey& k) const {
    std::size_t h = static_cast<std::size_t>(k.vertex) * 0x9e3779b97f4a7c15ull;
    h ^= static_cast<std::size_t>(k.normal) * 0xc2b2ae3d27d4eb4full + (h << 6) + (h >> 2);
    h ^= static_cast<std::size_t>(k.texcoord) * 0x165667b19e3779f9ull + (h << 6) + (h >> 2);
    return h;
  }
};

Mesh load_obj(const fs::path& file) {
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  // Penumbra takes no materials from an OBJ (scene files assign them), so `mtllib` files are
  // never opened: a FIFO or /dev/zero named there cannot block or fill memory.
  if (!reader.ParseFromString(read_mesh_file(file), std::string(), config)) {
    std::string message = reader.Error();
    while (!message.empty() && std::isspace(static_cast<unsigned char>(message.back()))) {
      message.pop_back();
    }
    fail(file, "OBJ parse error: " + message);
  }
  const tinyobj::attrib_t& attrib = reader.GetAttrib();
  const auto position_count = static_cast<int>(attrib.vertices.size() / 3);
  const auto normal_count = static_cast<int>(attrib.normals.size() / 3);
  const auto texcoord_count = static_cast<int>(attrib.texcoords.size() / 2);

  Mesh mesh;
  mesh.name = file.stem().string();
  bool has_normals = true;
  std::unordered_map<ObjKey, std::uint32_t, ObjKeyHash> ids;
  auto vertex_id = [&](const tinyobj::index_t& index) {
    if (index.vertex_index < 0 || index.vertex_index >= position_count) {
      fail(file, "a face refers to vertex " + std::to_string(index.vertex_index + 1) + " of " +
                     std::to_string(position_count));
    }
    const ObjKey key{
        index.vertex_index,
        index.normal_index >= 0 && index.normal_index < normal_count ? index.normal_index : -1,
        index.texcoord_index >= 0 && index.texcoord_index < texcoord_count ? index.texcoord_index
                                                                           : -1};
    const auto [it, inserted] =
        ids.try_emplace(key, static_cast<std::uint32_t>(mesh.vertices.size()));
    if (inserted) {
      Vertex v;
      const auto p = static_cast<std::size_t>(key.vertex) * 3;
      v.position = {attrib.vertices[p], attrib.vertices[p + 1], attrib.vertices[p + 2]};
      if (key.normal >= 0) {
        const auto n = static_cast<std::size_t>(key.normal) * 3;
        v.normal = {attrib.normals[n], attrib.normals[n + 1], attrib.normals[n + 2]};
        const float len = glm::length(v.normal);
        if (!std::isfinite(len) || len == 0.0f) has_normals = false;
      } else {
        has_normals = false;
      }
      if (key.texcoord >= 0) {
        const auto t = static_cast<std::size_t>(key.texcoord) * 2;
        v.uv = {attrib.texcoords[t], 1.0f - attrib.texcoords[t + 1]};
      }
      mesh.vertices.push_back(v);
    }
    return it->second;
  };
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    std::size_t offset = 0;
    for (const unsigned char face_size : shape.mesh.num_face_vertices) {
      if (offset + face_size > shape.mesh.indices.size()) fail(file, "truncated face list");
      // Fan-triangulate whatever tinyobjloader left as a polygon.
      for (std::size_t k = 1; k + 1 < face_size; ++k) {
        mesh.indices.push_back(vertex_id(shape.mesh.indices[offset]));
        mesh.indices.push_back(vertex_id(shape.mesh.indices[offset + k]));
        mesh.indices.push_back(vertex_id(shape.mesh.indices[offset + k + 1]));
      }
      offset += face_size;
    }
  }
  finish_mesh(mesh, file, has_normals);
  return mesh;
}

// ---- 3DS -------------------------------------------------------------------------------------

static_assert(std::endian::native == std::endian::little, "the 3DS reader assumes little endian");

constexpr std::uint16_t kMain = 0x4D4D;
constexpr std::uint16_t kEdit = 0x3D3D;
constexpr std::uint16_t kObject = 0x4000;
constexpr std::uint16_t kTrimesh = 0x4100;
constexpr std::uint16_t kVertices = 0x4110;
constexpr std::uint16_t kFaces = 0x4120;
constexpr std::uint16_t kTexcoords = 0x4140;

struct Chunk {
  std::uint16_t id = 0;
  std::size_t offset = 0;  // of the header
  std::size_t begin = 0;   // of the payload
  std::size_t end = 0;
};

std::string hex(std::uint16_t id) {
  char buffer[8];
  std::snprintf(buffer, sizeof(buffer), "0x%04X", static_cast<unsigned>(id));
  return buffer;
}

class ThreeDsReader {
 public:
  ThreeDsReader(const fs::path& file, std::vector<unsigned char> data)
      : file_(file), data_(std::move(data)) {}

  Mesh read() {
    if (data_.size() < 6) fail(file_, "too short for a 3DS file");
    if (u16(0) != kMain) fail(file_, "not a 3DS file (no MAIN chunk 0x4D4D at offset 0)");
    const std::uint32_t length = u32(2);
    if (length < 6 || length > data_.size()) {
      fail(file_, "MAIN chunk length " + std::to_string(length) + " exceeds the file size " +
                      std::to_string(data_.size()) + " (truncated file?)");
    }
    Mesh mesh;
    mesh.name = file_.stem().string();
    for (const Chunk& edit : children(6, length)) {
      if (edit.id != kEdit) continue;
      for (const Chunk& object : children(edit.begin, edit.end)) {
        if (object.id != kObject) continue;
        // A NUL-terminated name, then sub-chunks.
        std::size_t at = object.begin;
        while (at < object.end && data_[at] != 0) ++at;
        if (at >= object.end) {
          fail(file_, "object chunk at offset " + std::to_string(object.offset) +
                          " has an unterminated name");
        }
        for (const Chunk& trimesh : children(at + 1, object.end)) {
          if (trimesh.id == kTrimesh) read_trimesh(trimesh, mesh);
        }
      }
    }
    if (mesh.indices.empty()) fail(file_, "contains no triangle meshes (TRIMESH chunks 0x4100)");
    return mesh;
  }

 private:
  std::uint16_t u16(std::size_t at) const {
    std::uint16_t value = 0;
    std::memcpy(&value, data_.data() + at, sizeof(value));
    return value;
  }
  std::uint32_t u32(std::size_t at) const {
    std::uint32_t value = 0;
    std::memcpy(&value, data_.data() + at, sizeof(value));
    return value;
  }
  float f32(std::size_t at) const {
    float value = 0;
    std::memcpy(&value, data_.data() + at, sizeof(value));
    return value;
  }

  std::vector<Chunk> children(std::size_t begin, std::size_t end) const {
    std::vector<Chunk> out;
    std::size_t at = begin;
    while (at < end) {
      if (end - at < 6) {
        fail(file_, "truncated chunk header at offset " + std::to_string(at) +
                        " (truncated or corrupt file)");
      }
      const std::uint16_t id = u16(at);
      const std::uint32_t length = u32(at + 2);
      if (length < 6 || length > end - at) {
        fail(file_, "chunk " + hex(id) + " at offset " + std::to_string(at) + " has length " +
                        std::to_string(length) + ", past the end of its parent at offset " +
                        std::to_string(end) + " (truncated or corrupt file)");
      }
      out.push_back(Chunk{id, at, at + 6, at + length});
      at += length;
    }
    return out;
  }

  void need(const Chunk& chunk, std::size_t bytes, const char* what) const {
    if (chunk.end - chunk.begin < bytes) {
      fail(file_, std::string(what) + " chunk " + hex(chunk.id) + " at offset " +
                      std::to_string(chunk.offset) + " is shorter than its count says");
    }
  }

  void read_trimesh(const Chunk& trimesh, Mesh& mesh) const {
    std::vector<glm::vec3> positions;
    std::vector<glm::vec2> uvs;
    std::vector<std::uint32_t> faces;
    for (const Chunk& chunk : children(trimesh.begin, trimesh.end)) {
      if (chunk.id == kVertices) {
        need(chunk, 2, "vertex");
        const std::size_t count = u16(chunk.begin);
        need(chunk, 2 + count * 12, "vertex");
        for (std::size_t i = 0; i < count; ++i) {
          const std::size_t at = chunk.begin + 2 + i * 12;
          // 3DS is Z-up: (x, y, z) -> (x, z, -y), a rotation (winding is kept).
          positions.emplace_back(f32(at), f32(at + 8), -f32(at + 4));
        }
      } else if (chunk.id == kTexcoords) {
        need(chunk, 2, "texture coordinate");
        const std::size_t count = u16(chunk.begin);
        need(chunk, 2 + count * 8, "texture coordinate");
        for (std::size_t i = 0; i < count; ++i) {
          const std::size_t at = chunk.begin + 2 + i * 8;
          uvs.emplace_back(f32(at), 1.0f - f32(at + 4));
        }
      } else if (chunk.id == kFaces) {
        need(chunk, 2, "face");
        const std::size_t count = u16(chunk.begin);
        need(chunk, 2 + count * 8, "face");
        for (std::size_t i = 0; i < count; ++i) {
          const std::size_t at = chunk.begin + 2 + i * 8;
          faces.insert(faces.end(), {u16(at), u16(at + 2), u16(at + 4)});  // then u16 flags
        }
        // Material groups and smoothing groups follow as sub-chunks; unused.
      }
    }
    for (const std::uint32_t index : faces) {
      if (index >= positions.size()) {
        fail(file_, "a face of the TRIMESH at offset " + std::to_string(trimesh.offset) +
                        " refers to vertex " + std::to_string(index) + " of " +
                        std::to_string(positions.size()));
      }
    }
    const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
    const bool has_uvs = uvs.size() == positions.size();
    for (std::size_t i = 0; i < positions.size(); ++i) {
      mesh.vertices.push_back(
          Vertex{positions[i], glm::vec3(0.0f), has_uvs ? uvs[i] : glm::vec2(0.0f)});
    }
    for (const std::uint32_t index : faces) mesh.indices.push_back(base + index);
  }

  fs::path file_;
  std::vector<unsigned char> data_;
};

Mesh load_3ds(const fs::path& file) {
  const std::string bytes = read_mesh_file(file);
  Mesh mesh = ThreeDsReader(file, std::vector<unsigned char>(bytes.begin(), bytes.end())).read();
  finish_mesh(mesh, file, /*has_normals=*/false);
  return mesh;
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

}  // namespace

Mesh load_mesh(const std::filesystem::path& file) {
  std::error_code ec;
  if (!fs::exists(file, ec)) throw Error("mesh file '" + file.string() + "' not found");
  if (!fs::is_regular_file(file, ec)) fail(file, "is not a regular file");
  const std::string extension = lower(file.extension().string());
  if (extension == ".obj") return load_obj(file);
  if (extension == ".3ds") return load_3ds(file);
  fail(file, "unsupported format '" + file.extension().string() + "' (supported: .obj, .3ds)");
}

}  // namespace penumbra::scene
