#include "core/evaluate/reconstruction_evaluator.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <vector>

#include <glm/glm.hpp>

#include "absl/strings/str_cat.h"
#include "core/base/quantile.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/brdf/ggx.h"
#include "core/brdf/model.h"
#include "core/evaluate/calibration_truth.h"
#include "core/render/normal_detail.h"
#include "core/image/exr.h"
#include "core/scene/fingerprint.h"
#include "core/scene/sequence.h"
#include "core/synth/ground_truth.h"

namespace mvbrdf::evaluate {
namespace {

absl::StatusOr<cv::Mat> ReadImage(const std::filesystem::path& file, int type, int size) {
  MVBRDF_ASSIGN_OR_RETURN(image::ExrImage exr, image::ReadExr(file));
  if (exr.image.type() != type || (size > 0 && exr.image.rows != size)) {
    return absl::InvalidArgumentError(absl::StrCat(file.string(), ": unexpected image type or size"));
  }
  return exr.image;
}

// The truth's idea of the scene: its own fingerprint when synth wrote one,
// else what every truth file has (triangle count, cameras as rendered).
v1::SceneFingerprint TruthFingerprint(const v1::GroundTruth& truth) {
  v1::SceneFingerprint fp = truth.scene();
  if (fp.mesh_triangles() == 0) fp.set_mesh_triangles(static_cast<uint64_t>(truth.triangle_materials_size()));
  if (fp.cameras_size() == 0) {
    for (const v1::Camera& c : truth.cameras()) *fp.add_cameras() = scene::CameraFingerprintOf(c);
  }
  return fp;
}

// Before any work: the error atlas is a .png or .exr file name, not a directory.
absl::Status CheckErrorAtlasPath(const std::filesystem::path& file) {
  const std::string ext = file.extension().string();
  if (ext != ".png" && ext != ".exr") {
    return absl::InvalidArgumentError(
        absl::StrCat("error atlas ", file.string(), ": expected a file name ending in .png or .exr"));
  }
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec)) {
    return absl::InvalidArgumentError(absl::StrCat("error atlas ", file.string(), ": is a directory"));
  }
  return absl::OkStatus();
}

// The run's scene file: `scene` when given, else result.json's (relative to
// the run directory), else the scene.json of the truth's bundle; nullopt
// when none exists.
}  // namespace

std::optional<std::filesystem::path> SceneOfRun(const std::filesystem::path& run_dir, const v1::RunReport& run,
                                                const std::filesystem::path& truth_file,
                                                const std::filesystem::path& scene) {
  std::error_code ec;
  if (!scene.empty()) return scene;
  if (!run.scene().empty() && run.bundle_sha256().empty()) {
    // operator/ keeps an absolute path as it is.
    const std::filesystem::path p = run_dir / run.scene();
    if (std::filesystem::is_regular_file(p, ec)) return p;
  }
  const std::filesystem::path beside = truth_file.parent_path().parent_path() / "scene.json";
  if (std::filesystem::is_regular_file(beside, ec)) return beside;
  return std::nullopt;
}

std::filesystem::path TruthFileOf(const std::filesystem::path& truth) {
  std::filesystem::path truth_file = truth / "truth.json";
  if (!std::filesystem::exists(truth_file)) truth_file = truth / "ground_truth" / "truth.json";
  return truth_file;
}

namespace {

double RelativeError(double value, double truth) {
  return std::abs(value - truth) / std::max(std::abs(truth), 1e-12);
}

}  // namespace

