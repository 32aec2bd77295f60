#include "core/pipeline/refine_lights_stage.h"

#include <chrono>

#include "absl/strings/str_cat.h"
#include "core/base/process_stats.h"
#include "core/base/status_macros.h"
#include "core/calibrate/refine_lights.h"

namespace mvbrdf::pipeline {

absl::Status RefineLightsStage(const scene::Sequence& sequence, const samples::SampleSet& triangles,
                               const ReconstructOptions& options, v1::RunReport* report) {
  const auto start = std::chrono::steady_clock::now();
  const std::string& chosen = report->chosen_configuration();
  const v1::LightConfiguration* config = nullptr;
  for (const v1::LightConfiguration& c : sequence.scene.light_configurations()) {
    if (c.name() == chosen) config = &c;
  }
  if (config == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat("light configuration \"", chosen, "\": the scene has no such configuration"));
  }
  calibrate::LightRefinementOptions o;
  o.mode = options.refine_lights;
  o.inverse_square_falloff = sequence.scene.lighting().inverse_square_falloff();
  o.cancelled = options.cancelled;
  v1::CalibrationReport calibration;
  MVBRDF_RETURN_IF_ERROR(calibrate::RefineLights(sequence, triangles,
                                                 {config->lights().begin(), config->lights().end()}, o, &calibration));
  calibrate::CopyLightRefinement(calibration, report->mutable_calibration());
  if (options.progress) options.progress("refine_lights", 1, 1);
  v1::StageRow* row = report->add_stages();
  row->set_name("refine_lights");
  row->set_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  row->set_peak_rss_bytes(PeakRssBytes());
  if (options.stage_done) options.stage_done(*row);
  return absl::OkStatus();
}

absl::StatusOr<std::optional<scene::Sequence>> SequenceWithRefinedLights(const scene::Sequence& sequence,
                                                                         const v1::RunReport& table) {
  if (!table.calibration().lights_refined()) return std::optional<scene::Sequence>();
  scene::Sequence refined = sequence;
  MVBRDF_RETURN_IF_ERROR(calibrate::ApplyLightRefinement(table.calibration(), &refined));
  return std::optional<scene::Sequence>(std::move(refined));
}

v1::RunReport LightTableOf(const v1::RunReport& report) {
  v1::RunReport table;
  *table.mutable_light_configurations() = report.light_configurations();
  table.set_chosen_configuration(report.chosen_configuration());
  table.set_configuration_margin(report.configuration_margin());
  table.set_configuration_warning(report.configuration_warning());
  table.set_configuration_criterion(report.configuration_criterion());
  table.set_configuration_margin_e_d(report.configuration_margin_e_d());
  table.set_configuration_rule(report.configuration_rule());
  *table.mutable_calibration() = report.calibration();
  for (const v1::StageRow& stage : report.stages()) {
    if (stage.name() == "atlas") continue;
    v1::StageRow* row = table.add_stages();
    *row = stage;
    if (stage.name() == "gather_samples") row->set_name("gather_light_samples");
  }
  return table;
}

}  // namespace mvbrdf::pipeline
