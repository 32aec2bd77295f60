#include "server/clients_api/job_graph.h"

#include <algorithm>
#include <numeric>
#include <set>

#include "absl/strings/str_cat.h"
#include "core/pipeline/job_options.h"
#include "core/scene/names.h"

namespace mvbrdf::clients_api {
namespace {

bool SceneHasConfiguration(const v1::Scene& scene, const std::string& name) {
  for (const auto& c : scene.light_configurations()) {
    if (c.name() == name) return true;
  }
  return false;
}

// "(it has \"C\", \"NE,NW,SE,SW\", ...)" for an unknown configuration's message.
std::string KnownConfigurations(const v1::Scene& scene) {
  std::vector<std::string> names;
  for (const auto& c : scene.light_configurations()) names.push_back(c.name());
  return absl::StrCat(" (it has ", scene::NameList(names), ")");
}

}  // namespace

absl::StatusOr<JobPlan> PlanJob(const v1::SubmitJobRequest& request, const scene::Sequence& sequence) {
  // Outputs and options as every worker will read them (one function for both).
  absl::StatusOr<pipeline::ReconstructOptions> options = pipeline::ReconstructOptionsFor(request, 1);
  if (!options.ok()) return options.status();
  const pipeline::RunRequest& run = options->request;  // configuration and candidates as the request has them

  const v1::Scene& scene = sequence.scene;
  std::set<std::string> seen;
  for (int i = 0; i < request.configurations_size(); ++i) {
    const std::string& name = request.configurations(i);
    if (!SceneHasConfiguration(scene, name)) {
      return absl::InvalidArgumentError(absl::StrCat("configurations[", i, "]: the scene has no light configuration \"",
                                                     scene::ShownName(name), "\"", KnownConfigurations(scene)));
    }
    if (!seen.insert(name).second) {
      return absl::InvalidArgumentError(absl::StrCat("configurations[", i, "]: \"", name, "\" is listed twice"));
    }
  }
  if (!request.configuration().empty()) {
    if (!SceneHasConfiguration(scene, request.configuration())) {
      return absl::InvalidArgumentError(absl::StrCat("configuration: the scene has no light configuration \"",
                                                     scene::ShownName(request.configuration()), "\"",
                                                     KnownConfigurations(scene)));
    }
    if (request.configurations_size() != 0) {
      return absl::InvalidArgumentError("configuration: give either a known configuration or candidates to sweep");
    }
  }

  // The plan decides what is swept (the candidates, else the scene's), as
  // for a one-process run.
  absl::StatusOr<pipeline::Plan> plan = pipeline::MakePlan(sequence, run);
  if (!plan.ok()) return plan.status();
  JobPlan job_plan;
  job_plan.plan = *std::move(plan);
  if (job_plan.plan.Has(pipeline::Stage::kLightSweep)) job_plan.candidates = job_plan.plan.candidates;
  for (const std::string& name : job_plan.candidates) {
    size_t lights = 0;
    for (const auto& c : scene.light_configurations()) {
      if (c.name() == name) lights = static_cast<size_t>(c.lights_size());
    }
    job_plan.candidate_lights.push_back(lights);
  }
  return job_plan;
}

absl::StatusOr<std::vector<std::string>> AddJobTasks(store::JobStore& jobs, const std::string& job_id,
                                                     const JobPlan& job_plan, int64_t now_ms) {
  std::vector<std::string> ids;
  const auto add = [&](const char* kind, const std::string& key, store::TaskIds deps) -> absl::StatusOr<std::string> {
    absl::StatusOr<std::string> id = jobs.AddTask({job_id, kind, key, std::move(deps), 0}, now_ms);
    if (id.ok()) ids.push_back(*id);
    return id;
  };
  absl::StatusOr<std::string> gather = add("gather", "", {});
  if (!gather.ok()) return gather.status();
  std::string before_reflectance = *gather;
  if (!job_plan.candidates.empty()) {
    std::vector<size_t> order(job_plan.candidates.size());
    std::iota(order.begin(), order.end(), size_t{0});
    if (job_plan.candidate_lights.size() == order.size()) {
      std::stable_sort(order.begin(), order.end(), [&job_plan](size_t a, size_t b) {
        return job_plan.candidate_lights[a] > job_plan.candidate_lights[b];
      });
    }
    std::vector<std::string> sweeps(job_plan.candidates.size());
    for (size_t i : order) {
      absl::StatusOr<std::string> sweep = add("sweep", job_plan.candidates[i], *gather);
      if (!sweep.ok()) return sweep.status();
      sweeps[i] = *sweep;
    }
    // choose also reads gather's result: the report's gather stage.
    std::vector<std::string> choose_deps = {*gather};
    choose_deps.insert(choose_deps.end(), sweeps.begin(), sweeps.end());
    absl::StatusOr<std::string> choose = add("choose", "", choose_deps);
    if (!choose.ok()) return choose.status();
    before_reflectance = *choose;
  }
  if (job_plan.plan.Has(pipeline::Stage::kTexelPass)) {
    absl::StatusOr<std::string> reflectance =
        add("reflectance", job_plan.candidates.empty() ? job_plan.plan.fixed_configuration : "", before_reflectance);
    if (!reflectance.ok()) return reflectance.status();
  }
  return ids;
}

}  // namespace mvbrdf::clients_api
