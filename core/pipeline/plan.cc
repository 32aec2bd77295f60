#include "core/pipeline/plan.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/scene/names.h"

namespace mvbrdf::pipeline {

const char* StageName(Stage stage) {
  switch (stage) {
    case Stage::kAtlas: return "atlas";
    case Stage::kRefineCameras: return "refine_cameras";
    case Stage::kGatherSamples: return "gather_samples";
    case Stage::kLightSweep: return "light_sweep";
    case Stage::kRefineLights: return "refine_lights";
    case Stage::kClustering: return "clustering";
    case Stage::kClusterFit: return "cluster_fit";
    case Stage::kSolverComparison: return "solver_comparison";
    case Stage::kNormals: return "normals";
    case Stage::kTexelPass: return "texel_pass";
    case Stage::kCorrection: return "correction_atlases";
    case Stage::kCameraErrors: return "camera_errors";
    case Stage::kWriteAtlases: return "write_atlases";
  }
  return "?";
}

bool Plan::Has(Stage stage) const {
  for (const Step& s : steps) {
    if (s.stage == stage) return true;
  }
  return false;
}

void Plan::ToProto(v1::Plan* plan) const {
  for (const Step& s : steps) {
    v1::PlannedStage* p = plan->add_stages();
    p->set_name(StageName(s.stage));
    p->set_why(s.why);
  }
  for (const v1::SkippedStage& s : skipped) *plan->add_skipped() = s;
}

std::string Plan::Describe() const {
  std::string out = "plan:\n";
  for (const Step& s : steps) absl::StrAppend(&out, "  run   ", StageName(s.stage), ": ", s.why, "\n");
  for (const v1::SkippedStage& s : skipped) absl::StrAppend(&out, "  skip  ", s.name(), ": ", s.reason(), "\n");
  return out;
}

absl::StatusOr<Plan> MakePlan(const scene::Sequence& sequence, const RunRequest& request) {
  Plan plan;
  const v1::Scene& scene = sequence.scene;
  const auto run = [&](Stage stage, std::string why) { plan.steps.push_back({stage, std::move(why)}); };
  const auto skip = [&](Stage stage, std::string reason) {
    v1::SkippedStage s;
    s.set_name(StageName(stage));
    s.set_reason(std::move(reason));
    plan.skipped.push_back(std::move(s));
  };
  if (!request.light_table && !request.brdf_atlases && !request.correction && !request.camera_errors &&
      !request.normals) {
    return absl::InvalidArgumentError("outputs: nothing requested (light table, BRDF atlases, correction, errors, normals)");
  }
  const auto known = [&](const std::string& name) {
    for (const auto& c : scene.light_configurations()) {
      if (c.name() == name) return true;
    }
    return false;
  };
  const auto known_list = [&]() {
    std::vector<std::string> names;
    for (const auto& c : scene.light_configurations()) names.push_back(c.name());
    return scene::NameList(names);
  };
  if (!request.configuration.empty() && !known(request.configuration)) {
    return absl::InvalidArgumentError(absl::StrCat("--config: the scene has no light configuration \"",
                                                   scene::ShownName(request.configuration), "\" (it has ", known_list(),
                                                   ")"));
  }
  if (!request.configuration.empty() && !request.candidates.empty()) {
    return absl::InvalidArgumentError("--config: give either a known configuration or --candidates to sweep, not both");
  }
  for (size_t i = 0; i < request.candidates.size(); ++i) {
    const std::string& name = request.candidates[i];
    if (name.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("--candidates: configuration ", i + 1, " is empty (names are separated by ';')"));
    }
    if (!known(name)) {
      return absl::InvalidArgumentError(absl::StrCat("--candidates: the scene has no light configuration \"", name,
                                                     "\" (it has ", known_list(), ")"));
    }
    for (size_t j = 0; j < i; ++j) {
      if (request.candidates[j] == name) {
        return absl::InvalidArgumentError(absl::StrCat("--candidates: \"", name, "\" is listed twice"));
      }
    }
  }
  // Everything beyond the light table needs the reflectance stages.
  const bool reflectance = request.brdf_atlases || request.correction || request.camera_errors || request.normals;

