#include "server/workers_api/sample_key.h"

#include "absl/strings/str_cat.h"
#include "server/store/digest.h"

namespace mvbrdf::server {

std::string TriangleSampleOptions(const v1::SubmitJobRequest& request) {
  const unsigned atlas_size = request.options().atlas_size() == 0 ? kDefaultAtlasSize : request.options().atlas_size();
  return absl::StrCat("triangle-samples/v1;atlas_size=", atlas_size);
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
