// `mvbrdf report DIR [--out FILE.html]`: the HTML report of a reconstruction
// (core/report/report_page.h) — one self-contained file, viewable offline.
#include <stdlib.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/flags.h"
#include "client/output_dir.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"
#include "core/gl/egl_context.h"
#include "core/report/report_inputs.h"

namespace mvbrdf::client {

namespace fs = std::filesystem;

absl::Status WriteRunReport(const fs::path& run_dir, const fs::path& out, const ReportFlags& flags) {
  // Up front: the page must not replace a file it is made of (--out
  // DIR/result.json or the scene file exited 0 and destroyed it).
  std::vector<InputPath> read = RunInputs(run_dir, flags.scene);
  if (!flags.tradeoff.empty()) read.push_back({"--tradeoff", flags.tradeoff, false});
  if (!flags.truth.empty()) {
    read.push_back({"--truth", fs::path(flags.truth) / "truth.json", false});
    read.push_back({"--truth", fs::path(flags.truth) / "ground_truth" / "truth.json", false});
  }
  MVBRDF_RETURN_IF_ERROR(CheckOutputFileSparesInputs("--out", out, read));
  std::error_code dir_ec;
  if (fs::is_directory(out, dir_ec)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--out ", out.string(), ": is a directory, expected an HTML file name"));
  }
  report::ReportOptions options;
  options.truth = flags.truth;
  options.scene = flags.scene;
  options.use_truth = !flags.no_truth;
  options.tradeoff = flags.tradeoff;
  options.relit_frames = flags.relit_frames;
  // A fresh private directory (mkdtemp), not a guessable name in $TMPDIR.
  MVBRDF_ASSIGN_OR_RETURN(const fs::path tmp, TemporaryDirectory());
  std::string scratch = (tmp / "mvbrdf-report-XXXXXX").string();
  if (mkdtemp(scratch.data()) == nullptr) return ErrnoStatus(errno, "cannot create a temporary directory", scratch);
  options.scratch_dir = scratch;
  std::unique_ptr<gl::EglContext> context;
  if (!flags.no_render) {
    MVBRDF_ASSIGN_OR_RETURN(const gl::EglPlatform platform, gl::ParseEglPlatform(flags.egl));
    MVBRDF_ASSIGN_OR_RETURN(context, gl::EglContext::Create(platform));
    options.gl = context.get();
  }
  absl::StatusOr<report::ReportInputs> inputs = report::CollectReportInputs(run_dir, options);
  std::error_code ec;
  fs::remove_all(options.scratch_dir, ec);
  if (!inputs.ok()) return inputs.status();
  return WriteStringToFile(out, report::BuildReportHtml(*inputs));
}

void AddReportFlags(FlagParser& parser, ReportFlags* flags) {
  parser.AddString("--truth DIR", &flags->truth,
                   "ground-truth bundle (default: the scene's directory when it has one)");
  parser.AddBool("--no-truth", &flags->no_truth, "leave out the comparison with the ground truth");
  parser.AddString("--tradeoff FILE", &flags->tradeoff,
                   "error-against-run-time points (scripts/bench-tradeoff's JSON)");
  parser.AddInt("--relit-frames N", &flags->relit_frames,
                "positions of the light moving around the model, on the camera's side");
  parser.AddBool("--no-render", &flags->no_render, "no renderings (input vs reconstruction, relit sequence)");
}

int RunReport(const std::vector<std::string>& args) {
  std::string dir, out;
  ReportFlags report_flags;
  FlagParser flags("report",
                   "Writes the HTML report of a reconstruction (the output directory of 'mvbrdf run'): error\n"
                   "against run time (with --tradeoff), the plan, time and memory per stage, Tables 6.1, 6.2 and\n"
                   "7.1, the comparison with the ground truth, the atlases, input beside reconstruction per\n"
                   "camera and a relit sequence. One self-contained file: plots are inline SVG, images embedded.");
  flags.AddPositional("DIR", &dir, true, "the output directory of 'mvbrdf run'");
  flags.AddString("--out FILE", &out, "the HTML file (default: DIR/report.html)");
  AddReportFlags(flags, &report_flags);
  flags.AddString("--egl PLATFORM", &report_flags.egl, "EGL platform: auto, surfaceless (Mesa) or device (GPU)");
  flags.AddString(
      "--scene FILE", &report_flags.scene,
      "the scene file (default: result.json's scene, relative to DIR; needed for a fetched service result)");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf report: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  if (report_flags.relit_frames < 0 || report_flags.relit_frames > 360) {
    std::fprintf(stderr, "mvbrdf report: --relit-frames: must be in [0, 360]\n");
    return kExitUsage;
  }
  if (out.empty()) out = (fs::path(dir) / "report.html").string();
  if (absl::Status s = WriteRunReport(dir, out, report_flags); !s.ok()) return ReportFailure(s, "mvbrdf report");
  std::printf("wrote %s\n", out.c_str());
  return kExitOk;
}

}  // namespace mvbrdf::client
