// `mvbrdf import FORMAT INPUT --out scene.json`: a scene from a calibration
// other tools wrote (core/importers/). One row of kFormats per format; all the
// rest (subset, alignment, paths, lights, validation) is format-independent
// (importers::BuildScene).
#include <cstdio>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "client/commands.h"
#include "client/flags.h"
#include "core/base/proto_json.h"
#include "core/importers/colmap_model.h"
#include "core/importers/import_scene.h"
#include "core/importers/metashape_xml.h"
#include "core/importers/opencv_calibration.h"
#include "core/scene/names.h"
#include "core/scene/sequence.h"

namespace mvbrdf::client {
namespace {

// Reader options that only some formats use.
struct ReaderFlags {
  std::string camera_name = "stem";
  std::vector<std::string>* warnings = nullptr;  // lines the reader wants the user to see (not errors)
};

using Reader = absl::StatusOr<std::vector<v1::Camera>> (*)(const std::filesystem::path& input,
                                                           const ReaderFlags& flags);

absl::StatusOr<std::vector<v1::Camera>> ReadColmap(const std::filesystem::path& input, const ReaderFlags& flags) {
  importers::ColmapOptions options;
  if (flags.camera_name == "stem") {
    options.camera_name = importers::ColmapCameraName::kStem;
  } else if (flags.camera_name == "dir") {
    options.camera_name = importers::ColmapCameraName::kDirectory;
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat("--camera-name: expected stem or dir, got \"", flags.camera_name, "\""));
  }
  return importers::ReadColmapModel(input, options);
}

absl::StatusOr<std::vector<v1::Camera>> ReadOpenCv(const std::filesystem::path& input, const ReaderFlags&) {
  return importers::ReadOpenCvCalibration(input);
}

absl::StatusOr<std::vector<v1::Camera>> ReadMetashape(const std::filesystem::path& input, const ReaderFlags& flags) {
  return importers::ReadMetashapeCameras(input, flags.warnings);
}

struct Format {
  const char* name;
  const char* help;  // what INPUT is and what is converted
  Reader read;
};

const Format kFormats[] = {
    {"colmap",
     "INPUT is a COLMAP sparse model directory: cameras.txt + images.txt, or cameras.bin + images.bin\n"
     "      (points3D is not read). Each image is one camera (its pose, its COLMAP camera's intrinsics), in\n"
     "      IMAGE_ID order, named by --camera-name. Models SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL,\n"
     "      OPENCV, FULL_OPENCV (OpenCV distortion k1 k2 p1 p2[ k3 k4 k5 k6]); fisheye models are refused.\n"
     "      COLMAP's pixel centres are at +0.5 (the top-left pixel's centre is (0.5, 0.5)); mvbrdf's at\n"
     "      (0, 0): cx = cx_colmap - 0.5, cy = cy_colmap - 0.5. Poses (QW QX QY QZ, T: cam_from_world,\n"
     "      OpenCV axes) are mvbrdf's with the quaternion made a rotation matrix.",
     &ReadColmap},
    {"opencv",
     "INPUT is an OpenCV calibration file (cv::FileStorage YAML, JSON or XML) or a directory of them\n"
     "      (*.yml/*.yaml/*.json/*.xml in name order; camera name = the `name` key, else the file stem). Per\n"
     "      camera: camera_matrix (K, cameraMatrix) 3x3, no skew; distortion_coefficients (D, dist, distCoeffs)\n"
     "      k1 k2 p1 p2[ k3[ k4 k5 k6]], optional; image_width/image_height (width/height, image_size [w,h]);\n"
     "      R (3x3) or rvec (Rodrigues) and T/tvec, world-to-camera (point_in_cam = R X + T, as\n"
     "      calibrateCamera/solvePnP give them); `extrinsics_convention: camera_to_world` for a file that\n"
     "      stores the camera's pose. Or a `cameras:` sequence of such maps, each with a name. OpenCV's pixel\n"
     "      convention is mvbrdf's (no shift).",
     &ReadOpenCv},
    {"metashape",
     "INPUT is an Agisoft Metashape camera export (Export Cameras, Agisoft XML) of one chunk; camera name =\n"
     "      its label; frame sensors only. fx = f + b1, fy = f, cx = width/2 + cx - 0.5, cy likewise (Metashape\n"
     "      measures from the image centre); OpenCV p1, p2 = Metashape p2, p1; b2, k4, p3, p4 must be 0.\n"
     "      Poses: the camera transform, then the component and chunk transforms (rotation, translation,\n"
     "      scale; the scale removed), so the cameras are in the chunk's world frame. Cameras without a\n"
     "      transform (not aligned) are left out with a warning.",
     &ReadMetashape},
};

std::string Synopsis() {
  std::string s =
      "Writes a scene JSON from a camera calibration: cameras (name, size, intrinsics, cam_from_world) in\n"
      "mvbrdf's conventions (OpenCV camera axes, pixel (0,0) at the centre of the top-left pixel), the mesh,\n"
      "videos, frames and lights from the options, then checks it as `mvbrdf validate` does.\n"
      "Paths in the options are as you type them (relative to the working directory); the scene gets them\n"
      "relative to --out's directory (a file outside that directory is refused, as everywhere in a scene).\n"
      "Without --lights the scene is written with no lights (everything else checked) and a warning:\n"
      "add them before `validate` or `run`. With lights it is loaded as `validate --quick` does (frame 0's\n"
      "mesh, every camera seeing it); when that fails the scene stays written and the exit code is 3.\n"
      "\nFORMAT:\n";
  for (const Format& f : kFormats) absl::StrAppend(&s, "  ", f.name, ": ", f.help, "\n");
  return s;
}

absl::StatusOr<v1::ColorEncoding> ParseEncoding(const std::string& s) {
  if (s == "srgb") return v1::SRGB;
  if (s == "linear") return v1::LINEAR;
  return absl::InvalidArgumentError(absl::StrCat("--encoding: expected srgb or linear, got \"", s, "\""));
}

}  // namespace

