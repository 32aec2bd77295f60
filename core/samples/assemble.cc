#include "core/samples/assemble.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <optional>
#include <opencv2/core.hpp>
#include <string>
#include <utility>

#include "core/render/phong_model.h"
#include "core/scene/ray_triangle.h"

namespace mvbrdf::samples {
namespace assemble_internal {

void Check(bool condition, const char* message) {
  if (condition) return;
  std::fprintf(stderr, "core/samples/assemble: %s\n", message);
  std::abort();
}

void SurfaceBetween(const resample::CameraSurface& surface, double px, double py, glm::vec3* point,
                    glm::vec3* normal) {
  const int x0 = static_cast<int>(std::floor(px)), y0 = static_cast<int>(std::floor(py));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= surface.position_texel.cols || y0 + 1 >= surface.position_texel.rows) return;
  const float fx = static_cast<float>(px - x0), fy = static_cast<float>(py - y0);
  if (!(glm::length(*normal) > 0.0f)) return;
  const glm::vec3 reference = *point, reference_normal = glm::normalize(*normal);
  glm::vec3 p(0.0f), n(0.0f);
  for (int dy = 0; dy < 2; ++dy) {
    for (int dx = 0; dx < 2; ++dx) {
      const cv::Vec4f& q = surface.position_texel.at<cv::Vec4f>(y0 + dy, x0 + dx);
      if (!(q[3] > 0.5f)) return;
      const glm::vec3 at(q[0], q[1], q[2]);
      const glm::vec3 d = at - reference;
      if (std::fabs(glm::dot(reference_normal, d)) > kSmoothSurfaceSlope * glm::length(d)) return;
      const cv::Vec4f& m = surface.normal.at<cv::Vec4f>(y0 + dy, x0 + dx);
      const float w = (dx ? fx : 1.0f - fx) * (dy ? fy : 1.0f - fy);
      p += w * at;
      n += w * glm::vec3(m[0], m[1], m[2]);
    }
  }
  if (!(glm::length(n) > 0.0f) || !std::isfinite(p.x + p.y + p.z)) return;
  *point = p;
  *normal = n;
}

namespace {

// Map pixels around the nearest centre: itself, the ring of 8, the ring of 16.
struct RingOffsets {
  std::array<std::pair<int, int>, 25> offsets;
  RingOffsets() {
    size_t i = 0;
    offsets[i++] = {0, 0};
    for (int radius = 1; radius <= 2; ++radius) {
      for (int dy = -radius; dy <= radius; ++dy) {
        for (int dx = -radius; dx <= radius; ++dx) {
          if (std::max(std::abs(dx), std::abs(dy)) == radius) offsets[i++] = {dx, dy};
        }
      }
    }
  }
};

}  // namespace

bool SurfaceOnRay(const resample::CameraSurface& surface, const glm::dvec3& origin, const glm::dvec3& direction,
                  int mx, int my, glm::vec3* point, glm::vec3* normal) {
  if (surface.triangles == nullptr || surface.triangle.empty()) return false;
  static const RingOffsets kRings;
  const std::vector<resample::SurfaceTriangle>& triangles = *surface.triangles;
  constexpr double kInside = -1e-5;
  double best = std::numeric_limits<double>::infinity();
  glm::dvec3 best_b(0.0);
  int32_t best_t = -1;
  std::array<int32_t, 25> seen{};
  size_t num_seen = 0;
  // The ray meets the map within half a pixel of (mx, my). The triangle
  // visible at that centre, when the ray crosses it, is the ray's (a nearer
  // surface would have to hide the ray and not the centre); else the nearest
  // crossed of those at the 3 x 3 centres around it, or, for a sliver seen
  // edge-on near a silhouette, at the 5 x 5.
  for (size_t i = 0; i < kRings.offsets.size(); ++i) {
    if (best_t >= 0 && (i == 1 || i == 9)) break;
    const int x = mx + kRings.offsets[i].first, y = my + kRings.offsets[i].second;
    if (x < 0 || y < 0 || x >= surface.triangle.cols || y >= surface.triangle.rows) continue;
    const int32_t t = surface.triangle.at<int32_t>(y, x);
    if (t < 0 || static_cast<size_t>(t) >= triangles.size()) continue;
    const auto seen_end = seen.begin() + static_cast<std::ptrdiff_t>(num_seen);
    if (std::find(seen.begin(), seen_end, t) != seen_end) continue;
    seen[num_seen++] = t;
    const resample::SurfaceTriangle& tri = triangles[static_cast<size_t>(t)];
    const std::optional<scene::RayTriangleHit> hit = scene::IntersectRayTriangle(
        origin, direction, glm::dvec3(tri.position[0]), glm::dvec3(tri.position[1]), glm::dvec3(tri.position[2]));
    if (!hit) continue;
    const double b0 = 1.0 - hit->b1 - hit->b2;
    if (b0 < kInside || hit->b1 < kInside || hit->b2 < kInside || !(hit->distance > 0.0) || !(hit->distance < best)) {
      continue;
    }
    best = hit->distance;
    best_b = {b0, hit->b1, hit->b2};
    best_t = t;
  }
  if (best_t < 0) return false;
  const resample::SurfaceTriangle& tri = triangles[static_cast<size_t>(best_t)];
  glm::dvec3 p(0.0), n(0.0);
  for (int i = 0; i < 3; ++i) {
    p += best_b[i] * glm::dvec3(tri.position[i]);
    n += best_b[i] * glm::dvec3(tri.normal[i]);
  }
  *point = glm::vec3(p);
  *normal = glm::vec3(n);
  return true;
}

}  // namespace assemble_internal