absl::StatusOr<v1::EvaluationReport> EvaluateReconstruction(const std::filesystem::path& run_dir,
                                                            const std::filesystem::path& truth_path,
                                                            const std::filesystem::path& error_atlas,
                                                            const std::filesystem::path& scene,
                                                            const std::filesystem::path& kd_texels_of) {
  if (!error_atlas.empty()) MVBRDF_RETURN_IF_ERROR(CheckErrorAtlasPath(error_atlas));
  const std::filesystem::path truth_file = TruthFileOf(truth_path);
  MVBRDF_ASSIGN_OR_RETURN(const synth::GroundTruth truth, synth::GroundTruth::Load(truth_file));
  MVBRDF_ASSIGN_OR_RETURN(const v1::RunReport run, ReadJsonFileAs<v1::RunReport>(run_dir / "result.json"));
  // A truth of another scene must not give figures (it gave
  // "configurationCorrect": true for another mesh and other cameras).
  if (run.has_input()) {
    const absl::Status same =
        scene::CompareFingerprints(run.input(), TruthFingerprint(truth.message()),
                                   absl::StrCat("the run (", (run_dir / "result.json").string(), ")"),
                                   absl::StrCat("the truth (", truth_file.string(), ")"));
    if (!same.ok()) return absl::InvalidArgumentError(absl::StrCat("--truth: ", same.message()));
  }

  v1::EvaluationReport report;
  report.set_chosen_configuration(run.chosen_configuration());
  report.set_true_configuration(truth.message().active_configuration());
  report.set_configuration_correct(run.chosen_configuration() == truth.message().active_configuration());
  // Issue #14: cameras and lights as used against the truth (needs the scene).
  if (const std::optional<std::filesystem::path> scene_file = SceneOfRun(run_dir, run, truth_file, scene);
      scene_file.has_value()) {
    scene::LoadOptions load;
    load.check_all_frames = false;
    load.probe_videos = false;
    if (absl::StatusOr<scene::Sequence> sequence = scene::LoadSequence(*scene_file, load); sequence.ok()) {
      AddCalibrationTruth(run, truth, *sequence, &report);
    }
  }
  if (run.clusters_size() == 0) return report;  // light table only
  const double exposure = truth.message().perturbations().exposure();
  const float gain = exposure > 0.0 ? static_cast<float>(exposure) : 1.0f;
  report.set_truth_gain(gain);

  MVBRDF_ASSIGN_OR_RETURN(const cv::Mat triangle_id, ReadImage(run_dir / "atlas" / "triangle_id.exr", CV_32SC1, 0));
  const int size = triangle_id.rows;
  MVBRDF_ASSIGN_OR_RETURN(const cv::Mat rest, ReadImage(run_dir / "atlas" / "rest_position.exr", CV_32FC4, size));
  MVBRDF_ASSIGN_OR_RETURN(const cv::Mat kd, ReadImage(run_dir / "atlases" / "kd.exr", CV_32FC3, size));
  MVBRDF_ASSIGN_OR_RETURN(const cv::Mat confidence, ReadImage(run_dir / "atlases" / "confidence.exr", CV_32FC1, size));
  MVBRDF_ASSIGN_OR_RETURN(const cv::Mat cluster, ReadImage(run_dir / "atlases" / "cluster.exr", CV_32SC1, size));
  // The texels the kd figures are taken over: this run's seen >= 10 times, or
  // another run's (the same atlas: its triangle ids must match).
  cv::Mat kd_counts = confidence;
  if (!kd_texels_of.empty()) {
    MVBRDF_ASSIGN_OR_RETURN(const cv::Mat other_ids, ReadImage(kd_texels_of / "atlas" / "triangle_id.exr", CV_32SC1, 0));
    if (other_ids.rows != size || cv::countNonZero(other_ids != triangle_id) != 0) {
      return absl::InvalidArgumentError(absl::StrCat("--kd-texels-of ", kd_texels_of.string(),
                                                     ": not the same atlas as the run's (atlas/triangle_id.exr differs)"));
    }
    MVBRDF_ASSIGN_OR_RETURN(kd_counts, ReadImage(kd_texels_of / "atlases" / "confidence.exr", CV_32FC1, size));
    report.set_kd_texels_of(kd_texels_of.string());
  }

  const int num_clusters = run.clusters_size();
  const int num_materials = truth.message().materials_size();
  // votes[cluster][material]
  std::vector<std::vector<uint64_t>> votes(static_cast<size_t>(num_clusters),
                                           std::vector<uint64_t>(static_cast<size_t>(num_materials), 0));
  double sq10 = 0.0, sq_all = 0.0;
  uint64_t n10 = 0, n_all = 0, measured_texels = 0;
  std::vector<int32_t> texel_material(static_cast<size_t>(size) * size, -1);
  std::vector<double> abs_errors;
  cv::Mat error_image(size, size, CV_32FC4, cv::Scalar::all(0));
  cv::Mat truth_image(size, size, CV_32FC4, cv::Scalar::all(0));
  std::vector<double> cluster_sq(static_cast<size_t>(num_clusters), 0.0);
  std::vector<uint64_t> cluster_n(static_cast<size_t>(num_clusters), 0);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const int32_t tri = triangle_id.at<int32_t>(y, x);
      const float count = confidence.at<float>(y, x);
      const float kd_count = kd_counts.at<float>(y, x);
      const cv::Vec4f& p = rest.at<cv::Vec4f>(y, x);
      if (tri < 0 || (count <= 0.0f && kd_count < kMinObservationsForKd) || p[3] < 0.5f) continue;
      if (tri >= truth.message().triangle_materials_size()) {
        return absl::InvalidArgumentError(absl::StrCat("--truth: the run's atlas names triangle ", tri,
                                                       ", the truth has ", truth.message().triangle_materials_size(),
                                                       " triangles (not the same mesh)"));
      }
      const uint32_t material = truth.message().triangle_materials(tri);
      if (count > 0.0f) texel_material[static_cast<size_t>(y) * size + x] = static_cast<int32_t>(material);
      const int32_t k_cluster = cluster.at<int32_t>(y, x);
      if (count > 0.0f && k_cluster >= 0 && k_cluster < num_clusters) ++votes[static_cast<size_t>(k_cluster)][material];
      // A measured material has no kd to compare with (issue #15).
      if (truth.IsMeasured(static_cast<int>(material))) {
        if (count > 0.0f) ++measured_texels;
        continue;
      }
      const glm::vec2 uv((x + 0.5f) / size, 1.0f - (y + 0.5f) / size);
      render::PhongParams t = truth.At(static_cast<uint32_t>(tri), {p[0], p[1], p[2]}, uv);
      t.kd *= gain;
      const cv::Vec3f& k = kd.at<cv::Vec3f>(y, x);
      double sq = 0.0;
      for (int c = 0; c < 3; ++c) sq += (k[c] - t.kd[c]) * (k[c] - t.kd[c]);
      if (count > 0.0f) {  // seen by this run
        truth_image.at<cv::Vec4f>(y, x) = {t.kd[0], t.kd[1], t.kd[2], 1.0f};
        error_image.at<cv::Vec4f>(y, x) = {std::abs(k[0] - t.kd[0]), std::abs(k[1] - t.kd[1]),
                                           std::abs(k[2] - t.kd[2]), 1.0f};
        sq_all += sq;
        ++n_all;
      }
      const int32_t texel_cluster = cluster.at<int32_t>(y, x);
      if (kd_count >= kMinObservationsForKd) {
        sq10 += sq;
        ++n10;
        if (texel_cluster >= 0 && texel_cluster < num_clusters) {
          cluster_sq[static_cast<size_t>(texel_cluster)] += sq;
          ++cluster_n[static_cast<size_t>(texel_cluster)];
        }
        abs_errors.push_back((std::abs(k[0] - t.kd[0]) + std::abs(k[1] - t.kd[1]) + std::abs(k[2] - t.kd[2])) / 3.0);
      }
    }
  }
  report.set_kd_rmse(n10 > 0 ? std::sqrt(sq10 / (3.0 * static_cast<double>(n10))) : 0.0);
  report.set_kd_texels(n10);
  report.set_measured_texels(measured_texels);
  if (!abs_errors.empty()) {
    std::sort(abs_errors.begin(), abs_errors.end());
    report.set_kd_median_abs_error(abs_errors[abs_errors.size() / 2]);
    report.set_kd_p95_abs_error(abs_errors[abs_errors.size() * 95 / 100]);
  }
  if (!error_atlas.empty()) {
    // Beside it, the true kd of the same texels (for people to compare with
    // atlases/kd.png).
    std::filesystem::path truth_file = error_atlas;
    truth_file.replace_filename(error_atlas.stem().string() + "_truth_kd" + error_atlas.extension().string());
    if (error_atlas.extension() == ".exr") {
      MVBRDF_RETURN_IF_ERROR(image::WriteExr(error_atlas, error_image));
      MVBRDF_RETURN_IF_ERROR(image::WriteExr(truth_file, truth_image));
    } else {
      MVBRDF_RETURN_IF_ERROR(image::WritePngPreview(error_atlas, error_image, 10.0f));
      MVBRDF_RETURN_IF_ERROR(image::WritePngPreview(truth_file, truth_image));
    }
  }
  report.set_kd_rmse_all_seen(n_all > 0 ? std::sqrt(sq_all / (3.0 * static_cast<double>(n_all))) : 0.0);

  // The model of each cluster: its row's (--brdf auto picks per cluster),
  // else the run's.
  const auto model_of = [&](const v1::ClusterRow& row) -> absl::StatusOr<brdf::Model> {
    const std::string& name = !row.brdf().empty() ? row.brdf() : run.brdf();
    // A row without parameters (flagged tiny or no_samples) of an auto run.
    if (name.empty() || name == "auto") return brdf::Model::kPhong;
    absl::StatusOr<brdf::Model> parsed = brdf::ParseModel(name);
    if (!parsed.ok()) {
      return absl::InvalidArgumentError(absl::StrCat("result.json: cluster \"", row.name(), "\": brdf: ",
                                                     parsed.status().message()));
    }
    return *parsed;
  };
  std::vector<int32_t> cluster_material(static_cast<size_t>(num_clusters), -1);
  for (int k = 0; k < num_clusters; ++k) {
    uint64_t best = 0;
    for (int m = 0; m < num_materials; ++m) {
      if (votes[static_cast<size_t>(k)][static_cast<size_t>(m)] > best) {
        best = votes[static_cast<size_t>(k)][static_cast<size_t>(m)];
        cluster_material[static_cast<size_t>(k)] = m;
      }
    }
    v1::MaterialComparison* cmp = report.add_clusters();
    const v1::ClusterRow& row = run.clusters(k);
    MVBRDF_ASSIGN_OR_RETURN(const brdf::Model run_model, model_of(row));
    cmp->set_cluster(row.name());
    cmp->set_kd_texels(cluster_n[static_cast<size_t>(k)]);
    if (cluster_n[static_cast<size_t>(k)] > 0) {
      cmp->set_kd_rmse(std::sqrt(cluster_sq[static_cast<size_t>(k)] / (3.0 * cluster_n[static_cast<size_t>(k)])));
    }
    if (cluster_material[static_cast<size_t>(k)] < 0) continue;
    const v1::Material& m = truth.message().materials(cluster_material[static_cast<size_t>(k)]);
    cmp->set_material(m.name());
    // The model's two parameters (issue #15): comparable only when the run
    // fitted the model the truth was rendered with. The first (ks, F0)
    // scales with the data's units (gain), the second does not.
    cmp->set_brdf(brdf::ModelName(run_model));
    const bool measured = truth.IsMeasured(cluster_material[static_cast<size_t>(k)]);
    cmp->set_truth_brdf(measured ? absl::StrCat("measured ", m.measured()) : brdf::ModelName(truth.Model()));
    const bool ggx = run_model == brdf::Model::kGgx;
    const auto& p0 = ggx ? row.f0() : row.ks();
    const auto& p1 = ggx ? row.roughness() : row.ke();
    if (measured || run_model != truth.Model() || p0.size() != 3 || p1.size() != 3) continue;
    cmp->set_parameters_compared(true);
    const auto [true_p0, true_p1] = truth.Parameters(m);
    double ks_err = 0.0, ke_err = 0.0;
    for (int c = 0; c < 3; ++c) {
      cmp->add_ks(p0[c]);
      cmp->add_ks_true(gain * true_p0[c]);
      cmp->add_ke(p1[c]);
      cmp->add_ke_true(true_p1[c]);
      ks_err += RelativeError(p0[c], gain * true_p0[c]) / 3.0;
      ke_err += RelativeError(p1[c], true_p1[c]) / 3.0;
    }
    cmp->set_ks_rel_error(ks_err);
    cmp->set_ke_rel_error(ke_err);
    if (ggx && row.f90_ratio_size() == 3) {
      double ratio_err = 0.0;
      for (int c = 0; c < 3; ++c) {
        cmp->add_f90_ratio(row.f90_ratio(c));
        cmp->add_f90_ratio_true(brdf::Ggx::kDielectricRatio);
        ratio_err += RelativeError(row.f90_ratio(c), brdf::Ggx::kDielectricRatio) / 3.0;
      }
      cmp->set_f90_ratio_rel_error(ratio_err);
    }
  }
  uint64_t correct = 0, assigned = 0;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const int32_t k = cluster.at<int32_t>(y, x);
      const int32_t m = texel_material[static_cast<size_t>(y) * size + x];
      if (k < 0 || k >= num_clusters || m < 0) continue;
      ++assigned;
      if (cluster_material[static_cast<size_t>(k)] == m) ++correct;
    }
  }
  report.set_cluster_accuracy(assigned > 0 ? static_cast<double>(correct) / static_cast<double>(assigned) : 0.0);

  // Issue #18: normals against the truth's detail, in tangent space: the run
  // reads its normals in the frames of the atlas's UVs, the truth in those of
  // the scene mesh's (synth --normal-detail writes them), the same frames
  // when the run kept the mesh's UVs (atlas.keep_existing_uvs, the default).
  // A truth without detail has the mesh's normals (m = z): a run's refined
  // normals are then measured against those.
  const bool refined = std::filesystem::exists(run_dir / "atlases" / "normal.exr");
  if (truth.message().has_normal_detail() || refined) {
    const render::NormalDetail detail = truth.Detail();
    cv::Mat normal;
    if (refined) {
      MVBRDF_ASSIGN_OR_RETURN(normal, ReadImage(run_dir / "atlases" / "normal.exr", CV_32FC3, size));
    }
    std::vector<double> errors, mesh_errors;
    const auto angle = [](const glm::vec3& a, const glm::vec3& b) {
      return std::acos(std::clamp(static_cast<double>(glm::dot(glm::normalize(a), glm::normalize(b))), -1.0, 1.0)) *
             180.0 / 3.14159265358979323846;
    };
    for (int y = 0; y < size; ++y) {
      for (int x = 0; x < size; ++x) {
        const cv::Vec4f& p = rest.at<cv::Vec4f>(y, x);
        if (triangle_id.at<int32_t>(y, x) < 0 || p[3] < 0.5f || cluster.at<int32_t>(y, x) < 0 ||
            kd_counts.at<float>(y, x) < kMinObservationsForKd) {
          continue;
        }
        const glm::vec3 m_true = render::NormalDetailAt(detail, glm::vec3(p[0], p[1], p[2]));
        glm::vec3 m(0.0f, 0.0f, 1.0f);
        if (refined) {
          const cv::Vec3f& v = normal.at<cv::Vec3f>(y, x);
          if (v[2] > 0.0f) m = glm::vec3(v[0], v[1], v[2]);
        }
        errors.push_back(angle(m, m_true));
        mesh_errors.push_back(angle(glm::vec3(0.0f, 0.0f, 1.0f), m_true));
      }
    }
    v1::NormalEvaluation* n = report.mutable_normals();
    n->set_texels(errors.size());
    n->set_refined(refined);
    n->set_median_deg(Quantile(errors, 0.5));
    n->set_p90_deg(Quantile(errors, 0.9));
    n->set_mesh_median_deg(Quantile(mesh_errors, 0.5));
    n->set_mesh_p90_deg(Quantile(mesh_errors, 0.9));
  }
  return report;
}

}  // namespace mvbrdf::evaluate
