// The flags that describe a job (what to compute and how), shared by
// `mvbrdf run` and `mvbrdf submit`, and the v1::SubmitJobRequest they make.
#ifndef MVBRDF_CLIENT_JOB_FLAGS_H_
#define MVBRDF_CLIENT_JOB_FLAGS_H_

#include <string>

#include "absl/status/status.h"
#include "client/flags.h"
#include "mvbrdf/v1/service.pb.h"

namespace mvbrdf::client {

struct JobFlags {
  std::string outputs = "light,brdf,correction,errors";
  std::string configuration;   // --config: a known configuration, no sweep
  std::string candidates;      // --candidates: comma-separated configurations to sweep
  bool no_powell = false;
  int atlas = 512;
  int cluster_samples = 100000;
  int max_iterations = 100;
  int sweep_frame_stride = 0;  // 0: automatic (pipeline::SweepFrameStride)
  int grow = 2;
  // Resampling: empty = unset (the worker's default, relative 0.001).
  std::string depth_tolerance_absolute;
  std::string depth_tolerance_relative;
  double grazing_margin = 5.0;
  // Pseudo-observations of the cluster's kd per texel, at the data's typical
  // illumination (fit::DiffuseOptions::prior_weight).
  double kd_prior_strength = 1.0;
  // Issue #14 (robustness). Empty numbers: unset, the pipeline's default
  // (pipeline::ReconstructOptions).
  std::string refine_cameras = "auto";  // auto|on|off
  bool refine_focal = false;
  bool refine_distortion = false;
  bool refine_photometric = false;
  std::string refine_frames;
  std::string refine_lights = "auto";   // auto|on|off
  std::string robust = "on";            // on|off
  std::string edge_margin;
  std::string pixel_footprint;
  std::string gradient_rejection;
  std::string sweep_criterion = "held-out";  // held-out|e-d
  std::string brdf = "phong";                 // phong|blinn-phong|ggx
  std::string cluster_smoothness;
};

void AddJobFlags(FlagParser& flags, JobFlags* job);

// INVALID_ARGUMENT naming the flag for a value out of range or an unknown
// output. Sets everything but bundle_sha256 and scene_path.
absl::Status ToSubmitRequest(const JobFlags& job, v1::SubmitJobRequest* request);

}  // namespace mvbrdf::client

#endif  // MVBRDF_CLIENT_JOB_FLAGS_H_