int RunImport(const std::vector<std::string>& args) {
  std::string format;
  std::string input;
  std::string out;
  std::string encoding = "srgb";
  std::string transform;
  std::string cameras;
  int first = 0;
  int frames = 0;
  ReaderFlags reader_flags;
  importers::ImportOptions options;
  FlagParser flags("import", Synopsis());
  flags.AddPositional("FORMAT", &format, true, "the calibration's format (see above)");
  flags.AddPositional("INPUT", &input, true, "the calibration (file or directory, per FORMAT)");
  flags.AddString("--out FILE", &out, "the scene JSON to write (required)");
  flags.AddString("--mesh PATTERN", &options.mesh,
                  "mesh file or per-frame pattern, e.g. meshes/mesh_%04d.obj (required; scene.mesh.path)");
  flags.AddString("--video PATTERN", &options.video,
                  "video or image-sequence pattern per camera, {camera} replaced by its name, e.g. "
                  "videos/{camera}.mkv or frames/{camera}/%04d.png (required; scene.cameras[].video.path; "
                  "must contain {camera} when there is more than one camera)");
  flags.AddString("--encoding srgb|linear", &encoding, "the videos' colour encoding: srgb or linear");
  flags.AddUint("--bit-depth 8|16", &options.bit_depth, "bits per channel of the videos' frames: 8 or 16");
  flags.AddInt("--first N", &first, "absolute index of the first frame (scene.frames.first)");
  flags.AddInt("--frames N", &frames, "number of frames (required; scene.frames.count)");
  flags.AddDouble("--fps FPS", &options.fps, "frames per second of the videos (required; scene.frames.fps)");
  flags.AddString("--lights FILE", &options.lights_file,
                  "a LightList JSON ({\"lights\": [...]}) or a scene JSON whose lights, lightConfigurations, "
                  "frameLighting, lighting, materialSeeds, segmentMaterials and segmentationPath are copied");
  flags.AddString("--cameras A,B,...", &cameras, "keep only these cameras, comma-separated names (default all)");
  flags.AddString("--camera-name stem|dir", &reader_flags.camera_name,
                  "colmap: how an image NAME such as cam0/0001.png names its camera: stem (0001) or dir (cam0); "
                  "two images giving one name are refused");
  flags.AddString("--transform FILE", &transform,
                  "JSON file with a 4x4 row-major similarity world_from_calibration [s R | t; 0 0 0 1] (16 "
                  "numbers, scale s > 0 allowed) taking the calibration's world into the mesh's: every camera "
                  "becomes R' = R_c R^T, t' = s t_c - R_c R^T t");
  flags.AddString("--name TEXT", &options.name, "scene.name (free-form, for reports)");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf import: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  const Format* chosen = nullptr;
  std::vector<std::string> names;
  for (const Format& f : kFormats) {
    if (format == f.name) chosen = &f;
    names.push_back(f.name);
  }
  std::string usage_error;
  if (chosen == nullptr) {
    usage_error = absl::StrCat("unknown FORMAT \"", format, "\" (expected ", absl::StrJoin(names, ", "), ")");
  } else if (std::string(chosen->name) != "colmap" && reader_flags.camera_name != "stem") {
    usage_error = absl::StrCat("--camera-name is for colmap only; ", chosen->name, " names its cameras itself");
  } else if (out.empty()) {
    usage_error = "--out is required";
  } else if (options.mesh.empty()) {
    usage_error = "--mesh is required";
  } else if (options.video.empty()) {
    usage_error = "--video is required";
  } else if (frames <= 0) {
    usage_error = "--frames is required (> 0)";
  } else if (first < 0) {
    usage_error = "--first: must be >= 0";
  } else if (!(options.fps > 0.0)) {
    usage_error = "--fps is required (> 0)";
  }
  if (!usage_error.empty()) {
    std::fprintf(stderr, "mvbrdf import: %s\n", usage_error.c_str());
    return kExitUsage;
  }
  options.first = static_cast<uint32_t>(first);
  options.count = static_cast<uint32_t>(frames);
  absl::StatusOr<v1::ColorEncoding> parsed_encoding = ParseEncoding(encoding);
  if (!parsed_encoding.ok()) return ReportFailure(parsed_encoding.status(), "mvbrdf import");
  options.encoding = *parsed_encoding;
  if (!cameras.empty()) options.cameras = absl::StrSplit(cameras, ',');
  if (!transform.empty()) {
    absl::StatusOr<importers::Similarity> w = importers::ReadSimilarityFile(transform);
    if (!w.ok()) return ReportFailure(w.status(), "mvbrdf import");
    options.world_from_calibration = *w;
  }
  const std::filesystem::path out_file(out);
  options.scene_dir = std::filesystem::absolute(out_file).parent_path();

  std::vector<std::string> reader_warnings;
  reader_flags.warnings = &reader_warnings;
  absl::StatusOr<std::vector<v1::Camera>> read = chosen->read(input, reader_flags);
  for (const std::string& w : reader_warnings) {
    std::fprintf(stderr, "mvbrdf import: warning: %s\n", scene::ShownText(w).c_str());  // labels are the file's
  }
  if (!read.ok()) return ReportFailure(read.status(), "mvbrdf import");
  const size_t calibrated = read->size();
  absl::StatusOr<v1::Scene> scene = importers::BuildScene(*std::move(read), options);
  if (!scene.ok()) return ReportFailure(scene.status(), "mvbrdf import");
  if (absl::Status s = WriteJsonFile(out_file, *scene); !s.ok()) return ReportFailure(s, "mvbrdf import");
  std::printf("imported %d of %zu cameras (%s %s) into %s\n", scene->cameras_size(), calibrated, chosen->name,
              input.c_str(), out.c_str());
  if (scene->lights_size() == 0) {
    std::fprintf(stderr,
                 "mvbrdf import: warning: scene.lights: none (no --lights); add lights to %s before "
                 "`mvbrdf validate` or `mvbrdf run`\n",
                 out.c_str());
    return kExitOk;
  }
  scene::LoadOptions quick;
  quick.check_all_frames = false;
  quick.probe_videos = false;
  absl::StatusOr<scene::Sequence> loaded = scene::LoadSequence(out_file, quick);
  if (!loaded.ok()) {
    return ReportFailure(
        absl::Status(loaded.status().code(),
                     absl::StrCat("wrote ", out, ", but it does not load: ", loaded.status().message())),
        "mvbrdf import");
  }
  std::printf(
      "checked: the scene's fields, frame 0's mesh, that each camera sees it, lights (not the videos: "
      "`mvbrdf validate %s`)\n",
      out.c_str());
  return kExitOk;
}

}  // namespace mvbrdf::client
