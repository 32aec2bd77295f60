#include "core/brdf/model.h"
#include "core/pipeline/job_options.h"

#include <cmath>
#include <cstdint>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/samples/assemble.h"

namespace mvbrdf::pipeline {
namespace {

// INVALID_ARGUMENT "FIELD: must be EXPECTED, got VALUE" unless value is finite and >= 0.
absl::Status CheckFiniteNonNegative(const char* field, double value, const char* expected) {
  if (std::isfinite(value) && value >= 0.0) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(field, ": must be ", expected, ", got ", value));
}

// Upper bounds of the request's counts. The proto fields are unsigned 32-bit
// and the pipeline's are int: without a bound 4294967295 would become -1.
// Fits converge in tens of iterations (the thesis uses 100).
constexpr uint32_t kMaxIterations = 100000;
// No atlas is wider than 16384 texels, so more dilation rings change nothing.
constexpr uint32_t kMaxGrowIterations = 16384;
constexpr uint32_t kMaxFrameStride = INT32_MAX;

absl::Status OutOfRange(const char* field, uint64_t got, uint64_t lo, uint64_t hi) {
  return absl::InvalidArgumentError(absl::StrCat(field, ": must be in [", lo, ", ", hi, "], got ", got));
}

}  // namespace

absl::StatusOr<ReconstructOptions> ReconstructOptionsFor(const v1::SubmitJobRequest& request, int threads) {
  ReconstructOptions o;
  RunRequest& run = o.request;
  if (request.outputs_size() > 0) {
    run.light_table = run.brdf_atlases = run.correction = run.camera_errors = false;
    for (int i = 0; i < request.outputs_size(); ++i) {
      switch (request.outputs(i)) {
        case v1::OUTPUT_LIGHT_TABLE:
          run.light_table = true;
          break;
        case v1::OUTPUT_BRDF_ATLASES:
          run.brdf_atlases = true;
          break;
        case v1::OUTPUT_CORRECTION:
          run.correction = true;
          break;
        case v1::OUTPUT_CAMERA_ERRORS:
          run.camera_errors = true;
          break;
        case v1::OUTPUT_NORMALS:
          run.normals = true;
          break;
        default:
          return absl::InvalidArgumentError(
              absl::StrCat("outputs[", i, "]: unknown output ", static_cast<int>(request.outputs(i))));
      }
    }
  }
  run.compare_solvers = request.options().compare_solvers();
  // Checked against the scene by pipeline::MakePlan (one candidate is a
  // known configuration there), so that --direct and the service agree.
  run.configuration = request.configuration();
  run.candidates.assign(request.configurations().begin(), request.configurations().end());
  const v1::FittingOptions& f = request.options();
  if (f.atlas_size() != 0) {
    if (f.atlas_size() < 16 || f.atlas_size() > 16384) {
      return absl::InvalidArgumentError(
          absl::StrCat("options.atlas_size: must be in [16, 16384], got ", f.atlas_size()));
    }
    o.atlas.size = static_cast<int>(f.atlas_size());
  }
  if (f.max_iterations() != 0) {
    if (f.max_iterations() > kMaxIterations) {
      return OutOfRange("options.max_iterations", f.max_iterations(), 1, kMaxIterations);
    }
    o.fit.max_iterations = static_cast<int>(f.max_iterations());
  }
  if (f.max_cluster_samples() != 0) {
    if (f.max_cluster_samples() < 10) {
      return absl::InvalidArgumentError(
          absl::StrCat("options.max_cluster_samples: must be >= 10, got ", f.max_cluster_samples()));
    }
    o.max_cluster_samples = static_cast<size_t>(f.max_cluster_samples());
  }
  if (f.sweep_frame_stride() != 0) {
    if (f.sweep_frame_stride() > kMaxFrameStride) {
      return OutOfRange("options.sweep_frame_stride", f.sweep_frame_stride(), 1, kMaxFrameStride);
    }
    o.sweep_frame_stride = static_cast<int>(f.sweep_frame_stride());
  }
  if (f.has_grow_iterations()) {
    if (f.grow_iterations() > kMaxGrowIterations) {
      return OutOfRange("options.grow_iterations", f.grow_iterations(), 0, kMaxGrowIterations);
    }
    o.grow_iterations = static_cast<int>(f.grow_iterations());
  }
  // Resampling (issue #13 item 9): the occlusion test's depth tolerance and
  // the grazing margin.
  if (f.has_depth_tolerance_absolute() && f.has_depth_tolerance_relative()) {
    return absl::InvalidArgumentError(
        "options.depth_tolerance_absolute, depth_tolerance_relative: give at most one, got both");
  }
  if (f.has_depth_tolerance_absolute()) {
    MVBRDF_RETURN_IF_ERROR(CheckFiniteNonNegative("options.depth_tolerance_absolute", f.depth_tolerance_absolute(),
                                                  "a finite number >= 0 (world units)"));
    o.resampler.absolute_depth_tolerance = f.depth_tolerance_absolute();
    o.resampler.relative_depth_tolerance = 0.0;
  }
  if (f.has_depth_tolerance_relative()) {
    MVBRDF_RETURN_IF_ERROR(CheckFiniteNonNegative("options.depth_tolerance_relative", f.depth_tolerance_relative(),
                                                  "a finite number >= 0 (a fraction of the depth)"));
    o.resampler.relative_depth_tolerance = f.depth_tolerance_relative();
  }
  if (f.has_grazing_margin_degrees()) {
    const double v = f.grazing_margin_degrees();
    if (!(v >= 0.0 && v < 90.0)) {
      return absl::InvalidArgumentError(
          absl::StrCat("options.grazing_margin_degrees: must be in [0, 90) degrees, got ", v));
    }
    o.resampler.grazing_margin_deg = v;
  }
  if (f.has_kd_prior_strength()) {
    MVBRDF_RETURN_IF_ERROR(
        CheckFiniteNonNegative("options.kd_prior_strength", f.kd_prior_strength(), "finite and >= 0"));
    o.kd_prior_weight = f.kd_prior_strength();
  }
  // Issue #14 (robustness).
  o.refine_cameras = f.refine_cameras();
  o.refine_lights = f.refine_lights();
  run.refine_cameras = f.refine_cameras();
  run.refine_lights = f.refine_lights();
  if (!v1::Refinement_IsValid(f.refine_cameras()) || !v1::Refinement_IsValid(f.refine_lights())) {
    return absl::InvalidArgumentError("options.refine_cameras, refine_lights: expected AUTO, ON or OFF");
  }
  if (f.has_refine_focal()) o.refine_focal = f.refine_focal();
  if (f.has_refine_distortion()) o.refine_distortion = f.refine_distortion();
  if (f.has_refine_photometric()) o.refine_photometric = f.refine_photometric();
  if (f.has_refine_frames()) {
    if (f.refine_frames() < 1 || f.refine_frames() > 10000) {
      return OutOfRange("options.refine_frames", f.refine_frames(), 1, 10000);
    }
    o.refine_frames = static_cast<int>(f.refine_frames());
  }
  if (f.has_robust()) o.robust = f.robust();
  // The service's sweep tasks fit with o.fit and o.diffuse directly.
  o.fit.robust = o.diffuse.robust = RobustFitOf(o.robust);
  if (f.has_edge_margin_pixels()) {
    MVBRDF_RETURN_IF_ERROR(CheckFiniteNonNegative("options.edge_margin_pixels", f.edge_margin_pixels(),
                                                  "a finite number >= 0 (pixels)"));
    o.edge_margin_pixels = f.edge_margin_pixels();
  }
  if (f.has_gradient_rejection()) {
    MVBRDF_RETURN_IF_ERROR(
        CheckFiniteNonNegative("options.gradient_rejection", f.gradient_rejection(), "a finite number >= 0"));
    o.gradient_rejection = f.gradient_rejection();
  }
  o.resampler.edge_margin_pixels = o.edge_margin_pixels;
  o.resampler.gradient_rejection = o.gradient_rejection;
  if (!v1::SweepCriterion_IsValid(f.sweep_criterion())) {
    return absl::InvalidArgumentError("options.sweep_criterion: expected HELD_OUT or E_D");
  }
  o.sweep_criterion = f.sweep_criterion();
  if (f.brdf() == "auto") {
    o.brdf_auto = true;
  } else if (!f.brdf().empty()) {
    absl::StatusOr<brdf::Model> model = brdf::ParseModel(f.brdf());
    if (!model.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("options.brdf: expected phong, blinn-phong, ggx or auto, got \"", f.brdf(), "\""));
    }
    o.brdf_model = *model;
  }
  if (f.has_pixel_footprint()) {
    if (f.pixel_footprint() < 1 || f.pixel_footprint() > static_cast<uint32_t>(samples::kMaxPixelFootprint)) {
      return OutOfRange("options.pixel_footprint", f.pixel_footprint(), 1, samples::kMaxPixelFootprint);
    }
    o.pixel_footprint = static_cast<int>(f.pixel_footprint());
  }
  if (f.has_cluster_smoothness()) {
    MVBRDF_RETURN_IF_ERROR(
        CheckFiniteNonNegative("options.cluster_smoothness", f.cluster_smoothness(), "a finite number >= 0"));
    o.cluster_smoothness = f.cluster_smoothness();
  }
  if (absl::Status s = o.fit.Check(); !s.ok()) return absl::InvalidArgumentError(absl::StrCat("options.", s.message()));
  o.threads = threads;
  // result.json's record of the request, with the fitting options as
  // resolved (defaults filled in, the depth tolerance that applies).
  v1::RunOptions& r = o.run_options;
  r.mutable_outputs()->CopyFrom(request.outputs());
  r.mutable_configurations()->CopyFrom(request.configurations());
  r.set_configuration(request.configuration());
  v1::FittingOptions& fit = *r.mutable_fitting();
  fit.set_atlas_size(static_cast<uint32_t>(o.atlas.size));
  fit.set_max_iterations(static_cast<uint32_t>(o.fit.max_iterations));
  fit.set_max_cluster_samples(o.max_cluster_samples);
  fit.set_compare_solvers(run.compare_solvers);
  fit.set_sweep_frame_stride(static_cast<uint32_t>(o.sweep_frame_stride));  // 0: automatic (plan says the frames)
  fit.set_grow_iterations(static_cast<uint32_t>(o.grow_iterations));
  if (o.resampler.relative_depth_tolerance > 0.0 || o.resampler.absolute_depth_tolerance <= 0.0) {
    fit.set_depth_tolerance_relative(o.resampler.relative_depth_tolerance);
  } else {
    fit.set_depth_tolerance_absolute(o.resampler.absolute_depth_tolerance);
  }
  fit.set_grazing_margin_degrees(o.resampler.grazing_margin_deg);
  fit.set_kd_prior_strength(o.kd_prior_weight);
  fit.set_refine_cameras(o.refine_cameras);
  fit.set_refine_focal(o.refine_focal);
  fit.set_refine_distortion(o.refine_distortion);
  fit.set_refine_photometric(o.refine_photometric);
  fit.set_refine_frames(static_cast<uint32_t>(o.refine_frames));
  fit.set_refine_lights(o.refine_lights);
  fit.set_robust(o.robust);
  fit.set_edge_margin_pixels(o.edge_margin_pixels);
  fit.set_gradient_rejection(o.gradient_rejection);
  fit.set_sweep_criterion(o.sweep_criterion);
  fit.set_cluster_smoothness(o.cluster_smoothness);
  fit.set_pixel_footprint(static_cast<uint32_t>(o.pixel_footprint));
  run.pixel_footprint = o.pixel_footprint;
  fit.set_brdf(o.brdf_auto ? "auto" : brdf::ModelName(o.brdf_model));
  run.brdf = fit.brdf();
  return o;
}

}  // namespace mvbrdf::pipeline
