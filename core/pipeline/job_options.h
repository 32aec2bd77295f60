// What a job's request (v1::SubmitJobRequest) means to the pipeline: the
// plan's request and the reconstruction's options, with their checks. The
// server checks a submitted request with it, every worker derives its
// options from it and `mvbrdf run` builds its own request the same way, so
// the same request gives the same options everywhere and tasks of one job
// agree. In the library, so that neither the server nor the client reaches
// into the worker for it.
#ifndef MVBRDF_CORE_PIPELINE_JOB_OPTIONS_H_
#define MVBRDF_CORE_PIPELINE_JOB_OPTIONS_H_

#include "absl/status/statusor.h"
#include "core/pipeline/reconstruct_stage.h"
#include "mvbrdf/v1/job_options.pb.h"

namespace mvbrdf::pipeline {

// INVALID_ARGUMENT naming the request field for an unknown output or an
// option out of range. `threads`: the caller's own (a worker's, `run`'s).
absl::StatusOr<ReconstructOptions> ReconstructOptionsFor(const v1::SubmitJobRequest& request, int threads);

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_JOB_OPTIONS_H_
