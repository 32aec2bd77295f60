#include "core/pipeline/normal_stage.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "core/atlas/texel_tangents.h"
#include "core/base/quantile.h"
#include "core/base/status_macros.h"
#include "core/image/exr.h"
#include "core/pipeline/atlas_parts.h"
#include "core/pipeline/frame_stream.h"
#include "core/resample/atlas_ops.h"
#include "core/scene/tangent_frames.h"

namespace mvbrdf::pipeline {
namespace {

constexpr double kDegrees = 180.0 / 3.14159265358979323846;
// Forward-difference step of the normal's Jacobian, radians.
constexpr double kNormalStep = 1e-3;

// Unit direction from `point` towards light `light`.
glm::vec3 ToLight(const scene::Light& light, const glm::vec3& point) {
  return light.directional ? glm::normalize(light.direction) : glm::normalize(light.position - point);
}

// One texel observation as a pass hands it to its visitor.
struct Observation {
  uint32_t texel;
  glm::vec3 rgb, point;
  scene::TangentFrame frame;  // at the (mesh) normal of the texel
  glm::vec4 view;             // the camera's view origin
  const uint16_t* bits;
  int t;
};

}  // namespace

absl::StatusOr<TexelNormals> RefineTexelNormals(const NormalStageInput& in) {
  MVBRDF_RETURN_IF_ERROR(in.options.Check());
  const scene::Sequence& sequence = *in.sequence;
  const atlas::Atlas& atlas = *in.atlas;
  const std::vector<int32_t>& texel_cluster = *in.texel_cluster;
  const size_t num_texels = static_cast<size_t>(atlas.size) * static_cast<size_t>(atlas.size);
  const samples::LightMask all_lights = samples::AllLights(sequence.lights.size());
  const int num_cameras = static_cast<int>(sequence.cameras.size());

  MVBRDF_ASSIGN_OR_RETURN(auto stream, FrameStream::Open(sequence, *in.context, atlas, in.resampler, in.shadows, in.atlases));
  const atlas::TexelTangents texel_tangents(atlas);

  // One pass over every frame and camera, each texel observation handed to
  // visit(part, observation) on its atlas part's thread.
  const auto pass = [&](const char* name, const auto& visit) -> absl::Status {
    for (int t = 0; t < sequence.num_frames; ++t) {
      if (in.progress) in.progress(name, t, sequence.num_frames);
      if (in.cancelled && in.cancelled()) return absl::CancelledError("cancelled");
      MVBRDF_RETURN_IF_ERROR(stream->SetFrame(t));
      const std::vector<glm::vec4> tangents = texel_tangents.Compute(stream->positions());
      for (int c = 0; c < num_cameras; ++c) {
        MVBRDF_ASSIGN_OR_RETURN(const cv::Mat resampled, stream->ResampledAtlas(c));
        const glm::vec4 view(sequence.cameras[static_cast<size_t>(c)].ViewOrigin());
        InAtlasParts([&](int part) {
          samples::ForEachTexelObservation(
              resampled, stream->geometry(), stream->shadows(), sequence.cameras[static_cast<size_t>(c)],
              sequence.lights.size(),
              [&](uint32_t texel, const glm::vec3& rgb, const glm::vec3& point, const glm::vec3& n,
                  const uint16_t* bits) {
                if (texel_cluster[texel] < 0) return;
                visit(part, Observation{texel, rgb, point, scene::FrameAt(tangents[texel], n), view, bits, t});
              },
              AtlasPartRows(part, atlas.size));
        });
      }
    }
    return absl::OkStatus();
  };
  std::array<std::unique_ptr<samples::PointTerms>, kAtlasParts * 3> buffers;
  for (auto& b : buffers) b = std::make_unique<samples::PointTerms>();
  const auto terms_at = [&](int part, int which, const Observation& o, const glm::vec3& n) {
    return buffers[static_cast<size_t>(part * 3 + which)]->Fill(sequence.lights, o.point, n, o.view, o.bits,
                                                                in.assemble.inverse_square_falloff,
                                                                in.assemble.half_vector_geometry);
  };
  const auto cluster_kd = [&](int32_t k) {
    const fit::PhongRgb& p = in.clusters[static_cast<size_t>(k)].phong;
    return glm::dvec3(p[0].kd, p[1].kd, p[2].kd);
  };
  // The kd pass's weight: (n.v)^2 as square root weight.
  const auto view_weight = [](const Observation& o) {
    const float cos_view = std::max(0.0f, glm::dot(o.frame.n, scene::ViewDirection(o.view, o.point)));
    return static_cast<double>(cos_view * cos_view);
  };

  TexelNormals out;
  out.m.assign(num_texels, glm::vec3(0.0f, 0.0f, 1.0f));
  out.sigma_deg.assign(num_texels, -1.0f);
  out.flags.assign(num_texels, 0);
  out.refined.assign(num_texels, 0);

  // The closed-form start: the diffuse part, the lobe read at the mesh
  // normal; observations the lobe dominates there weigh less.
  {
    fit::NormalStereoSums sums(num_texels);
    MVBRDF_RETURN_IF_ERROR(pass("normals", [&](int part, const Observation& o) {
      const int32_t k = texel_cluster[o.texel];
      const samples::LightMask& mask = in.selection->Of(static_cast<size_t>(o.t), all_lights);
      const samples::LightTerms terms = terms_at(part, 0, o, o.frame.n);
      glm::vec3 g, s;
      ShadeTexel(in.clusters[static_cast<size_t>(k)], terms, in.intensity, mask, &g, &s);
      const glm::dvec3 kd = cluster_kd(k);
      glm::dvec3 q(0.0);
      for (size_t j = 0; j < terms.count; ++j) {
        const size_t light = terms.light[j];
        if (!mask.Test(light)) continue;
        const glm::dvec3 i(in.intensity[light]);
        q += glm::dot(kd, i) * static_cast<double>(terms.falloff[j]) *
             glm::dvec3(o.frame.ToTangent(ToLight(sequence.lights[light], o.point)));
      }
      const double y = static_cast<double>(o.rgb.x + o.rgb.y + o.rgb.z - (s.x + s.y + s.z));
      const double diffuse = glm::dot(kd, glm::dvec3(g)), specular = static_cast<double>(s.x + s.y + s.z);
      double w = view_weight(o);
      if (diffuse > 0.0) w /= 1.0 + (specular / diffuse) * (specular / diffuse);
      sums.Add(o.texel, w, y, q);
    }));
    for (size_t i = 0; i < num_texels; ++i) {
      if (texel_cluster[i] < 0) continue;
      const fit::NormalStereoSums::Solution s = sums.Solve(i, in.options);
      out.m[i] = s.m;
      out.flags[i] = s.flags;
    }
    out.passes = 1;
  }

  // Gauss-Newton steps on the full model.
  std::vector<glm::dvec3> kd(num_texels, glm::dvec3(0.0));
  for (size_t i = 0; i < num_texels; ++i) {
    if (texel_cluster[i] >= 0) kd[i] = cluster_kd(texel_cluster[i]);
  }
  for (int iteration = 0; iteration < in.options.iterations; ++iteration) {
    const bool last = iteration + 1 == in.options.iterations;
    fit::NormalGaussNewtonSums sums(num_texels);
    MVBRDF_RETURN_IF_ERROR(pass("normals", [&](int part, const Observation& o) {
      if (out.flags[o.texel] != 0) return;
      const int32_t k = texel_cluster[o.texel];
      const ClusterShading& cluster = in.clusters[static_cast<size_t>(k)];
      const samples::LightMask& mask = in.selection->Of(static_cast<size_t>(o.t), all_lights);
      const fit::NormalTangentBasis basis(glm::dvec3(out.m[o.texel]));
      const std::array<glm::dvec3, 3> m = {basis.m, basis.At(kNormalStep, 0.0), basis.At(0.0, kNormalStep)};
      std::array<glm::dvec3, 3> model;
      glm::dvec3 g0(0.0);
      for (int which = 0; which < 3; ++which) {
        const glm::vec3 n = glm::normalize(o.frame.ToWorld(glm::vec3(m[static_cast<size_t>(which)])));
        glm::vec3 g, s;
        ShadeTexel(cluster, terms_at(part, which, o, n), in.intensity, mask, &g, &s);
        model[static_cast<size_t>(which)] = kd[o.texel] * glm::dvec3(g) + glm::dvec3(s);
        if (which == 0) g0 = glm::dvec3(g);
      }
      std::array<std::array<double, 5>, 3> j{};
      glm::dvec3 res, w(view_weight(o));
      const glm::dvec3& scale = in.residual_scale[static_cast<size_t>(k)];
      for (int c = 0; c < 3; ++c) {
        res[c] = static_cast<double>(o.rgb[c]) - model[0][c];
        j[static_cast<size_t>(c)][0] = (model[1][c] - model[0][c]) / kNormalStep;
        j[static_cast<size_t>(c)][1] = (model[2][c] - model[0][c]) / kNormalStep;
        j[static_cast<size_t>(c)][static_cast<size_t>(2 + c)] = g0[c];
        if (scale[c] > 0.0 && in.robust.enabled()) w[c] *= std::sqrt(in.robust.Weight(res[c] / scale[c]));
      }
      sums.Add(o.texel, j, res, w);
      if (last) {
        // The mesh normal's fit of the same observation, for the test.
        glm::vec3 g, sz;
        ShadeTexel(cluster, terms_at(part, 0, o, o.frame.n), in.intensity, mask, &g, &sz);
        sums.AddMeshNormal(o.texel, glm::dvec3(o.rgb) - glm::dvec3(sz), glm::dvec3(g), w);
      }
    }));
    for (size_t i = 0; i < num_texels; ++i) {
      if (texel_cluster[i] < 0 || out.flags[i] != 0) continue;
      if (last && !sums.Significant(i, in.options)) {
        out.flags[i] = fit::kNormalNotSignificant;
        continue;
      }
      const fit::NormalTangentBasis basis{glm::dvec3(out.m[i])};
      const fit::NormalGaussNewtonSums::Step step =
          sums.Solve(i, basis, kd[i], cluster_kd(texel_cluster[i]), in.options);
      if (!step.ok) continue;
      out.m[i] = glm::vec3(basis.At(step.alpha, step.beta));
      kd[i] = step.kd;
      out.sigma_deg[i] = static_cast<float>(step.sigma_deg);
    }
    ++out.passes;
  }

  for (size_t i = 0; i < num_texels; ++i) {
    if (texel_cluster[i] < 0 || out.flags[i] != 0) continue;
    const double tilt = std::acos(std::clamp(static_cast<double>(out.m[i].z), -1.0, 1.0)) * kDegrees;
    if (tilt > in.options.max_tilt_deg) out.flags[i] = fit::kNormalAtTiltLimit;
  }
  CountNormals(texel_cluster, &out);
  return out;
}

void CountNormals(const std::vector<int32_t>& texel_cluster, TexelNormals* normals) {
  TexelNormals& out = *normals;
  out.texels = out.refined_texels = out.few_observations = out.coplanar = out.tilt_limit = out.not_significant =
      out.cluster_no_better = 0;
  std::vector<double> tilts, sigmas;
  for (size_t i = 0; i < texel_cluster.size(); ++i) {
    out.refined[i] = 0;
    if (texel_cluster[i] < 0) continue;
    ++out.texels;
    if (out.flags[i] != 0) {
      out.m[i] = glm::vec3(0.0f, 0.0f, 1.0f);
      out.sigma_deg[i] = -1.0f;
      if (out.flags[i] & fit::kNormalFewObservations) ++out.few_observations;
      if (out.flags[i] & fit::kNormalCoplanarLights) ++out.coplanar;
      if (out.flags[i] & fit::kNormalAtTiltLimit) ++out.tilt_limit;
      if (out.flags[i] & fit::kNormalNotSignificant) ++out.not_significant;
      if (out.flags[i] & kNormalClusterNoBetter) ++out.cluster_no_better;
      continue;
    }
    out.refined[i] = 1;
    ++out.refined_texels;
    tilts.push_back(std::acos(std::clamp(static_cast<double>(out.m[i].z), -1.0, 1.0)) * kDegrees);
    if (out.sigma_deg[i] >= 0.0f) sigmas.push_back(out.sigma_deg[i]);
  }
  out.median_tilt_deg = Quantile(tilts, 0.5);
  out.median_sigma_deg = Quantile(sigmas, 0.5);
}

cv::Mat EncodeNormalMap(const cv::Mat& tangent_normals) {
  const auto code = [](double c) {
    return static_cast<uint8_t>(std::lround(255.0 * std::clamp(0.5 * (c + 1.0), 0.0, 1.0)));
  };
  cv::Mat png(tangent_normals.size(), CV_8UC3);
  for (int y = 0; y < png.rows; ++y) {
    for (int x = 0; x < png.cols; ++x) {
      const cv::Vec3f& m = tangent_normals.at<cv::Vec3f>(y, x);
      const bool valid = m[2] > 0.0f;  // texels outside every chart: the flat normal
      png.at<cv::Vec3b>(y, x) = {code(valid ? m[2] : 1.0), code(valid ? m[1] : 0.0),
                                 code(valid ? m[0] : 0.0)};  // OpenCV's B, G, R
    }
  }
  return png;
}

absl::Status WriteNormalAtlases(const TexelNormals& normals, const std::vector<int32_t>& texel_cluster, int size,
                                int grow_iterations, const std::filesystem::path& dir) {
  cv::Mat m(size, size, CV_32FC4, cv::Scalar::all(0)), sigma(size, size, CV_32FC1, cv::Scalar(-1.0f));
  for (size_t i = 0; i < texel_cluster.size(); ++i) {
    if (texel_cluster[i] < 0) continue;
    const int y = static_cast<int>(i / static_cast<size_t>(size)), x = static_cast<int>(i % static_cast<size_t>(size));
    const glm::vec3& n = normals.m[i];
    m.at<cv::Vec4f>(y, x) = {n.x, n.y, n.z, 1.0f};
    sigma.at<float>(y, x) = normals.sigma_deg[i];
  }
  const cv::Mat grown = resample::GrowAtlas(m, grow_iterations);
  cv::Mat rgb;
  cv::cvtColor(grown, rgb, cv::COLOR_BGRA2BGR);  // drops alpha, keeps the channel order
  MVBRDF_RETURN_IF_ERROR(image::WriteExr(dir / "normal.exr", rgb));
  MVBRDF_RETURN_IF_ERROR(image::WriteExr(dir / "normal_sigma.exr", sigma));
  const std::filesystem::path file = dir / "normal.png";
  if (!cv::imwrite(file.string(), EncodeNormalMap(rgb))) {
    return absl::InternalError(absl::StrCat("cannot write ", file.string()));
  }
  return absl::OkStatus();
}

}  // namespace mvbrdf::pipeline
