#include "core/bundle/bundle.h"

#include <archive.h>
#include <archive_entry.h>
#include <gtest/gtest.h>
#include <stdlib.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <system_error>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/files.h"
#include "core/base/proto_json.h"
#include "core/scene/sequence.h"
#include "google/protobuf/util/message_differencer.h"
#include "mvbrdf/v1/ground_truth.pb.h"

namespace mvbrdf::bundle {
namespace {

namespace fs = std::filesystem;

constexpr int kFrames = 3;
constexpr int kWidth = 16;
constexpr int kHeight = 12;

// A fresh directory under the system temp dir, removed on destruction.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (fs::temp_directory_path() / "mvbrdf_bundle_test_XXXXXX").string();
    if (mkdtemp(tmpl.data()) == nullptr) ADD_FAILURE() << "mkdtemp failed for " << tmpl;
    path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

void WriteText(const fs::path& file, const std::string& text) {
  const absl::Status status = WriteStringToFile(file, text);
  ASSERT_TRUE(status.ok()) << status;
}

std::string PyramidObj(int frame) {
  std::string obj;
  const double v[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}, {0.5, 1, 0.5}};
  for (const auto& p : v) absl::StrAppendFormat(&obj, "v %.9g %.9g %.9g\n", p[0] + 0.1 * frame, p[1], p[2]);
  obj += "f 1 2 3\nf 1 3 4\nf 1 5 2\nf 2 5 3\nf 3 5 4\nf 4 5 1\n";
  return obj;
}

// A tiny valid scene (the core/scene fixture, cut down): a per-frame mesh
// pattern, two cameras with PNG sequences, a light, a segmentation.
v1::Scene TinyScene() {
  v1::Scene s;
  s.set_name("tiny");
  s.mutable_mesh()->set_path("meshes/mesh_%04d.obj");
  s.mutable_frames()->set_first(0);
  s.mutable_frames()->set_count(kFrames);
  s.mutable_frames()->set_fps(25);
  for (int i = 0; i < 2; ++i) {
    v1::Camera* c = s.add_cameras();
    c->set_name(absl::StrCat("cam", i));
    c->set_width(kWidth);
    c->set_height(kHeight);
    c->mutable_intrinsics()->set_fx(20);
    c->mutable_intrinsics()->set_fy(20);
    c->mutable_intrinsics()->set_cx(7.5);
    c->mutable_intrinsics()->set_cy(5.5);
    for (double r : {1, 0, 0, 0, 1, 0, 0, 0, 1}) c->mutable_cam_from_world()->add_rotation(r);
    for (double t : {-0.5, -0.5, 3.0}) c->mutable_cam_from_world()->add_translation(t);
    c->mutable_video()->set_path(absl::StrCat("videos/cam", i, "/%04d.png"));
    c->mutable_video()->set_encoding(v1::SRGB);
  }
  v1::Light* light = s.add_lights();
  light->set_name("key");
  for (double p : {2.0, 3.0, 2.0}) light->add_position(p);
  v1::LightConfiguration* config = s.add_light_configurations();
  config->set_name("key");
  config->add_lights("key");
  s.set_segmentation_path("segments.txt");
  return s;
}

fs::path WriteScene(const fs::path& dir, const v1::Scene& scene) {
  for (int t = 0; t < kFrames; ++t) WriteText(dir / absl::StrFormat("meshes/mesh_%04d.obj", t), PyramidObj(t));
  WriteText(dir / "segments.txt", "a\na\nb\nb\nb\nb\n");
  for (int c = 0; c < 2; ++c) {
    fs::create_directories(dir / absl::StrCat("videos/cam", c));
    for (int t = 0; t < kFrames; ++t) {
      cv::Mat image(kHeight, kWidth, CV_8UC3, cv::Scalar(10 * t, 50 + c, 100));
      const std::string file = (dir / absl::StrFormat("videos/cam%d/%04d.png", c, t)).string();
      EXPECT_TRUE(cv::imwrite(file, image)) << file;
    }
  }
  const fs::path file = dir / "scene.json";
  const absl::Status status = WriteJsonFile(file, scene);
  EXPECT_TRUE(status.ok()) << status;
  return file;
}

std::vector<std::string> ListTree(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) out.push_back(e.path().lexically_relative(dir).string());
  std::sort(out.begin(), out.end());
  return out;
}

