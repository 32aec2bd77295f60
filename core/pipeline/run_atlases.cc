#include "core/pipeline/run_atlases.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/image/exr.h"
#include "core/pipeline/reconstruct_stage.h"
#include "core/resample/atlas_ops.h"

namespace mvbrdf::pipeline {
namespace {

absl::StatusOr<cv::Mat> ReadAtlasExr(const std::filesystem::path& file, int type, const char* what) {
  MVBRDF_ASSIGN_OR_RETURN(image::ExrImage exr, image::ReadExr(file));
  if (exr.image.type() != type) return absl::InvalidArgumentError(absl::StrCat(file.string(), ": expected ", what));
  return exr.image;
}

}  // namespace

absl::StatusOr<atlas::Atlas> OpenRunAtlas(const std::filesystem::path& run_dir, const v1::RunReport& run,
                                          const scene::Sequence& sequence) {
  atlas::AtlasOptions atlas_options;
  atlas_options.size = static_cast<int>(run.atlas().size());
  MVBRDF_ASSIGN_OR_RETURN(atlas::Atlas atlas,
                          atlas::BuildAtlas(sequence.topology, sequence.rest_positions, atlas_options));
  MVBRDF_ASSIGN_OR_RETURN(const image::ExrImage ids, image::ReadExr(run_dir / "atlas" / "triangle_id.exr"));
  if (ids.image.size() != atlas.triangle_id.size() || cv::norm(ids.image, atlas.triangle_id, cv::NORM_INF) != 0) {
    return absl::FailedPreconditionError(
        absl::StrCat(run_dir.string(), "/atlas/triangle_id.exr: the run's atlas differs from the one built now"));
  }
  return atlas;
}

absl::StatusOr<RunAtlases> ReadRunAtlases(const std::filesystem::path& run_dir, const v1::RunReport& run) {
  RunAtlases a;
  const std::filesystem::path dir = run_dir / "atlases";
  MVBRDF_ASSIGN_OR_RETURN(a.kd, ReadAtlasExr(dir / "kd.exr", CV_32FC3, "RGB"));
  // The model's two parameter atlases (issue #15: ks, ke; GGX's f0, roughness).
  a.per_texel_model = run.brdf() == "auto";  // --brdf auto: model.png, parameter_1, parameter_2
  if (!run.brdf().empty() && !a.per_texel_model) {
    absl::StatusOr<brdf::Model> parsed = brdf::ParseModel(run.brdf());
    if (!parsed.ok()) {
      return absl::FailedPreconditionError(
          absl::StrCat(run_dir.string(), "/result.json: brdf: ", parsed.status().message()));
    }
    a.model = *parsed;
  }
  const std::array<std::string, 2> names =
      a.per_texel_model
          ? std::array<std::string, 2>{"parameter_1", "parameter_2"}
          : std::array<std::string, 2>{brdf::ParameterNames(a.model)[0], brdf::ParameterNames(a.model)[1]};
  MVBRDF_ASSIGN_OR_RETURN(a.p1, ReadAtlasExr(dir / absl::StrCat(names[0], ".exr"), CV_32FC3, "RGB"));
  MVBRDF_ASSIGN_OR_RETURN(a.p2, ReadAtlasExr(dir / absl::StrCat(names[1], ".exr"), CV_32FC3, "RGB"));
  const std::filesystem::path p3_file =
      dir / (a.per_texel_model ? std::string("parameter_3.exr")
                               : absl::StrCat(brdf::ParameterNames(a.model)[2], ".exr"));
  if (brdf::NumParameters(a.model) > 2 || a.per_texel_model) {
    std::error_code error;
    if (std::filesystem::exists(p3_file, error)) {
      MVBRDF_ASSIGN_OR_RETURN(a.p3, ReadAtlasExr(p3_file, CV_32FC3, "RGB"));
      if (a.p3.size() != a.kd.size()) {
        return absl::InvalidArgumentError(absl::StrCat(p3_file.string(), ": not the kd atlas's size"));
      }
    }
  }
  MVBRDF_ASSIGN_OR_RETURN(a.confidence, ReadAtlasExr(dir / "confidence.exr", CV_32FC1, "one channel"));
  if (a.p1.size() != a.kd.size() || a.p2.size() != a.kd.size() || a.confidence.size() != a.kd.size()) {
    return absl::InvalidArgumentError(absl::StrCat(dir.string(), ": the atlases differ in size"));
  }
  if (a.per_texel_model) {
    const std::filesystem::path file = dir / "model.png";
    a.model_atlas = cv::imread(file.string(), cv::IMREAD_GRAYSCALE);
    if (a.model_atlas.empty() || a.model_atlas.size() != a.kd.size()) {
      return absl::FailedPreconditionError(
          absl::StrCat(file.string(), ": missing, unreadable or not the kd atlas's size (--brdf auto's model atlas)"));
    }
    // Texels of no cluster (255) draw as Phong with the parameters 0 there.
    for (auto it = a.model_atlas.begin<uint8_t>(); it != a.model_atlas.end<uint8_t>(); ++it) {
      if (*it >= brdf::kModels.size()) *it = static_cast<uint8_t>(brdf::Model::kPhong);
    }
  }
  return a;
}

absl::StatusOr<cv::Mat> GgxSupportAtlas(const std::filesystem::path& run_dir, const v1::RunReport& run, int size) {
  std::vector<float> support(static_cast<size_t>(run.clusters_size()), 0.0f);
  bool any = false;
  for (int k = 0; k < run.clusters_size(); ++k) {
    support[static_cast<size_t>(k)] = static_cast<float>(run.clusters(k).ggx_grazing_support());
    any |= support[static_cast<size_t>(k)] > 0.0f;
  }
  if (!any) return cv::Mat();
  const std::filesystem::path file = run_dir / "atlases" / "cluster.exr";
  MVBRDF_ASSIGN_OR_RETURN(const cv::Mat cluster, ReadAtlasExr(file, CV_32SC1, "one integer channel"));
  if (cluster.rows != size || cluster.cols != size) {
    return absl::InvalidArgumentError(absl::StrCat(file.string(), ": not the kd atlas's size"));
  }
  cv::Mat rgba(size, size, CV_32FC4, cv::Scalar::all(0));
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const int32_t k = cluster.at<int32_t>(y, x);
      if (k < 0) continue;
      if (k >= run.clusters_size()) {
        return absl::InvalidArgumentError(
            absl::StrCat(file.string(), ": texel (", x, ", ", y, ") names cluster ", k, " of ", run.clusters_size()));
      }
      const float s = support[static_cast<size_t>(k)];
      rgba.at<cv::Vec4f>(y, x) = {s, s, s, 1.0f};
    }
  }
  const v1::FittingOptions& fitting = run.options().fitting();
  const int grow = fitting.has_grow_iterations() ? static_cast<int>(fitting.grow_iterations())
                                                 : ReconstructOptions().grow_iterations;
  cv::Mat rgb;
  cv::cvtColor(resample::GrowAtlas(rgba, grow), rgb, cv::COLOR_RGBA2RGB);
  return rgb;
}

}  // namespace mvbrdf::pipeline
