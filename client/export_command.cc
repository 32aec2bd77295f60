// `mvbrdf export DIR --out model.glb|model.gltf [--frame T]`: a reconstruction
// written as glTF 2.0 (issue #16; core/export/gltf_export.h says what it holds).
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/flags.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/export/gltf_export.h"
#include "core/export/obj_export.h"
#include "core/pipeline/run_scene.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::client {

absl::Status CheckExportFile(const std::string& flag, const std::string& out) {
  const std::string ext = std::filesystem::path(out).extension().string();
  if (out.empty()) return absl::InvalidArgumentError(absl::StrCat(flag, ": required"));
  if (ext != ".glb" && ext != ".gltf" && ext != ".obj") {
    return absl::InvalidArgumentError(absl::StrCat(flag, ": expected a .glb, .gltf or .obj file, got ", out));
  }
  if (std::filesystem::is_directory(out)) {
    return absl::InvalidArgumentError(absl::StrCat(flag, " ", out, ": is a directory, expected a file name"));
  }
  return absl::OkStatus();
}

absl::Status ExportRun(const std::filesystem::path& run_dir, const scene::Sequence& sequence, const std::string& out,
                       int frame, bool animation) {
  if (std::filesystem::path(out).extension() == ".obj") {
    if (animation) return absl::InvalidArgumentError("--animation: glTF only (.glb, .gltf), not OBJ");
    MVBRDF_ASSIGN_OR_RETURN(const exporter::ObjExportSummary summary, exporter::ExportObj(run_dir, sequence, out, frame));
    std::printf("export: %d vertices, %d triangles; scale %.6g (Kd, Ks x scale)\n", summary.vertices,
                summary.triangles, summary.scale);
    if (summary.clipped_fraction > 0.0) {
      std::printf("warning: %.2f %% of the observed texels clipped at Kd or Ks 1\n", 100.0 * summary.clipped_fraction);
    }
    for (const std::filesystem::path& file : summary.files) std::printf("wrote %s\n", file.string().c_str());
    return absl::OkStatus();
  }
  exporter::GltfExportOptions options;
  options.frame = frame;
  options.animation = animation;
  MVBRDF_ASSIGN_OR_RETURN(const exporter::GltfExportSummary summary,
                          exporter::ExportGltf(run_dir, sequence, out, options));
  std::printf("export: %d vertices, %d triangles, %dx%d textures, %d cameras, %d lights; scale %.6g (materials x "
              "scale, lights / scale)\n",
              summary.vertices, summary.triangles, summary.texture_size, summary.texture_size, summary.cameras,
              summary.lights, summary.scale);
  if (summary.clipped_fraction > 0.0) {
    std::printf("warning: %.2f %% of the observed texels clipped at baseColor or specularFactor 1\n",
                100.0 * summary.clipped_fraction);
  }
  if (summary.point_lights_without_falloff) {
    std::printf("warning: the scene's point lights do not fall off with distance; glTF's do (inverse square), so "
                "a viewer draws them differently\n");
  }
  if (summary.morph_targets > 0) {
    std::printf("export: the tracked motion as %d morph targets, animated at the scene's frame rate\n",
                summary.morph_targets);
  }
  std::printf("wrote %s\n", out.c_str());
  return absl::OkStatus();
}

namespace {

absl::Status Export(const std::filesystem::path& run_dir, const std::string& out, int frame, bool animation,
                    const std::string& scene_flag) {
  MVBRDF_ASSIGN_OR_RETURN(const v1::RunReport run, ReadJsonFileAs<v1::RunReport>(run_dir / "result.json"));
  MVBRDF_ASSIGN_OR_RETURN(const scene::Sequence sequence, pipeline::LoadSceneOfRun(run_dir, run, scene_flag));
  return ExportRun(run_dir, sequence, out, frame, animation);
}

}  // namespace

int RunExport(const std::vector<std::string>& args) {
  std::string dir, out, scene_flag;
  int frame = -1;
  bool animation = false;
  FlagParser flags("export",
                   "Writes a reconstruction (the output directory of 'mvbrdf run') as glTF 2.0: the mesh with the\n"
                   "atlas UVs, one metallic-roughness material with KHR_materials_specular (every texel's lobe as\n"
                   "GGX), the confidence atlas as an extra texture, the scene's cameras and lights\n"
                   "(KHR_lights_punctual); core/export/gltf_export.h and README say how each value is made.");
  flags.AddPositional("DIR", &dir, true, "the output directory of 'mvbrdf run'");
  flags.AddString("--out FILE", &out,
                  "model.glb (binary), model.gltf (JSON, buffers and images embedded) or model.obj (OBJ + MTL: the "
                  "thesis's Phong, maps beside it)");
  flags.AddInt("--frame N", &frame, "the pose of frame N (0-based; default -1: the rest pose)");
  flags.AddBool("--animation", &animation,
                "the tracked motion: one morph target per frame and an animation at the scene's frame rate "
                "(from the rest pose; not with --frame)");
  flags.AddString(
      "--scene FILE", &scene_flag,
      "the scene file (default: result.json's scene, relative to DIR; needed for a fetched service result)");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf export: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  absl::Status usage = CheckExportFile("--out", out);
  if (usage.ok() && animation && std::filesystem::path(out).extension() == ".obj") {
    usage = absl::InvalidArgumentError("--animation: glTF only (.glb, .gltf), not OBJ");
  }
  if (usage.ok() && animation && frame >= 0) {
    usage = absl::InvalidArgumentError("--animation: the animation starts from the rest pose; leave out --frame");
  }
  if (absl::Status s = usage; !s.ok()) {
    std::fprintf(stderr, "mvbrdf export: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (absl::Status s = Export(dir, out, frame, animation, scene_flag); !s.ok()) return ReportFailure(s, "mvbrdf export");
  return kExitOk;
}

}  // namespace mvbrdf::client