TEST(BundleTest, ListsEveryReferencedFile) {
  TempDir tmp;
  const fs::path scene_file = WriteScene(tmp.path(), TinyScene());
  const auto files = BundleFiles(scene_file, {});
  ASSERT_TRUE(files.ok()) << files.status();
  const std::vector<std::string> expected = {
      "meshes/mesh_0000.obj",  "meshes/mesh_0001.obj",  "meshes/mesh_0002.obj",  "scene.json",
      "segments.txt",          "videos/cam0/0000.png",  "videos/cam0/0001.png",  "videos/cam0/0002.png",
      "videos/cam1/0000.png",  "videos/cam1/0001.png",  "videos/cam1/0002.png"};
  EXPECT_EQ(*files, expected);
}

// Video.frame_offset: a camera's files are its own frames f + frame_offset
// (camera 1's videos/cam1/0003.png is frame 2 of the sequence), so the bundle
// carries those and not the unshifted ones.
TEST(BundleTest, CameraFilesFollowTheirFrameOffset) {
  TempDir tmp;
  v1::Scene scene = TinyScene();
  scene.mutable_cameras(1)->mutable_video()->set_frame_offset(1);
  scene.mutable_cameras(1)->mutable_video()->set_mask_path("masks/%04d.png");
  const fs::path scene_file = WriteScene(tmp.path(), scene);
  fs::create_directories(tmp.path() / "masks");
  for (int t = 1; t <= kFrames; ++t) {
    WriteText(tmp.path() / absl::StrFormat("videos/cam1/%04d.png", t), "x");
    WriteText(tmp.path() / absl::StrFormat("masks/%04d.png", t), "x");
  }
  const auto files = BundleFiles(scene_file, {});
  ASSERT_TRUE(files.ok()) << files.status();
  const std::vector<std::string> expected = {
      "masks/0001.png",        "masks/0002.png",        "masks/0003.png",        "meshes/mesh_0000.obj",
      "meshes/mesh_0001.obj",  "meshes/mesh_0002.obj",  "scene.json",            "segments.txt",
      "videos/cam0/0000.png",  "videos/cam0/0001.png",  "videos/cam0/0002.png",  "videos/cam1/0001.png",
      "videos/cam1/0002.png",  "videos/cam1/0003.png"};
  EXPECT_EQ(*files, expected);
}

TEST(BundleTest, IncludesGroundTruthAndItsTextures) {
  TempDir tmp;
  const fs::path scene_file = WriteScene(tmp.path(), TinyScene());
  v1::GroundTruth truth;
  truth.add_materials()->set_kd_texture_path("kd.png");
  ASSERT_TRUE(WriteJsonFile(tmp.path() / "ground_truth" / "truth.json", truth).ok());
  WriteText(tmp.path() / "ground_truth" / "kd.png", "png");
  auto files = BundleFiles(scene_file, {});
  ASSERT_TRUE(files.ok()) << files.status();
  EXPECT_EQ(std::count(files->begin(), files->end(), "ground_truth/truth.json"), 1);
  EXPECT_EQ(std::count(files->begin(), files->end(), "ground_truth/kd.png"), 1);
  PackOptions no_truth;
  no_truth.include_ground_truth = false;
  files = BundleFiles(scene_file, no_truth);
  ASSERT_TRUE(files.ok()) << files.status();
  EXPECT_EQ(files->size(), 11u);

  truth.mutable_materials(0)->set_kd_texture_path("../../secret.png");
  ASSERT_TRUE(WriteJsonFile(tmp.path() / "ground_truth" / "truth.json", truth).ok());
  const absl::Status escape = BundleFiles(scene_file, {}).status();
  EXPECT_TRUE(absl::IsInvalidArgument(escape)) << escape;
  EXPECT_TRUE(absl::StrContains(escape.message(), "ground_truth.materials[0].kd_texture_path")) << escape;
}

