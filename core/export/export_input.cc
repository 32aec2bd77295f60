#include "core/export/export_input.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/scene/mesh.h"

namespace mvbrdf::exporter {

namespace {

absl::Status CheckFrame(const scene::Sequence& sequence, int frame) {
  if (frame < -1 || frame >= sequence.num_frames) {
    return absl::InvalidArgumentError(absl::StrCat("--frame: expected -1 (the rest pose) or a frame in [0, ",
                                                   sequence.num_frames, "), got ", frame));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status PoseOf(const scene::Sequence& sequence, const scene::MeshTopology& topology, int frame,
                    std::vector<glm::vec3>* vertices, std::vector<glm::vec3>* normals) {
  MVBRDF_RETURN_IF_ERROR(CheckFrame(sequence, frame));
  scene::FramePositions positions = sequence.rest_positions;
  if (frame >= 0) {
    MVBRDF_ASSIGN_OR_RETURN(positions, sequence.LoadFrame(frame));
  }
  *vertices = scene::ToRenderVertices(topology, positions);
  *normals = scene::ToRenderVertices(topology, scene::ComputeFileVertexNormals(topology, positions));
  return absl::OkStatus();
}

absl::StatusOr<ExportInput> ReadExportInput(const std::filesystem::path& run_dir, const scene::Sequence& sequence,
                                            int frame) {
  MVBRDF_RETURN_IF_ERROR(CheckFrame(sequence, frame));  // before any file is read
  ExportInput in;
  MVBRDF_ASSIGN_OR_RETURN(in.run, ReadJsonFileAs<v1::RunReport>(run_dir / "result.json"));
  MVBRDF_ASSIGN_OR_RETURN(in.atlas, pipeline::OpenRunAtlas(run_dir, in.run, sequence));
  MVBRDF_ASSIGN_OR_RETURN(in.atlases, pipeline::ReadRunAtlases(run_dir, in.run));
  MVBRDF_RETURN_IF_ERROR(PoseOf(sequence, in.atlas.topology, frame, &in.vertices, &in.normals));
  return in;
}

uint8_t Srgb8(double linear) {
  const double c = std::clamp(linear, 0.0, 1.0);
  const double e = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
  return static_cast<uint8_t>(std::lround(255.0 * e));
}

uint8_t Linear8(double value) { return static_cast<uint8_t>(std::lround(255.0 * std::clamp(value, 0.0, 1.0))); }


}  // namespace mvbrdf::exporter
