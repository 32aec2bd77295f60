#include "core/samples/assemble.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <opencv2/core.hpp>

#include "core/render/phong_model.h"

namespace mvbrdf::samples {
namespace assemble_internal {

void Check(bool condition, const char* message) {
  if (condition) return;
  std::fprintf(stderr, "core/samples/assemble: %s\n", message);
  std::abort();
}

}  // namespace assemble_internal

using assemble_internal::Check;

LightMask AllLights(size_t num_lights) {
  Check(num_lights <= static_cast<size_t>(kMaxLights), "AllLights: more than kMaxLights lights");
  return num_lights >= 32 ? ~LightMask{0} : (LightMask{1} << num_lights) - 1u;
}

std::vector<LightMask> FrameLightMasks(const scene::Sequence& sequence) {
  const LightMask all = AllLights(sequence.lights.size());
  std::vector<LightMask> masks(static_cast<size_t>(std::max(0, sequence.num_frames)), all);
  for (int t = 0; t < sequence.num_frames; ++t) {
    const v1::FrameLighting* fl = sequence.FrameLightingOf(t);
    if (fl == nullptr) continue;
    LightMask on = 0;
    for (const std::string& name : fl->lights()) {
      const int k = sequence.FindLight(name);
      // Validation (core/scene/sequence.cc) refuses unknown names.
      Check(k >= 0, "FrameLightMasks: scene.frame_lighting names an unknown light");
      on |= LightMask{1} << k;
    }
    masks[static_cast<size_t>(t)] = on;
  }
  return masks;
}

void ApplyLightMask(LightMask on, size_t num_lights, cv::Mat* shadows) {
  Check(shadows != nullptr && shadows->type() == CV_16UC1, "ApplyLightMask: shadows must be CV_16UC1");
  if ((on & AllLights(num_lights)) == AllLights(num_lights)) return;
  cv::bitwise_and(*shadows, cv::Scalar(static_cast<double>(on & 0xffffu)), *shadows);
}

SampleSet MakeSampleSet(const std::vector<scene::Light>& lights) {
  Check(lights.size() <= static_cast<size_t>(kMaxLights), "MakeSampleSet: more than kMaxLights lights");
  SampleSet set;
  for (const scene::Light& light : lights) {
    set.light_names.push_back(light.name);
    set.light_intensity.push_back(light.intensity);
  }
  return set;
}

void AppendTriangleSamples(const std::vector<resample::TriangleMean>& means, const atlas::Atlas& atlas,
                           const scene::FramePositions& file_positions, const cv::Mat& shadows,
                           const scene::CameraModel& camera, int camera_index, int frame,
                           const std::vector<scene::Light>& lights, const AssembleOptions& options, SampleSet* out) {
  const std::vector<glm::uvec3>& triangles = atlas.topology.file_triangles;
  Check(out != nullptr, "AppendTriangleSamples: null output");
  Check(out->num_lights() == static_cast<int>(lights.size()),
        "AppendTriangleSamples: the sample set was made for other lights (MakeSampleSet)");
  Check(means.size() == triangles.size() && atlas.triangle_texels.size() == triangles.size(),
        "AppendTriangleSamples: one TriangleMean and one texel list per triangle expected");
  Check(shadows.type() == CV_16UC1 && shadows.rows == atlas.size && shadows.cols == atlas.size,
        "AppendTriangleSamples: shadows must be CV_16UC1 of the atlas size");

  std::vector<bool> zero_area(triangles.size(), false);
  for (uint32_t t : atlas.topology.zero_area_triangles) {
    if (t < zero_area.size()) zero_area[t] = true;
  }
  const glm::vec4 view(camera.ViewOrigin());  // v: scene::ViewDirection (pinhole or orthographic)
  const size_t num_lights = lights.size();
  float g_row[kMaxLights], h_row[kMaxLights], falloff_row[kMaxLights];
  int visible_texels[kMaxLights];
  for (size_t t = 0; t < triangles.size(); ++t) {
    if (!means[t].valid || zero_area[t]) continue;
    const glm::uvec3& tri = triangles[t];
    Check(tri.x < file_positions.size() && tri.y < file_positions.size() && tri.z < file_positions.size(),
          "AppendTriangleSamples: file_positions does not cover the mesh");
    const glm::vec3 p0 = file_positions[tri.x], p1 = file_positions[tri.y], p2 = file_positions[tri.z];
    // Counter-clockwise seen from outside (core/scene/mesh.h): the cross
    // product points outwards.
    const glm::vec3 cross = glm::cross(p1 - p0, p2 - p0);
    const float length = glm::length(cross);
    if (!(length > 0.0f) || !std::isfinite(length)) continue;  // zero area in this pose
    const glm::vec3 n = cross / length;
    const glm::vec3 c = (p0 + p1 + p2) / 3.0f;
    if (!(glm::dot(n, scene::ViewDirection(view, c)) > 0.0f)) continue;  // back-facing (or edge-on)

    // Visibility of each light: the share of the triangle's texels whose
    // shadow bit is set.
    const std::vector<uint32_t>& texels = atlas.triangle_texels[t];
    for (size_t k = 0; k < num_lights; ++k) visible_texels[k] = 0;
    for (uint32_t texel : texels) {
      const int row = static_cast<int>(texel / static_cast<uint32_t>(atlas.size));
      const int column = static_cast<int>(texel % static_cast<uint32_t>(atlas.size));
      Check(row < atlas.size, "AppendTriangleSamples: texel outside the atlas");
      const uint16_t bits = shadows.at<uint16_t>(row, column);
      for (size_t k = 0; k < num_lights; ++k) visible_texels[k] += (bits >> k) & 1;
    }
    uint32_t visible_bits = 0;
    for (size_t k = 0; k < num_lights; ++k) {
      const bool visible = !texels.empty() && static_cast<double>(visible_texels[k]) >=
                                                  static_cast<double>(options.min_visible_fraction) * texels.size();
      if (visible) visible_bits |= 1u << k;
    }
    const bool any_falloff = assemble_internal::LightRows(lights, c, n, view, visible_bits,
                                                          options.inverse_square_falloff, g_row, h_row, falloff_row);
    out->Add(static_cast<uint32_t>(t), frame, camera_index, means[t].rgb, g_row, h_row,
             any_falloff || !out->falloff.empty() ? falloff_row : nullptr);
  }
}

}  // namespace mvbrdf::samples