TEST(BundleTest, PackUnpackLoadsTheSameScene) {
  TempDir tmp;
  const v1::Scene scene = TinyScene();
  const fs::path scene_file = WriteScene(tmp.path() / "src", scene);
  const auto info = PackBundle(scene_file, tmp.path() / "b.tar", {});
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->num_files, 11);
  EXPECT_EQ(info->scene_name, "scene.json");
  EXPECT_EQ(info->size, static_cast<int64_t>(fs::file_size(tmp.path() / "b.tar")));
  EXPECT_EQ(info->sha256.size(), 64u);
  const auto hash = Sha256File(tmp.path() / "b.tar");
  ASSERT_TRUE(hash.ok()) << hash.status();
  EXPECT_EQ(*hash, info->sha256);

  UnpackOptions options;
  options.expected_sha256 = info->sha256;
  const auto unpacked = UnpackBundle(tmp.path() / "b.tar", tmp.path() / "dst", options);
  ASSERT_TRUE(unpacked.ok()) << unpacked.status();
  EXPECT_EQ(*unpacked, tmp.path() / "dst" / "scene.json");
  const auto seq = scene::LoadSequence(*unpacked);
  ASSERT_TRUE(seq.ok()) << seq.status();
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(seq->scene, scene));
  EXPECT_EQ(seq->num_frames, kFrames);
  // Only the bundle and the destination beside it: no temporaries left.
  std::vector<std::string> top;
  for (const auto& e : fs::directory_iterator(tmp.path())) top.push_back(e.path().filename().string());
  std::sort(top.begin(), top.end());
  EXPECT_EQ(top, (std::vector<std::string>{"b.tar", "dst", "src"}));
  // The destination must be new (or empty).
  EXPECT_TRUE(absl::IsAlreadyExists(UnpackBundle(tmp.path() / "b.tar", tmp.path() / "dst", {}).status()));
}

// A text glTF pyramid whose vertex and index data live in an external
// buffer file at `buffer_uri` (relative to the .gltf), naming an image too.
std::string PyramidGltf(const std::string& buffer_uri, const std::string& image_uri) {
  return absl::StrCat(R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
  "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
  "buffers": [{"uri": ")",
                      buffer_uri, R"(", "byteLength": 96}],
  "images": [{"uri": ")",
                      image_uri, R"("}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 60},
                  {"buffer": 0, "byteOffset": 60, "byteLength": 36}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 5, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 1]},
                {"bufferView": 1, "componentType": 5123, "count": 18, "type": "SCALAR"}]})");
}

std::string PyramidBuffer() {
  const float v[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}, {0.5f, 1, 0.5f}};
  const uint16_t f[18] = {0, 1, 2, 0, 2, 3, 0, 4, 1, 1, 4, 2, 2, 4, 3, 3, 4, 0};
  return std::string(reinterpret_cast<const char*>(v), sizeof(v)) +
         std::string(reinterpret_cast<const char*>(f), sizeof(f));
}

// Issue #19: a glTF scene with an external .bin ran with --direct but not
// through the service: the bundle lacked the buffer.
TEST(BundleTest, GltfBuffersAndImagesTravelWithTheMesh) {
  TempDir tmp;
  v1::Scene scene = TinyScene();
  scene.mutable_mesh()->set_path("meshes/pyramid.gltf");
  const fs::path scene_file = WriteScene(tmp.path() / "src", scene);
  // The buffer's URI as assimp opens it (not percent-decoded); the image's
  // only decoded (the glTF standard's reading).
  WriteText(tmp.path() / "src/meshes/pyramid.gltf", PyramidGltf("buffers/pyramid.bin", "../textures/kd%20map.png"));
  WriteText(tmp.path() / "src/meshes/buffers/pyramid.bin", PyramidBuffer());
  WriteText(tmp.path() / "src/textures/kd map.png", "not read by the loader");
  const auto files = BundleFiles(scene_file, {});
  ASSERT_TRUE(files.ok()) << files.status();
  for (const char* want : {"meshes/pyramid.gltf", "meshes/buffers/pyramid.bin", "textures/kd map.png"}) {
    EXPECT_NE(std::find(files->begin(), files->end(), want), files->end()) << want;
  }
  const auto info = PackBundle(scene_file, tmp.path() / "b.tar", {});
  ASSERT_TRUE(info.ok()) << info.status();
  const auto unpacked = UnpackBundle(tmp.path() / "b.tar", tmp.path() / "dst", {});
  ASSERT_TRUE(unpacked.ok()) << unpacked.status();
  const auto seq = scene::LoadSequence(*unpacked);
  ASSERT_TRUE(seq.ok()) << seq.status();
  EXPECT_EQ(seq->topology.triangles.size(), 6u);
}

