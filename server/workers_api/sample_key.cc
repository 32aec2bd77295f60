#include "server/workers_api/sample_key.h"

#include "absl/strings/str_cat.h"
#include "server/store/digest.h"

namespace mvbrdf::server {

std::string TriangleSampleOptions(const v1::SubmitJobRequest& request) {
  const v1::FittingOptions& options = request.options();
  const unsigned atlas_size = options.atlas_size() == 0 ? kDefaultAtlasSize : options.atlas_size();
  // v2: stride 0 means "automatic" (at most pipeline::kMaxSweepFrames frames),
  // no longer "every frame", so it is always named and v1 entries are never read.
  std::string text = absl::StrCat("triangle-samples/v2;atlas_size=", atlas_size, ";sweep_frame_stride=",
                                  options.sweep_frame_stride() == 0 ? std::string("auto")
                                                                    : absl::StrCat(options.sweep_frame_stride()));
  // Issue #14: the resampler's reliability criteria change the Samples
  // (named only when set, so that earlier entries stay valid).
  if (options.edge_margin_pixels() > 0.0) absl::StrAppend(&text, ";edge_margin=", options.edge_margin_pixels());
  if (options.gradient_rejection() > 0.0) absl::StrAppend(&text, ";gradient_rejection=", options.gradient_rejection());
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
