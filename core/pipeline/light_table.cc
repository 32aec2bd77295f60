#include "core/pipeline/light_table.h"

#include "absl/strings/str_cat.h"

namespace mvbrdf::pipeline {

void SweepRowToProto(const fit::SweepRow& row, v1::LightConfigurationRow* out) {
  out->set_name(row.name);
  out->clear_lights();
  for (const std::string& l : row.lights) out->add_lights(l);
  out->set_lit_triangles(row.lit_triangles);
  out->set_e_a(row.e_a);
  out->set_e_d(row.e_d);
  out->set_seconds(row.seconds);
  out->clear_robust_scales();
  if (row.fit.channels[0].robust_scale > 0.0 || row.triangle_kd_scale != glm::dvec3(0.0)) {
    v1::RobustScale* brdf = out->add_robust_scales();
    brdf->set_stage("light_sweep");
    brdf->set_name(row.name + "/average_brdf");
    double scale = 0.0, outliers = 0.0;
    for (const fit::ChannelFitSummary& c : row.fit.channels) {
      scale += c.robust_scale / 3.0;
      outliers += c.outlier_fraction / 3.0;
    }
    brdf->set_scale(scale);
    brdf->set_outlier_fraction(outliers);
    v1::RobustScale* kd = out->add_robust_scales();
    kd->set_stage("light_sweep");
    kd->set_name(row.name + "/triangle_kd");
    kd->set_scale((row.triangle_kd_scale.x + row.triangle_kd_scale.y + row.triangle_kd_scale.z) / 3.0);
    kd->set_outlier_fraction(row.triangle_kd_outliers);
  }
}

absl::Status ChooseConfiguration(v1::RunReport* report) {
  const auto& rows = report->light_configurations();
  if (rows.empty()) return absl::FailedPreconditionError("light sweep: no configuration could be fitted");
  int best = 0;
  for (int i = 1; i < rows.size(); ++i) {
    if (fit::PreferConfiguration(rows[i].e_d(), rows[i].e_a(), rows[best].e_d(), rows[best].e_a())) best = i;
  }
  const v1::LightConfigurationRow& chosen = rows[best];
  report->set_chosen_configuration(chosen.name());
  double runner_up = -1.0;
  int best_e_a = best;
  for (int i = 0; i < rows.size(); ++i) {
    if (i != best && (runner_up < 0.0 || rows[i].e_d() < runner_up)) runner_up = rows[i].e_d();
    if (rows[i].e_a() < rows[best_e_a].e_a()) best_e_a = i;
  }
  report->clear_configuration_margin();
  report->clear_configuration_warning();
  if (runner_up >= 0.0 && chosen.e_d() > 0.0) report->set_configuration_margin(runner_up / chosen.e_d() - 1.0);
  if (best_e_a != best) {
    report->set_configuration_warning(absl::StrCat("E_a prefers ", rows[best_e_a].name(), " (", rows[best_e_a].e_a(),
                                                   " vs ", chosen.e_a(), "); the choice by E_d may be ambiguous"));
  }
  return absl::OkStatus();
}

}  // namespace mvbrdf::pipeline
