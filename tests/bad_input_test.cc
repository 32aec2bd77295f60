// Bad input against the real service (issue #7, "Bad input"): one in-process
// server on a loopback port with two real workers, one small valid synthetic
// scene, and a table of cases. Each case copies the valid scene, breaks one
// thing, packs the directory into a tar by hand (so that the server, not the
// client's packer, has to catch what a hostile client could send), uploads it
// over gRPC and submits. Expected per case:
// - kRejected: the upload or SubmitJob fails with a given gRPC code and a
//   message naming the field or file;
// - kJobFails: the problem shows only while running: the job ends FAILED in
//   one attempt (permanent) with Job.error naming the field or file;
// - kJobSucceeds: input the service accepts on purpose (decisions stated in
//   the case's comment).
// A valid job runs before the cases and another after them; both must
// succeed with byte-identical atlases, and after every case the server must
// still answer (the service keeps serving, other jobs are unaffected).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "client/bundle_upload.h"
#include "client/embedded_service.h"
#include "core/base/proto_json.h"
#include "core/bundle/sha256.h"
#include "core/scene/sequence.h"
#include "core/synth/synthesizer.h"

namespace mvbrdf {
namespace {

namespace fs = std::filesystem;

constexpr char kClient[] = "bad-input-test";
constexpr int kFrames = 3;
constexpr int kWidth = 64;
constexpr int kHeight = 48;
// The server's largest message in this test (small, so that an oversized
// chunk is cheap to send).
constexpr int64_t kMaxMessageBytes = int64_t{1} << 20;
// A known configuration keeps the valid job short (no sweep).
constexpr char kConfiguration[] = "NE,NW,SE,SW";

// ---------------------------------------------------------------------------
// Small file helpers.

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void WriteText(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}

std::string FramePath(int frame) {
  char name[32];
  std::snprintf(name, sizeof(name), "meshes/mesh_%04d.obj", frame);
  return name;
}

// Replaces the first occurrence of `from` in the file; fails the test when absent.
void ReplaceInFile(const fs::path& path, const std::string& from, const std::string& to) {
  std::string text = ReadText(path);
  const size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << "\"" << from << "\" not in " << path;
  text.replace(at, from.size(), to);
  WriteText(path, text);
}

// The n-th (0-based) line starting with `prefix`.
std::string NthLine(const std::string& text, const std::string& prefix, int n) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(prefix, 0) == 0 && n-- == 0) return line;
  }
  return "";
}

// ---------------------------------------------------------------------------
// A tar written by hand (POSIX ustar): regular files, symlinks and whatever
// names a case wants, including ones the packer would refuse.

struct TarEntry {
  std::string name;
  std::string data;
  char type = '0';       // '0' regular file, '2' symlink, '5' directory
  std::string linkname;  // for symlinks
};

void PutOctal(char* field, size_t width, uint64_t value) {
  std::snprintf(field, width, "%0*llo", static_cast<int>(width - 1), static_cast<unsigned long long>(value));
}

std::string TarArchive(const std::vector<TarEntry>& entries) {
  std::string out;
  for (const TarEntry& e : entries) {
    char header[512] = {};
    std::memcpy(header, e.name.data(), std::min<size_t>(e.name.size(), 100));
    PutOctal(header + 100, 8, e.type == '5' ? 0755 : 0644);
    PutOctal(header + 108, 8, 0);
    PutOctal(header + 116, 8, 0);
    PutOctal(header + 124, 12, e.type == '0' ? e.data.size() : 0);
    PutOctal(header + 136, 12, 0);
    std::memset(header + 148, ' ', 8);
    header[156] = e.type;
    std::memcpy(header + 157, e.linkname.data(), std::min<size_t>(e.linkname.size(), 100));
    std::memcpy(header + 257, "ustar", 6);
    std::memcpy(header + 263, "00", 2);
    unsigned sum = 0;
    for (unsigned char c : header) sum += c;
    std::snprintf(header + 148, 8, "%06o", sum);
    header[155] = ' ';
    out.append(header, sizeof(header));
    if (e.type == '0') {
      out += e.data;
      out.append((512 - e.data.size() % 512) % 512, '\0');
    }
  }
  out.append(1024, '\0');
  return out;
}

// Every file under `dir` (sorted, relative names): regular files with their
// bytes, symlinks as symlinks (not followed), directories skipped.
std::vector<TarEntry> EntriesOf(const fs::path& dir) {
  std::vector<TarEntry> entries;
  for (auto it = fs::recursive_directory_iterator(dir); it != fs::recursive_directory_iterator(); ++it) {
    const fs::path& p = it->path();
    TarEntry e;
    e.name = p.lexically_relative(dir).generic_string();  // not fs::relative: it follows symlinks
    if (fs::is_symlink(it->symlink_status())) {
      e.type = '2';
      e.linkname = fs::read_symlink(p).string();
    } else if (fs::is_regular_file(it->symlink_status())) {
      e.data = ReadText(p);
    } else {
      continue;
    }
    entries.push_back(std::move(e));
  }
  std::sort(entries.begin(), entries.end(), [](const TarEntry& a, const TarEntry& b) { return a.name < b.name; });
  return entries;
}

// ---------------------------------------------------------------------------
// The table.

// What a case's mutation works on: a private copy of the valid scene, extra
// raw tar entries, and the request it is submitted with.
struct CaseInput {
  fs::path dir;                  // the scene directory to break
  std::vector<TarEntry> extra;   // appended to the archive as they are
  v1::SubmitJobRequest request;  // bundle_sha256 is filled in after the upload when empty
  std::string claimed_sha256;    // upload under this hash instead of the archive's
  std::string raw_archive;       // upload these bytes instead of the packed directory
  // Replaces upload + submit (for cases about the upload stream itself).
  std::function<grpc::Status(v1::Mvbrdf::Stub&)> custom_call;

  fs::path scene_file() const { return dir / "scene.json"; }
  v1::Scene Scene() const {
    auto scene = scene::ReadScene(scene_file());
    EXPECT_TRUE(scene.ok()) << scene.status();
    return scene.ok() ? *scene : v1::Scene();
  }
  void Write(const v1::Scene& scene) const { ASSERT_TRUE(WriteJsonFile(scene_file(), scene).ok()); }
  void EditScene(const std::function<void(v1::Scene*)>& edit) const {
    v1::Scene scene = Scene();
    edit(&scene);
    Write(scene);
  }
  fs::path Frame(int t) const { return dir / FramePath(t); }
  // Applies `edit` to every frame's mesh text (the topology stays the same across frames).
  void EditEveryFrame(const std::function<std::string(std::string)>& edit) const {
    for (int t = 0; t < kFrames; ++t) WriteText(Frame(t), edit(ReadText(Frame(t))));
  }
};