TEST(BundleTest, GltfReferencesOutsideTheSceneAreRefused) {
  TempDir tmp;
  v1::Scene scene = TinyScene();
  scene.mutable_mesh()->set_path("meshes/pyramid.gltf");
  const fs::path scene_file = WriteScene(tmp.path() / "src", scene);
  WriteText(tmp.path() / "outside.bin", PyramidBuffer());
  for (const std::string& uri : {std::string("../../outside.bin"), (tmp.path() / "outside.bin").string(),
                                 std::string("%2e%2e/%2e%2e/outside.bin"), std::string("http://example.com/x.bin"),
                                 std::string("bad%zzescape.bin")}) {
    WriteText(tmp.path() / "src/meshes/pyramid.gltf", PyramidGltf(uri, "data:image/png;base64,AAAA"));
    const absl::Status status = BundleFiles(scene_file, {}).status();
    EXPECT_TRUE(absl::IsInvalidArgument(status)) << uri << ": " << status;
    EXPECT_TRUE(absl::StrContains(status.message(), "scene.mesh.path: meshes/pyramid.gltf: buffers[0].uri")) << status;
  }
}

TEST(BundleTest, PackingIsDeterministic) {
  TempDir tmp;
  const fs::path scene_file = WriteScene(tmp.path() / "src", TinyScene());
  const auto a = PackBundle(scene_file, tmp.path() / "a.tar", {});
  ASSERT_TRUE(a.ok()) << a.status();
  // Touch a file: mtimes must not reach the archive.
  fs::last_write_time(tmp.path() / "src" / "segments.txt", fs::file_time_type::clock::now() - std::chrono::hours(5));
  const auto b = PackBundle(scene_file, tmp.path() / "b.tar", {});
  ASSERT_TRUE(b.ok()) << b.status();
  EXPECT_EQ(a->sha256, b->sha256);
  EXPECT_EQ(ReadFileToString(tmp.path() / "a.tar").value(), ReadFileToString(tmp.path() / "b.tar").value());
}

TEST(BundleTest, MissingFileIsNotFoundNamingTheField) {
  TempDir tmp;
  const fs::path scene_file = WriteScene(tmp.path(), TinyScene());
  fs::remove(tmp.path() / "videos/cam1/0002.png");
  const absl::Status status = PackBundle(scene_file, tmp.path() / "out" / "b.tar", {}).status();
  EXPECT_TRUE(absl::IsNotFound(status)) << status;
  EXPECT_TRUE(absl::StrContains(status.message(), "scene.cameras[1].video.path (frame 2)")) << status;
  EXPECT_FALSE(fs::exists(tmp.path() / "out" / "b.tar"));
  EXPECT_FALSE(fs::exists(tmp.path() / "out"));
}

TEST(BundleTest, PathOutsideTheSceneIsInvalid) {
  TempDir tmp;
  v1::Scene scene = TinyScene();
  scene.mutable_mesh()->set_path("../outside.obj");
  WriteText(tmp.path() / "outside.obj", PyramidObj(0));
  const fs::path scene_file = WriteScene(tmp.path() / "scene", scene);
  absl::Status status = BundleFiles(scene_file, {}).status();
  EXPECT_TRUE(absl::IsInvalidArgument(status)) << status;
  EXPECT_TRUE(absl::StrContains(status.message(), "scene.mesh.path")) << status;

  scene.mutable_mesh()->set_path((tmp.path() / "outside.obj").string());
  ASSERT_TRUE(WriteJsonFile(scene_file, scene).ok());
  status = BundleFiles(scene_file, {}).status();
  EXPECT_TRUE(absl::IsInvalidArgument(status)) << status;

  // A symlink inside the folder that points outside it.
  fs::create_symlink(tmp.path() / "outside.obj", tmp.path() / "scene" / "link.obj");
  scene.mutable_mesh()->set_path("link.obj");
  ASSERT_TRUE(WriteJsonFile(scene_file, scene).ok());
  status = BundleFiles(scene_file, {}).status();
  EXPECT_TRUE(absl::IsInvalidArgument(status)) << status;
}

// ---- Hand-crafted archives --------------------------------------------------

