#include "server/workers_api/sample_key.h"

#include "absl/strings/str_cat.h"
#include "server/store/digest.h"

namespace mvbrdf::server {

std::string TriangleSampleOptions(const v1::SubmitJobRequest& request) {
  const v1::FittingOptions& options = request.options();
  const unsigned atlas_size = options.atlas_size() == 0 ? kDefaultAtlasSize : options.atlas_size();
  // v2: stride 0 means "automatic" (at most pipeline::kMaxSweepFrames frames),
  // no longer "every frame", so it is always named and v1 entries are never read.
  // v3 (issue #14): the camera refinement resamples with other cameras, and
  // rejected observations change the Samples.
  std::string text = absl::StrCat(
      "triangle-samples/v3;atlas_size=", atlas_size, ";sweep_frame_stride=",
      options.sweep_frame_stride() == 0 ? std::string("auto") : absl::StrCat(options.sweep_frame_stride()));
  const v1::Refinement mode = options.refine_cameras();
  absl::StrAppend(&text, ";refine_cameras=",
                  mode == v1::REFINEMENT_OFF  ? "off"
                  : mode == v1::REFINEMENT_ON ? "on"
                                              : "auto");
  if (mode != v1::REFINEMENT_OFF) {
    absl::StrAppend(&text, ";refine_focal=", options.refine_focal() ? 1 : 0,
                    ";refine_distortion=", options.refine_distortion() ? 1 : 0, ";refine_frames=",
                    options.has_refine_frames() ? absl::StrCat(options.refine_frames()) : std::string("default"));
    // Only when set, so that the keys of earlier entries stay what they were.
    if (options.refine_photometric()) absl::StrAppend(&text, ";refine_photometric=1");
  }
  absl::StrAppend(
      &text, ";edge_margin=", options.has_edge_margin_pixels() ? absl::StrCat(options.edge_margin_pixels()) : "default",
      ";gradient_rejection=",
      options.has_gradient_rejection() ? absl::StrCat(options.gradient_rejection()) : "default");
  // Empty and "scene.json" name the same file (BundleArea::UnpackedScene).
  if (!request.scene_path().empty() && request.scene_path() != "scene.json") {
    absl::StrAppend(&text, ";scene_path=", request.scene_path());
  }
  return text;
}

store::SampleKey TriangleSampleKey(const std::string& bundle_sha256, const v1::SubmitJobRequest& request) {
  store::SampleKey key;
  key.sequence_hash = bundle_sha256;
  key.configuration = kAllLightsConfiguration;
  key.sample_level = kTriangleSampleLevel;
  key.options_hash = store::Sha256Hex(TriangleSampleOptions(request));
  return key;
}

}  // namespace mvbrdf::server

namespace mvbrdf::server {

store::SampleKey CalibrationKey(const std::string& bundle_sha256, const v1::SubmitJobRequest& request) {
  store::SampleKey key = TriangleSampleKey(bundle_sha256, request);
  key.sample_level = kCalibrationLevel;
  return key;
}

}  // namespace mvbrdf::server
