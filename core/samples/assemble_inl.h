// The template of assemble.h; include assemble.h, not this file.
#ifndef MVBRDF_CORE_SAMPLES_ASSEMBLE_INL_H_
#define MVBRDF_CORE_SAMPLES_ASSEMBLE_INL_H_

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/render/phong_model.h"

namespace mvbrdf::samples {
namespace assemble_internal {

// Aborts with `message` unless `condition` (programmer invariants: wrong image
// types or sizes).
void Check(bool condition, const char* message);

// The surface at subpixel (px, py) of a camera's surface maps (pixel centres
// at integers): position and normal bilinear between the four map pixels
// around it, when all four show the mesh on one smooth piece of it (each
// within kSmoothSurfaceSlope, as |n . d| / |d|, of the tangent plane of
// `*point`, `*normal`: the nearest pixel's); otherwise both are left as they
// are. A distorted pixel's ray meets the pinhole map up to half a pixel
// from the nearest centre: a sharp lobe read there looks broader, so
// ForEachPixelSample reads such rays' own triangles where the maps carry
// them (SurfaceOnRay) and interpolates only where they do not.
inline constexpr float kSmoothSurfaceSlope = 0.25f;
void SurfaceBetween(const resample::CameraSurface& surface, double px, double py, glm::vec3* point,
                    glm::vec3* normal);

// The surface where the ray origin + s direction (s > 0, world units) meets
// the mesh, exactly, from the triangles the surface maps show around map
// pixel (mx, my) (surface.triangle, surface.triangles): the one visible at
// (mx, my) when the ray crosses it (barycentric coordinates >= -1e-5), else
// the nearest crossed of those at the 3 x 3 centres around it, else of the
// 5 x 5. Its point and the barycentric mean of its vertex normals
// (unnormalised, as the depth pass interpolates them). False (nothing
// written) without the triangle maps or when none is crossed: the caller
// falls back to SurfaceBetween.
bool SurfaceOnRay(const resample::CameraSurface& surface, const glm::dvec3& origin, const glm::dvec3& direction,
                  int mx, int my, glm::vec3* point, glm::vec3* normal);

// The terms of one surface point, as SampleSet stores them: for every light
// k visible in the shadow atlas texel `bits` (ShadowChannels(lights.size())
// values; bit k % 16 of bits[k / 16]) that faces the point (g > 0):
// g = a max(0, l.n), h = max(0, R(l).v), a = fall-off, n.h and v.h (the
// half vector's, render::LightCosines). Returns the count;
// `any_falloff` is set when some kept a != 1.
inline size_t LightTermsAt(const std::vector<scene::Light>& lights, const glm::vec3& point,
                           const glm::vec3& unit_normal, const glm::vec4& view_origin, const uint16_t* bits,
                           bool inverse_square_falloff, uint16_t* light, float* g, float* h, float* falloff,
                           float* n_dot_h, float* v_dot_h, bool half_vector, bool* any_falloff) {
  size_t count = 0;
  const size_t num = lights.size();
  const size_t channels = static_cast<size_t>(ShadowChannels(num));
  for (size_t c = 0; c < channels; ++c) {
    for (uint32_t word = bits[c]; word != 0; word &= word - 1) {
      const size_t k = 16 * c + static_cast<size_t>(__builtin_ctz(word));
      if (k >= num) break;
      const render::LightCosines cos =
          render::ComputeLightCosines(lights[k], point, unit_normal, view_origin, inverse_square_falloff, half_vector);
      const float gk = cos.g * cos.attenuation;
      if (!(gk > 0.0f) && std::isfinite(gk)) continue;
      light[count] = static_cast<uint16_t>(k);
      g[count] = gk;
      h[count] = cos.h;
      falloff[count] = cos.attenuation;
      if (half_vector) {
        n_dot_h[count] = cos.n_dot_h;
        v_dot_h[count] = cos.v_dot_h;
      }
      *any_falloff |= cos.attenuation != 1.0f;
      ++count;
    }
  }
  return count;
}

// Buffers for one point's terms (at most kMaxLights).
struct TermBuffers {
  uint16_t light[kMaxLights];
  float g[kMaxLights], h[kMaxLights], falloff[kMaxLights], n_dot_h[kMaxLights], v_dot_h[kMaxLights];
  LightTerms Fill(const std::vector<scene::Light>& lights, const glm::vec3& point, const glm::vec3& unit_normal,
                  const glm::vec4& view_origin, const uint16_t* bits, bool inverse_square_falloff,
                  bool half_vector) {
    LightTerms t;
    t.count = LightTermsAt(lights, point, unit_normal, view_origin, bits, inverse_square_falloff, light, g, h,
                           falloff, n_dot_h, v_dot_h, half_vector, &t.any_falloff);
    t.light = light;
    t.g = g;
    t.h = h;
    t.falloff = falloff;
    if (half_vector) {
      t.n_dot_v = glm::dot(unit_normal, scene::ViewDirection(view_origin, point));
      t.n_dot_h = n_dot_h;
      t.v_dot_h = v_dot_h;
    }
    return t;
  }
};

// The terms of a pixel's footprint (ForEachPixelSample with footprint > 1):
// subpixel s's term of light k becomes light k * count + s (FootprintLights
// lists each light `count` times), with g and a divided by `count`, so that
// the model's sum over terms is the mean over the subpixels. Lights ascend.
struct FootprintTerms {
  struct Term {
    uint16_t light;
    float g, h, falloff, n_dot_h, v_dot_h;
  };
  std::vector<Term> terms;
  double n_dot_v_sum = 0.0;
  bool half_vector = false;
  TermBuffers out;  // what Terms() hands out

