// Per texel, the illumination sum G = sum over its observations of
// sum_k I_k g_k under a light configuration, which the clustering divides the
// texel's reflectance sum by (its albedo estimate sum r / G). The
// configuration is chosen only after the gathering pass (the light sweep
// runs on the same pass's triangle Samples), so the pass keeps what any
// configuration the reconstruction may choose needs, whichever is smaller:
//  - per light: sum_obs g_k, one float per texel and light (texels x L;
//    1 GiB at a 1024² atlas with 256 lights), or
//  - per configuration: sum_obs sum_{k in mask} I_k g_k, three doubles per
//    texel and configuration (the scene's configurations and "all lights").
// Both give G to rounding (the per-light sums are float, the per-configuration
// ones double).
#ifndef MVBRDF_CORE_PIPELINE_TEXEL_ILLUMINATION_H_
#define MVBRDF_CORE_PIPELINE_TEXEL_ILLUMINATION_H_

#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "absl/status/statusor.h"
#include "core/samples/assemble.h"
#include "core/samples/sample_set.h"

namespace mvbrdf::pipeline {

class TexelIllumination {
 public:
  enum class Layout { kPerLight, kPerConfiguration };

  // Bytes per texel of each layout, and the one chosen (the smaller; per
  // light on a tie).
  static size_t BytesPerTexel(Layout layout, size_t num_lights, size_t num_masks);
  static Layout ChooseLayout(size_t num_lights, size_t num_masks);

  TexelIllumination() = default;
  // `intensity`: I_k per light; `masks`: the configurations Of() may be asked
  // for. `layout`: forced (tests), else ChooseLayout.
  TexelIllumination(size_t num_texels, std::vector<glm::vec3> intensity, std::vector<samples::LightMask> masks);
  TexelIllumination(size_t num_texels, std::vector<glm::vec3> intensity, std::vector<samples::LightMask> masks,
                    Layout layout);

  // One observation of `texel` (its terms' g). `own`: from a frame with its
  // own lights (samples::LightSelection), whose terms count under every
  // configuration.
  // Add of distinct texels may run on threads of their own once ReserveOwn
  // has run (if any observation is own-lit).
  void Add(uint32_t texel, const samples::LightTerms& terms, bool own = false);
  // Allocates the own-lit sums, which Add otherwise allocates on first use.
  void ReserveOwn() {
    if (own_.empty()) own_.assign(num_texels_, glm::dvec3(0.0));
  }
  // G of `texel` under `mask` (plus the observations of frames with their
  // own lights, under all of their lights); INTERNAL when `mask` is none of the masks
  // given (per-configuration layout).
  absl::StatusOr<glm::dvec3> Of(uint32_t texel, const samples::LightMask& mask) const;

  Layout layout() const { return layout_; }
  size_t MemoryBytes() const {
    return per_light_.size() * sizeof(float) + (per_mask_.size() + own_.size()) * sizeof(glm::dvec3);
  }

 private:
  Layout layout_ = Layout::kPerLight;
  size_t num_texels_ = 0;
  size_t num_lights_ = 0;
  std::vector<glm::vec3> intensity_;
  std::vector<samples::LightMask> masks_;
  std::vector<float> per_light_;      // texel * L + k: sum_obs g_k
  std::vector<glm::dvec3> per_mask_;  // texel * masks + m: sum_obs sum_{k in m} I_k g_k
  std::vector<glm::dvec3> own_;       // per texel: sum_obs sum_k I_k g_k over own-lit frames (allocated on use)
  // Per light: the masks that hold it (per-configuration layout).
  std::vector<std::vector<uint32_t>> masks_of_light_;
};

}  // namespace mvbrdf::pipeline

#endif  // MVBRDF_CORE_PIPELINE_TEXEL_ILLUMINATION_H_
