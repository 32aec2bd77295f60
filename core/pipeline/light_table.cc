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
  out->set_e_held_out(row.e_held_out);
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

namespace {

fit::ConfigurationErrors ErrorsOf(const v1::LightConfigurationRow& row) {
  return {row.e_a(), row.e_d(), row.e_held_out()};
}

// The row the rule picks among `rows`, in their order (the first of equals).
int Best(const google::protobuf::RepeatedPtrField<v1::LightConfigurationRow>& rows, fit::SweepCriterion criterion) {
  int best = 0;
  for (int i = 1; i < rows.size(); ++i) {
    if (fit::PreferConfiguration(criterion, ErrorsOf(rows[i]), ErrorsOf(rows[best]))) best = i;
  }
  return best;
}

// How much higher the runner-up's error is than the best's (0.03: 3 %);
// negative when there is no runner-up or the best's error is 0.
double Margin(const google::protobuf::RepeatedPtrField<v1::LightConfigurationRow>& rows, int best,
              double (v1::LightConfigurationRow::*error)() const) {
  double runner_up = -1.0;
  for (int i = 0; i < rows.size(); ++i) {
    if (i != best && (runner_up < 0.0 || (rows[i].*error)() < runner_up)) runner_up = (rows[i].*error)();
  }
  const double chosen = (rows[best].*error)();
  return runner_up >= 0.0 && chosen > 0.0 ? runner_up / chosen - 1.0 : -1.0;
}

}  // namespace

absl::Status ChooseConfiguration(v1::RunReport* report) {
  const auto& rows = report->light_configurations();
  if (rows.empty()) return absl::FailedPreconditionError("light sweep: no configuration could be fitted");
  // The held-out error needs Samples in two frames (or cameras): without
  // any, every row's is 0 and the rule falls back to E_d's.
  bool held_out = report->options().fitting().sweep_criterion() == v1::SWEEP_CRITERION_HELD_OUT;
  bool no_held_out_data = true;
  for (const v1::LightConfigurationRow& row : rows) no_held_out_data &= row.e_held_out() == 0.0;
  const bool fallback = held_out && no_held_out_data && rows.size() > 1;
  if (fallback) held_out = false;
  const fit::SweepCriterion criterion = held_out ? fit::SweepCriterion::kHeldOut : fit::SweepCriterion::kErrorD;
  const int best = Best(rows, criterion);
  const int best_e_d = Best(rows, fit::SweepCriterion::kErrorD);
  const v1::LightConfigurationRow& chosen = rows[best];
  report->set_chosen_configuration(chosen.name());
  report->set_configuration_criterion(held_out ? "held-out" : "e-d");
  report->set_configuration_rule(held_out ? "lowest held-out error; E_d, then E_a, break ties"
                                          : "lowest E_d; E_a breaks ties");
  report->clear_configuration_margin();
  report->clear_configuration_margin_e_d();
  report->clear_configuration_warning();
  const double margin_e_d = Margin(rows, best_e_d, &v1::LightConfigurationRow::e_d);
  if (margin_e_d >= 0.0) report->set_configuration_margin_e_d(margin_e_d);
  if (held_out) {
    const double margin = Margin(rows, best, &v1::LightConfigurationRow::e_held_out);
    if (margin >= 0.0) report->set_configuration_margin(margin);
    if (margin >= 0.0 && margin < fit::kAmbiguousHeldOutMargin) {
      int runner_up = best == 0 ? 1 : 0;
      for (int i = 0; i < rows.size(); ++i) {
        if (i != best && rows[i].e_held_out() < rows[runner_up].e_held_out()) runner_up = i;
      }
      report->set_configuration_warning(absl::StrCat(
          "the held-out error of ", rows[runner_up].name(), " is only ", absl::SixDigits(100.0 * margin), " % higher (",
          rows[runner_up].e_held_out(), " vs ", chosen.e_held_out(), "); the choice may be ambiguous"));
    }
    return absl::OkStatus();
  }
  if (margin_e_d >= 0.0) report->set_configuration_margin(margin_e_d);
  int best_e_a = best;
  for (int i = 0; i < rows.size(); ++i) {
    if (rows[i].e_a() < rows[best_e_a].e_a()) best_e_a = i;
  }
  std::string warning;
  if (fallback) {
    warning = "no held-out error (the light sweep's Samples span one frame and one camera): chosen by E_d";
  }
  if (best_e_a != best) {
    absl::StrAppend(&warning, warning.empty() ? "" : "; ", "E_a prefers ", rows[best_e_a].name(), " (",
                    rows[best_e_a].e_a(), " vs ", chosen.e_a(), "); the choice by E_d may be ambiguous");
  }
  report->set_configuration_warning(warning);
  return absl::OkStatus();
}

}  // namespace mvbrdf::pipeline
