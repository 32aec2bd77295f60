// The resampling stage as a job step: a loaded sequence in, atlases and
// figures out (`mvbrdf resample`, and later the worker).
//
// It streams: one frame's mesh, geometry and atlases at a time, so memory does
// not grow with the number of frames.
//
// Output layout under `out_dir`:
//   resample.json                         ResampleReport (figures per camera and overall, stage times)
//   atlas/mesh.obj, seams.txt             the rest-pose mesh with the atlas UVs in the input's vertex order
//   atlas/triangle_id.exr, charts.png     the layout: triangle per texel, charts for people
//   frames/NNNN/CAM.exr (+ .png)          resampled radiance, RGBA half: A = 1 valid, 0 invalid
//   frames/NNNN/CAM_averaged.exr (+.png)  per-triangle means (thesis Fig. 5.5)
//   frames/NNNN/CAM_grown.exr (+.png)     grown for rendering (thesis Fig. 5.4)
//   frames/NNNN/position.exr, normal.exr  the frame's geometry atlas
//   frames/NNNN/shadows.exr               light-visibility bitmask (bit k = light k, see resample.json): one
//                                         UINT channel "Y" for <= 16 lights, else one per 16 lights named
//                                         "lightsAAAA-BBBB" (bit k % 16 of channel k / 16, samples::ShadowChannels)
#ifndef MVBRDF_CORE_PIPELINE_RESAMPLE_STAGE_H_
#define MVBRDF_CORE_PIPELINE_RESAMPLE_STAGE_H_

#include <filesystem>
#include <functional>
#include <string>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/atlas/atlas.h"
#include "core/gl/egl_context.h"
#include "core/resample/resampler.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/resample_report.pb.h"

namespace mvbrdf::pipeline {

enum class SaveFrames { kNone, kFirst, kAll };

struct ResampleStageOptions {
  atlas::AtlasOptions atlas;
  resample::ResamplerOptions resampler;
  // Dilation iterations of the grown atlases (thesis Fig. 5.4 shows 2).
  int grow_iterations = 2;
  // Averaging: a triangle counts as seen when this share of its texels is valid.
  float min_valid_fraction = 0.75f;
  // Which frames' atlases are written (figures cover every frame regardless).
  SaveFrames save = SaveFrames::kFirst;
  // Compare with ground_truth/truth.json beside the scene when it exists.
  bool evaluate = true;
  std::filesystem::path out_dir;
  // Called on the calling thread with frames done and the total; may be empty.
  std::function<void(const std::string& stage, int done, int total)> progress;
};

// Writes a shadow atlas (CV_16UC(n), samples::ShadowChannels) as the
// shadows.exr above.
absl::Status WriteShadowAtlas(const std::filesystem::path& file, const cv::Mat& shadows);

absl::StatusOr<v1::ResampleReport> RunResampleStage(const scene::Sequence& sequence, gl::EglContext& context,
                                                    const ResampleStageOptions& options);

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_RESAMPLE_STAGE_H_