using assemble_internal::Check;

std::vector<scene::Light> FootprintLights(const std::vector<scene::Light>& lights, int footprint) {
  const int copies = footprint * footprint;
  std::vector<scene::Light> out;
  out.reserve(lights.size() * static_cast<size_t>(copies));
  for (const scene::Light& light : lights) out.insert(out.end(), static_cast<size_t>(copies), light);
  return out;
}

LightSelection FootprintSelection(const LightSelection& selection, int footprint) {
  const size_t copies = static_cast<size_t>(footprint) * static_cast<size_t>(footprint);
  if (copies == 1) return selection;
  LightMask widened;
  selection.config.ForEach([&](size_t k) {
    for (size_t s = 0; s < copies; ++s) widened.Set(k * copies + s);
  });
  return LightSelection(std::move(widened), selection.own);
}

int ShadowChannels(size_t num_lights) { return std::max(1, static_cast<int>((num_lights + 15) / 16)); }

int ShadowAtlasType(size_t num_lights) { return CV_16UC(ShadowChannels(num_lights)); }

bool ShadowBit(const cv::Mat& shadows, int row, int column, size_t k) {
  const int channels = shadows.channels();
  Check(shadows.depth() == CV_16U && k / 16 < static_cast<size_t>(channels), "ShadowBit: light beyond the atlas");
  const uint16_t* bits = shadows.ptr<uint16_t>(row) + static_cast<size_t>(column) * static_cast<size_t>(channels);
  return (bits[k / 16] >> (k % 16)) & 1u;
}

void SetShadowBit(cv::Mat* shadows, int row, int column, size_t k) {
  Check(shadows != nullptr && shadows->depth() == CV_16U && k / 16 < static_cast<size_t>(shadows->channels()),
        "SetShadowBit: light beyond the atlas");
  uint16_t* bits = shadows->ptr<uint16_t>(row) + static_cast<size_t>(column) * static_cast<size_t>(shadows->channels());
  bits[k / 16] = static_cast<uint16_t>(bits[k / 16] | (1u << (k % 16)));
}

LightMask AllLights(size_t num_lights) {
  Check(num_lights <= static_cast<size_t>(kMaxLights), "AllLights: more than kMaxLights lights");
  return LightMask::FirstN(num_lights);
}

std::vector<LightMask> FrameLightMasks(const scene::Sequence& sequence) {
  const LightMask all = AllLights(sequence.lights.size());
  std::vector<LightMask> masks(static_cast<size_t>(std::max(0, sequence.num_frames)), all);
  for (int t = 0; t < sequence.num_frames; ++t) {
    const v1::FrameLighting* fl = sequence.FrameLightingOf(t);
    if (fl == nullptr) continue;
    LightMask on;
    for (const std::string& name : fl->lights()) {
      const int k = sequence.FindLight(name);
      // Validation (core/scene/sequence.cc) refuses unknown names.
      Check(k >= 0, "FrameLightMasks: scene.frame_lighting names an unknown light");
      on.Set(static_cast<size_t>(k));
    }
    masks[static_cast<size_t>(t)] = std::move(on);
  }
  return masks;
}