  if (sequence.topology.has_uvs()) {
    skip(Stage::kAtlas, "the mesh has UVs: they are the atlas");
  } else {
    run(Stage::kAtlas, "the mesh has no UVs");
  }
  if (request.refine_cameras == v1::REFINEMENT_OFF) {
    skip(Stage::kRefineCameras, "--refine-cameras off");
  } else if (sequence.cameras.size() < 2 && request.refine_cameras == v1::REFINEMENT_AUTO) {
    skip(Stage::kRefineCameras, "one camera: no cross-camera consistency to measure the calibration by");
  } else if (request.refine_cameras == v1::REFINEMENT_ON) {
    run(Stage::kRefineCameras, "--refine-cameras on");
  } else {
    run(Stage::kRefineCameras, absl::StrCat("auto: the refined poses of ", sequence.cameras.size(),
                                            " cameras are used when cross-camera consistency says the calibration "
                                            "is off"));
  }
  run(Stage::kGatherSamples, reflectance ? "Samples for the light sweep and texel statistics for clustering"
                                         : "triangle Samples for the light sweep");

  if (sequence.every_frame_lit_own()) {
    // Every frame's lights are known: each Sample holds only its frame's
    // lights (FrameStream), and no configuration is left to choose.
    plan.fixed_configuration = "";  // every light, as each frame has it
    std::string reason = absl::StrCat("lighting is given per frame (scene.frame_lighting names the lights of all ",
                                      sequence.num_frames, " frames)");
    if (!request.configuration.empty()) absl::StrAppend(&reason, "; --config ", request.configuration, " is not used");
    if (!request.candidates.empty()) absl::StrAppend(&reason, "; --candidates are not used");
    skip(Stage::kLightSweep, std::move(reason));
  } else if (!request.configuration.empty()) {
    plan.fixed_configuration = request.configuration;
    skip(Stage::kLightSweep, absl::StrCat("configuration given: ", request.configuration));
  } else if (request.candidates.size() == 1) {
    plan.fixed_configuration = request.candidates[0];
    skip(Stage::kLightSweep, absl::StrCat("one candidate configuration: ", plan.fixed_configuration));
  } else if (!request.candidates.empty()) {
    plan.candidates = request.candidates;
    run(Stage::kLightSweep,
        absl::StrCat(plan.candidates.size(), " candidate configurations (of the scene's ",
                     scene.light_configurations_size(), "): ", absl::StrJoin(plan.candidates, "; ")));
  } else if (scene.light_configurations_size() == 1) {
    plan.fixed_configuration = scene.light_configurations(0).name();
    skip(Stage::kLightSweep, absl::StrCat("one candidate configuration: ", plan.fixed_configuration));
  } else if (scene.light_configurations_size() == 0) {
    plan.fixed_configuration = "";  // all lights on
    skip(Stage::kLightSweep, "no candidate configurations: every light is on");
  } else {
    for (const auto& c : scene.light_configurations()) plan.candidates.push_back(c.name());
    run(Stage::kLightSweep, absl::StrCat(scene.light_configurations_size(), " candidate configurations"));
  }

