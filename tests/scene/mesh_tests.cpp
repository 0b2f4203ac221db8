// Procedural meshes, normal generation and mesh files (OBJ, 3DS).

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <iterator>
#include <penumbra/core/error.hpp>
#include <penumbra/scene/mesh.hpp>
#include <string>
#include <vector>

#include "scene_test_util.hpp"

namespace penumbra::scene {
namespace {

namespace fs = std::filesystem;
using testing::expect_valid_mesh;
using ::testing::HasSubstr;
using testing::signed_volume;

const fs::path kModels = PENUMBRA_MODEL_DIR;
const fs::path kData = fs::path(PENUMBRA_TEST_DATA_DIR) / "scene";

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// Every triangle's geometric normal points away from `centre`.
void expect_outward(const Mesh& mesh, glm::vec3 centre) {
  for (std::size_t t = 0; t < mesh.indices.size(); t += 3) {
    const glm::vec3 a = mesh.vertices[mesh.indices[t]].position;
    const glm::vec3 b = mesh.vertices[mesh.indices[t + 1]].position;
    const glm::vec3 c = mesh.vertices[mesh.indices[t + 2]].position;
    const glm::vec3 face = glm::cross(b - a, c - a);
    if (!(glm::length(face) > 1e-12f)) continue;
    const glm::vec3 middle = (a + b + c) / 3.0f;
    EXPECT_GT(glm::dot(face, middle - centre), 0.0f) << mesh.name << " triangle " << t / 3;
  }
}

TEST(Bounds, EmptyExtendTransform) {
  Bounds b;
  EXPECT_TRUE(b.empty());
  b.extend(glm::vec3(1, 2, 3));
  EXPECT_FALSE(b.empty());
  EXPECT_EQ(b.min, glm::vec3(1, 2, 3));
  EXPECT_EQ(b.max, glm::vec3(1, 2, 3));
  b.extend(glm::vec3(-1, 5, 0));
  EXPECT_EQ(b.min, glm::vec3(-1, 2, 0));
  EXPECT_EQ(b.max, glm::vec3(1, 5, 3));
  Bounds other;
  b.extend(other);  // empty: no change
  EXPECT_EQ(b.min, glm::vec3(-1, 2, 0));

  const glm::mat4 m = glm::translate(glm::mat4(1.0f), glm::vec3(10, 0, 0)) *
                      glm::rotate(glm::mat4(1.0f), glm::half_pi<float>(), glm::vec3(0, 1, 0));
  const Bounds t = transform_bounds(Bounds{glm::vec3(-1, 0, -2), glm::vec3(1, 1, 2)}, m);
  EXPECT_NEAR(t.min.x, 8.0f, 1e-5f);
  EXPECT_NEAR(t.max.x, 12.0f, 1e-5f);
  EXPECT_NEAR(t.min.z, -1.0f, 1e-5f);
  EXPECT_NEAR(t.max.z, 1.0f, 1e-5f);
  EXPECT_TRUE(transform_bounds(Bounds{}, m).empty());
}

TEST(ProceduralMesh, BoxIsClosedWithOutwardNormals) {
  const glm::vec3 size(2.0f, 1.0f, 0.5f);
  const Mesh box = make_box(size);
  expect_valid_mesh(box);
  EXPECT_EQ(box.vertices.size(), 24u);
  EXPECT_EQ(box.indices.size(), 36u);
  EXPECT_EQ(box.bounds.min, -0.5f * size);
  EXPECT_EQ(box.bounds.max, 0.5f * size);
  expect_outward(box, glm::vec3(0.0f));
  // Each vertex normal is its face's axis and points away from the centre.
  for (const Vertex& v : box.vertices) {
    EXPECT_GT(glm::dot(v.normal, v.position), 0.0f);
    EXPECT_FLOAT_EQ(std::abs(v.normal.x) + std::abs(v.normal.y) + std::abs(v.normal.z), 1.0f);
  }
  EXPECT_NEAR(signed_volume(box), 2.0 * 1.0 * 0.5, 1e-5);
  // The uv (0, 0) corner of the +Z face is its top-left.
  bool found = false;
  for (const Vertex& v : box.vertices) {
    if (v.normal == glm::vec3(0, 0, 1) && v.uv == glm::vec2(0, 0)) {
      EXPECT_EQ(v.position, glm::vec3(-1.0f, 0.5f, 0.25f));
      found = true;
    }
  }
  EXPECT_TRUE(found);
}

// A mask cuts through a box: each corner of a panel's face has the uv of the same corner on the
// opposite face (the pair's axis dropped), so a masked panel's holes go through both faces.
// With the faces' own uvs the back's pattern was the front's mirror image, and a striped fence
// cast an almost solid shadow.
TEST(ProceduralMesh, BoxMasksCutThrough) {
  const Mesh box = make_box(glm::vec3(4.0f, 1.0f, 0.03f));
  size_t matched = 0;
  for (const Vertex& a : box.vertices) {
    for (const Vertex& b : box.vertices) {
      if (a.normal != -b.normal || a.normal.z == 0.0f) continue;  // the panel's two faces
      const glm::vec3 axis = glm::abs(a.normal);
      const glm::vec3 across = (glm::vec3(1.0f) - axis);
      if (a.position * across != b.position * across) continue;  // not the same corner
      EXPECT_EQ(a.uv, b.uv) << "corner " << a.position.x << ", " << a.position.y << ", "
                            << a.position.z;
      ++matched;
    }
  }
  EXPECT_EQ(matched, 8u);  // every corner of the front and the back has its partner
  // The panel's faces span the whole [0, 1]^2; its thin edges carry the panel's uvs at the same
  // point (the mask is extruded through them): the top edge is the image's top row (v = 0), the
  // ends its first and last columns.
  for (const Vertex& v : box.vertices) {
    const glm::vec2 panel(0.5f + v.position.x / 4.0f, 0.5f - v.position.y / 1.0f);
    EXPECT_EQ(v.uv, panel) << "normal " << v.normal.x << ", " << v.normal.y << ", " << v.normal.z;
    if (v.normal == glm::vec3(0, 1, 0)) {
      EXPECT_EQ(v.uv.y, 0.0f);
    }
    if (v.normal == glm::vec3(1, 0, 0)) {
      EXPECT_EQ(v.uv.x, 1.0f);
    }
  }
  // A cube has no thin edges: every face keeps its own pair's uvs and spans [0, 1]^2.
  const Mesh cube = make_box(glm::vec3(1.0f));
  for (size_t f = 0; f < 6; ++f) {
    glm::vec2 lo(1.0f), hi(0.0f);
    for (size_t k = 0; k < 4; ++k) {
      lo = glm::min(lo, cube.vertices[4 * f + k].uv);
      hi = glm::max(hi, cube.vertices[4 * f + k].uv);
    }
    EXPECT_EQ(lo, glm::vec2(0.0f)) << "face " << f;
    EXPECT_EQ(hi, glm::vec2(1.0f)) << "face " << f;
  }
}

TEST(ProceduralMesh, PlaneFacesUp) {
  const Mesh plane = make_plane(4.0f, 2.0f, 3);
  expect_valid_mesh(plane);
  EXPECT_EQ(plane.vertices.size(), 16u);
  EXPECT_EQ(plane.indices.size(), 3u * 2 * 9);
  EXPECT_EQ(plane.bounds.min, glm::vec3(-2.0f, 0.0f, -1.0f));
  EXPECT_EQ(plane.bounds.max, glm::vec3(2.0f, 0.0f, 1.0f));
  for (const Vertex& v : plane.vertices) EXPECT_EQ(v.normal, glm::vec3(0, 1, 0));
  for (std::size_t t = 0; t < plane.indices.size(); t += 3) {
    const glm::vec3 a = plane.vertices[plane.indices[t]].position;
    const glm::vec3 b = plane.vertices[plane.indices[t + 1]].position;
    const glm::vec3 c = plane.vertices[plane.indices[t + 2]].position;
    EXPECT_GT(glm::cross(b - a, c - a).y, 0.0f);
  }
}

TEST(ProceduralMesh, SphereIsRoundAndOutward) {
  const float r = 0.75f;
  const Mesh sphere = make_sphere(r, 24, 12);
  expect_valid_mesh(sphere);
  for (const Vertex& v : sphere.vertices) {
    EXPECT_NEAR(glm::length(v.position), r, 1e-5f);
    EXPECT_NEAR(glm::dot(v.normal, v.position / r), 1.0f, 1e-5f);
  }
  expect_outward(sphere, glm::vec3(0.0f));
  const double exact = 4.0 / 3.0 * glm::pi<double>() * r * r * r;
  EXPECT_NEAR(signed_volume(sphere), exact, 0.05 * exact);
  EXPECT_NEAR(sphere.bounds.max.y, r, 1e-6f);
  EXPECT_NEAR(sphere.bounds.min.y, -r, 1e-6f);
  EXPECT_NEAR(sphere.bounds.max.x, r, 1e-3f);
  // Two triangles per quad, one at each pole quad.
  EXPECT_EQ(sphere.indices.size(), 3u * (2u * 24 * 12 - 2u * 24));
}

TEST(ProceduralMesh, PostStandsOnTheGround) {
  const Mesh post = make_post(0.05f, 2.0f, 12);
  expect_valid_mesh(post);
  EXPECT_FLOAT_EQ(post.bounds.min.y, 0.0f);
  EXPECT_FLOAT_EQ(post.bounds.max.y, 2.0f);
  EXPECT_NEAR(post.bounds.max.x, 0.05f, 1e-6f);
  EXPECT_NEAR(post.bounds.min.z, -0.05f, 1e-3f);
  expect_outward(post, glm::vec3(0.0f, 1.0f, 0.0f));
  // A 12-gon prism: area = 12/2 r^2 sin(30 deg).
  const double area = 6.0 * 0.05 * 0.05 * 0.5;
  EXPECT_NEAR(signed_volume(post), area * 2.0, 1e-6);
}

TEST(ProceduralMesh, ChairAndTable) {
  const Mesh chair = make_chair();
  expect_valid_mesh(chair);
  EXPECT_FLOAT_EQ(chair.bounds.min.y, 0.0f);
  EXPECT_NEAR(chair.bounds.max.y, 0.95f, 0.01f);
  EXPECT_NEAR(chair.bounds.size().x, 0.46f, 0.01f);
  EXPECT_NEAR(chair.bounds.size().z, 0.46f, 0.01f);
  EXPECT_NEAR(chair.bounds.center().x, 0.0f, 1e-5f);
  EXPECT_EQ(chair.indices.size(), 6u * 36u);  // six boxes
  EXPECT_GT(signed_volume(chair), 0.0);
  // The backrest is on the -Z side: its top vertices are at the back.
  for (const Vertex& v : chair.vertices) {
    if (v.position.y > 0.9f) {
      EXPECT_LT(v.position.z, -0.15f);
    }
  }

  const Mesh table = make_table(glm::vec3(1.4f, 0.75f, 0.8f));
  expect_valid_mesh(table);
  EXPECT_NEAR(table.bounds.min.x, -0.7f, 1e-5f);
  EXPECT_NEAR(table.bounds.max.y, 0.75f, 1e-5f);
  EXPECT_FLOAT_EQ(table.bounds.min.y, 0.0f);
  EXPECT_NEAR(table.bounds.max.z, 0.4f, 1e-5f);
  EXPECT_GT(signed_volume(table), 0.0);
}

TEST(ProceduralMesh, InvalidSizesThrow) {
  EXPECT_THAT(error_of([] { make_box(glm::vec3(1, -1, 1)); }), HasSubstr("size.y"));
  EXPECT_THAT(error_of([] { make_plane(0.0f, 1.0f); }), HasSubstr("size_x"));
  EXPECT_THAT(error_of([] { make_sphere(1.0f, 2, 8); }), HasSubstr("segments"));
  EXPECT_THAT(error_of([] { make_post(0.1f, NAN); }), HasSubstr("height"));
  EXPECT_THAT(error_of([] { make_table(glm::vec3(1, 0.05f, 1)); }), HasSubstr("make_table"));
}

TEST(ComputeNormals, CreaseKeepsCubeEdgesHard) {
  // A cube from 8 shared corners: 60-degree creases split it into 24 flat-shaded vertices.
  Mesh cube = make_box(glm::vec3(1.0f));
  Mesh welded;
  std::vector<glm::vec3> corners;
  for (const Vertex& v : cube.vertices) {
    if (std::find(corners.begin(), corners.end(), v.position) == corners.end()) {
      corners.push_back(v.position);
    }
  }
  ASSERT_EQ(corners.size(), 8u);
  for (const glm::vec3& p : corners) welded.vertices.push_back(Vertex{p, glm::vec3(0), {}});
  for (std::uint32_t index : cube.indices) {
    const auto it = std::find(corners.begin(), corners.end(), cube.vertices[index].position);
    welded.indices.push_back(static_cast<std::uint32_t>(it - corners.begin()));
  }
  update_bounds(welded);
  Mesh smooth = welded;
  compute_normals(welded);
  expect_valid_mesh(welded);
  EXPECT_EQ(welded.vertices.size(), 24u);
  for (const Vertex& v : welded.vertices) {
    EXPECT_FLOAT_EQ(std::abs(v.normal.x) + std::abs(v.normal.y) + std::abs(v.normal.z), 1.0f);
  }
  // With a crease above 90 degrees the corners are smooth (8 vertices, diagonal normals: the
  // faces are weighted by their corner angles, not by how they were triangulated).
  compute_normals(smooth, 100.0f);
  EXPECT_EQ(smooth.vertices.size(), 8u);
  for (const Vertex& v : smooth.vertices) {
    EXPECT_NEAR(glm::dot(v.normal, glm::normalize(v.position)), 1.0f, 1e-5f);
  }
}

TEST(ComputeNormals, SphereNormalsMatchTheAnalyticOnes) {
  Mesh sphere = make_sphere(2.0f, 32, 16);
  for (Vertex& v : sphere.vertices) v.normal = glm::vec3(0.0f);
  compute_normals(sphere);
  expect_valid_mesh(sphere);
  for (const Vertex& v : sphere.vertices) {
    EXPECT_GT(glm::dot(v.normal, glm::normalize(v.position)), 0.99f);
  }
}

TEST(LoadMesh, StanfordBunnyObj) {
  const Mesh bunny = load_mesh(kModels / "bunny.obj");
  EXPECT_EQ(bunny.name, "bunny");
  EXPECT_EQ(bunny.indices.size(), 3u * 69666u);
  EXPECT_GE(bunny.vertices.size(), 34835u);  // + splits at creases
  EXPECT_LE(bunny.vertices.size(), 40000u);
  expect_valid_mesh(bunny);
  // Normals point out of the body: positive signed volume about its centre.
  EXPECT_GT(signed_volume(bunny, glm::dvec3(bunny.bounds.center())), 0.0);
  // Y is up: the bunny is about as tall as it is long.
  EXPECT_GT(bunny.bounds.size().y, 1.5f);
}

TEST(LoadMesh, Asteroid3ds) {
  const Mesh low = load_mesh(kModels / "asteroid-low.3ds");
  EXPECT_EQ(low.indices.size(), 3u * 480u);
  EXPECT_GE(low.vertices.size(), 240u);
  EXPECT_LE(low.vertices.size(), 1440u);
  expect_valid_mesh(low);
  expect_outward(low, low.bounds.center());
  EXPECT_GT(signed_volume(low, glm::dvec3(low.bounds.center())), 0.0);
  EXPECT_GT(low.bounds.size().x, 1.0f);

  const Mesh high = load_mesh(kModels / "asteroid-high.3ds");
  EXPECT_EQ(high.indices.size(), 3u * 48000u);
  expect_valid_mesh(high);
  EXPECT_GT(signed_volume(high, glm::dvec3(high.bounds.center())), 0.0);
}

TEST(LoadMesh, Cube3dsKeepsHardEdges) {
  const Mesh cube = load_mesh(kModels / "cube.3ds");
  EXPECT_EQ(cube.indices.size(), 36u);
  EXPECT_EQ(cube.vertices.size(), 24u);
  expect_valid_mesh(cube);
  expect_outward(cube, glm::vec3(0.0f));
  EXPECT_NEAR(cube.bounds.min.x, -1.0f, 1e-5f);
  EXPECT_NEAR(cube.bounds.max.z, 1.0f, 1e-5f);
}

TEST(LoadMesh, ClockwiseObjIsFlippedAndGetsNormals) {
  const Mesh tetra = load_mesh(kData / "tetra_cw.obj");
  expect_valid_mesh(tetra);
  EXPECT_EQ(tetra.indices.size(), 12u);
  EXPECT_NEAR(signed_volume(tetra), 1.0 / 6.0, 1e-6);
  expect_outward(tetra, glm::vec3(0.25f));
}

TEST(LoadMesh, ObjNormalsAndFlippedTexcoords) {
  const Mesh quad = load_mesh(kData / "quad.obj");
  expect_valid_mesh(quad);
  EXPECT_EQ(quad.vertices.size(), 4u);
  EXPECT_EQ(quad.indices.size(), 6u);
  for (const Vertex& v : quad.vertices) {
    EXPECT_EQ(v.normal, glm::vec3(0, 0, 1));
    // OBJ (0, 0) is the bottom-left: in the image convention the top-left is (0, 0).
    if (v.position == glm::vec3(-1, 1, 0)) {
      EXPECT_EQ(v.uv, glm::vec2(0, 0));
    }
    if (v.position == glm::vec3(1, -1, 0)) {
      EXPECT_EQ(v.uv, glm::vec2(1, 1));
    }
  }
}

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() /
            ("penumbra_scene_test_" + std::to_string(reinterpret_cast<std::uintptr_t>(this)) + "_" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }
  fs::path write(const std::string& name, const std::string& bytes) const {
    const fs::path p = path_ / name;
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  }