enum class Expect { kRejected, kJobFails, kJobSucceeds };

struct BadInputCase {
  const char* name;
  std::function<void(CaseInput&)> mutate;
  Expect expect;
  grpc::StatusCode code;              // kRejected only
  std::vector<std::string> expected;  // substrings of the message / Job.error
};

// Where the shared inputs live: dir_ of the fixture (a case's dir is dir_/cases/<name>).
fs::path Shared(const CaseInput& in) { return in.dir.parent_path().parent_path(); }

// Camera 1 reads an image sequence (videos/png1/%04d.png) instead of its video.
void UsePngCamera(CaseInput& in) {
  fs::copy(Shared(in) / "png/videos/cam1", in.dir / "videos/png1", fs::copy_options::recursive);
  in.EditScene([](v1::Scene* s) { s->mutable_cameras(1)->mutable_video()->set_path("videos/png1/%04d.png"); });
}

// The mean of frame 0's vertices of the triangles labelled `segment` in
// segments.txt: inside that part when it is convex (the actor's head).
std::vector<double> SegmentCentre(const CaseInput& in, const std::string& segment) {
  std::vector<std::vector<double>> vertices;
  std::vector<std::string> labels;
  std::istringstream segments(ReadText(in.dir / "segments.txt"));
  for (std::string line; std::getline(segments, line);) labels.push_back(line);
  std::istringstream lines(ReadText(in.Frame(0)));
  std::vector<double> sum(3, 0.0);
  int count = 0;
  size_t face = 0;
  for (std::string line; std::getline(lines, line);) {
    std::istringstream fields(line.substr(std::min<size_t>(2, line.size())));
    if (line.rfind("v ", 0) == 0) {
      std::vector<double> v(3);
      fields >> v[0] >> v[1] >> v[2];
      vertices.push_back(v);
    } else if (line.rfind("f ", 0) == 0) {
      int a, b, c;
      fields >> a >> b >> c;
      if (face < labels.size() && labels[face] == segment) {
        for (int k : {a, b, c}) {
          for (int i = 0; i < 3; ++i) sum[i] += vertices[static_cast<size_t>(k - 1)][i];
          ++count;
        }
      }
      ++face;
    }
  }
  EXPECT_GT(count, 0) << "no triangle labelled " << segment;
  for (double& v : sum) v /= std::max(count, 1);
  return sum;
}

// Replaces the face line `n` (0-based) of every frame with `face`.
std::string ReplaceFace(const std::string& text, int n, const std::string& face) {
  const std::string line = NthLine(text, "f ", n);
  std::string out = text;
  out.replace(out.find(line + "\n"), line.size(), face);
  return out;
}

// Reverses the winding of every face line ("f a b c" -> "f a c b").
std::string FlipFaces(const std::string& text) {
  std::istringstream lines(text);
  std::string out;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("f ", 0) == 0) {
      std::istringstream fields(line.substr(2));
      std::string a, b, c;
      fields >> a >> b >> c;
      line = absl::StrCat("f ", a, " ", c, " ", b);
    }
    out += line + "\n";
  }
  return out;
}