  const bool swept = plan.Has(Stage::kLightSweep);
  const bool fixed_lights = !sequence.every_frame_lit_own() && !plan.fixed_configuration.empty();
  if (request.refine_lights == v1::REFINEMENT_OFF) {
    skip(Stage::kRefineLights, "--refine-lights off");
  } else if (!reflectance) {
    skip(Stage::kRefineLights, "only the light table was requested");
  } else if (request.refine_lights == v1::REFINEMENT_ON && (swept || fixed_lights)) {
    run(Stage::kRefineLights, "--refine-lights on");
  } else if (request.refine_lights == v1::REFINEMENT_ON) {
    skip(Stage::kRefineLights, "no configuration to refine the lights of (lighting per frame or every light on)");
  } else {
    // Measured (issue #14): on correct lights the refinement still moves
    // them by several sigma: 0.12-0.14 m at 0.023-0.027 m on cli_light_refinement's
    // small scene (z 4.6-5.3), 0.010-0.042 m at ~0.007 m on the actor 8 x 30
    // (z 1.4-6.1). The sigma is already clustered by triangle
    // (clustered_covariance.h; Ceres's own gave 0.015-0.025 m there); the move
    // is a bias of the triangle-Sample model (one centre and face normal per
    // triangle) shared by every triangle, which no covariance shows, so
    // auto cannot tell when to use it. It costs 9-33 s and a second pass 1.
    skip(Stage::kRefineLights,
         "auto: light refinement runs only with --refine-lights on (its uncertainty is not yet calibrated well "
         "enough to decide by itself when the scene's lights are off)");
  }

  if (!reflectance) {
    const char* why = "only the light table was requested";
    for (Stage s : {Stage::kClustering, Stage::kClusterFit, Stage::kSolverComparison, Stage::kNormals, Stage::kTexelPass,
                    Stage::kCorrection, Stage::kCameraErrors, Stage::kWriteAtlases}) {
      skip(s, why);
    }
    return plan;
  }
  run(Stage::kClustering, scene.material_seeds_size() > 0
                              ? absl::StrCat(scene.material_seeds_size(), " material seeds from the scene")
                              : std::string("no material seeds: k chosen automatically"));
  run(Stage::kClusterFit,
      absl::StrCat(request.brdf == "auto" ? "per cluster the model that predicts held-out data best"
                                          : absl::StrCat("one ", request.brdf, " BRDF per cluster"),
                   request.pixel_footprint > 1
                       ? absl::StrCat(", each pixel the mean over ", request.pixel_footprint, " x ",
                                      request.pixel_footprint, " subpixels (--pixel-footprint)")
                       : ""));
  if (request.compare_solvers) {
    run(Stage::kSolverComparison, "Table 6.2: Powell's method beside Levenberg-Marquardt");
  } else {
    skip(Stage::kSolverComparison, "not requested");
  }
  const bool normals_run = request.normals && sequence.lights.size() * static_cast<size_t>(sequence.num_frames) >= 3;
  if (!request.normals) {
    skip(Stage::kNormals, "not requested (--outputs ...,normals)");
  } else if (sequence.lights.size() * static_cast<size_t>(sequence.num_frames) < 3) {
    // A direction has two degrees of freedom and kd a third: fewer than three
    // (light, frame) pairs cannot constrain a texel's normal.
    skip(Stage::kNormals, absl::StrCat("the observations cannot constrain normals: ", sequence.lights.size(),
                                       " light(s) x ", sequence.num_frames, " frame(s), fewer than 3 light directions"));
  } else {
    run(Stage::kNormals, "per-texel normals (tangent space) from every frame's observations, then pass 2 with them");
  }
  run(Stage::kTexelPass, normals_run ? "per-texel kd with the clusters' specular part removed, read with the "
                                       "refined normals"
                                     : "per-texel kd with the clusters' specular part removed");
  if (!request.correction) {
    skip(Stage::kCorrection, "not requested");
  } else if (sequence.num_frames < 2) {
    skip(Stage::kCorrection, "a single frame: the BRDF atlases already fit it");
  } else {
    run(Stage::kCorrection, absl::StrCat("a diffuse correction atlas for each of ", sequence.num_frames, " frames"));
  }
  if (request.camera_errors) {
    run(Stage::kCameraErrors, absl::StrCat("Table 7.1 for ", sequence.cameras.size(), " cameras"));
  } else {
    skip(Stage::kCameraErrors, "not requested");
  }
  if (request.brdf_atlases) {
    run(Stage::kWriteAtlases, "kd, ks, ke, cluster and confidence atlases");
  } else {
    skip(Stage::kWriteAtlases, "not requested");
  }
  return plan;
}

}  // namespace mvbrdf::pipeline
