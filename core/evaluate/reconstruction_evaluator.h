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
absl::StatusOr<v1::EvaluationReport> EvaluateReconstruction(const std::filesystem::path& run_dir,
                                                            const std::filesystem::path& truth,
                                                            const std::filesystem::path& error_atlas = {},
                                                            const std::filesystem::path& scene = {});

// The truth.json of `truth` (a bundle or its ground_truth directory).
std::filesystem::path TruthFileOf(const std::filesystem::path& truth);

// The scene the run reconstructed: `scene` when given, else result.json's
// (when the run read it from disk), else scene.json beside the truth's bundle.
std::optional<std::filesystem::path> SceneOfRun(const std::filesystem::path& run_dir, const v1::RunReport& run,
                                                const std::filesystem::path& truth_file,
                                                const std::filesystem::path& scene = {});

}  // namespace mvbrdf::evaluate

#endif  // MVBRDF_CORE_EVALUATE_RECONSTRUCTION_EVALUATOR_H_
