// The plan's `refine_lights` stage (issue #14 item 2) as both paths run it:
// RunReconstruction after its own sweep, the service's `choose` task after
// the sweep tasks (on the gather task's triangle Samples, the same ones), so
// both give the same lights. The refined lights reach everything after the
// sweep (clustering, cluster fits, per-texel kd, Table 7.1) through
// SequenceWithRefinedLights: pass 1's texel statistics were gathered with the
// scene's lights, so the reconstruction then gathers them again with the
// refined ones (core/calibrate/refine_lights.h).
#ifndef MVBRDF_CORE_PIPELINE_REFINE_LIGHTS_STAGE_H_
#define MVBRDF_CORE_PIPELINE_REFINE_LIGHTS_STAGE_H_

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/pipeline/reconstruct_stage.h"
#include "core/samples/sample_set.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::pipeline {

// Refines the lights of report->chosen_configuration() from `triangles` as
// options.refine_lights says, into report->calibration's lights_*, and adds
// the "refine_lights" StageRow (options.progress, stage_done). A chosen
// configuration the scene does not have is INVALID_ARGUMENT.
absl::Status RefineLightsStage(const scene::Sequence& sequence, const samples::SampleSet& triangles,
                               const ReconstructOptions& options, v1::RunReport* report);

// `sequence` with the lights of table.calibration() when they were refined
// (lights_refined), else nullopt.
absl::StatusOr<std::optional<scene::Sequence>> SequenceWithRefinedLights(const scene::Sequence& sequence,
                                                                         const v1::RunReport& table);

// The light table a reconstruction continues from after refining the lights
// in-process: `report`'s sweep (rows, choice, margin, warnings, calibration)
// and its stages after the atlas, pass 1 named "gather_light_samples" (the
// continuation gathers the texel statistics again with the refined lights).
v1::RunReport LightTableOf(const v1::RunReport& report);

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_REFINE_LIGHTS_STAGE_H_