std::vector<BadInputCase> Cases() {
  using C = grpc::StatusCode;
  const C kInvalid = C::INVALID_ARGUMENT;
  return {
      // --- The scene file itself.
      {"MalformedJson",
       [](CaseInput& in) { WriteText(in.scene_file(), "{\"name\": \"x\",, }"); },
       Expect::kRejected,
       kInvalid,
       {"scene.json"}},
      {"TruncatedJson",
       [](CaseInput& in) {
         const std::string text = ReadText(in.scene_file());
         WriteText(in.scene_file(), text.substr(0, text.size() / 2));
       },
       Expect::kRejected,
       kInvalid,
       {"scene.json"}},
      {"UnknownField",
       [](CaseInput& in) { ReplaceInFile(in.scene_file(), "\"frames\"", "\"cameraz\": [], \"frames\""); },
       Expect::kRejected,
       kInvalid,
       {"scene.json", "cameraz"}},
      {"EmptyObject",
       [](CaseInput& in) { WriteText(in.scene_file(), "{}"); },
       Expect::kRejected,
       kInvalid,
       {"scene.mesh.path"}},
      {"UnknownEnumValue",
       [](CaseInput& in) { ReplaceInFile(in.scene_file(), "\"encoding\": \"SRGB\"", "\"encoding\": \"XYZ\""); },
       Expect::kRejected,
       kInvalid,
       {"scene.json", "encoding"}},
      {"WrongJsonType",
       [](CaseInput& in) { ReplaceInFile(in.scene_file(), "\"fps\": 15", "\"fps\": \"fast\""); },
       Expect::kRejected,
       kInvalid,
       {"scene.json", "fps"}},
      // Issue #19: protobuf took the last of two equal keys.
      {"DuplicateJsonKey",
       [](CaseInput& in) { ReplaceInFile(in.scene_file(), "\"frames\": {", "\"frames\": {\"count\": 99, "); },
       Expect::kRejected,
       kInvalid,
       {"scene.json: duplicate key \"count\" in frames"}},
      // Issue #19 defect 12: an 18 s, 5.9 GB expansion and a 1 GB error line.
      {"MeshPatternOfABillionDigits",
       [](CaseInput& in) { in.EditScene([](v1::Scene* s) { s->mutable_mesh()->set_path("mesh_%999999999d.obj"); }); },
       Expect::kRejected,
       kInvalid,
       {"scene.mesh.path: a frame number is at most 9 digits wide"}},
      {"VideoPatternOfABillionDigits",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) { s->mutable_cameras(0)->mutable_video()->set_path("v/%0999999999d.png"); });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[0].video.path: a frame number is at most 9 digits wide"}},
      {"ZeroFps",
       [](CaseInput& in) { in.EditScene([](v1::Scene* s) { s->mutable_frames()->set_fps(0); }); },
       Expect::kRejected,
       kInvalid,
       {"scene.frames.fps: must be > 0, got 0"}},
      {"NotATar",
       [](CaseInput& in) { in.raw_archive = std::string(5000, 'z'); },
       Expect::kRejected,
       C::INVALID_ARGUMENT,
       {"bundle"}},
      {"NoSceneFileInBundle",
       [](CaseInput& in) { fs::rename(in.scene_file(), in.dir / "scene.txt"); },
       Expect::kRejected,
       kInvalid,
       {"scene"}},

      // --- Missing, unreadable and misplaced files.
      {"MissingMeshFile",
       [](CaseInput& in) { fs::remove(in.Frame(0)); },
       Expect::kRejected,
       kInvalid,
       {"scene.mesh.path (frame 0)", "mesh_0000.obj"}},
      {"MissingLaterMeshFrame",
       [](CaseInput& in) { fs::remove(in.Frame(2)); },
       Expect::kRejected,
       kInvalid,
       {"scene.mesh.path (frame 2): mesh file not found: meshes/mesh_0002.obj"}},
      {"DirectoryWhereMeshFileExpected",
       [](CaseInput& in) {
         fs::remove(in.Frame(0));
         in.extra.push_back({FramePath(0) + "/", "", '5', ""});
       },
       Expect::kRejected,
       kInvalid,
       {"mesh_0000.obj"}},
      {"DanglingSymlinkForVideo",
       [](CaseInput& in) {
         fs::remove(in.dir / "videos/cam1.mkv");
         fs::create_symlink("nowhere.mkv", in.dir / "videos/cam1.mkv");
       },
       Expect::kRejected,
       kInvalid,
       {"videos/cam1.mkv"}},
      {"MissingSegmentationFile",
       [](CaseInput& in) { fs::remove(in.dir / "segments.txt"); },
       Expect::kRejected,
       kInvalid,
       {"scene.segmentation_path", "segments.txt"}},

      // --- Videos and images.
      {"VideoWithFewerFramesThanTheScene",
       [](CaseInput& in) {
         fs::copy_file(Shared(in) / "short.mkv", in.dir / "videos/cam1.mkv", fs::copy_options::overwrite_existing);
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].video", "has 2 frames", "needs 3"}},
      // Video.frame_offset (issue #20): the shifted frames must lie in the video.
      {"FrameOffsetBeforeTheVideosStart",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) { s->mutable_cameras(1)->mutable_video()->set_frame_offset(-1); });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].video.frame_offset: camera \"cam1\": frame 0 of the sequence would be frame -1 of its "
        "video"}},
      {"FrameOffsetPastTheVideosEnd",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) { s->mutable_cameras(1)->mutable_video()->set_frame_offset(1); });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].video",
        "camera \"cam1\": frame 2 of the sequence is frame 3 of its video, past the video's end"}},
      {"CorruptVideoFile",
       [](CaseInput& in) { WriteText(in.dir / "videos/cam0.mkv", std::string(4096, 'x')); },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[0].video", "cam0.mkv"}},
      {"VideoOfTheWrongFrameSize",
       [](CaseInput& in) { in.EditScene([](v1::Scene* s) { s->mutable_cameras(1)->set_width(80); }); },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].video", "64x48, expected 80x48"}},
      {"CorruptFirstImage",
       [](CaseInput& in) {
         UsePngCamera(in);
         WriteText(in.dir / "videos/png1/0000.png", "\x89PNG\r\n\x1a\nnot really");
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].video", "videos/png1/0000.png"}},
      {"CorruptLaterImage",
       [](CaseInput& in) {
         UsePngCamera(in);
         WriteText(in.dir / "videos/png1/0001.png", "\x89PNG\r\n\x1a\nnot really");
       },
       Expect::kJobFails,
       C::OK,
       {"scene.cameras[1].video: frame 1 (videos/png1/0001.png): cannot decode image"}},
      {"ImageOfTheWrongSize",
       [](CaseInput& in) {
         UsePngCamera(in);
         fs::copy_file(Shared(in) / "small.png", in.dir / "videos/png1/0000.png", fs::copy_options::overwrite_existing);
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].video", "expected 64x48"}},
      {"MissingLaterImage",
       [](CaseInput& in) {
         UsePngCamera(in);
         fs::remove(in.dir / "videos/png1/0002.png");
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].video", "has 2 frames"}},

      // --- Meshes.
      {"MeshWithNoFaces",
       [](CaseInput& in) { WriteText(in.Frame(0), "v 0 0 0\nv 1 0 0\nv 0 1 0\n"); },
       Expect::kRejected,
       kInvalid,
       {"scene.mesh.path (frame 0)", "mesh_0000.obj"}},
      {"NanVertexInFirstFrame",
       [](CaseInput& in) { ReplaceInFile(in.Frame(0), "v 0 1.06999993 0", "v 0 nan 0"); },
       Expect::kRejected,
       kInvalid,
       {"mesh_0000.obj", "non-finite"}},
      {"NanVertexInLaterFrame",
       [](CaseInput& in) {
         const std::string line = NthLine(ReadText(in.Frame(2)), "v ", 0);
         ReplaceInFile(in.Frame(2), line + "\n", "v 0 nan 0\n");
       },
       Expect::kJobFails,
       C::OK,
       {"scene.mesh.path (frame 2): meshes/mesh_0002.obj", "non-finite"}},
      {"TopologyChangesBetweenFrames",
       [](CaseInput& in) { WriteText(in.Frame(1), ReplaceFace(ReadText(in.Frame(1)), 5, "")); },
       Expect::kJobFails,
       C::OK,
       {"scene.mesh.path (frame 1): meshes/mesh_0001.obj: topology differs from frame 0"}},
      {"UvsOutOfRange",
       [](CaseInput& in) {
         std::string text = ReadText(in.Frame(0));
         std::string out = "vt 5 5\n";
         std::istringstream lines(text);
         std::string line;
         while (std::getline(lines, line)) {
           if (line.rfind("f ", 0) == 0) {
             std::istringstream f(line.substr(2));
             std::string a, b, c;
             f >> a >> b >> c;
             line = absl::StrCat("f ", a, "/1 ", b, "/1 ", c, "/1");
           }
           out += line + "\n";
         }
         WriteText(in.Frame(0), out);
       },
       Expect::kRejected,
       kInvalid,
       {"mesh_0000.obj", "outside [0,1]^2"}},
      // Decision: non-manifold edges are accepted (the pipeline works per
      // triangle: resampling, Samples and fits never walk edges).
      {"NonManifoldEdge",
       [](CaseInput& in) {
         // Faces 0 and 1 share the edge 1-3 ("f 1 3 2", "f 1 4 3"); face 40
         // becomes a third triangle on that edge.
         in.EditEveryFrame([](std::string text) { return ReplaceFace(text, 40, "f 1 3 100"); });
       },
       Expect::kJobSucceeds,
       C::OK,
       {}},
      // Decision: zero-area triangles are kept in the topology (indices stay
      // stable) and excluded from resampling and fitting, counted in
      // `mvbrdf validate`'s summary.
      {"ZeroAreaTriangle",
       [](CaseInput& in) {
         in.EditEveryFrame([](std::string t) { return ReplaceFace(t, 40, "f 1 1 2"); });
         // Counted where `mvbrdf validate` shows it.
         auto seq = scene::LoadSequence(in.scene_file());
         ASSERT_TRUE(seq.ok()) << seq.status();
         EXPECT_EQ(seq->topology.zero_area_triangles, std::vector<uint32_t>{40});
         EXPECT_NE(scene::Summarize(*seq).find("zero-area triangles: 1 excluded"), std::string::npos);
       },
       Expect::kJobSucceeds,
       C::OK,
       {}},

      // --- Cameras.
      {"NonPositiveFocalLength",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) { s->mutable_cameras(1)->mutable_intrinsics()->set_fx(0); });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].intrinsics.fx: must be > 0, got 0"}},
      {"SeedWithSrgb8AndLinearRgb",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           for (double v : {0.1, 0.2, 0.3}) s->mutable_material_seeds(0)->add_linear_rgb(v);
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.material_seeds[0]: give one of srgb8 and linear_rgb, not both"}},
      {"SeedLinearRgbNegative",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           s->mutable_material_seeds(0)->clear_srgb8();
           for (double v : {0.1, -0.2, 0.3}) s->mutable_material_seeds(0)->add_linear_rgb(v);
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.material_seeds[0].linear_rgb[1]: must be a finite number in [0, 1e+12], got -0.2"}},
      {"SeedLinearRgbTwoValues",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           s->mutable_material_seeds(0)->clear_srgb8();
           for (double v : {0.1, 0.2}) s->mutable_material_seeds(0)->add_linear_rgb(v);
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.material_seeds[0].linear_rgb"}},
      {"NegativeFocalLengthY",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) { s->mutable_cameras(0)->mutable_intrinsics()->set_fy(-3); });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[0].intrinsics.fy: must be > 0, got -3"}},
      // Issue #13: the orthographic camera model (pixel_size, no focal
      // lengths, no distortion), and pixel_size only for it.
      {"OrthographicWithoutPixelSize",
       [](CaseInput& in) { in.EditScene([](v1::Scene* s) { s->mutable_cameras(1)->set_model(v1::ORTHOGRAPHIC); }); },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].pixel_size: must be > 0, got 0"}},
      {"OrthographicNegativePixelSize",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           s->mutable_cameras(0)->set_model(v1::ORTHOGRAPHIC);
           s->mutable_cameras(0)->set_pixel_size(-0.5);
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[0].pixel_size: must be > 0, got -0.5"}},
      {"OrthographicWithFocalLength",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           s->mutable_cameras(1)->set_model(v1::ORTHOGRAPHIC);
           s->mutable_cameras(1)->set_pixel_size(0.01);
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].intrinsics.fx: must be 0 (or absent) for an ORTHOGRAPHIC camera, whose scale is pixel_size"}},
      {"OrthographicWithDistortion",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           v1::Camera* c = s->mutable_cameras(1);
           c->set_model(v1::ORTHOGRAPHIC);
           c->set_pixel_size(0.01);
           c->mutable_intrinsics()->set_fx(0);
           c->mutable_intrinsics()->set_fy(0);
           for (double k : {0.1, 0.0, 0.0, 0.0}) c->mutable_intrinsics()->add_distortion(k);
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].intrinsics.distortion: must be empty for an ORTHOGRAPHIC camera"}},
      {"PinholeWithPixelSize",
       [](CaseInput& in) { in.EditScene([](v1::Scene* s) { s->mutable_cameras(0)->set_pixel_size(0.01); }); },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[0].pixel_size: only for an ORTHOGRAPHIC camera"}},
      {"UnknownCameraModel",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) { s->mutable_cameras(0)->set_model(static_cast<v1::CameraModel>(7)); });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[0].model: unknown value 7"}},
      {"RotationNotOrthonormal",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) { s->mutable_cameras(1)->mutable_cam_from_world()->set_rotation(0, 2.0); });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].cam_from_world.rotation"}},
      // Decision: a camera that sees none of the mesh in frame 0 is rejected
      // at submit (it can only add nothing or mislead a fit).
      {"CameraThatSeesNothing",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           // Turn camera 1 around (a rotation of pi about its y axis): R' = diag(-1, 1, -1) R, t' likewise.
           auto* pose = s->mutable_cameras(1)->mutable_cam_from_world();
           for (int k : {0, 1, 2, 6, 7, 8}) pose->set_rotation(k, -pose->rotation(k));
           pose->set_translation(0, -pose->translation(0));
           pose->set_translation(2, -pose->translation(2));
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1]", "sees none of the mesh"}},
      {"DuplicateCameraNames",
       [](CaseInput& in) { in.EditScene([](v1::Scene* s) { s->mutable_cameras(1)->set_name("cam0"); }); },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].name: duplicate \"cam0\""}},

      // --- Lights and configurations.
      {"DuplicateLightNames",
       [](CaseInput& in) { in.EditScene([](v1::Scene* s) { s->mutable_lights(1)->set_name(s->lights(0).name()); }); },
       Expect::kRejected,
       kInvalid,
       {"scene.lights[1].name: duplicate"}},
      {"LightWithPositionAndDirection",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           for (double v : {0.0, 1.0, 0.0}) s->mutable_lights(2)->add_direction(v);
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.lights[2]: exactly one of position", "got both"}},
      {"SegmentationOfTheWrongLength",
       [](CaseInput& in) {
         const std::string text = ReadText(in.dir / "segments.txt");
         WriteText(in.dir / "segments.txt", text.substr(0, text.size() / 2));
       },
       Expect::kRejected,
       kInvalid,
       {"scene.segmentation_path: segments.txt has"}},
      {"ConfigurationNamesUnknownLight",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) { s->mutable_light_configurations(0)->set_lights(0, "moon"); });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.light_configurations[0].lights[0]: unknown light \"moon\""}},
      {"RequestNamesUnknownConfiguration",
       [](CaseInput& in) { in.request.set_configuration("XX,YY"); },
       Expect::kRejected,
       kInvalid,
       {"configuration", "XX,YY"}},
      {"RequestNamesUnknownCandidate",
       [](CaseInput& in) {
         in.request.clear_configuration();
         in.request.add_configurations("C");
         in.request.add_configurations("nope");
       },
       Expect::kRejected,
       kInvalid,
       {"configurations[1]", "nope"}},
      // Decision: a point light inside the mesh is accepted (it lights back
      // faces only, which n.l <= 0 clamps to no light; the configuration then
      // explains the images badly, which is what the sweep measures). It must
      // not crash or produce NaN: the light "NE" sits inside the head, and
      // the job sweeps two configurations, one with NE. On this tiny scene
      // (2 cameras, 64x48, atlas 64) the head's 64 "skin" texels then hold no
      // lit Sample, and since issue #13 item 7 that fails the job naming the
      // cluster instead of printing its initial guess as the result.
      {"LightInsideTheMesh",
       [](CaseInput& in) {
         const std::vector<double> centre = SegmentCentre(in, "head");
         in.EditScene([&](v1::Scene* s) {
           for (auto& light : *s->mutable_lights()) {
             if (light.name() == "NE") {
               light.clear_position();
               for (double v : centre) light.add_position(v);
             }
           }
         });
         in.request.clear_configuration();
         in.request.add_configurations(kConfiguration);
         in.request.add_configurations("C");
         // The thesis's rule picks the configuration with the light inside
         // the head (the held-out criterion picks C, which lights everything).
         in.request.mutable_options()->set_sweep_criterion(v1::SWEEP_CRITERION_E_D);
         // Unsmoothed labels: the smoothing hands the unlit skin texels to
         // their lit neighbours' clusters, and this case is about the check.
         in.request.mutable_options()->set_cluster_smoothness(0.0);
       },
       Expect::kJobFails,
       C::OK,
       {"cluster \"skin\"", "no Samples to fit its BRDF"}},

      // Issue #13: up to 1024 candidate lights (samples::kMaxLights); more
      // are refused at submit, naming scene.lights.
      {"MoreThanTheMostLights",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           const v1::Light first = s->lights(0);
           while (s->lights_size() < 1025) {
             v1::Light* light = s->add_lights();
             *light = first;
             light->set_name(absl::StrCat("extra", s->lights_size()));
           }
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.lights: at most 1024 lights, got 1025"}},
      // Issue #19 defect 7: 1e30 gave "mseBrdf": "Infinity" in a SUCCEEDED job.
      {"IntensityThatOverflowsFloatMaths",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           auto* light = s->mutable_lights(0);
           light->clear_intensity();
           for (int c = 0; c < 3; ++c) light->add_intensity(1e30);
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.lights[0].intensity[0]: must be a finite number in [0, 1e+12]"}},
      // Issue #13 item 5: 48 lights passed validation and the run failed
      // ("task gather '' failed: scene.lights: at most 16 lights").
      {"MoreLightsThanARunTakes",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           for (int i = s->lights_size(); i <= scene::kMaxLights; ++i) {
             v1::Light* light = s->add_lights();
             *light = s->lights(0);
             light->set_name(absl::StrCat("extra", i));
           }
         });
       },
       Expect::kRejected,
       kInvalid,
       {absl::StrCat("scene.lights: at most ", scene::kMaxLights, " lights")}},
      {"LightDirectionFarFromUnitLength",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           s->mutable_lights(0)->clear_position();
           for (double v : {0.0, 1.002, 0.0}) s->mutable_lights(0)->add_direction(v);
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.lights[0].direction: must have unit length (within 0.001"}},
      // Decision: off unit length by less than 1e-3 (rounded published data)
      // is renormalised, and the job runs.
      {"LightDirectionNearUnitLength",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           s->mutable_lights(0)->clear_position();
           for (double v : {0.0, 1.0 + 6e-5, 0.0}) s->mutable_lights(0)->add_direction(v);
         });
       },
       Expect::kJobSucceeds,
       C::OK,
       {}},
      // Issue #13 item 6: masks and saturation levels.
      {"MaskFileMissing",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) { s->mutable_cameras(1)->mutable_video()->set_mask_path("masks/none.png"); });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].video.mask_path", "masks/none.png"}},
      {"MaskOutsideTheSceneFolder",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) { s->mutable_cameras(0)->mutable_video()->set_mask_path("../mask.png"); });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[0].video.mask_path: must be a relative path inside the scene's directory"}},
      {"SaturationLevelZero",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) { s->mutable_cameras(1)->mutable_video()->set_saturation_level(0); });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[1].video.saturation_level: must be in [1, 256]"}},
      {"SaturationLevelAboveTheBitDepth",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) { s->mutable_cameras(0)->mutable_video()->set_saturation_level(1000); });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[0].video.saturation_level: must be in [1, 256]", "got 1000"}},
      // Issue #13 item 9: the resampling's job options.
      {"BothDepthTolerances",
       [](CaseInput& in) {
         in.request.mutable_options()->set_depth_tolerance_absolute(0.01);
         in.request.mutable_options()->set_depth_tolerance_relative(0.01);
       },
       Expect::kRejected,
       kInvalid,
       {"options.depth_tolerance_absolute, depth_tolerance_relative: give at most one"}},
      {"NegativeAbsoluteDepthTolerance",
       [](CaseInput& in) { in.request.mutable_options()->set_depth_tolerance_absolute(-1); },
       Expect::kRejected,
       kInvalid,
       {"options.depth_tolerance_absolute: must be a finite number >= 0"}},
      {"NonFiniteRelativeDepthTolerance",
       [](CaseInput& in) { in.request.mutable_options()->set_depth_tolerance_relative(NAN); },
       Expect::kRejected,
       kInvalid,
       {"options.depth_tolerance_relative: must be a finite number >= 0"}},
      {"GrazingMarginOf90Degrees",
       [](CaseInput& in) { in.request.mutable_options()->set_grazing_margin_degrees(90); },
       Expect::kRejected,
       kInvalid,
       {"options.grazing_margin_degrees: must be in [0, 90) degrees, got 90"}},
      // Issue #13 item 5: frames chosen by frames.step or frames.indices.
      {"FramesIndicesNotIncreasing",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           s->mutable_frames()->set_count(0);
           for (uint32_t i : {0u, 2u, 2u}) s->mutable_frames()->add_indices(i);
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.frames.indices[2]: must be strictly increasing, got 2 after 2"}},
      {"FramesIndicesWithStep",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           s->mutable_frames()->set_step(2);
           for (uint32_t i : {0u, 1u}) s->mutable_frames()->add_indices(i);
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.frames.step: must be 0 or 1 when frames.indices is given, got 2"}},
      {"FramesIndicesAndAnotherCount",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           s->mutable_frames()->set_count(3);
           for (uint32_t i : {0u, 1u}) s->mutable_frames()->add_indices(i);
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.frames.count: must be 0 or the number of frames.indices (2), got 3"}},
      {"FramesIndicesWithFirst",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) {
           s->mutable_frames()->set_count(0);
           s->mutable_frames()->set_first(1);
           for (uint32_t i : {1u, 2u}) s->mutable_frames()->add_indices(i);
         });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.frames.first: must be 0 when frames.indices is given"}},
      {"FramesStepPastTheLastFile",
       [](CaseInput& in) { in.EditScene([](v1::Scene* s) { s->mutable_frames()->set_step(2); }); },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[0].video: has 2 frames from frame 0, the scene needs 3 (of those scene.frames selects)"}},
      {"FramesStepOverflows",
       [](CaseInput& in) { in.EditScene([](v1::Scene* s) { s->mutable_frames()->set_step(2000000000u); }); },
       Expect::kRejected,
       kInvalid,
       {"scene.frames: first + (count - 1) * step must be < 2^31 - 1"}},
      // Issue #13 item 5: an inside-out mesh ran to the initial guess, exit 0.
      {"MeshFacingInwards",
       [](CaseInput& in) { WriteText(in.Frame(0), FlipFaces(ReadText(in.Frame(0)))); },
       Expect::kRejected,
       kInvalid,
       {"scene.mesh.path (frame 0)", "triangles face inwards", "scene.mesh.flipWinding"}},
      {"FlipWindingOfAnOutwardMesh",
       [](CaseInput& in) { in.EditScene([](v1::Scene* s) { s->mutable_mesh()->set_flip_winding(true); }); },
       Expect::kRejected,
       kInvalid,
       {"scene.mesh.path (frame 0)", "triangles face inwards", "flipWinding", "it is true"}},
      // Issue #19 defect 7: a camera inside the head sees only back faces; its
      // MSE was 0.000000. Issue #13 item 7: on this small scene the hair's
      // texels are seen by that camera alone, so the hair cluster has no
      // Sample for its fit and the job fails naming it (it printed the fit's
      // initial guess, kd 0.5 ks 0 ke 10, as the hair's BRDF). The camera's
      // own warning ("observed no lit texel") is not reached on this scene.
      {"CameraInsideTheMesh",
       [](CaseInput& in) {
         const std::vector<double> centre = SegmentCentre(in, "head");
         in.EditScene([&](v1::Scene* s) {
           auto* pose = s->mutable_cameras(1)->mutable_cam_from_world();
           for (int r = 0; r < 3; ++r) {  // t = -R c: the camera's centre at c
             double t = 0.0;
             for (int k = 0; k < 3; ++k) t -= pose->rotation(r * 3 + k) * centre[static_cast<size_t>(k)];
             pose->set_translation(r, t);
           }
         });
       },
       Expect::kJobFails,
       C::OK,
       {"cluster \"hair\"", "no Samples to fit its BRDF"}},

      // --- Absurd sizes.
      // The server's limit (max_atlas_size, 4096 by default) answers first.
      {"AtlasOf100000Texels",
       [](CaseInput& in) { in.request.mutable_options()->set_atlas_size(100000); },
       Expect::kRejected,
       C::RESOURCE_EXHAUSTED,
       {"options.atlas_size", "100000"}},
      {"AtlasOf8Texels",
       [](CaseInput& in) { in.request.mutable_options()->set_atlas_size(8); },
       Expect::kRejected,
       kInvalid,
       {"options.atlas_size: must be in [16, 16384], got 8"}},
      {"IterationsThatWouldWrap",
       [](CaseInput& in) { in.request.mutable_options()->set_max_iterations(4294967295u); },
       Expect::kRejected,
       kInvalid,
       {"options.max_iterations: must be in [1, 100000], got 4294967295"}},
      {"NegativeKdPriorStrength",
       [](CaseInput& in) { in.request.mutable_options()->set_kd_prior_strength(-0.5); },
       Expect::kRejected,
       kInvalid,
       {"options.kd_prior_strength: must be finite and >= 0, got -0.5"}},
      {"NegativeClusterSmoothness",
       [](CaseInput& in) { in.request.mutable_options()->set_cluster_smoothness(-1.0); },
       Expect::kRejected,
       kInvalid,
       {"options.cluster_smoothness: must be a finite number >= 0, got -1"}},
      {"MillionFrames",
       [](CaseInput& in) { in.EditScene([](v1::Scene* s) { s->mutable_frames()->set_count(1000000); }); },
       Expect::kRejected,
       C::RESOURCE_EXHAUSTED,
       {"scene.frames.count", "1000000", "max_frames"}},
      {"OutputOutOfRange",
       [](CaseInput& in) { in.request.add_outputs(static_cast<v1::Output>(99)); },
       Expect::kRejected,
       kInvalid,
       {"outputs[0]", "99"}},

      // --- Paths that leave the bundle.
      {"MeshPathWithDotDot",
       [](CaseInput& in) { in.EditScene([](v1::Scene* s) { s->mutable_mesh()->set_path("../x_%04d.obj"); }); },
       Expect::kRejected,
       kInvalid,
       {"scene.mesh.path", "../x_%04d.obj"}},
      {"AbsoluteVideoPath",
       [](CaseInput& in) {
         in.EditScene([](v1::Scene* s) { s->mutable_cameras(0)->mutable_video()->set_path("/etc/passwd"); });
       },
       Expect::kRejected,
       kInvalid,
       {"scene.cameras[0].video.path", "/etc/passwd"}},
      {"TarEntryWithDotDot",
       [](CaseInput& in) {
         in.extra.push_back({"../x.obj", "v 0 0 0\n", '0', ""});
       },
       Expect::kRejected,
       kInvalid,
       {"../x.obj"}},
      {"TarEntryAbsolute",
       [](CaseInput& in) {
         in.extra.push_back({"/tmp/bad_input_abs.obj", "v 0 0 0\n", '0', ""});
       },
       Expect::kRejected,
       kInvalid,
       {"/tmp/bad_input_abs.obj"}},
      {"SymlinkPointingOutside",
       [](CaseInput& in) {
         fs::remove(in.Frame(1));
         fs::create_symlink("/etc/passwd", in.Frame(1));
       },
       Expect::kRejected,
       kInvalid,
       {"mesh_0001.obj"}},

      // --- The request and the upload.
      {"ScenePathEscapes",
       [](CaseInput& in) { in.request.set_scene_path("../scene.json"); },
       Expect::kRejected,
       kInvalid,
       {"scene_path"}},
      {"ScenePathNotInBundle",
       [](CaseInput& in) { in.request.set_scene_path("other.json"); },
       Expect::kRejected,
       kInvalid,
       {"scene_path", "other.json"}},
      {"BundleShaNotHex",
       [](CaseInput& in) { in.request.set_bundle_sha256("not-a-hash"); },
       Expect::kRejected,
       kInvalid,
       {"bundle_sha256"}},
      {"BundleShaNotUploaded",
       [](CaseInput& in) { in.request.set_bundle_sha256(std::string(64, 'a')); },
       Expect::kRejected,
       C::FAILED_PRECONDITION,
       {"bundle_sha256", "not uploaded"}},
      {"UploadHashMismatch",
       [](CaseInput& in) { in.claimed_sha256 = std::string(64, 'b'); },
       Expect::kRejected,
       kInvalid,
       {"sha256"}},
      {"OversizedChunk",
       [](CaseInput& in) {
         in.custom_call = [](v1::Mvbrdf::Stub& stub) {
           grpc::ClientContext context;
           context.AddMetadata("x-mvbrdf-client", kClient);
           v1::UploadStatus status;
           auto writer = stub.UploadBundle(&context, &status);
           v1::UploadChunk chunk;
           chunk.set_sha256(std::string(64, 'c'));
           const size_t size = static_cast<size_t>(kMaxMessageBytes) * 2;
           chunk.set_total_size(size);
           chunk.set_data(std::string(size, 'x'));
           writer->Write(chunk);
           writer->WritesDone();
           return writer->Finish();
         };
       },
       Expect::kRejected,
       C::RESOURCE_EXHAUSTED,
       {}},
      // Over the service's limit but inside the transport's margin: the
      // service's own check answers, with the same code.
      {"OversizedChunkWithinTheTransportMargin",
       [](CaseInput& in) {
         in.custom_call = [](v1::Mvbrdf::Stub& stub) {
           grpc::ClientContext context;
           context.AddMetadata("x-mvbrdf-client", kClient);
           v1::UploadStatus status;
           auto writer = stub.UploadBundle(&context, &status);
           v1::UploadChunk chunk;
           chunk.set_sha256(std::string(64, 'd'));
           const size_t size = static_cast<size_t>(kMaxMessageBytes) + 1000;
           chunk.set_total_size(size);
           chunk.set_data(std::string(size, 'x'));
           writer->Write(chunk);
           writer->WritesDone();
           return writer->Finish();
         };
       },
       Expect::kRejected,
       C::RESOURCE_EXHAUSTED,
       {"data"}},
  };
}

// ---------------------------------------------------------------------------

class BadInputTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("mvbrdf_bad_input_test_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    {
      auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
      ASSERT_TRUE(context.ok()) << context.status();
      synth::SynthOptions so;
      so.num_cameras = 2;
      so.num_frames = kFrames;
      so.width = kWidth;
      so.height = kHeight;
      so.actor_segments = 6;
      so.shadow_map_size = 256;
      so.out_dir = dir_ / "valid";
      auto valid = synth::Synthesize(so, **context);
      ASSERT_TRUE(valid.ok()) << valid.status();
      // The same scene as image sequences, for the image cases.
      so.video_format = synth::VideoFormat::kPng;
      so.out_dir = dir_ / "png";
      ASSERT_TRUE(synth::Synthesize(so, **context).ok());
      // A video one frame short.
      so.video_format = synth::VideoFormat::kFfv1;
      so.num_frames = kFrames - 1;
      so.out_dir = dir_ / "short";
      ASSERT_TRUE(synth::Synthesize(so, **context).ok());
      // A smaller image.
      so.width = kWidth / 2;
      so.height = kHeight / 2;
      so.num_frames = 1;
      so.num_cameras = 1;
      so.video_format = synth::VideoFormat::kPng;
      so.out_dir = dir_ / "small";
      ASSERT_TRUE(synth::Synthesize(so, **context).ok());
    }
    fs::copy_file(dir_ / "short/videos/cam1.mkv", dir_ / "short.mkv");
    fs::copy_file(dir_ / "small/videos/cam0/0000.png", dir_ / "small.png");
    client::EmbeddedOptions eo;
    eo.data_dir = dir_ / "server";
    eo.workers = 2;
    eo.egl = gl::EglPlatform::kSurfaceless;
    eo.threads_per_worker = 1;
    eo.server.limits.max_message_bytes = kMaxMessageBytes;
    auto service = client::EmbeddedService::Start(eo);
    ASSERT_TRUE(service.ok()) << service.status();
    service_ = service->release();
    stub_ = v1::Mvbrdf::NewStub(service_->channel()).release();
  }

  static void TearDownTestSuite() {
    delete stub_;
    delete service_;
    std::error_code ec;
    if (std::getenv("MVBRDF_KEEP_TEST_DIR") == nullptr) fs::remove_all(dir_, ec);
  }

  static v1::SubmitJobRequest ValidRequest() {
    v1::SubmitJobRequest request;
    request.set_configuration(kConfiguration);
    request.mutable_options()->set_atlas_size(64);
    request.mutable_options()->set_max_iterations(10);
    return request;
  }

  // Packs `in` (its directory and extra entries), uploads and submits; the
  // first failing step's status, else OK with the job's id.
  static grpc::Status UploadAndSubmit(const CaseInput& in, std::string* job_id) {
    std::vector<TarEntry> entries = EntriesOf(in.dir);
    entries.insert(entries.end(), in.extra.begin(), in.extra.end());
    const std::string archive = in.raw_archive.empty() ? TarArchive(entries) : in.raw_archive;
    const fs::path archive_file = in.dir.string() + ".tar";
    WriteText(archive_file, archive);
    const std::string sha256 = in.claimed_sha256.empty() ? bundle::Sha256Bytes(archive) : in.claimed_sha256;
    client::UploadOutcome outcome;
    const absl::Status uploaded =
        client::UploadBundleFile(*stub_, kClient, archive_file, sha256, archive.size(), nullptr, &outcome);
    if (!uploaded.ok()) {
      return grpc::Status(static_cast<grpc::StatusCode>(uploaded.code()), std::string(uploaded.message()));
    }
    v1::SubmitJobRequest request = in.request;
    if (request.bundle_sha256().empty()) request.set_bundle_sha256(sha256);
    grpc::ClientContext context;
    context.AddMetadata("x-mvbrdf-client", kClient);
    v1::SubmitJobResponse response;
    const grpc::Status status = stub_->SubmitJob(&context, request, &response);
    if (status.ok()) *job_id = response.job().id();
    return status;
  }

  static v1::Job WaitForJob(const std::string& job_id) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(3);
    while (std::chrono::steady_clock::now() < deadline) {
      grpc::ClientContext context;
      context.AddMetadata("x-mvbrdf-client", kClient);
      v1::ListJobsRequest request;
      v1::ListJobsResponse response;
      EXPECT_TRUE(stub_->ListJobs(&context, request, &response).ok());
      for (const v1::Job& job : response.jobs()) {
        if (job.id() == job_id &&
            (job.state() == v1::SUCCEEDED || job.state() == v1::FAILED || job.state() == v1::CANCELLED)) {
          return job;
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    ADD_FAILURE() << "job " << job_id << " did not end";
    return v1::Job();
  }

  static std::string Fetch(const std::string& job_id, const std::string& name) {
    grpc::ClientContext context;
    context.AddMetadata("x-mvbrdf-client", kClient);
    v1::FetchArtifactRequest request;
    request.set_job_id(job_id);
    request.set_name(name);
    auto reader = stub_->FetchArtifact(&context, request);
    std::string bytes;
    v1::ArtifactChunk chunk;
    while (reader->Read(&chunk)) bytes += chunk.data();
    const grpc::Status status = reader->Finish();
    EXPECT_TRUE(status.ok()) << name << ": " << status.error_message();
    return bytes;
  }

  // The server still answers a cheap call.
  static bool Serving() {
    grpc::ClientContext context;
    context.AddMetadata("x-mvbrdf-client", kClient);
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    v1::ListJobsRequest request;
    v1::ListJobsResponse response;
    return stub_->ListJobs(&context, request, &response).ok();
  }

  // A fresh copy of the valid scene under dir_/cases/<name>.
  static CaseInput NewCase(const std::string& name) {
    CaseInput in;
    in.dir = dir_ / "cases" / name;
    fs::create_directories(in.dir.parent_path());
    fs::copy(dir_ / "valid", in.dir, fs::copy_options::recursive);
    fs::remove_all(in.dir / "ground_truth");  // not needed by a job
    in.request = ValidRequest();
    return in;
  }

  static fs::path dir_;
  static client::EmbeddedService* service_;
  static v1::Mvbrdf::Stub* stub_;
};

fs::path BadInputTest::dir_;
client::EmbeddedService* BadInputTest::service_ = nullptr;
v1::Mvbrdf::Stub* BadInputTest::stub_ = nullptr;

std::string Describe(const grpc::Status& s) { return absl::StrCat(s.error_code(), " \"", s.error_message(), "\""); }

TEST_F(BadInputTest, EveryCaseGetsAClearErrorAndTheServiceKeepsServing) {
  // A valid job first; it runs while the bad input arrives.
  std::string valid_before;
  ASSERT_TRUE(UploadAndSubmit(NewCase("valid_before"), &valid_before).ok());

  const std::vector<BadInputCase> cases = Cases();
  EXPECT_GE(cases.size(), 30u);
  std::map<std::string, std::string> jobs;  // case name -> job id
  for (const BadInputCase& c : cases) {
    SCOPED_TRACE(c.name);
    CaseInput in = NewCase(c.name);
    c.mutate(in);
    std::string job_id;
    const grpc::Status status = in.custom_call ? in.custom_call(*stub_) : UploadAndSubmit(in, &job_id);
    if (c.expect == Expect::kRejected) {
      EXPECT_EQ(status.error_code(), c.code) << Describe(status);
      for (const std::string& s : c.expected) {
        EXPECT_NE(status.error_message().find(s), std::string::npos) << "\"" << s << "\" not in " << Describe(status);
      }
      EXPECT_EQ(status.error_message().find(dir_.string()), std::string::npos)
          << "the message shows the server's private paths: " << Describe(status);
      std::printf("%-36s -> rejected %s\n", c.name, Describe(status).c_str());
    } else {
      EXPECT_TRUE(status.ok()) << Describe(status);
      if (status.ok()) jobs[c.name] = job_id;
    }
    EXPECT_TRUE(Serving()) << "the server stopped answering after " << c.name;
  }

  std::string valid_after;
  ASSERT_TRUE(UploadAndSubmit(NewCase("valid_after"), &valid_after).ok());

  for (const BadInputCase& c : cases) {
    if (jobs.count(c.name) == 0) continue;
    SCOPED_TRACE(c.name);
    const v1::Job job = WaitForJob(jobs[c.name]);
    if (c.expect == Expect::kJobFails) {
      EXPECT_EQ(job.state(), v1::FAILED) << job.error();
      for (const std::string& s : c.expected) {
        EXPECT_NE(job.error().find(s), std::string::npos) << "\"" << s << "\" not in \"" << job.error() << "\"";
      }
      EXPECT_EQ(job.error().find(dir_.string()), std::string::npos) << "the error shows a worker's private paths";
      for (const v1::TaskInfo& task : job.tasks()) EXPECT_LE(task.attempts(), 1u) << task.kind();
      std::printf("%-36s -> job FAILED \"%s\"\n", c.name, job.error().c_str());
    } else {
      EXPECT_EQ(job.state(), v1::SUCCEEDED) << job.error();
      for (const auto& config : job.report().light_configurations()) {
        EXPECT_TRUE(std::isfinite(config.e_d()) && std::isfinite(config.e_a())) << config.name();
      }
      for (const auto& camera : job.report().cameras()) {
        EXPECT_TRUE(std::isfinite(camera.mse_brdf())) << camera.name();
        // An error over no observation is absent, not 0.
        EXPECT_EQ(camera.has_mse_brdf(), camera.samples() > 0) << camera.name();
      }
      const std::string report = MessageToJson(job.report());
      std::string warnings;  // as they are, not JSON-escaped
      for (const std::string& w : job.report().warnings()) warnings += w + "\n";
      for (const std::string& s : c.expected) {
        EXPECT_TRUE(report.find(s) != std::string::npos || warnings.find(s) != std::string::npos)
            << "\"" << s << "\" not in the report " << report;
      }
      EXPECT_EQ(report.find("NaN"), std::string::npos) << report;
      EXPECT_EQ(report.find("Infinity"), std::string::npos) << report;
      std::printf("%-36s -> job SUCCEEDED\n", c.name);
    }
  }

  // The valid jobs before and after: both succeeded with the same atlases.
  const v1::Job before = WaitForJob(valid_before), after = WaitForJob(valid_after);
  ASSERT_EQ(before.state(), v1::SUCCEEDED) << before.error();
  ASSERT_EQ(after.state(), v1::SUCCEEDED) << after.error();
  for (const char* name : {"atlases/kd.exr", "atlases/ks.exr", "atlas/mesh.obj"}) {
    const std::string a = Fetch(valid_before, name);
    EXPECT_FALSE(a.empty()) << name;
    EXPECT_EQ(a, Fetch(valid_after, name)) << name;
  }
}

}  // namespace
}  // namespace mvbrdf
