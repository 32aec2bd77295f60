// The plan's `normals` stage (issue #18): per-texel normals refined from the
// video, between the cluster fits and pass 2. Streams every frame once for the
// closed-form start and once per Gauss-Newton step (core/fit/texel_normal_fit.h
// has the model), reading the cluster's BRDF as pass 2 does
// (texel_shading.h). Pass 2 then reads its Samples with the refined normals
// (FrameStream::UseNormals), so kd, the correction atlases and Table 7.1 see
// them.
#ifndef MVBRDF_CORE_PIPELINE_NORMAL_STAGE_H_
#define MVBRDF_CORE_PIPELINE_NORMAL_STAGE_H_

#include <filesystem>
#include <functional>
#include <glm/glm.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/atlas/atlas.h"
#include "core/fit/phong_fit.h"
#include "core/fit/texel_normal_fit.h"
#include "core/gl/egl_context.h"
#include "core/pipeline/resampled_atlas_cache.h"
#include "core/pipeline/shadow_atlas_cache.h"
#include "core/pipeline/texel_shading.h"
#include "core/resample/resampler.h"
#include "core/samples/assemble.h"
#include "core/scene/sequence.h"

namespace mvbrdf::pipeline {

struct NormalStageInput {
  const scene::Sequence* sequence = nullptr;
  gl::EglContext* context = nullptr;
  const atlas::Atlas* atlas = nullptr;
  resample::ResamplerOptions resampler;
  ShadowAtlasCache* shadows = nullptr;  // pass 1's, may be null
  ResampledAtlasCache* atlases = nullptr;  // pass 1's, may be null
  samples::AssembleOptions assemble;
  const std::vector<int32_t>* texel_cluster = nullptr;  // per texel, -1: none
  std::vector<ClusterShading> clusters;
  std::vector<glm::dvec3> residual_scale;  // per cluster, the robust loss's sigma (0: least squares)
  fit::RobustOptions robust;
  const samples::LightSelection* selection = nullptr;
  std::vector<glm::vec3> intensity;  // per light
  fit::TexelNormalOptions options;
  std::function<void(const char* stage, int frame, int frames)> progress;
  std::function<bool()> cancelled;  // asked on the calling thread only
};

struct TexelNormals {
  std::vector<glm::vec3> m;      // per texel, tangent space (0, 0, 1): the mesh's
  std::vector<float> sigma_deg;  // per refined texel (-1 where no Gauss-Newton step succeeded), else -1
  std::vector<uint8_t> flags;    // fit::TexelNormalFlag; 0 and m != z: refined
  std::vector<uint8_t> refined;  // 1 where m is the refined normal
  uint64_t texels = 0;           // texels of a cluster
  uint64_t refined_texels = 0, few_observations = 0, coplanar = 0, tilt_limit = 0, not_significant = 0;
  uint64_t cluster_no_better = 0;  // texels of clusters the refined normals did not fit better (kNormalClusterNoBetter)
  int passes = 0;
  double median_tilt_deg = 0.0, median_sigma_deg = 0.0;
};

absl::StatusOr<TexelNormals> RefineTexelNormals(const NormalStageInput& input);

// A texel flag beside fit::TexelNormalFlag: its cluster's BRDF, fitted again
// with the refined normals' Samples, explained them no better than the mesh
// normals' fit explained its own (reconstruct_stage.cc), so the cluster keeps
// the mesh's normals and its first fit.
inline constexpr uint8_t kNormalClusterNoBetter = 16;

// Texels with a flag get the mesh normal (m = z, sigma -1); `refined` and
// the counts and medians follow the flags.
void CountNormals(const std::vector<int32_t>& texel_cluster, TexelNormals* normals);

// A tangent-space normal atlas (CV_32FC3, x y z in R G B, z <= 0 where no
// normal is: the flat one) in the usual 8-bit linear normal-map encoding
// (m + 1) / 2, as glTF's normalTexture reads it; CV_8UC3 in OpenCV's B, G, R
// order (cv::imwrite, cv::imencode).
cv::Mat EncodeNormalMap(const cv::Mat& tangent_normals);

// Writes dir/normal.exr (RGB: tangent-space m per texel of a cluster, grown
// `grow_iterations` texels past the charts like the other atlases),
// dir/normal.png (the usual 8-bit linear normal-map encoding (m + 1) / 2, as
// glTF's normalTexture reads it) and dir/normal_sigma.exr (the refined
// normal's standard deviation in degrees, -1 where the mesh's is kept).
absl::Status WriteNormalAtlases(const TexelNormals& normals, const std::vector<int32_t>& texel_cluster, int size,
                                int grow_iterations, const std::filesystem::path& dir);

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_NORMAL_STAGE_H_
