// Table 6.1 (one row per candidate light configuration) and the choice among
// its rows by the stated rule (fit::PreferConfiguration): shared by the
// one-process reconstruction and the service's `sweep` and `choose` tasks,
// so both choose alike.
#ifndef MVBRDF_CORE_PIPELINE_LIGHT_TABLE_H_
#define MVBRDF_CORE_PIPELINE_LIGHT_TABLE_H_

#include "absl/status/status.h"
#include "core/fit/light_sweep.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::pipeline {

void SweepRowToProto(const fit::SweepRow& row, v1::LightConfigurationRow* out);

// Sets chosen_configuration by the rule of report->options().fitting()
// .sweep_criterion (fit::PreferConfiguration) among
// report->light_configurations(), in their order; configuration_criterion
// ("held-out" or "e-d") and configuration_rule; configuration_margin (how
// much higher the runner-up's error is by that criterion),
// configuration_margin_e_d (the same by E_d, for E_d's own pick, as before
// issue #14) and configuration_warning (held-out: the margin is below
// fit::kAmbiguousHeldOutMargin; E_d: E_a prefers another row). Rows without
// held-out errors (all 0: one frame, one camera) are chosen by E_d, with a
// warning. FAILED_PRECONDITION when there are no rows.
absl::Status ChooseConfiguration(v1::RunReport* report);

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_LIGHT_TABLE_H_