  void Clear() {
    terms.clear();
    n_dot_v_sum = 0.0;
    half_vector = false;
  }
  void Add(int s, int count, const LightTerms& t) {
    const float w = 1.0f / static_cast<float>(count);
    for (size_t j = 0; j < t.count; ++j) {
      const bool hv = t.n_dot_h != nullptr;
      terms.push_back({static_cast<uint16_t>(t.light[j] * count + s), t.g[j] * w, t.h[j],
                       (t.falloff != nullptr ? t.falloff[j] : 1.0f) * w, hv ? t.n_dot_h[j] : 0.0f,
                       hv ? t.v_dot_h[j] : 0.0f});
    }
    half_vector |= t.n_dot_h != nullptr;
    n_dot_v_sum += t.n_dot_v;
  }
  LightTerms Terms(int count) {
    std::sort(terms.begin(), terms.end(), [](const Term& a, const Term& b) { return a.light < b.light; });
    LightTerms t;
    t.count = terms.size();
    for (size_t j = 0; j < terms.size(); ++j) {
      out.light[j] = terms[j].light;
      out.g[j] = terms[j].g;
      out.h[j] = terms[j].h;
      out.falloff[j] = terms[j].falloff;
      out.n_dot_h[j] = terms[j].n_dot_h;
      out.v_dot_h[j] = terms[j].v_dot_h;
    }
    t.light = out.light;
    t.g = out.g;
    t.h = out.h;
    t.falloff = out.falloff;
    t.any_falloff = true;  // every a is divided by the count
    // n.v is one per Sample: the subpixels' mean.
    t.n_dot_v = static_cast<float>(n_dot_v_sum / count);
    if (half_vector) {
      t.n_dot_h = out.n_dot_h;
      t.v_dot_h = out.v_dot_h;
    }
    return t;
  }
};

}  // namespace assemble_internal

// The terms of one surface point as the assemblers compute them (Fill: the
// lights of `bits` that face it), in buffers for every light; the terms are
// valid until the next Fill.
using PointTerms = assemble_internal::TermBuffers;

template <typename Visit>
void ForEachTexelObservation(const cv::Mat& resampled, const resample::GeometryAtlas& geometry, const cv::Mat& shadows,
                             const scene::CameraModel& camera, size_t num_lights, Visit&& visit, TexelRows rows) {
  using assemble_internal::Check;
  Check(resampled.type() == CV_32FC4 && resampled.rows == resampled.cols,
        "ForEachTexelSample: resampled must be a square CV_32FC4 atlas");
  Check(geometry.position.type() == CV_32FC4 && geometry.position.size() == resampled.size(),
        "ForEachTexelSample: geometry.position must be CV_32FC4 of the atlas size");
  Check(geometry.normal.type() == CV_32FC4 && geometry.normal.size() == resampled.size(),
        "ForEachTexelSample: geometry.normal must be CV_32FC4 of the atlas size");
  Check(num_lights <= static_cast<size_t>(kMaxLights), "ForEachTexelSample: more than kMaxLights lights");
  Check(shadows.type() == ShadowAtlasType(num_lights) && shadows.size() == resampled.size(),
        "ForEachTexelSample: shadows must be CV_16UC(ShadowChannels) of the atlas size");

  const glm::vec4 view(camera.ViewOrigin());  // v: scene::ViewDirection (pinhole or orthographic)
  const int channels = ShadowChannels(num_lights);
  const int size = resampled.cols;
  const int row_end = rows.end < 0 ? size : std::min(rows.end, size);
  for (int row = std::max(rows.begin, 0); row < row_end; ++row) {
    const cv::Vec4f* value = resampled.ptr<cv::Vec4f>(row);
    const cv::Vec4f* position = geometry.position.ptr<cv::Vec4f>(row);
    const cv::Vec4f* normal = geometry.normal.ptr<cv::Vec4f>(row);
    const uint16_t* bits = shadows.ptr<uint16_t>(row);
    for (int column = 0; column < size; ++column) {
      // Valid resampled value (a > 0.5, core/resample/atlas_ops) on a covered texel.
      if (!(value[column][3] > 0.5f) || !(position[column][3] > 0.5f)) continue;
      const glm::vec3 point(position[column][0], position[column][1], position[column][2]);
      const glm::vec3 n_raw(normal[column][0], normal[column][1], normal[column][2]);
      const float length = glm::length(n_raw);
      if (!(length > 0.0f) || !std::isfinite(length)) continue;
      // Interpolated normals are unit up to the GPU's rounding; renormalise.
      const glm::vec3 n = n_raw / length;
      // The resampler already rejects back-facing texels; this guards against
      // a camera centre that differs from the one resampled with.
      if (!(glm::dot(n, scene::ViewDirection(view, point)) > 0.0f)) continue;
      const uint32_t texel = static_cast<uint32_t>(row) * static_cast<uint32_t>(size) + static_cast<uint32_t>(column);
      const glm::vec3 rgb(value[column][0], value[column][1], value[column][2]);
      visit(texel, rgb, point, n, bits + static_cast<size_t>(column) * channels);
    }
  }
}

template <typename Visit>
void ForEachTexelSample(const cv::Mat& resampled, const resample::GeometryAtlas& geometry, const cv::Mat& shadows,
                        const scene::CameraModel& camera, const std::vector<scene::Light>& lights,
                        const AssembleOptions& options, Visit&& visit, TexelRows rows) {
  const glm::vec4 view(camera.ViewOrigin());
  auto buffers = std::make_unique<PointTerms>();
  ForEachTexelObservation(
      resampled, geometry, shadows, camera, lights.size(),
      [&](uint32_t texel, const glm::vec3& rgb, const glm::vec3& point, const glm::vec3& n, const uint16_t* bits) {
        const LightTerms terms =
            buffers->Fill(lights, point, n, view, bits, options.inverse_square_falloff, options.half_vector_geometry);
        visit(texel, rgb, terms);
      },
      rows);
}

template <typename Visit>
void ForEachPixelSample(const cv::Mat& frame, const resample::CameraSurface& surface, const cv::Mat& shadows,
                        const scene::CameraModel& camera, const std::vector<scene::Light>& lights,
                        const AssembleOptions& options, double min_cos_view, Visit&& visit, int footprint) {
  using assemble_internal::Check;
  Check(frame.type() == CV_32FC3 && frame.cols == camera.width && frame.rows == camera.height,
        "ForEachPixelSample: frame must be CV_32FC3 of the camera's size");
  Check(surface.position_texel.type() == CV_32FC4 && surface.normal.size() == surface.position_texel.size(),
        "ForEachPixelSample: surface maps must be CV_32FC4 of one size");
  Check(lights.size() <= static_cast<size_t>(kMaxLights), "ForEachPixelSample: more than kMaxLights lights");
  Check(shadows.type() == ShadowAtlasType(lights.size()) && shadows.rows == shadows.cols,
        "ForEachPixelSample: shadows must be CV_16UC(ShadowChannels)");
  Check(footprint >= 1 && footprint <= kMaxPixelFootprint &&
            lights.size() * static_cast<size_t>(footprint * footprint) <= static_cast<size_t>(kMaxLights),
        "ForEachPixelSample: footprint out of [1, kMaxPixelFootprint] or too many lights for it");
  const glm::vec4 view(camera.ViewOrigin());  // v: scene::ViewDirection (pinhole or orthographic)
  const int size = shadows.cols;
  const int map_w = surface.position_texel.cols, map_h = surface.position_texel.rows;
  const bool distorted = camera.has_distortion();
  const int channels = ShadowChannels(lights.size());
  const int subpoints = footprint * footprint;
  auto buffers = std::make_unique<assemble_internal::TermBuffers>();
  auto merged = footprint > 1 ? std::make_unique<assemble_internal::FootprintTerms>() : nullptr;
  const auto covered = [&](int mx, int my) {
    return mx >= 0 && my >= 0 && mx < map_w && my < map_h && surface.position_texel.at<cv::Vec4f>(my, mx)[3] > 0.5f;
  };
  // The pinhole map's (sub)pixel showing the video's (sub)pixel (x, y).
  const auto map_at = [&](double x, double y) {
    if (!distorted) return glm::dvec2(x - camera.cx + surface.cx, y - camera.cy + surface.cy);
    const glm::dvec2 u = camera.Undistort({(x - camera.cx) / camera.fx, (y - camera.cy) / camera.fy});
    return glm::dvec2(camera.fx * u.x + surface.cx, camera.fy * u.y + surface.cy);
  };
  // A pinhole camera's rays between map centres (a distorted camera's, or a
  // footprint's subpixels), exactly (SurfaceOnRay), where the maps carry their
  // triangles: the ray through map (sub)pixel `at` of the pinhole.
  const bool on_rays = !camera.orthographic() && surface.triangles != nullptr && !surface.triangle.empty();
  const glm::dmat3 world_from_cam = glm::transpose(camera.cam_from_world_rotation);
  const glm::dvec3 camera_centre = camera.CenterInWorld();
  for (int y = 0; y < frame.rows; ++y) {
    for (int x = 0; x < frame.cols; ++x) {
      const glm::dvec2 centre = map_at(x, y);
      // Masked or saturated (marked negative by scene::VideoSource): never a Sample.
      if (frame.at<cv::Vec3f>(y, x)[0] < 0.0f) continue;
      const int mx = static_cast<int>(std::lround(centre.x)), my = static_cast<int>(std::lround(centre.y));
      // Pixels at silhouettes integrate background in a real camera: only
      // pixels whose four neighbours show the mesh too.
      if (!covered(mx, my) || !covered(mx - 1, my) || !covered(mx + 1, my) || !covered(mx, my - 1) ||
          !covered(mx, my + 1)) {
        continue;
      }
      const cv::Vec4f& p = surface.position_texel.at<cv::Vec4f>(my, mx);
      const cv::Vec4f& nv = surface.normal.at<cv::Vec4f>(my, mx);
      const glm::vec3 nearest_point(p[0], p[1], p[2]);
      const glm::vec3 nearest_normal(nv[0], nv[1], nv[2]);
      const int64_t texel = static_cast<int64_t>(p[3]) - 1;
      if (texel < 0 || texel >= static_cast<int64_t>(size) * size) continue;
      const uint16_t* bits = shadows.ptr<uint16_t>(static_cast<int>(texel / size)) +
                             static_cast<size_t>(texel % size) * static_cast<size_t>(channels);
      // The surface at one (sub)pixel of the video: false when it faces away.
      const auto surface_at = [&](const glm::dvec2& at, bool exact, glm::vec3* point, glm::vec3* n) {
        *point = nearest_point;
        *n = nearest_normal;
        // A distorted pixel's ray, or a subpixel's, meets the pinhole map
        // between its pixel centres: the surface there, on the ray's own
        // triangle where the maps say which, else interpolated.
        const auto on_ray = [&] {
          const glm::dvec3 ray =
              world_from_cam * glm::dvec3((at.x - surface.cx) / camera.fx, (at.y - surface.cy) / camera.fy, 1.0);
          return assemble_internal::SurfaceOnRay(surface, camera_centre, ray, static_cast<int>(std::lround(at.x)),
                                                 static_cast<int>(std::lround(at.y)), point, n);
        };
        if (!exact && !(on_rays && on_ray())) assemble_internal::SurfaceBetween(surface, at.x, at.y, point, n);
        const float length = glm::length(*n);
        if (!(length > 0.0f) || !std::isfinite(length)) return false;
        *n /= length;
        return glm::dot(*n, scene::ViewDirection(view, *point)) > static_cast<float>(min_cos_view);
      };
      glm::vec3 point, n;
      if (!surface_at(centre, !distorted, &point, &n)) continue;
      const cv::Vec3f& rgb = frame.at<cv::Vec3f>(y, x);
      if (footprint == 1) {
        const LightTerms terms = buffers->Fill(lights, point, n, view, bits, options.inverse_square_falloff,
                                               options.half_vector_geometry);
        visit(static_cast<uint32_t>(texel), glm::vec3(rgb[0], rgb[1], rgb[2]), terms);
        continue;
      }
      // The pixel's footprint: footprint x footprint subpixels, each a
      // light's copy (FootprintLights) with g and a divided by their count.
      merged->Clear();
      for (int s = 0; s < subpoints; ++s) {
        const double dx = (s % footprint + 0.5) / footprint - 0.5, dy = (s / footprint + 0.5) / footprint - 0.5;
        glm::vec3 sub_point, sub_n;
        if (!surface_at(map_at(x + dx, y + dy), false, &sub_point, &sub_n)) {
          sub_point = point;  // a subpixel facing away: the centre's surface stands in
          sub_n = n;
        }
        merged->Add(s, subpoints, buffers->Fill(lights, sub_point, sub_n, view, bits, options.inverse_square_falloff,
                                                options.half_vector_geometry));
      }
      visit(static_cast<uint32_t>(texel), glm::vec3(rgb[0], rgb[1], rgb[2]), merged->Terms(subpoints));
    }
  }
}

}  // namespace mvbrdf::samples

#endif  // MVBRDF_CORE_SAMPLES_ASSEMBLE_INL_H_