std::vector<uint8_t> OwnLightingFrames(const scene::Sequence& sequence) {
  std::vector<uint8_t> own;
  if (sequence.scene.frame_lighting_size() == 0 || sequence.every_frame_lit_own()) return own;
  own.assign(static_cast<size_t>(std::max(0, sequence.num_frames)), 0);
  for (int t = 0; t < sequence.num_frames; ++t) own[static_cast<size_t>(t)] = sequence.FrameLightingOf(t) != nullptr;
  return own;
}

size_t MaxLightsOn(const std::vector<LightMask>& frame_masks, size_t num_lights) {
  size_t most = 0;
  for (const LightMask& m : frame_masks) most = std::max(most, (m & AllLights(num_lights)).Count());
  return frame_masks.empty() ? num_lights : most;
}

void ApplyLightMask(const LightMask& on, size_t num_lights, cv::Mat* shadows) {
  Check(shadows != nullptr && shadows->type() == ShadowAtlasType(num_lights),
        "ApplyLightMask: shadows must be CV_16UC(ShadowChannels)");
  const LightMask all = AllLights(num_lights);
  if ((on & all) == all) return;
  const int channels = shadows->channels();
  std::vector<uint16_t> keep(static_cast<size_t>(channels));
  for (int c = 0; c < channels; ++c) keep[static_cast<size_t>(c)] = on.Bits16(static_cast<size_t>(c));
  for (int row = 0; row < shadows->rows; ++row) {
    uint16_t* bits = shadows->ptr<uint16_t>(row);
    for (int column = 0; column < shadows->cols; ++column) {
      for (int c = 0; c < channels; ++c) bits[c] &= keep[static_cast<size_t>(c)];
      bits += channels;
    }
  }
}

SampleSet MakeSampleSet(const std::vector<scene::Light>& lights, bool half_vector) {
  Check(lights.size() <= static_cast<size_t>(kMaxLights), "MakeSampleSet: more than kMaxLights lights");
  SampleSet set;
  set.half_vector = half_vector;
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
  Check(shadows.type() == ShadowAtlasType(lights.size()) && shadows.rows == atlas.size && shadows.cols == atlas.size,
        "AppendTriangleSamples: shadows must be CV_16UC(ShadowChannels) of the atlas size");

  std::vector<bool> zero_area(triangles.size(), false);
  for (uint32_t t : atlas.topology.zero_area_triangles) {
    if (t < zero_area.size()) zero_area[t] = true;
  }
  const glm::vec4 view(camera.ViewOrigin());  // v: scene::ViewDirection (pinhole or orthographic)
  const size_t num_lights = lights.size();
  const size_t channels = static_cast<size_t>(ShadowChannels(num_lights));
  std::vector<int> visible_texels(num_lights);
  std::vector<uint16_t> visible_bits(channels);
  auto buffers = std::make_unique<assemble_internal::TermBuffers>();
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
      const uint16_t* bits = shadows.ptr<uint16_t>(row) + static_cast<size_t>(column) * channels;
      for (size_t ch = 0; ch < channels; ++ch) {
        for (uint32_t word = bits[ch]; word != 0; word &= word - 1) {
          const size_t k = 16 * ch + static_cast<size_t>(__builtin_ctz(word));
          if (k < num_lights) ++visible_texels[k];
        }
      }
    }
    std::fill(visible_bits.begin(), visible_bits.end(), uint16_t{0});
    for (size_t k = 0; k < num_lights; ++k) {
      const bool visible = !texels.empty() && static_cast<double>(visible_texels[k]) >=
                                                  static_cast<double>(options.min_visible_fraction) * texels.size();
      if (visible) visible_bits[k / 16] = static_cast<uint16_t>(visible_bits[k / 16] | (1u << (k % 16)));
    }
    const LightTerms terms = buffers->Fill(lights, c, n, view, visible_bits.data(), options.inverse_square_falloff,
                                           options.half_vector_geometry || out->half_vector);
    out->AddTerms(static_cast<uint32_t>(t), frame, camera_index, means[t].rgb, terms.count, terms.light, terms.g,
                  terms.h, terms.any_falloff || !out->falloff.empty() ? terms.falloff : nullptr, terms.HalfVector());
  }
}

}  // namespace mvbrdf::samples
