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

// Sets chosen_configuration, configuration_margin (how much higher the next
// best E_d is) and configuration_warning (when E_a prefers another row) from
// report->light_configurations(), in their order. FAILED_PRECONDITION when
// there are no rows.
absl::Status ChooseConfiguration(v1::RunReport* report);

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_LIGHT_TABLE_H_
