// `mvbrdf evaluate DIR --truth TRUTH_DIR`: a reconstruction against the truth.
#include <cstdio>
#include <filesystem>
#include <vector>

#include "client/commands.h"
#include "client/flags.h"
#include "client/output_dir.h"
#include "core/base/proto_json.h"
#include "core/evaluate/reconstruction_evaluator.h"

namespace mvbrdf::client {

int RunEvaluate(const std::vector<std::string>& args) {
  std::string dir, truth, error_atlas;
  FlagParser flags("evaluate",
                   "Compares a reconstruction (the output directory of 'mvbrdf run') with the synthetic\n"
                   "generator's ground truth and prints JSON: configuration_correct, kd_rmse (texels seen at\n"
                   "least 10 times), per cluster ks and ke relative errors, cluster_accuracy; per camera the\n"
                   "rotation, centre and reprojection error of the scene's calibration (before) and of the cameras\n"
                   "as used (after, refined), per light its position, direction and intensity error (intensities\n"
                   "after one common scale: the data cannot tell it from kd's).");
  flags.AddPositional("DIR", &dir, true, "the output directory of 'mvbrdf run'");
  flags.AddString("--truth DIR", &truth, "the synthetic bundle (or its ground_truth/ directory)");
  flags.AddString("--error-atlas FILE", &error_atlas, "also write the per-texel kd error (.png, x10, or .exr)");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf evaluate: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  if (truth.empty()) {
    std::fprintf(stderr, "mvbrdf evaluate: --truth: required\n");
    return kExitUsage;
  }
  if (!error_atlas.empty()) {
    // The error atlas and its "_truth_kd" sibling must not replace a file of
    // the run or its scene (--error-atlas DIR/atlases/kd.exr exited 0 and
    // destroyed the reconstruction).
    std::vector<InputPath> inputs = RunInputs(dir);
    inputs.push_back({"--truth", std::filesystem::path(truth) / "truth.json", false});
    inputs.push_back({"--truth", std::filesystem::path(truth) / "ground_truth" / "truth.json", false});
    std::filesystem::path sibling = error_atlas;
    sibling.replace_filename(sibling.stem().string() + "_truth_kd" + sibling.extension().string());
    for (const std::filesystem::path& file : {std::filesystem::path(error_atlas), sibling}) {
      if (absl::Status s = CheckOutputFileSparesInputs("--error-atlas", file, inputs); !s.ok()) {
        return ReportFailure(s);
      }
    }
  }
  auto report = evaluate::EvaluateReconstruction(dir, truth, error_atlas);
  if (!report.ok()) return ReportFailure(report.status());
  std::fputs(MessageToJsonWithDefaults(*report).c_str(), stdout);  // "configurationCorrect": false too
  std::fputs("\n", stdout);
  return kExitOk;
}

}  // namespace mvbrdf::client
