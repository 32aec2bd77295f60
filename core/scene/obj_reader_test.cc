#include "core/scene/obj_reader.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/scene/mesh_loader.h"
#include "core/scene/scene_test_util.h"

namespace mvbrdf::scene {
namespace {

using testing::TempDir;
using testing::WriteText;

uint32_t Bits(float f) {
  uint32_t u;
  std::memcpy(&u, &f, sizeof(u));
  return u;
}

// The corners assimp gives (through LoadMesh: positions per file triangle).
std::vector<glm::vec3> AssimpCorners(const LoadedMesh& mesh) {
  std::vector<glm::vec3> corners;
  for (const glm::uvec3& f : mesh.topology.file_triangles) {
    for (int k = 0; k < 3; ++k) corners.push_back(mesh.positions[f[k]]);
  }
  return corners;
}

void ExpectSameBits(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b, const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (size_t i = 0; i < a.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(Bits(a[i][k]), Bits(b[i][k])) << what << ": corner " << i << " coordinate " << k << ": " << a[i][k]
                                              << " vs " << b[i][k];
    }
  }
}

// A number in one of the ways exporters write them (`scaled`: some of them
// times 1e20 or 1e-20).
std::string Number(std::mt19937& rng, double value, bool scaled = true) {
  char buffer[64];
  switch (rng() % (scaled ? 9 : 6)) {
    case 0: std::snprintf(buffer, sizeof(buffer), "%.9g", value); break;
    case 1: std::snprintf(buffer, sizeof(buffer), "%.17g", value); break;
    case 2: std::snprintf(buffer, sizeof(buffer), "%e", value); break;
    case 3: std::snprintf(buffer, sizeof(buffer), "%.6f", value); break;
    case 4: std::snprintf(buffer, sizeof(buffer), "%+.7f", value); break;
    case 5: std::snprintf(buffer, sizeof(buffer), "%.12E", value); break;
    case 6: std::snprintf(buffer, sizeof(buffer), "%.3g", value * 1e20); break;
    case 7: std::snprintf(buffer, sizeof(buffer), "%.5g", value * 1e-20); break;
    default: std::snprintf(buffer, sizeof(buffer), "%d", static_cast<int>(value * 100.0)); break;
  }
  return buffer;
}

// A random plain OBJ: numbers in every way above, vt and vn lines, every
// corner form, comments, blank lines, `s` between faces, CRLF or LF.
std::string RandomPlainObj(std::mt19937& rng) {
  std::uniform_real_distribution<double> coordinate(-3.0, 3.0), unit(0.0, 1.0);
  const bool crlf = rng() % 2 == 0;
  const char* eol = crlf ? "\r\n" : "\n";
  const int num_vertices = 50 + static_cast<int>(rng() % 100);
  const bool uvs = rng() % 2 == 0, normals = rng() % 2 == 0;
  std::string text = absl::StrCat("# exported", eol, "mtllib scene.mtl", eol, "o body", eol, "g skin", eol);
  for (int v = 0; v < num_vertices; ++v) {
    absl::StrAppend(&text, "v", rng() % 4 == 0 ? "\t" : " ", Number(rng, coordinate(rng)), " ",
                    Number(rng, coordinate(rng)), "  ", Number(rng, coordinate(rng)), rng() % 5 == 0 ? " " : "", eol);
    if (uvs) absl::StrAppend(&text, "vt ", unit(rng), " ", unit(rng), rng() % 3 == 0 ? " 0" : "", eol);
    if (normals) absl::StrAppend(&text, "vn ", Number(rng, unit(rng)), " 0 ", Number(rng, -unit(rng)), eol);
  }
  absl::StrAppend(&text, "usemtl skin", eol, "s 1", eol, eol);
  const int num_faces = 40 + static_cast<int>(rng() % 80);
  for (int f = 0; f < num_faces; ++f) {
    absl::StrAppend(&text, "f");
    for (int k = 0; k < 3; ++k) {
      const int p = 1 + static_cast<int>(rng() % num_vertices);
      if (uvs && normals) {
        absl::StrAppend(&text, " ", p, "/", p, "/", p);
      } else if (uvs) {
        absl::StrAppend(&text, " ", p, "/", p);
      } else if (normals) {
        absl::StrAppend(&text, " ", p, "//", p);
      } else {
        absl::StrAppend(&text, " ", p);
      }
    }
    absl::StrAppend(&text, eol);
    if (rng() % 10 == 0) absl::StrAppend(&text, "s off", eol, "# a comment", eol);
  }
  return text;
}

TEST(ObjReaderTest, PlainFilesReadBitForBitAsAssimpReadsThem) {
  TempDir dir;
  std::mt19937 rng(17);
  for (int i = 0; i < 40; ++i) {
    const std::string text = RandomPlainObj(rng);
    const std::string name = absl::StrCat("m", i, ".obj");
    WriteText(dir / name, text);
    const std::optional<std::vector<glm::vec3>> plain = ReadPlainObjCorners(text);
    ASSERT_TRUE(plain.has_value()) << name << ":\n" << text.substr(0, 400);
    absl::StatusOr<LoadedMesh> mesh = LoadMesh(dir / name, "m");
    ASSERT_TRUE(mesh.ok()) << mesh.status();
    ExpectSameBits(*plain, AssimpCorners(*mesh), name);
    EXPECT_TRUE(mesh->topology.plain_obj) << name;
  }
}

TEST(ObjReaderTest, AnythingElseIsLeftToAssimp) {
  const std::string v = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";
  ASSERT_TRUE(ReadPlainObjCorners(v + "f 1 2 3\n").has_value());
  for (const std::string& text : std::vector<std::string>{
           v + "f 1 2 3 4\n",                       // a quad: assimp triangulates it its own way
           v + "f 1 2\n",                           // a line
           v + "l 1 2\n",                           //
           v + "p 1\n",                             //
           v + "f -1 -2 -3\n",                      // relative indices
           v + "f 1 2 5\n",                         // past the last vertex
           v + "f 0 1 2\n",                         //
           v + "f 1/1 2/1 3/1\n",                   // no vt lines
           v + "f 1//1 2//1 3//1\n",                // no vn lines
           v + "f 1/ 2/ 3/\n",                      //
           v + "f 1 2 3 # comment\n",               // a comment after a face
           v + "f 1 2 3\ng other\nf 1 3 4\n",       // a group after a face
           v + "f 1 2 3\nusemtl b\nf 1 3 4\n",      // a material after a face
           v + "f 1 2 3\no b\nf 1 3 4\n",           //
           "v 0 0 0 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  // a w
           "v 0 0 0 1 1 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  // colours
           "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",    //
           "v .5 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  // assimp does not count ".5" as a number
           "v 1. 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  //
           "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  //
           "v inf 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  //
           "v 1e 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  //
           "v 1,5 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  //
           " v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  // a line that starts with a blank
           "v 0 0 \\\n0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  // a continuation
           "v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r",  // old Mac line ends
           std::string("v 0 0 0\nv 1 0 0\0\nv 0 1 0\nf 1 2 3\n", 33),  // a byte 0
           "\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  // a byte-order mark
           v + "vt 0.5\nf 1 2 3\n",                 // one texture coordinate
           v + "vp 0 0\nf 1 2 3\n",                 // unknown keywords
           v + "cstype bspline\nf 1 2 3\n",         //
           v + "f 1234567890 2 3\n",                // ten digits
           v + "f 1 3 04\n",                        // a leading zero: assimp reads "04" as 4, then 4 again (fuzzer)
           "v " + std::string(70, '1') + " 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  // a token too long
           v,                                       // no faces
           "",                                      //
       }) {
    EXPECT_FALSE(ReadPlainObjCorners(text).has_value()) << "\"" << text << "\"";
  }
}

TEST(ObjReaderTest, MoreCornersOrVerticesThanExpectedAreLeftToAssimp) {
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  EXPECT_TRUE(ReadPlainObjCorners(tri, 3).has_value());
  EXPECT_FALSE(ReadPlainObjCorners(tri + "f 1 3 2\n", 3).has_value());     // a second triangle
  EXPECT_FALSE(ReadPlainObjCorners("v 0 0 1\n" + tri, 3).has_value());    // a fourth vertex
  EXPECT_TRUE(ReadPlainObjCorners("v 0 0 1\n" + tri, 4).has_value());
}

TEST(ObjReaderTest, LaterFramesReadInProcessGiveWhatAssimpGives) {
  TempDir dir;
  std::mt19937 rng(5);
  const std::string rest = RandomPlainObj(rng);
  WriteText(dir / "rest.obj", rest);
  absl::StatusOr<LoadedMesh> mesh = LoadMesh(dir / "rest.obj", "m");
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  ASSERT_TRUE(mesh->topology.plain_obj);
  MeshTopology through_assimp = mesh->topology;
  through_assimp.plain_obj = false;
  // The same faces, the vertices moved and written otherwise.
  std::string moved;
  for (const glm::vec3& p : mesh->positions) {
    absl::StrAppend(&moved, "v ", Number(rng, p.x + 0.25, false), " ", Number(rng, p.y, false), " ",
                    Number(rng, p.z * 2.0, false), "\n");
  }
  std::string faces;
  for (const glm::uvec3& f : mesh->topology.file_triangles) {
    absl::StrAppend(&faces, "f ", f.x + 1, " ", f.y + 1, " ", f.z + 1, "\n");
  }
  WriteText(dir / "moved.obj", moved + faces);
  for (bool flip : {false, true}) {
    absl::StatusOr<LoadedMesh> rest_mesh = LoadMesh(dir / "rest.obj", "m", flip);
    ASSERT_TRUE(rest_mesh.ok()) << rest_mesh.status();
    MeshTopology assimp_only = rest_mesh->topology;
    assimp_only.plain_obj = false;
    absl::StatusOr<FramePositions> fast = LoadFramePositions(dir / "moved.obj", rest_mesh->topology, "m", flip);
    absl::StatusOr<FramePositions> slow = LoadFramePositions(dir / "moved.obj", assimp_only, "m", flip);
    ASSERT_TRUE(fast.ok()) << fast.status();
    ASSERT_TRUE(slow.ok()) << slow.status();
    ExpectSameBits(*fast, *slow, flip ? "flipped" : "as written");
  }
  // A frame whose connectivity changed: the same error either way.
  const size_t first_face = faces.find('\n');
  const glm::uvec3 f0 = mesh->topology.file_triangles[0];
  WriteText(dir / "rewired.obj", moved + absl::StrCat("f ", f0.x + 1, " ", f0.z + 1, " ", f0.y + 1) +
                                     faces.substr(first_face));
  const absl::Status fast = LoadFramePositions(dir / "rewired.obj", mesh->topology, "m").status();
  const absl::Status slow = LoadFramePositions(dir / "rewired.obj", through_assimp, "m").status();
  EXPECT_EQ(fast.code(), absl::StatusCode::kInvalidArgument) << fast;
  EXPECT_EQ(fast, slow);
  // A frame that is not plain (a w on each vertex) is read by assimp.
  std::string homogeneous;
  for (const glm::vec3& p : mesh->positions) absl::StrAppend(&homogeneous, "v ", p.x, " ", p.y, " ", p.z, " 1\n");
  ASSERT_FALSE(ReadPlainObjCorners(homogeneous + faces).has_value());
  WriteText(dir / "w.obj", homogeneous + faces);
  absl::StatusOr<FramePositions> w = LoadFramePositions(dir / "w.obj", mesh->topology, "m");
  ASSERT_TRUE(w.ok()) << w.status();
  absl::StatusOr<FramePositions> w_assimp = LoadFramePositions(dir / "w.obj", through_assimp, "m");
  ASSERT_TRUE(w_assimp.ok()) << w_assimp.status();
  ExpectSameBits(*w, *w_assimp, "w");
  // A missing frame is NOT_FOUND, as through assimp.
  EXPECT_EQ(LoadFramePositions(dir / "gone.obj", mesh->topology, "m").status().code(), absl::StatusCode::kNotFound);
}

TEST(ObjReaderTest, OnlyAPlainObjRestPoseReadsLaterFramesInProcess) {
  TempDir dir;
  WriteText(dir / "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  WriteText(dir / "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
  WriteText(dir / "w.obj", "v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nf 1 2 3\n");
  WriteText(dir / "tri.ply",
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  for (const auto& [name, plain] : std::vector<std::pair<std::string, bool>>{
           {"tri.obj", true}, {"quad.obj", false}, {"w.obj", false}, {"tri.ply", false}}) {
    absl::StatusOr<LoadedMesh> mesh = LoadMesh(dir / name, "m");
    ASSERT_TRUE(mesh.ok()) << name << ": " << mesh.status();
    EXPECT_EQ(mesh->topology.plain_obj, plain) << name;
  }
}

}  // namespace
}  // namespace mvbrdf::scene
