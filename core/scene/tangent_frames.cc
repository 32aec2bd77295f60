#include "core/scene/tangent_frames.h"

#include <algorithm>
#include <cmath>

namespace mvbrdf::scene {
namespace {

// Some unit vector orthogonal to unit n.
glm::vec3 AnyOrthogonal(const glm::vec3& n) {
  const glm::vec3 helper = std::fabs(n.x) < 0.9f ? glm::vec3(1.0f, 0.0f, 0.0f) : glm::vec3(0.0f, 1.0f, 0.0f);
  return glm::normalize(glm::cross(helper, n) == glm::vec3(0.0f) ? glm::vec3(0.0f, 0.0f, 1.0f) : glm::cross(helper, n));
}

float CornerAngle(const glm::vec3& a, const glm::vec3& b) {
  const float la = glm::length(a), lb = glm::length(b);
  if (!(la > 0.0f) || !(lb > 0.0f)) return 0.0f;
  return std::acos(std::clamp(glm::dot(a, b) / (la * lb), -1.0f, 1.0f));
}

}  // namespace

std::vector<glm::vec4> VertexTangents(const std::vector<glm::uvec3>& triangles, const std::vector<glm::vec3>& positions,
                                      const std::vector<glm::vec3>& normals, const std::vector<glm::vec2>& uvs) {
  const size_t n = positions.size();
  std::vector<glm::vec3> t_sum(n, glm::vec3(0.0f)), b_sum(n, glm::vec3(0.0f));
  if (uvs.size() == n) {
    for (const glm::uvec3& tri : triangles) {
      if (tri.x >= n || tri.y >= n || tri.z >= n) continue;
      const glm::vec3 e1 = positions[tri.y] - positions[tri.x], e2 = positions[tri.z] - positions[tri.x];
      const glm::vec2 w1 = uvs[tri.y] - uvs[tri.x], w2 = uvs[tri.z] - uvs[tri.x];
      const float det = w1.x * w2.y - w2.x * w1.y;
      if (!(std::fabs(det) > 0.0f)) continue;
      glm::vec3 dpdu = (e1 * w2.y - e2 * w1.y) / det, dpdv = (e2 * w1.x - e1 * w2.x) / det;
      const float lu = glm::length(dpdu), lv = glm::length(dpdv);
      if (!(lu > 0.0f) || !(lv > 0.0f) || !std::isfinite(lu) || !std::isfinite(lv)) continue;
      dpdu /= lu;
      dpdv /= lv;
      const uint32_t corner[3] = {tri.x, tri.y, tri.z};
      for (int c = 0; c < 3; ++c) {
        const glm::vec3& p = positions[corner[c]];
        const float angle = CornerAngle(positions[corner[(c + 1) % 3]] - p, positions[corner[(c + 2) % 3]] - p);
        t_sum[corner[c]] += angle * dpdu;
        b_sum[corner[c]] += angle * dpdv;
      }
    }
  }
  std::vector<glm::vec4> tangents(n);
  for (size_t i = 0; i < n; ++i) {
    const glm::vec3& nv = normals[i];
    glm::vec3 t = t_sum[i] - nv * glm::dot(nv, t_sum[i]);
    const float length = glm::length(t);
    if (!(length > 1e-12f) || !std::isfinite(length)) {
      tangents[i] = glm::vec4(AnyOrthogonal(nv), 1.0f);
      continue;
    }
    t /= length;
    const float w = glm::dot(glm::cross(nv, t), b_sum[i]) < 0.0f ? -1.0f : 1.0f;
    tangents[i] = glm::vec4(t, w);
  }
  return tangents;
}

TangentFrame FrameAt(const glm::vec4& interpolated_tangent, const glm::vec3& unit_normal) {
  TangentFrame f;
  f.n = unit_normal;
  const glm::vec3 t(interpolated_tangent);
  glm::vec3 o = t - unit_normal * glm::dot(unit_normal, t);
  const float length = glm::length(o);
  f.t = length > 1e-12f && std::isfinite(length) ? o / length : AnyOrthogonal(unit_normal);
  f.b = (interpolated_tangent.w < 0.0f ? -1.0f : 1.0f) * glm::cross(unit_normal, f.t);
  return f;
}

}  // namespace mvbrdf::scene
