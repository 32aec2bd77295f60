// Per-texel tangents of an atlas in one frame (issue #18): the interpolated
// vertex tangent (scene/tangent_frames.h) at every covered texel centre, so
// that a tangent-space normal atlas can be read where the reconstruction
// reads its Samples (the geometry atlas's interpolated normals).
#ifndef MVBRDF_CORE_ATLAS_TEXEL_TANGENTS_H_
#define MVBRDF_CORE_ATLAS_TEXEL_TANGENTS_H_

#include <glm/glm.hpp>
#include <vector>

#include "core/atlas/atlas.h"
#include "core/scene/mesh.h"

namespace mvbrdf::atlas {

class TexelTangents {
 public:
  // Locates every texel centre in its triangle (atlas.triangle_id) once.
  explicit TexelTangents(const Atlas& atlas);
  // Per texel (row * size + column): the interpolated tangent (xyz, w the
  // handedness) of the pose `file_positions` (one per file vertex), with the
  // vertex normals the resampler uses (scene::ComputeFileVertexNormals); 0
  // where no triangle covers the texel. Any thread; const.
  std::vector<glm::vec4> Compute(const scene::FramePositions& file_positions) const;

 private:
  const Atlas& atlas_;
  std::vector<int32_t> triangle_;       // per texel, -1: uncovered
  std::vector<glm::vec3> barycentric_;  // per texel
};

}  // namespace mvbrdf::atlas

#endif  // MVBRDF_CORE_ATLAS_TEXEL_TANGENTS_H_
