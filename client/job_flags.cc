#include "client/job_flags.h"

#include <cmath>
#include <tuple>

#include "absl/status/statusor.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "core/base/status_macros.h"
#include "core/brdf/model.h"
#include "core/samples/assemble.h"

namespace mvbrdf::client {

void AddJobFlags(FlagParser& flags, JobFlags* job) {
  flags.AddString("--outputs LIST", &job->outputs, "comma-separated: light (Table 6.1), brdf (atlases), correction, errors, normals (per-texel "
                 "normals refined from the video, atlases/normal.exr; off by default: extra passes over the frames)");
  flags.AddString("--config NAME", &job->configuration, "a known light configuration: skips the sweep");
  flags.AddString("--candidates LIST", &job->candidates,
                  "configurations to sweep, separated by ';' (default: every configuration of the scene)");
  flags.AddBool("--no-powell", &job->no_powell, "skip the Powell comparison (Table 6.2)");
  flags.AddInt("--atlas N", &job->atlas, "atlas resolution in texels per side");
  flags.AddInt("--cluster-samples N", &job->cluster_samples, "Samples per cluster fit, at most");
  flags.AddInt("--max-iterations N", &job->max_iterations, "iterations of each BRDF fit, at most");
  flags.AddInt("--sweep-frame-stride N", &job->sweep_frame_stride, "use every n-th frame for the light sweep (0: every frame up to 64 frames, else at most 64)");
  flags.AddInt("--grow N", &job->grow, "dilation iterations of the written atlases");
  flags.AddString("--depth-tolerance-absolute DISTANCE", &job->depth_tolerance_absolute,
                  "occlusion test: a texel is hidden when it lies farther than the camera's depth map by more than "
                  "this, in world units (default: relative 0.001; at most one of the two)");
  flags.AddString("--depth-tolerance-relative FRACTION", &job->depth_tolerance_relative,
                  "occlusion test as a fraction of the texel's depth (default: 0.001)");
  flags.AddDouble("--grazing-margin DEGREES", &job->grazing_margin,
                  "texels seen within this angle of edge-on are not observations, degrees in [0, 90)");
  flags.AddDouble("--kd-prior-strength X", &job->kd_prior_strength,
                  "per-texel kd shrinks towards its cluster's kd with this many pseudo-observations at the data's "
                  "typical illumination (>= 0; 0: plain least squares; relative, so independent of intensity units)");
  flags.AddString("--refine-cameras MODE", &job->refine_cameras,
                  "auto (refine each camera's pose from the video when cross-camera consistency says the "
                  "calibration is off), on or off");
  flags.AddBool("--refine-focal", &job->refine_focal, "camera refinement also refines each camera's focal length");
  flags.AddBool("--refine-distortion", &job->refine_distortion,
                "camera refinement also refines each camera's radial distortion k1");
  flags.AddBool("--refine-photometric", &job->refine_photometric,
                "camera refinement also fits the colour of textured surface points seen by several cameras "
                "(photometric consistency; default: the mesh's silhouettes only, as good on the synthetic actor "
                "at a third of the time)");
  flags.AddString("--refine-frames N", &job->refine_frames, "frames the camera refinement uses (default: 8)");
  flags.AddString("--refine-lights MODE", &job->refine_lights,
                  "on (refine the chosen configuration's light positions and intensities after the sweep), off, "
                  "or auto (for now the same as off: the plan says why)");
  flags.AddString("--robust MODE", &job->robust,
                  "on: robust loss with a scale estimated from the data in the sweep and per-texel kd (the "
                  "cluster fits are least squares either way); off: least squares");
  flags.AddString("--edge-margin PIXELS", &job->edge_margin,
                  "observations this close to a silhouette or depth discontinuity are rejected (0: none)");
  flags.AddString(
      "--gradient-rejection X", &job->gradient_rejection,
      "observations on steep image gradients are rejected: |grad I| x 1 pixel / the local mean of I above X "
      "(unit-free; 0: none)");
  flags.AddString("--sweep-criterion NAME", &job->sweep_criterion,
                  "held-out (kd fitted on some frames, error measured on the others) or e-d (the thesis's E_d)");
  flags.AddString("--brdf MODEL", &job->brdf,
                  "reflectance model fitted per cluster: phong (the thesis's mirror lobe), blinn-phong "
                  "(energy-normalised half-vector lobe), ggx (glTF's metallic-roughness: atlases f0, roughness, "
                  "f90_ratio) or auto (per cluster the model with the lowest error on held-out frames and a held-out "
                  "camera; atlases model.png, parameter_1, parameter_2, and parameter_3 where GGX was picked)");
  flags.AddString("--pixel-footprint N", &job->pixel_footprint,
                  "the cluster fits model each video pixel as the mean over N x N subpixels of its area, as a "
                  "sensor records it (1-4; default 1: the pixel centre, as synth's frames without --pixel-samples)");
  flags.AddString("--cluster-smoothness X", &job->cluster_smoothness,
                  "spatial coherence of the clusters over the surface (0: each texel on its own)");
}

namespace {

absl::StatusOr<v1::Refinement> ParseRefinement(const char* flag, const std::string& text) {
  if (text == "auto") return v1::REFINEMENT_AUTO;
  if (text == "on") return v1::REFINEMENT_ON;
  if (text == "off") return v1::REFINEMENT_OFF;
  return absl::InvalidArgumentError(absl::StrCat(flag, ": expected auto, on or off, got \"", text, "\""));
}

// An optional finite number >= 0 (empty: unset).
absl::Status ParseNonNegative(const char* flag, const std::string& text, const char* unit, double* value,
                              bool* set) {
  *set = false;
  if (text.empty()) return absl::OkStatus();
  if (!absl::SimpleAtod(text, value) || !std::isfinite(*value) || *value < 0.0) {
    return absl::InvalidArgumentError(absl::StrCat(flag, ": must be a finite number >= 0 (", unit, "), got \"",
                                                   text, "\""));
  }
  *set = true;
  return absl::OkStatus();
}

absl::Status SetRobustnessOptions(const JobFlags& job, v1::FittingOptions* o) {
  absl::StatusOr<v1::Refinement> cameras = ParseRefinement("--refine-cameras", job.refine_cameras);
  if (!cameras.ok()) return cameras.status();
  absl::StatusOr<v1::Refinement> lights = ParseRefinement("--refine-lights", job.refine_lights);
  if (!lights.ok()) return lights.status();
  o->set_refine_cameras(*cameras);
  o->set_refine_lights(*lights);
  if (job.refine_focal) o->set_refine_focal(true);
  if (job.refine_distortion) o->set_refine_distortion(true);
  if (job.refine_photometric) o->set_refine_photometric(true);
  if (!job.refine_frames.empty()) {
    uint32_t frames = 0;
    if (!absl::SimpleAtoi(job.refine_frames, &frames) || frames < 1 || frames > 10000) {
      return absl::InvalidArgumentError(
          absl::StrCat("--refine-frames: must be an integer in [1, 10000], got \"", job.refine_frames, "\""));
    }
    o->set_refine_frames(frames);
  }
  if (job.robust == "on") o->set_robust(true);
  else if (job.robust == "off") o->set_robust(false);
  else return absl::InvalidArgumentError(absl::StrCat("--robust: expected on or off, got \"", job.robust, "\""));
  if (job.sweep_criterion == "held-out") o->set_sweep_criterion(v1::SWEEP_CRITERION_HELD_OUT);
  else if (job.sweep_criterion == "e-d") o->set_sweep_criterion(v1::SWEEP_CRITERION_E_D);
  else {
    return absl::InvalidArgumentError(
        absl::StrCat("--sweep-criterion: expected held-out or e-d, got \"", job.sweep_criterion, "\""));
  }
  if (job.brdf == "auto") {
    o->set_brdf("auto");
  } else if (absl::StatusOr<brdf::Model> model = brdf::ParseModel(job.brdf); !model.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--brdf: expected phong, blinn-phong, ggx or auto, got \"", job.brdf, "\""));
  } else if (*model != brdf::Model::kPhong) {
    o->set_brdf(brdf::ModelName(*model));
  }
  double v = 0.0;
  bool set = false;
  MVBRDF_RETURN_IF_ERROR(ParseNonNegative("--edge-margin", job.edge_margin, "pixels", &v, &set));
  if (set) o->set_edge_margin_pixels(v);
  MVBRDF_RETURN_IF_ERROR(ParseNonNegative("--gradient-rejection", job.gradient_rejection, "relative", &v, &set));
  if (set) o->set_gradient_rejection(v);
  MVBRDF_RETURN_IF_ERROR(ParseNonNegative("--cluster-smoothness", job.cluster_smoothness, "relative", &v, &set));
  if (set) o->set_cluster_smoothness(v);
  if (!job.pixel_footprint.empty()) {
    uint32_t n = 0;
    if (!absl::SimpleAtoi(job.pixel_footprint, &n) || n < 1 || n > static_cast<uint32_t>(samples::kMaxPixelFootprint)) {
      return absl::InvalidArgumentError(absl::StrCat("--pixel-footprint: must be an integer in [1, ",
                                                     samples::kMaxPixelFootprint, "], got \"", job.pixel_footprint,
                                                     "\""));
    }
    o->set_pixel_footprint(n);
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status ToSubmitRequest(const JobFlags& job, v1::SubmitJobRequest* request) {
  request->clear_outputs();
  for (absl::string_view part : absl::StrSplit(job.outputs, ',', absl::SkipEmpty())) {
    if (part == "light") request->add_outputs(v1::OUTPUT_LIGHT_TABLE);
    else if (part == "brdf") request->add_outputs(v1::OUTPUT_BRDF_ATLASES);
    else if (part == "correction") request->add_outputs(v1::OUTPUT_CORRECTION);
    else if (part == "errors") request->add_outputs(v1::OUTPUT_CAMERA_ERRORS);
    else if (part == "normals") request->add_outputs(v1::OUTPUT_NORMALS);
    else {
      return absl::InvalidArgumentError(
          absl::StrCat("--outputs: expected light, brdf, correction, errors or normals, got \"", part, "\""));
    }
  }
  if (request->outputs_size() == 0) return absl::InvalidArgumentError("--outputs: name at least one output");
  // Configuration names contain commas ("NE,NW,SE,SW"), so candidates are
  // separated by semicolons.
  // Each is checked against the scene by pipeline::MakePlan (`run`) or the
  // server (`submit`); an empty one ("A;;B", a trailing ';') is a typo here.
  request->clear_configurations();
  if (!job.candidates.empty()) {
    int index = 0;
    for (absl::string_view name : absl::StrSplit(job.candidates, ';')) {
      ++index;
      if (name.empty()) {
        return absl::InvalidArgumentError(absl::StrCat(
            "--candidates: configuration ", index, " is empty (names are separated by ';', e.g. \"C;NE,NW,SE,SW\")"));
      }
      request->add_configurations(std::string(name));
    }
  }
  request->set_configuration(job.configuration);
  if (job.atlas < 16 || job.atlas > 16384) {
    return absl::InvalidArgumentError(absl::StrCat("--atlas: must be in [16, 16384], got ", job.atlas));
  }
  if (job.cluster_samples < 10) {
    return absl::InvalidArgumentError(absl::StrCat("--cluster-samples: must be >= 10, got ", job.cluster_samples));
  }
  // The request's bound (core/pipeline/job_options.cc) with the flag's name: above it
  // the error named options.max_iterations and exited 3.
  if (job.max_iterations < 1 || job.max_iterations > 100000) {
    return absl::InvalidArgumentError(
        absl::StrCat("--max-iterations: must be in [1, 100000], got ", job.max_iterations));
  }
  if (job.sweep_frame_stride < 0) {
    return absl::InvalidArgumentError(absl::StrCat("--sweep-frame-stride: must be >= 0, got ", job.sweep_frame_stride));
  }
  if (job.grow < 0 || job.grow > 1000) {
    return absl::InvalidArgumentError(absl::StrCat("--grow: must be in [0, 1000], got ", job.grow));
  }
  if (!std::isfinite(job.kd_prior_strength) || job.kd_prior_strength < 0.0) {
    return absl::InvalidArgumentError(
        absl::StrCat("--kd-prior-strength: must be finite and >= 0, got ", job.kd_prior_strength));
  }
  v1::FittingOptions* o = request->mutable_options();
  if (!job.depth_tolerance_absolute.empty() && !job.depth_tolerance_relative.empty()) {
    return absl::InvalidArgumentError(
        "--depth-tolerance-absolute, --depth-tolerance-relative: give at most one (absolute in world units, or "
        "relative to the depth)");
  }
  for (const auto& [flag, text, unit] :
       {std::tuple<const char*, const std::string*, const char*>{"--depth-tolerance-absolute",
                                                                 &job.depth_tolerance_absolute, "world units"},
        {"--depth-tolerance-relative", &job.depth_tolerance_relative, "a fraction of the depth"}}) {
    if (text->empty()) continue;
    double v = 0.0;
    if (!absl::SimpleAtod(*text, &v) || !std::isfinite(v) || v < 0.0) {
      return absl::InvalidArgumentError(
          absl::StrCat(flag, ": must be a finite number >= 0 (", unit, "), got \"", *text, "\""));
    }
    if (text == &job.depth_tolerance_absolute) o->set_depth_tolerance_absolute(v);
    else o->set_depth_tolerance_relative(v);
  }
  if (!(job.grazing_margin >= 0.0 && job.grazing_margin < 90.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--grazing-margin: must be in [0, 90) degrees, got ", job.grazing_margin));
  }
  o->set_grazing_margin_degrees(job.grazing_margin);
  o->set_atlas_size(static_cast<uint32_t>(job.atlas));
  o->set_max_cluster_samples(static_cast<uint64_t>(job.cluster_samples));
  o->set_max_iterations(static_cast<uint32_t>(job.max_iterations));
  o->set_compare_solvers(!job.no_powell);
  o->set_sweep_frame_stride(static_cast<uint32_t>(job.sweep_frame_stride));
  o->set_grow_iterations(static_cast<uint32_t>(job.grow));
  o->set_kd_prior_strength(job.kd_prior_strength);
  return SetRobustnessOptions(job, o);
}

}  // namespace mvbrdf::client
