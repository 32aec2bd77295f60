// What a job's request (v1::SubmitJobRequest) means to the pipeline on a
// worker: the plan's request and the reconstruction's options. The same
// request gives the same options on every worker, so tasks of one job agree.
#ifndef MVBRDF_WORKER_JOB_OPTIONS_H_
#define MVBRDF_WORKER_JOB_OPTIONS_H_

#include "absl/status/statusor.h"
#include "core/pipeline/reconstruct_stage.h"
#include "mvbrdf/v1/service.pb.h"

namespace mvbrdf::worker {

// INVALID_ARGUMENT naming the request field for an unknown output or an
// option out of range. `threads` is the worker's own.
absl::StatusOr<pipeline::ReconstructOptions> ReconstructOptionsFor(const v1::SubmitJobRequest& request, int threads);

}  // namespace mvbrdf::worker

#endif  // MVBRDF_WORKER_JOB_OPTIONS_H_
