// Tangent frames of a mesh with UVs (issue #18): the basis a tangent-space
// normal map is read in, the one glTF 2.0's TANGENT attribute carries.
//
// Per render vertex, the tangent t is the direction of increasing u on the
// surface, the bitangent that of increasing v: per triangle with corners
// p0, p1, p2 and UVs w0, w1, w2 (e1 = p1 - p0, e2 = p2 - p0, (du1, dv1) =
// w1 - w0, (du2, dv2) = w2 - w0, det = du1 dv2 - du2 dv1)
//   dP/du = (e1 dv2 - e2 dv1) / det,   dP/dv = (e2 du1 - e1 du2) / det,
// each normalised and weighted by the corner's angle (as MikkTSpace does),
// summed over the vertex's triangles, then t made orthogonal to the vertex
// normal n (Gram-Schmidt) and w = sign((n x t) . sum dP/dv) recording the
// handedness: b = w (n x t). A fragment (or texel) interpolates t and w,
// orthogonalises t against its interpolated normal N again, T = that,
// B = w (N x T), and reads a tangent-space normal m as
//   n' = m.x T + m.y B + m.z N
// (glTF 2.0's normalTexture convention, +Y the direction of increasing v).
//
// Computed per frame from the posed positions, the tangents are (up to the
// normalisation, angle weights and Gram-Schmidt: exactly for locally rigid
// motion) the rest pose's carried by the deformation: dP/du is a fixed
// combination of the triangle's edges, so a normal map stays valid in every
// frame.
#ifndef MVBRDF_CORE_SCENE_TANGENT_FRAMES_H_
#define MVBRDF_CORE_SCENE_TANGENT_FRAMES_H_

#include <glm/glm.hpp>
#include <vector>

namespace mvbrdf::scene {

// Per render vertex: xyz the unit tangent (orthogonal to normals[i]), w = +1
// or -1 (handedness, see above). A vertex whose triangles have degenerate UVs
// or zero area gets some unit vector orthogonal to its normal and w = 1.
// `uvs` one per position (the mesh's render vertices), `normals` unit.
std::vector<glm::vec4> VertexTangents(const std::vector<glm::uvec3>& triangles, const std::vector<glm::vec3>& positions,
                                      const std::vector<glm::vec3>& normals, const std::vector<glm::vec2>& uvs);

// The orthonormal frame of an interpolated tangent `t` (w: handedness) at
// unit normal `n`, as a fragment builds it (above): T, B with n.
struct TangentFrame {
  glm::vec3 t{1.0f, 0.0f, 0.0f};
  glm::vec3 b{0.0f, 1.0f, 0.0f};
  glm::vec3 n{0.0f, 0.0f, 1.0f};
  // World from tangent space and back.
  glm::vec3 ToWorld(const glm::vec3& m) const { return m.x * t + m.y * b + m.z * n; }
  glm::vec3 ToTangent(const glm::vec3& d) const { return {glm::dot(d, t), glm::dot(d, b), glm::dot(d, n)}; }
};
TangentFrame FrameAt(const glm::vec4& interpolated_tangent, const glm::vec3& unit_normal);

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_TANGENT_FRAMES_H_