struct Entry {
  std::string name;
  std::string data;
  unsigned type = AE_IFREG;
  std::string symlink;
  std::string hardlink;
};

Entry File(std::string name, std::string data) { return Entry{std::move(name), std::move(data), AE_IFREG, "", ""}; }
Entry Special(std::string name, unsigned type) { return Entry{std::move(name), "", type, "", ""}; }
Entry Symlink(std::string name, std::string target) { return Entry{std::move(name), "", AE_IFLNK, std::move(target), ""}; }
Entry Hardlink(std::string name, std::string target) { return Entry{std::move(name), "", AE_IFREG, "", std::move(target)}; }

void WriteTar(const fs::path& file, const std::vector<Entry>& entries) {
  archive* a = archive_write_new();
  ASSERT_EQ(archive_write_set_format_pax_restricted(a), ARCHIVE_OK);
  ASSERT_EQ(archive_write_open_filename(a, file.c_str()), ARCHIVE_OK);
  for (const Entry& e : entries) {
    archive_entry* entry = archive_entry_new();
    archive_entry_set_pathname(entry, e.name.c_str());
    archive_entry_set_filetype(entry, e.type);
    archive_entry_set_perm(entry, 0644);
    if (!e.symlink.empty()) archive_entry_set_symlink(entry, e.symlink.c_str());
    if (!e.hardlink.empty()) archive_entry_set_hardlink(entry, e.hardlink.c_str());
    archive_entry_set_size(entry, e.type == AE_IFREG && e.hardlink.empty() ? e.data.size() : 0);
    ASSERT_EQ(archive_write_header(a, entry), ARCHIVE_OK) << archive_error_string(a);
    if (!e.data.empty()) {
      ASSERT_EQ(archive_write_data(a, e.data.data(), e.data.size()), static_cast<la_ssize_t>(e.data.size()));
    }
    archive_entry_free(entry);
  }
  ASSERT_EQ(archive_write_close(a), ARCHIVE_OK);
  archive_write_free(a);
}

struct BadCase {
  std::string label;
  std::vector<Entry> entries;
  absl::StatusCode code;
  std::string message;  // expected in the error
};

TEST(BundleTest, RejectsMaliciousArchives) {
  const std::vector<BadCase> cases = {
      {"dotdot", {File("scene.json", "{}"), File("../evil", "x")}, absl::StatusCode::kInvalidArgument, "../evil"},
      {"absolute", {File("scene.json", "{}"), File("/etc/passwd", "x")}, absl::StatusCode::kInvalidArgument, "/etc/passwd"},
      {"inner dotdot", {File("scene.json", "{}"), File("a/../../b", "x")}, absl::StatusCode::kInvalidArgument, "a/../../b"},
      {"dot", {File("./scene.json", "{}")}, absl::StatusCode::kInvalidArgument, "./scene.json"},
      {"empty component", {File("a//b", "x")}, absl::StatusCode::kInvalidArgument, "a//b"},
      {"backslash", {File("a\\..\\b", "x")}, absl::StatusCode::kInvalidArgument, "backslash"},
      {"symlink", {File("scene.json", "{}"), Symlink("link", "/etc/passwd")},
       absl::StatusCode::kInvalidArgument, "symbolic link"},
      {"hardlink", {File("scene.json", "{}"), Hardlink("hard", "scene.json")},
       absl::StatusCode::kInvalidArgument, "hard link"},
      {"directory", {Special("dir", AE_IFDIR)}, absl::StatusCode::kInvalidArgument, "directory"},
      {"device", {Special("dev", AE_IFCHR)}, absl::StatusCode::kInvalidArgument, "device"},
      {"duplicate", {File("scene.json", "{}"), File("scene.json", "{}")}, absl::StatusCode::kInvalidArgument, "duplicate"},
      {"no scene", {File("a.txt", "x")}, absl::StatusCode::kInvalidArgument, "scene.json"},
  };
  for (const BadCase& c : cases) {
    SCOPED_TRACE(c.label);
    TempDir tmp;
    const fs::path tar = tmp.path() / "in" / "bad.tar";
    fs::create_directories(tar.parent_path());
    fs::create_directories(tmp.path() / "out");
    WriteTar(tar, c.entries);
    const absl::Status status = UnpackBundle(tar, tmp.path() / "out" / "dst", {}).status();
    EXPECT_EQ(status.code(), c.code) << status;
    EXPECT_TRUE(absl::StrContains(status.message(), c.message)) << status;
    EXPECT_TRUE(fs::is_empty(tmp.path() / "out")) << ::testing::PrintToString(ListTree(tmp.path() / "out"));
    EXPECT_EQ(ListTree(tmp.path()), (std::vector<std::string>{"in", "in/bad.tar", "out"}));
  }
}