 private:
  fs::path path_;
};

std::string read_bytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A non-finite vertex anywhere (not only where the bounds would show it) is an error.
TEST(LoadMesh, ANonFiniteVertexIsAnErrorNamingIt) {
  TempDir dir;
  std::string cube = read_bytes(kModels / "cube.3ds");
  const std::size_t vertices = cube.find(std::string("\x10\x41", 2));  // the vertex list chunk
  ASSERT_NE(vertices, std::string::npos);
  // chunk id (2) + length (4) + count (2), then x, y, z floats: vertex 2's y.
  const std::size_t at = vertices + 8 + 2 * 12 + 4;
  const std::string nan("\x00\x00\xc0\x7f", 4);
  cube.replace(at, 4, nan);
  const fs::path file = dir.write("nan.3ds", cube);
  const std::string e = error_of([&] { load_mesh(file); });
  EXPECT_THAT(e, HasSubstr(file.string()));
  EXPECT_THAT(e, HasSubstr("vertex 2 has a non-finite position"));
  const fs::path obj = dir.write("nan.obj", "v 0 0 0\nv 1 0 0\nv 0 1e39 0\nf 1 2 3\n");  // inf as a float
  EXPECT_THAT(error_of([&] { load_mesh(obj); }), HasSubstr("non-finite position"));
}

// An OBJ's mtllib is never opened (scene files assign materials): a FIFO or /dev/zero there
// neither blocks nor fills memory, and the mesh loads.
TEST(LoadMesh, MtllibIsNeverOpenedSoAFifoOrDevZeroCannotHang) {
  TempDir dir;
  ASSERT_EQ(::mkfifo((dir.path() / "fifo.mtl").c_str(), 0600), 0);
  fs::create_symlink("/dev/zero", dir.path() / "zero.mtl");
  for (const std::string lib : {"fifo.mtl", "zero.mtl"}) {
    const fs::path obj = dir.write("m-" + lib + ".obj", "mtllib " + lib +
                                                           "\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                                           "usemtl stone\nf 1 2 3\n");
    const Mesh m = load_mesh(obj);
    EXPECT_EQ(m.indices.size(), 3u) << lib;
  }
  // The mesh file itself must be a regular file.
  ASSERT_EQ(::mkfifo((dir.path() / "mesh.obj").c_str(), 0600), 0);
  EXPECT_THAT(error_of([&] { load_mesh(dir.path() / "mesh.obj"); }),
              HasSubstr("is not a regular file"));
}

TEST(LoadMesh, ErrorsNameTheFile) {
  TempDir dir;
  const fs::path missing = dir.path() / "nope.obj";
  EXPECT_THAT(error_of([&] { load_mesh(missing); }),
              HasSubstr("mesh file '" + missing.string() + "' not found"));

  const fs::path ply = dir.write("mesh.ply", "ply\n");
  EXPECT_THAT(error_of([&] { load_mesh(ply); }),
              HasSubstr("mesh file '" + ply.string() + "': unsupported format '.ply'"));

  const std::string cube = read_bytes(kModels / "cube.3ds");
  ASSERT_GT(cube.size(), 300u);
  const fs::path truncated = dir.write("truncated.3ds", cube.substr(0, 300));
  const std::string truncated_error = error_of([&] { load_mesh(truncated); });
  EXPECT_THAT(truncated_error, HasSubstr(truncated.string()));
  EXPECT_THAT(truncated_error, HasSubstr("truncated"));

  const fs::path not3ds = dir.write("text.3ds", "this is not a 3DS file at all");
  EXPECT_THAT(error_of([&] { load_mesh(not3ds); }), HasSubstr("not a 3DS file"));

  // A face index past the vertex list.
  std::string bad = cube;
  const std::size_t faces = bad.find(std::string("\x20\x41", 2));
  ASSERT_NE(faces, std::string::npos);
  bad[faces + 8] = '\x7f';  // first index of the first face
  const fs::path bad_index = dir.write("bad_index.3ds", bad);
  EXPECT_THAT(error_of([&] { load_mesh(bad_index); }), HasSubstr("refers to vertex"));

  const fs::path empty_obj = dir.write("empty.obj", "# nothing\nv 0 0 0\n");
  EXPECT_THAT(error_of([&] { load_mesh(empty_obj); }), HasSubstr("contains no triangles"));

  const fs::path bad_obj = dir.write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
  EXPECT_THAT(error_of([&] { load_mesh(bad_obj); }), HasSubstr(bad_obj.string()));
}

}  // namespace
}  // namespace penumbra::scene
