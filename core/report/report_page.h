// The HTML report of a reconstruction (issue #6): one self-contained file —
// inline SVG plots, embedded PNGs, a few lines of script that only check the
// page — that a person would rather look at than read result.json:
//   the run at a glance; error against run time (Pareto front over the knobs
//   that trade one for the other, the chosen operating point marked); the
//   plan with every skipped stage and why; time and peak memory per stage;
//   Tables 6.1, 6.2 and 7.1 with their run times; the comparison with the
//   ground truth when there is one; the atlases; input beside reconstruction
//   per camera; a relit sequence with a light moving around the model.
#ifndef MVBRDF_CORE_REPORT_REPORT_PAGE_H_
#define MVBRDF_CORE_REPORT_REPORT_PAGE_H_

#include <optional>
#include <string>
#include <vector>

#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::report {

struct ReportImage {
  std::string caption;
  std::string png;  // the PNG file's bytes
};

struct CameraComparison {
  std::string camera;
  int frame = 0;
  std::string input_png;           // the video frame
  std::string reconstruction_png;  // rendered with the BRDF atlases
  std::string corrected_png;       // with the frame's correction atlas (may be empty)
};

struct ReportInputs {
  v1::RunReport run;
  std::optional<v1::EvaluationReport> evaluation;  // against the ground truth
  std::vector<ReportImage> atlases;
  std::vector<CameraComparison> cameras;
  std::vector<ReportImage> relit;  // frames of a light moving around the model
  std::optional<v1::TradeoffReport> tradeoff;
};

std::string BuildReportHtml(const ReportInputs& inputs);

}  // namespace mvbrdf::report

#endif  // MVBRDF_CORE_REPORT_REPORT_PAGE_H_