class PackedBundleTest : public ::testing::Test {
 protected:
  void SetUp() override {
    scene_file_ = WriteScene(tmp_.path() / "src", TinyScene());
    auto info = PackBundle(scene_file_, tar_, {});
    ASSERT_TRUE(info.ok()) << info.status();
    info_ = *info;
    fs::create_directories(out_);
  }
  absl::Status Unpack(const UnpackOptions& options) { return UnpackBundle(tar_, out_ / "dst", options).status(); }

  TempDir tmp_;
  fs::path scene_file_;
  fs::path tar_ = tmp_.path() / "b.tar";
  fs::path out_ = tmp_.path() / "out";
  BundleInfo info_;
};

TEST_F(PackedBundleTest, FileSizeLimit) {
  UnpackOptions options;
  options.max_file_bytes = 0;
  const absl::Status status = Unpack(options);
  EXPECT_TRUE(absl::IsResourceExhausted(status)) << status;
  EXPECT_TRUE(absl::StrContains(status.message(), "max_file_bytes=0")) << status;
  EXPECT_TRUE(absl::StrContains(status.message(), "meshes/mesh_0000.obj")) << status;
  EXPECT_TRUE(fs::is_empty(out_));
}

TEST_F(PackedBundleTest, TotalSizeLimit) {
  UnpackOptions options;
  options.max_total_bytes = 100;
  const absl::Status status = Unpack(options);
  EXPECT_TRUE(absl::IsResourceExhausted(status)) << status;
  EXPECT_TRUE(absl::StrContains(status.message(), "max_total_bytes=100")) << status;
  EXPECT_TRUE(fs::is_empty(out_));
}

TEST_F(PackedBundleTest, TooManyFiles) {
  UnpackOptions options;
  options.max_files = 3;
  const absl::Status status = Unpack(options);
  EXPECT_TRUE(absl::IsResourceExhausted(status)) << status;
  EXPECT_TRUE(absl::StrContains(status.message(), "max_files=3")) << status;
  EXPECT_TRUE(fs::is_empty(out_));
}

TEST_F(PackedBundleTest, TruncatedArchiveIsDataLoss) {
  const std::string bytes = ReadFileToString(tar_).value();
  for (size_t cut : {bytes.size() / 2, size_t{512 * 3}, bytes.size() - 1024}) {
    SCOPED_TRACE(cut);
    WriteText(tar_, bytes.substr(0, cut));
    const absl::Status status = Unpack({});
    EXPECT_TRUE(absl::IsDataLoss(status)) << status;
    EXPECT_TRUE(fs::is_empty(out_));
  }
}

TEST_F(PackedBundleTest, CorruptHeaderIsDataLoss) {
  std::string bytes = ReadFileToString(tar_).value();
  bytes[148] ^= 0x55;  // the first header's checksum
  WriteText(tar_, bytes);
  const absl::Status status = Unpack({});
  EXPECT_TRUE(absl::IsDataLoss(status)) << status;
  EXPECT_TRUE(fs::is_empty(out_));
}

TEST_F(PackedBundleTest, HashMismatch) {
  UnpackOptions options;
  options.expected_sha256 = std::string(64, '0');
  const absl::Status status = Unpack(options);
  EXPECT_TRUE(absl::IsInvalidArgument(status)) << status;
  EXPECT_EQ(status.message(),
            absl::StrCat("bundle hash mismatch: expected ", std::string(64, '0'), ", got ", info_.sha256));
  EXPECT_TRUE(fs::is_empty(out_));
}

TEST(Sha256Test, KnownDigest) {
  TempDir tmp;
  WriteText(tmp.path() / "abc", "abc");
  EXPECT_EQ(Sha256File(tmp.path() / "abc").value(),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_TRUE(absl::IsNotFound(Sha256File(tmp.path() / "missing").status()));
}

}  // namespace
}  // namespace mvbrdf::bundle
