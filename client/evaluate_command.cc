// `mvbrdf evaluate DIR --truth TRUTH_DIR`: a reconstruction against the truth.
#include <cstdio>

#include "client/commands.h"
#include "client/flags.h"
#include "core/base/proto_json.h"
#include "core/evaluate/reconstruction_evaluator.h"

namespace mvbrdf::client {

int RunEvaluate(const std::vector<std::string>& args) {
  std::string dir, truth, error_atlas;
  FlagParser flags("evaluate",
                   "Compares a reconstruction (the output directory of 'mvbrdf run') with the synthetic\n"
                   "generator's ground truth and prints JSON: configuration_correct, kd_rmse (texels seen at\n"
                   "least 10 times), per cluster ks and ke relative errors, cluster_accuracy.");
  flags.AddPositional("DIR", &dir, true, "the output directory of 'mvbrdf run'");
  flags.AddString("--truth", &truth, "the synthetic bundle (or its ground_truth/ directory)");
  flags.AddString("--error-atlas", &error_atlas, "also write the per-texel kd error (.png, x10, or .exr)");
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
  auto report = evaluate::EvaluateReconstruction(dir, truth, error_atlas);
  if (!report.ok()) return ReportFailure(report.status());
  std::fputs(MessageToJsonWithDefaults(*report).c_str(), stdout);  // "configurationCorrect": false too
  std::fputs("\n", stdout);
  return kExitOk;
}

}  // namespace mvbrdf::client
