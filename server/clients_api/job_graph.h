// A submitted job's task graph (docs/service.md, "A job is a task graph"):
//
//   gather ──▶ sweep[c1] ─┐
//          ──▶ sweep[c2] ─┼──▶ choose ──▶ reflectance
//          ──▶ ...       ─┘
//          ──────────────────▶ choose (for gather's time in the report)
//
// `sweep` (one per candidate configuration, key = its name) and `choose`
// exist only when the plan runs the light sweep; `reflectance` only when it
// runs the texel pass, depending on `choose`, or on `gather` without a sweep
// (its key is then the fixed configuration, empty for "every light on").
#ifndef MVBRDF_SERVER_CLIENTS_API_JOB_GRAPH_H_
#define MVBRDF_SERVER_CLIENTS_API_JOB_GRAPH_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/pipeline/plan.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/service.pb.h"
#include "server/store/job_store.h"

namespace mvbrdf::clients_api {

struct JobPlan {
  pipeline::Plan plan;
  // The configurations swept (empty when the plan has no sweep).
  std::vector<std::string> candidates;
  // Per candidate its number of lights: its sweep's cost grows with it.
  std::vector<size_t> candidate_lights;
};

// The plan of `request` on `sequence`. INVALID_ARGUMENT naming the request
// field: an unknown `configuration` or `configurations[i]`, a repeated
// candidate, an unknown output, nothing requested. One candidate in
// `configurations` is treated as a known configuration (no sweep).
absl::StatusOr<JobPlan> PlanJob(const v1::SubmitJobRequest& request, const scene::Sequence& sequence);

// Adds the graph of `job_plan` to the (unsealed) job; returns the task ids in
// creation order. Workers lease in creation order, so the sweep tasks are
// created most lights first (longest first: the short ones fill the last
// gaps when several workers sweep); choose reads them in candidate order.
absl::StatusOr<std::vector<std::string>> AddJobTasks(store::JobStore& jobs, const std::string& job_id,
                                                     const JobPlan& job_plan, int64_t now_ms);

}  // namespace mvbrdf::clients_api

#endif  // MVBRDF_SERVER_CLIENTS_API_JOB_GRAPH_H_
