// What every export reads of a run (core/export): its result.json, layout and
// atlases (pipeline/run_atlases.h), and the mesh in one pose with the atlas
// UVs; plus the encodings the exports share.
#ifndef MVBRDF_CORE_EXPORT_EXPORT_INPUT_H_
#define MVBRDF_CORE_EXPORT_EXPORT_INPUT_H_

#include <cstdint>
#include <filesystem>
#include <vector>

#include <glm/glm.hpp>

#include "absl/status/statusor.h"
#include "core/base/quantile.h"
#include "core/atlas/atlas.h"
#include "core/pipeline/run_atlases.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::exporter {

struct ExportInput {
  v1::RunReport run;
  atlas::Atlas atlas;
  pipeline::RunAtlases atlases;
  // Per render vertex of atlas.topology: the pose's positions and smooth
  // normals (as the renderer's).
  std::vector<glm::vec3> vertices, normals;
};

// `frame` -1: the rest pose; else a frame in [0, num_frames) (INVALID_ARGUMENT
// naming --frame otherwise).
absl::StatusOr<ExportInput> ReadExportInput(const std::filesystem::path& run_dir, const scene::Sequence& sequence,
                                            int frame);

// The pose of frame `frame` (-1: the rest pose) per render vertex.
absl::Status PoseOf(const scene::Sequence& sequence, const scene::MeshTopology& topology, int frame,
                    std::vector<glm::vec3>* vertices, std::vector<glm::vec3>* normals);

// Linear [0, 1] (clamped) to an sRGB or a linear 8-bit code value.
uint8_t Srgb8(double linear);
uint8_t Linear8(double value);

}  // namespace mvbrdf::exporter

#endif  // MVBRDF_CORE_EXPORT_EXPORT_INPUT_H_
