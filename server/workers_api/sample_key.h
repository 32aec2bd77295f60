// Where a job's triangle Samples sit in the Sample cache (issue #5,
// docs/service.md "The Sample cache").
//
// A gather task resamples every candidate light of the scene at once, so one
// entry serves every light configuration of the sweep: the configuration part
// of the key is "*". The options part hashes exactly the request fields that
// change the triangle Samples (pipeline::GatherTriangleSamples): the atlas
// size, the sweep frame stride and the scene file inside the bundle. Adding
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
// FittingOptions.atlas_size when the request leaves it 0.
inline constexpr unsigned kDefaultAtlasSize = 512;

// The text whose SHA-256 is SampleKey::options_hash:
// "triangle-samples/v2;atlas_size=N;sweep_frame_stride=S" (N: 512 for 0; S:
// "auto" for 0, which means at most pipeline::kMaxSweepFrames frames), then
// ";scene_path=P" when P is neither empty nor "scene.json".
std::string TriangleSampleOptions(const v1::SubmitJobRequest& request);

// The cache key of the triangle Samples of `bundle_sha256` under `request`.
store::SampleKey TriangleSampleKey(const std::string& bundle_sha256, const v1::SubmitJobRequest& request);

}  // namespace mvbrdf::server

#endif  // MVBRDF_SERVER_WORKERS_API_SAMPLE_KEY_H_
