// What a reconstruction (the output directory of `mvbrdf run`) holds in its
// atlases, read back for drawing (ReconstructionRenderer) and export
// (core/export): the layout rebuilt from the run's scene and checked against
// atlas/triangle_id.exr, and kd, the model's two parameter atlases and
// confidence.
#ifndef MVBRDF_CORE_PIPELINE_RUN_ATLASES_H_
#define MVBRDF_CORE_PIPELINE_RUN_ATLASES_H_

#include <filesystem>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "core/atlas/atlas.h"
#include "core/brdf/model.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::pipeline {

// The layout of the run (result.json's atlas size), rebuilt
// (deterministically) from `sequence`, the run's scene; FAILED_PRECONDITION
// when it differs from the run's atlas/triangle_id.exr.
absl::StatusOr<atlas::Atlas> OpenRunAtlas(const std::filesystem::path& run_dir, const v1::RunReport& run,
                                          const scene::Sequence& sequence);

struct RunAtlases {
  // The run's model (result.json's brdf; Phong when empty). With --brdf auto
  // (per_texel_model) each texel's model is in `model_atlas`.
  brdf::Model model = brdf::Model::kPhong;
  bool per_texel_model = false;
  cv::Mat kd;              // CV_32FC3
  cv::Mat p1, p2;          // CV_32FC3: the model's two parameters (ks, ke; f0, roughness; parameter_1, _2)
  // CV_32FC3, the third parameter where the run's model has one (GGX's
  // f90_ratio.exr; parameter_3.exr under auto when a cluster picked GGX);
  // empty when absent (a run before it: a dielectric's ratio, 25).
  cv::Mat p3;
  cv::Mat model_atlas;     // CV_8UC1 with per_texel_model: brdf::Model values (texels of no cluster: Phong)
  cv::Mat confidence;      // CV_32FC1: observations per texel (0: never observed)

  // The model of texel (x, y): model_atlas's under auto, else `model`.
  brdf::Model ModelAt(int x, int y) const {
    return per_texel_model ? static_cast<brdf::Model>(model_atlas.at<uint8_t>(y, x)) : model;
  }
};

// atlases/ of the run: kd.exr, the two parameter atlases the model names,
// model.png under auto, confidence.exr; errors name the file.
absl::StatusOr<RunAtlases> ReadRunAtlases(const std::filesystem::path& run_dir, const v1::RunReport& run);

// Per texel the grazing support its cluster's GGX lobe is drawn within
// (result.json's clusters[].ggxGrazingSupport, core/fit/grazing_support.h),
// from atlases/cluster.exr, grown into the charts' gutters as the parameter
// atlases are (result.json's grow iterations): CV_32FC3, `size` square, the
// value in every channel, 0 where nothing is held. Empty when no cluster has
// a support (a run without GGX, or from before supports were recorded).
absl::StatusOr<cv::Mat> GgxSupportAtlas(const std::filesystem::path& run_dir, const v1::RunReport& run, int size);

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_RUN_ATLASES_H_
