// Where a job's triangle Samples sit in the Sample cache (issue #5,
// docs/service.md "The Sample cache").
//
// A gather task resamples every candidate light of the scene at once, so one
// entry serves every light configuration of the sweep: the configuration part
// of the key is "*". The options part hashes exactly the request fields that
// change the triangle Samples (pipeline::GatherTriangleSamples): the atlas
// size, the sweep frame stride, the scene file inside the bundle and (issue
// #14) the camera refinement and the Sample rejection options. Adding
// one that changes existing keys means a new "triangle-samples/vN" prefix,
// so old entries are never misread.
#ifndef MVBRDF_SERVER_WORKERS_API_SAMPLE_KEY_H_
#define MVBRDF_SERVER_WORKERS_API_SAMPLE_KEY_H_

#include <string>

#include "mvbrdf/v1/service.pb.h"
#include "server/store/sample_cache.h"

namespace mvbrdf::server {

// Configuration of an entry holding every scene light.
inline constexpr char kAllLightsConfiguration[] = "*";
// SampleKey::sample_level of triangle Samples (texel Samples would be 1).
inline constexpr int kTriangleSampleLevel = 0;
// SampleKey::sample_level of the gather's camera refinement (an encoded
// v1::CalibrationReport) kept beside its triangle Samples (issue #14): a
// gather answered from the cache hands on the cameras its Samples were
// resampled with; without it the entry is a miss.
inline constexpr int kCalibrationLevel = 2;
// FittingOptions.atlas_size when the request leaves it 0.
inline constexpr unsigned kDefaultAtlasSize = 512;

// The text whose SHA-256 is SampleKey::options_hash:
// "triangle-samples/v3;atlas_size=N;sweep_frame_stride=S;refine_cameras=M" (N:
// 512 for 0; S: "auto" for 0, which means at most pipeline::kMaxSweepFrames
// frames; M: auto, on or off), unless M is off
// ";refine_focal=0|1;refine_distortion=0|1;refine_frames=F" (F: "default"
// when unset; then ";refine_photometric=1" when set), then ";edge_margin=E;gradient_rejection=G" (each "default"
// when unset), then ";scene_path=P" when P is neither empty nor "scene.json".
std::string TriangleSampleOptions(const v1::SubmitJobRequest& request);

// The cache key of the triangle Samples of `bundle_sha256` under `request`.
store::SampleKey TriangleSampleKey(const std::string& bundle_sha256, const v1::SubmitJobRequest& request);
// The key of the camera refinement beside them (kCalibrationLevel).
store::SampleKey CalibrationKey(const std::string& bundle_sha256, const v1::SubmitJobRequest& request);

}  // namespace mvbrdf::server

#endif  // MVBRDF_SERVER_WORKERS_API_SAMPLE_KEY_H_
