// `mvbrdf evaluate DIR --truth TRUTH_DIR`: a reconstruction (the outputs of
// `mvbrdf run`) against the generator's ground truth.
#ifndef MVBRDF_CORE_EVALUATE_RECONSTRUCTION_EVALUATOR_H_
#define MVBRDF_CORE_EVALUATE_RECONSTRUCTION_EVALUATOR_H_

#include <filesystem>
#include <optional>

#include "absl/status/statusor.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::evaluate {

// Texels observed at least this often count for the kd RMSE (issue #4's
// target is stated over them).
constexpr float kMinObservationsForKd = 10.0f;

// `run_dir` holds result.json, atlas/ and atlases/; `truth` is a bundle
// directory (with ground_truth/truth.json) or the ground_truth directory.
// Clusters are matched to the true material most of their texels have.
// `error_atlas` (optional, .png or .exr): the per-texel kd error, |kd - kd_true|
// per channel, where the texel was seen (a PNG shows it times 10), and beside
// it NAME_truth_kd.EXT with the true kd of the same texels.
// Issue #14: cameras and lights as used against the truth
// (core/evaluate/calibration_truth.h) from the run's scene: `scene` when
// given, else result.json's, else the truth bundle's scene.json (no rows when
// none is found).
// `kd_texels_of` (optional): another run of the same scene and atlas; the kd
// figures over ">= 10 times" are then taken over the texels that run saw
// >= 10 times, with this run's kd there even where this run saw a texel less
// often or never (EvaluationReport.kd_texels_of). Rejecting observations
// changes which texels a run counts: a run that drops its hardest texels
// below 10 observations otherwise scores better without being better.
absl::StatusOr<v1::EvaluationReport> EvaluateReconstruction(const std::filesystem::path& run_dir,
                                                            const std::filesystem::path& truth,
                                                            const std::filesystem::path& error_atlas = {},
                                                            const std::filesystem::path& scene = {},
                                                            const std::filesystem::path& kd_texels_of = {});

// The truth.json of `truth` (a bundle or its ground_truth directory).
std::filesystem::path TruthFileOf(const std::filesystem::path& truth);

// The scene the run reconstructed: `scene` when given, else result.json's
// (when the run read it from disk), else scene.json beside the truth's bundle.
std::optional<std::filesystem::path> SceneOfRun(const std::filesystem::path& run_dir, const v1::RunReport& run,
                                                const std::filesystem::path& truth_file,
                                                const std::filesystem::path& scene = {});

}  // namespace mvbrdf::evaluate

#endif  // MVBRDF_CORE_EVALUATE_RECONSTRUCTION_EVALUATOR_H_
