#include "core/pipeline/reconstruct_stage.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <unordered_map>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/atlas/texel_graph.h"
#include "core/base/files.h"
#include "core/base/process_stats.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/base/version.h"
#include "core/brdf/ggx.h"
#include "core/calibrate/refine_lights.h"
#include "core/cluster/kmeans.h"
#include "core/cluster/label_smoothing.h"
#include "core/fit/light_sweep.h"
#include "core/fit/grazing_support.h"
#include "core/fit/lobe_fit.h"
#include "core/fit/lobe_texel_kd_fit.h"
#include "core/fit/model_selection.h"
#include "core/fit/texel_kd_fit.h"
#include "core/image/exr.h"
#include "core/pipeline/atlas_figures.h"
#include "core/pipeline/atlas_parts.h"
#include "core/pipeline/calibration_stage.h"
#include "core/pipeline/frame_stream.h"
#include "core/pipeline/gather_stage.h"
#include "core/pipeline/light_table.h"
#include "core/pipeline/normal_stage.h"
#include "core/pipeline/refine_lights_stage.h"
#include "core/pipeline/run_scene.h"
#include "core/pipeline/texel_shading.h"
#include "core/pipeline/texel_reservoir.h"
#include "core/resample/atlas_ops.h"
#include "core/samples/sample_set.h"
#include "core/scene/atlas_mesh.h"
#include "core/scene/fingerprint.h"
#include "core/scene/mesh_loader.h"
#include "core/scene/names.h"
#include "core/scene/video_source.h"

namespace mvbrdf::pipeline {
namespace {

// One texel observation of the frame as the camera-error pass needs it once
// the frame's observed kd is known: its cluster's G and specular term as the
// fold computed them (Phong: the sums before ks, SpecularSums; the other
// models: S), so that the terms are not assembled and shaded twice.
struct ErrorObservation {
  uint32_t texel;
  int32_t cluster;
  glm::vec3 rgb, illumination, specular;
};

// The texel pass's sums over texels per atlas part (atlas_parts.h).
struct FoldPart {
  std::vector<uint64_t> outliers, observations;  // per cluster
  std::vector<double> s_rr, corr_sq;             // per camera
  std::vector<uint64_t> count;                   // per camera
  // Per camera: this frame's observations in the part, in the fold's order.
  std::vector<std::vector<ErrorObservation>> frame_observations;
};

// The key of the texel pass's observed kd atlases in their ResampledAtlasCache.
constexpr char kObservedKey[] = "observed kd";

// Frame t's correction atlas c = kd_o - kd (half-float RGB) from its observed
// kd_o (the texel pass's): kept in `kept` (may be null) when it has it, else
// in observed_dir; named by the frame's number.
absl::Status WriteCorrectionAtlas(const ResampledAtlasCache* kept, const std::filesystem::path& observed_dir, int t,
                                  const scene::Sequence& sequence, const std::vector<glm::vec3>& kd, int size,
                                  const std::filesystem::path& dir) {
  image::ExrImage observed;
  if (kept != nullptr && kept->Contains(t, 0, kObservedKey)) {
    std::optional<ResampledAtlasCache::Kept> found = kept->Find(t, 0, kObservedKey);
    if (!found.has_value()) {
      return absl::UnavailableError(absl::StrCat("frame ", t,
                                                 ": its observed kd could not be read back from the temporary file "
                                                 "(an I/O error in TMPDIR)"));
    }
    observed.image = std::move(found->atlas);
  } else {
    MVBRDF_ASSIGN_OR_RETURN(observed, image::ReadExr(observed_dir / absl::StrCat(t, ".exr")));
  }
  cv::Mat corr(size, size, CV_32FC3, cv::Scalar::all(0));
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const cv::Vec4f& o = observed.image.at<cv::Vec4f>(y, x);
      if (o[3] < 0.5f) continue;
      const glm::vec3& k = kd[static_cast<size_t>(y) * size + x];
      corr.at<cv::Vec3f>(y, x) = {o[0] - k.x, o[1] - k.y, o[2] - k.z};
    }
  }
  char name[32];
  std::snprintf(name, sizeof(name), "%04d.exr", sequence.AbsoluteFrame(t));
  image::ExrOptions half;
  half.half = true;
  return image::WriteExr(dir / name, corr, half);
}

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

void AddStage(v1::RunReport* report, const char* name, double seconds, const ReconstructOptions& options) {
  if (options.progress) options.progress(name, 1, 1);
  v1::StageRow* row = report->add_stages();
  row->set_name(name);
  row->set_seconds(seconds);
  row->set_peak_rss_bytes(PeakRssBytes());
  if (options.stage_done) options.stage_done(*row);
}

std::vector<std::string> FlagNames(uint32_t flags) {
  std::vector<std::string> names;
  if (flags & fit::kKsKeNotIdentifiable) names.push_back("ks_ke_not_identifiable");
  if (flags & fit::kKdNotIdentifiable) names.push_back("kd_not_identifiable");
  if (flags & fit::kNoSamples) names.push_back("no_samples");
  if (flags & fit::kNonFiniteInput) names.push_back("non_finite_input");
  if (flags & fit::kDidNotConverge) names.push_back("did_not_converge");
  if (flags & fit::kAtBound) names.push_back("at_bound");
  return names;
}

void SolverRowFrom(const std::string& cluster, const fit::PhongFitResult& r, v1::SolverRow* row) {
  row->set_cluster(cluster);
  row->set_solver(fit::SolverName(r.solver));
  double cost = 0.0;
  for (int c = 0; c < 3; ++c) {
    row->add_kd(r.params[c].kd);
    row->add_ks(r.params[c].ks);
    row->add_ke(r.params[c].ke);
    cost += r.channels[c].final_cost;
  }
  row->set_final_cost(cost);
  row->set_mse(r.mse);
  row->set_seconds(r.seconds);
  row->set_samples(r.samples_used);
  for (const std::string& f : FlagNames(r.flags())) row->add_flags(f);
}

// A seed as a linear albedo in the data's units: linear_rgb as given, or
// srgb8 linearised (scene validation allows exactly one of them).
glm::vec3 SeedAlbedo(const v1::MaterialSeed& seed) {
  glm::vec3 out(0.0f);
  if (seed.linear_rgb_size() > 0) {
    for (int c = 0; c < 3 && c < seed.linear_rgb_size(); ++c) out[c] = static_cast<float>(seed.linear_rgb(c));
    return out;
  }
  for (int c = 0; c < 3 && c < seed.srgb8_size(); ++c) out[c] = scene::SrgbToLinear(seed.srgb8(c) / 255.0f);
  return out;
}

// Texels of a cluster for its fit, spread so that their kept Samples add up
// to about `budget` (every kept Sample equally likely to be used, whatever
// the texel it belongs to), in texel order. `kept` counts a texel's Samples.
std::vector<uint32_t> SpreadOverSamples(const std::vector<uint32_t>& texels, size_t budget,
                                        const std::function<size_t(uint32_t)>& kept) {
  size_t total = 0;
  for (uint32_t t : texels) total += kept(t);
  if (total <= budget) return texels;
  const double ratio = static_cast<double>(budget) / static_cast<double>(total);
  std::vector<uint32_t> out;
  double target = 0.0;
  size_t taken = 0;
  for (uint32_t t : texels) {
    const size_t n = kept(t);
    if (n == 0) continue;
    target += ratio * static_cast<double>(n);
    // Error diffusion: take the texel when that keeps `taken` nearer the target.
    if (static_cast<double>(taken) + 0.5 * static_cast<double>(n) <= target) {
      out.push_back(t);
      taken += n;
    }
  }
  return out;
}

// A warning line for a cluster fit's flags (empty when none deserves one).
std::string ClusterFitWarning(const std::string& cluster, uint32_t flags, const fit::PhongFitOptions& options) {
  std::vector<std::string> why;
  if (flags & fit::kKsKeNotIdentifiable) {
    why.push_back(absl::StrCat("ks and ke not identifiable (fewer than ", options.min_highlight_samples,
                               " Samples near a highlight): ks = 0 and ke = ", options.initial.ke,
                               " are placeholders, not measurements"));
  }
  if (flags & fit::kNoSamples) why.push_back("no texel: its kd, ks and ke are the initial guess, unused");
  if (flags & fit::kAtBound) why.push_back("a parameter ended on its bound");
  if (flags & fit::kDidNotConverge) why.push_back("the solver did not converge");
  if (flags & fit::kNonFiniteInput) why.push_back("non-finite Samples were skipped");
  if (why.empty()) return "";
  return absl::StrCat("cluster \"", scene::ShownName(cluster), "\": ", absl::StrJoin(why, "; "));
}

// Per-triangle segment index and per segment the allowed clusters, from the
// scene's segmentation file and segment_materials (seed names).
absl::Status ReadSegments(const scene::Sequence& sequence, const std::vector<std::string>& cluster_names,
                          std::vector<uint32_t>* triangle_segment,
                          std::vector<std::vector<uint32_t>>* allowed) {
  const v1::Scene& scene = sequence.scene;
  if (scene.segmentation_path().empty() || scene.segment_materials_size() == 0) return absl::OkStatus();
  MVBRDF_ASSIGN_OR_RETURN(const std::string text,
                          ReadFileToString(ResolvePath(sequence.scene_dir, scene.segmentation_path())));
  std::vector<std::string> segment_names;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    uint32_t index = 0;
    while (index < segment_names.size() && segment_names[index] != line) ++index;
    if (index == segment_names.size()) segment_names.push_back(line);
    triangle_segment->push_back(index);
  }
  if (triangle_segment->size() != sequence.topology.triangles.size()) {
    return absl::InvalidArgumentError(absl::StrCat("scene.segmentation_path: ", triangle_segment->size(),
                                                   " lines, the mesh has ", sequence.topology.triangles.size(),
                                                   " triangles"));
  }
  allowed->assign(segment_names.size(), {});
  // Segments without an entry allow every cluster.
  for (size_t s = 0; s < segment_names.size(); ++s) {
    bool listed = false;
    for (const v1::SegmentMaterials& sm : scene.segment_materials()) {
      if (sm.segment() != segment_names[s]) continue;
      listed = true;
      for (const std::string& m : sm.materials()) {
        for (uint32_t c = 0; c < cluster_names.size(); ++c) {
          if (cluster_names[c] == m) (*allowed)[s].push_back(c);
        }
      }
    }
    if (!listed || (*allowed)[s].empty()) {
      for (uint32_t c = 0; c < cluster_names.size(); ++c) (*allowed)[s].push_back(c);
    }
  }
  return absl::OkStatus();
}

cv::Mat Rgba(const std::vector<glm::vec3>& rgb, const std::vector<uint8_t>& valid, int size) {
  cv::Mat out(size, size, CV_32FC4, cv::Scalar::all(0));
  for (size_t i = 0; i < rgb.size(); ++i) {
    if (!valid[i]) continue;
    out.at<cv::Vec4f>(static_cast<int>(i / size), static_cast<int>(i % size)) = {rgb[i].x, rgb[i].y, rgb[i].z, 1.0f};
  }
  return out;
}

cv::Mat RgbOf(const cv::Mat& rgba) {
  cv::Mat rgb;
  cv::cvtColor(rgba, rgb, cv::COLOR_RGBA2RGB);
  return rgb;
}

absl::Status WriteRgbAtlas(const std::filesystem::path& stem, const cv::Mat& rgba, float preview_gain) {
  MVBRDF_RETURN_IF_ERROR(image::WriteExr(stem.string() + ".exr", RgbOf(rgba)));
  return image::WritePngPreview(stem.string() + ".png", rgba, preview_gain);
}

// --brdf auto's model atlas (ReconstructOptions::brdf_auto): brdf::Model's
// value per texel, kNoModel where no cluster is; grown by `iterations` rings
// (each empty texel next to a set one takes the lowest of its set
// 8-neighbours) like the parameter atlases, 8-bit PNG.
constexpr uint8_t kNoModel = 255;

absl::Status WriteModelAtlas(const std::filesystem::path& file, cv::Mat model, int iterations) {
  for (int it = 0; it < iterations; ++it) {
    cv::Mat next = model.clone();
    bool grew = false;
    for (int y = 0; y < model.rows; ++y) {
      for (int x = 0; x < model.cols; ++x) {
        if (model.at<uint8_t>(y, x) != kNoModel) continue;
        uint8_t best = kNoModel;
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const int yy = y + dy, xx = x + dx;
            if (yy < 0 || xx < 0 || yy >= model.rows || xx >= model.cols) continue;
            best = std::min(best, model.at<uint8_t>(yy, xx));
          }
        }
        if (best != kNoModel) {
          next.at<uint8_t>(y, x) = best;
          grew = true;
        }
      }
    }
    model = next;
    if (!grew) break;
  }
  if (!cv::imwrite(file.string(), model)) return absl::InternalError(absl::StrCat("cannot write ", file.string()));
  return absl::OkStatus();
}

// Why no texel was seen lit, as precisely as pass 1's statistics tell.
absl::Status NothingLit(const scene::Sequence& sequence, const TexelStatistics& texels, const std::string& chosen,
                        const samples::LightMask& mask) {
  bool observed = false;
  for (uint32_t n : texels.texel_count) observed = observed || n > 0;
  if (!observed) {
    return absl::FailedPreconditionError(
        "no camera observed any texel of the mesh (every camera's view is blocked, e.g. from inside the mesh, or "
        "faces only back faces, or its lens distortion maps the mesh outside the image; check scene.cameras' poses "
        "and intrinsics.distortion)");
  }
  bool some_intensity = false;
  for (size_t k = 0; k < sequence.lights.size(); ++k) {
    const glm::vec3& i = sequence.lights[k].intensity;
    if (mask.Test(k) && i.x > 0.0f && i.y > 0.0f && i.z > 0.0f) some_intensity = true;
  }
  if (!some_intensity) {
    return absl::FailedPreconditionError(absl::StrCat("light configuration \"", chosen,
                                                      "\": no light of it has intensity > 0 in every channel, so no "
                                                      "observed texel is lit (scene.lights[].intensity)"));
  }
  return absl::FailedPreconditionError(absl::StrCat(
      "light configuration \"", chosen,
      "\": every texel the cameras observed is unlit by its lights (they face away from the observed surfaces or are "
      "shadowed on all of them; check scene.lights' positions and directions)"));
}

}  // namespace

absl::StatusOr<v1::RunReport> NewRunReport(const scene::Sequence& sequence, const ReconstructOptions& options,
                                           const std::string& gl_renderer) {
  v1::RunReport report;
  if (!options.bundle_sha256.empty()) {
    report.set_scene(options.scene_in_bundle);
    report.set_bundle_sha256(options.bundle_sha256);
  } else if (!options.out_dir.empty()) {
    report.set_scene(SceneRelativeTo(sequence.scene_file, options.out_dir));
  } else {
    report.set_scene(sequence.scene_file.string());
  }
  report.set_mvbrdf_version(std::string(MvbrdfVersion()));
  report.set_git_commit(std::string(GitCommit()));
  *report.mutable_options() = options.run_options;
  // The rule ChooseConfiguration applies (the worker records the same).
  report.mutable_options()->mutable_fitting()->set_sweep_criterion(options.sweep_criterion);
  report.set_frames(static_cast<uint32_t>(sequence.num_frames));
  report.set_gl_renderer(gl_renderer);
  report.set_configuration_rule("lowest E_d; E_a breaks ties");
  *report.mutable_input() = scene::Fingerprint(sequence);
  MVBRDF_ASSIGN_OR_RETURN(const Plan plan, MakePlan(sequence, options.request));
  plan.ToProto(report.mutable_plan());
  NoteSweepFrames(options, sequence.num_frames, report.mutable_plan());
  // Validation renormalises directions within 1e-3 of unit length (scene::Light).
  for (int i = 0; i < sequence.scene.lights_size(); ++i) {
    const auto& d = sequence.scene.lights(i).direction();
    if (d.size() != 3) continue;
    const double length = std::sqrt(d.Get(0) * d.Get(0) + d.Get(1) * d.Get(1) + d.Get(2) * d.Get(2));
    if (std::abs(length - 1.0) > 1e-6) {
      report.add_warnings(absl::StrCat("scene.lights[", i, "].direction has length ", length,
                                       ": renormalised to unit length"));
    }
  }
  return report;
}

absl::Status CheckMetricsFinite(const v1::RunReport& report) {
  const auto bad = [](absl::string_view what, double value) {
    return absl::FailedPreconditionError(
        absl::StrCat(what, " is ", value,
                     ", not a finite number (input values out of range? e.g. light intensities "
                     "or coordinates far beyond the scene's scale, or frames of nothing but 0 or NaN)"));
  };
  for (const v1::LightConfigurationRow& r : report.light_configurations()) {
    if (!std::isfinite(r.e_a())) return bad(absl::StrCat("light configuration \"", r.name(), "\": E_a"), r.e_a());
    if (!std::isfinite(r.e_d())) return bad(absl::StrCat("light configuration \"", r.name(), "\": E_d"), r.e_d());
    if (!std::isfinite(r.e_held_out())) {
      return bad(absl::StrCat("light configuration \"", r.name(), "\": the held-out error"), r.e_held_out());
    }
  }
  for (const v1::SolverRow& r : report.solvers()) {
    const std::string row = absl::StrCat("cluster \"", r.cluster(), "\" (", r.solver(), "): ");
    if (!std::isfinite(r.final_cost())) return bad(row + "final cost", r.final_cost());
    if (!std::isfinite(r.mse())) return bad(row + "MSE", r.mse());
    for (int c = 0; c < r.kd_size(); ++c) {
      if (!std::isfinite(r.kd(c))) return bad(absl::StrCat(row, "kd[", c, "]"), r.kd(c));
    }
    for (int c = 0; c < r.ks_size(); ++c) {
      if (!std::isfinite(r.ks(c))) return bad(absl::StrCat(row, "ks[", c, "]"), r.ks(c));
    }
    for (int c = 0; c < r.ke_size(); ++c) {
      if (!std::isfinite(r.ke(c))) return bad(absl::StrCat(row, "ke[", c, "]"), r.ke(c));
    }
  }
  for (const v1::CameraErrorRow& r : report.cameras()) {
    const std::string row = absl::StrCat("camera \"", r.name(), "\": ");
    if (r.has_mse_brdf() && !std::isfinite(r.mse_brdf())) return bad(row + "MSE with the BRDF atlases", r.mse_brdf());
    if (r.has_mse_correction() && !std::isfinite(r.mse_correction())) {
      return bad(row + "MSE with the correction atlases", r.mse_correction());
    }
  }
  if (!std::isfinite(report.configuration_margin())) {
    return bad("the configuration margin", report.configuration_margin());
  }
  return absl::OkStatus();
}

int SweepFrameStride(const ReconstructOptions& options, int num_frames) {
  if (options.sweep_frame_stride > 0) return options.sweep_frame_stride;
  return std::max(1, (num_frames + kMaxSweepFrames - 1) / kMaxSweepFrames);
}

absl::Status CheckCancelled(const ReconstructOptions& options) {
  if (options.cancelled && options.cancelled()) return absl::CancelledError("the task was cancelled");
  return absl::OkStatus();
}

namespace {

// Observations of a texel before the texel pass's robust weights apply.
constexpr uint32_t kMinRunningObservations = 3;

// The residual scale of per-texel kd over the cluster's kept Samples
// (elements renumbered to the texels present): 1.4826 MAD of
// r - s - kd_texel G per channel.
glm::dvec3 TexelResidualScale(const samples::SampleSet& cluster_set, const samples::LightSelection& selection,
                              const fit::PhongRgb& brdf, const fit::DiffuseOptions& diffuse) {
  samples::SampleSet set = cluster_set;
  std::unordered_map<uint32_t, uint32_t> local;
  for (uint32_t& e : set.element) e = local.emplace(e, static_cast<uint32_t>(local.size())).first->second;
  fit::DiffuseOptions options = diffuse;
  options.robust.iterations = 0;  // the scale only
  return fit::SolveDiffuse(set, selection, brdf, local.size(), options).robust_scale;
}

}  // namespace

fit::RobustOptions RobustFitOf(bool robust) {
  fit::RobustOptions r;
  // Cauchy, measured against Huber and least squares on the actor sequence
  // (8 cameras x 30 frames, 320x240), cameras 0.3 deg / 5 mm off, with
  // robust cluster fits: kd RMSE 0.048 least squares, 0.036 Huber, 0.035
  // Cauchy. As used (sweep and texel pass robust, cluster fits least
  // squares): kd RMSE 0.048 -> 0.040 (cameras off), 0.019 -> 0.015 (clean),
  // ks and ke errors unchanged.
  r.loss = robust ? fit::RobustLoss::kCauchy : fit::RobustLoss::kNone;
  return r;
}

absl::StatusOr<v1::RunReport> RunReconstruction(const scene::Sequence& scene_sequence, gl::EglContext& context,
                                                const ReconstructOptions& requested) {
  // The fits' robust loss and the resampler's reliability criteria follow
  // options.robust, edge_margin_pixels and gradient_rejection (issue #14).
  ReconstructOptions options = requested;
  MVBRDF_RETURN_IF_ERROR(CheckPixelFootprint(options.pixel_footprint, scene_sequence.lights.size()));
  options.fit.robust = options.diffuse.robust = RobustFitOf(options.robust);
  options.resampler.edge_margin_pixels = options.edge_margin_pixels;
  options.resampler.gradient_rejection = options.gradient_rejection;
  if (options.light_table.has_value() && !options.refined_lights_applied) {
    // Lights refined after the sweep (refine_lights_stage.h): everything
    // after it uses them, pass 1's texel statistics included.
    MVBRDF_ASSIGN_OR_RETURN(std::optional<scene::Sequence> refined,
                            SequenceWithRefinedLights(scene_sequence, *options.light_table));
    if (refined.has_value()) {
      ReconstructOptions o = options;
      o.refined_lights_applied = true;
      o.texel_statistics = nullptr;  // gathered with the scene's lights
      o.light_table = LightTableOf(*options.light_table);  // its pass 1: "gather_light_samples"
      return RunReconstruction(*refined, context, o);
    }
  }
  const auto start = Clock::now();
  MVBRDF_ASSIGN_OR_RETURN(v1::RunReport report, NewRunReport(scene_sequence, options, context.Describe()));
  MVBRDF_ASSIGN_OR_RETURN(const Plan plan, MakePlan(scene_sequence, options.request));
  const std::filesystem::path& out = options.out_dir;
  const int num_cameras = static_cast<int>(scene_sequence.cameras.size());
  samples::AssembleOptions assemble = options.assemble;
  assemble.inverse_square_falloff = scene_sequence.scene.lighting().inverse_square_falloff();
  // The texel pass of a half-vector model reads the geometry (fit::LobeTerms).
  assemble.half_vector_geometry = options.brdf_auto || brdf::NeedsHalfVector(options.brdf_model);

  // The atlas (kept UVs are still rasterised into the layout).
  auto t0 = Clock::now();
  MVBRDF_ASSIGN_OR_RETURN(const atlas::Atlas atlas,
                          atlas::BuildAtlas(scene_sequence.topology, scene_sequence.rest_positions, options.atlas));
  SetAtlasFigures(atlas, Since(t0), report.mutable_atlas());
  MVBRDF_RETURN_IF_ERROR(scene::WriteAtlasMesh(out / "atlas", atlas.topology, scene_sequence));
  MVBRDF_RETURN_IF_ERROR(image::WriteExr(out / "atlas" / "triangle_id.exr", atlas.triangle_id));
  AddStage(&report, "atlas", Since(t0), options);

  // Camera refinement (issue #14): every stage from pass 1 on, and Table
  // 7.1, sees the cameras as used (refined or the scene's). Run here, or by
  // the service's gather task (options.calibration; its stage row comes with
  // the light table when there is one).
  std::optional<scene::Sequence> calibrated;
  {
    t0 = Clock::now();
    v1::CalibrationReport cameras;
    if (options.calibration.has_value()) {
      cameras = *options.calibration;
    } else {
      MVBRDF_ASSIGN_OR_RETURN(cameras, RefineCamerasStage(scene_sequence, context, plan, options));
    }
    MVBRDF_ASSIGN_OR_RETURN(calibrated, CalibratedSequence(scene_sequence, cameras));
    const double seconds = options.calibration.has_value() ? cameras.cameras_seconds() : Since(t0);
    *report.mutable_calibration() = std::move(cameras);
    if (plan.Has(Stage::kRefineCameras) && !options.light_table.has_value()) {
      AddStage(&report, "refine_cameras", seconds, options);
    }
  }
  const scene::Sequence& sequence = calibrated.has_value() ? *calibrated : scene_sequence;
  const size_t num_texels = static_cast<size_t>(atlas.size) * static_cast<size_t>(atlas.size);
  const bool reflectance = plan.Has(Stage::kTexelPass);

  // Pass 1: triangle Samples, texel means and kept texel Samples.
  t0 = Clock::now();
  const bool gather_triangles =
      (plan.Has(Stage::kLightSweep) || plan.Has(Stage::kRefineLights)) && !options.light_table.has_value();
  const bool gather_texels = reflectance && options.texel_statistics == nullptr;
  Gathered g;
  if (gather_triangles || gather_texels) {
    MVBRDF_ASSIGN_OR_RETURN(g, GatherPass(sequence, context, atlas, options, gather_triangles, gather_texels));
  } else {
    g.triangle_samples = samples::MakeSampleSet(sequence.lights, options.half_vector_geometry);
  }
  if (reflectance && !gather_texels) {
    g.texels = options.texel_statistics;  // gathered by an earlier task
    g.rest_position = g.texels->rest_position;
  }
  // A copy: the triangle Samples are released after the sweep.
  const std::vector<glm::vec3> intensity = g.triangle_samples.light_intensity;
  std::vector<glm::vec4> camera_views;  // scene::CameraModel::ViewOrigin
  for (const scene::CameraModel& cam : sequence.cameras) camera_views.push_back(glm::vec4(cam.ViewOrigin()));
  if (!g.rest_position.empty()) {
    MVBRDF_RETURN_IF_ERROR(image::WriteExr(out / "atlas" / "rest_position.exr", g.rest_position));
  }
  // (No stage when another task gathered everything: its report has it.)
  if (gather_triangles || gather_texels) AddStage(&report, "gather_samples", Since(t0), options);

  // The light configuration.
  t0 = Clock::now();
  samples::LightMask mask;
  std::string chosen = plan.fixed_configuration;
  if (options.light_table.has_value()) {
    // Swept elsewhere (the service's sweep and choose tasks).
    report.mutable_light_configurations()->CopyFrom(options.light_table->light_configurations());
    for (const v1::StageRow& stage : options.light_table->stages()) *report.add_stages() = stage;
    report.set_configuration_margin(options.light_table->configuration_margin());
    report.set_configuration_warning(options.light_table->configuration_warning());
    calibrate::CopyLightRefinement(options.light_table->calibration(), report.mutable_calibration());
    report.set_configuration_criterion(options.light_table->configuration_criterion());
    report.set_configuration_margin_e_d(options.light_table->configuration_margin_e_d());
    report.set_configuration_rule(options.light_table->configuration_rule());
    chosen = options.light_table->chosen_configuration();
  } else if (plan.Has(Stage::kLightSweep)) {
    // What the plan sweeps: the request's candidates, else the scene's.
    std::vector<fit::LightConfiguration> configs;
    for (const std::string& name : plan.candidates) {
      for (const v1::LightConfiguration& c : sequence.scene.light_configurations()) {
        if (c.name() == name) configs.push_back({c.name(), {c.lights().begin(), c.lights().end()}});
      }
    }
    MVBRDF_ASSIGN_OR_RETURN(const fit::SweepResult sweep,
                            fit::SweepConfigurations(g.triangle_samples, atlas.topology.triangles.size(), configs,
                                                     options.fit, options.diffuse, options.threads,
                                                     options.sweep_fit_samples, samples::OwnLightingFrames(sequence)));
    for (const fit::SweepRow& row : sweep.rows) SweepRowToProto(row, report.add_light_configurations());
    MVBRDF_RETURN_IF_ERROR(ChooseConfiguration(&report));
    chosen = report.chosen_configuration();
    AddStage(&report, "light_sweep", Since(t0), options);
  }
  if (chosen.empty()) {
    mask = samples::AllLights(sequence.lights.size());
    // With every frame's own lights the Samples hold only those (FrameStream).
    chosen = sequence.every_frame_lit_own() ? scene::kPerFrameLighting : "all lights";
  } else {
    bool found = false;
    for (const v1::LightConfiguration& c : sequence.scene.light_configurations()) {
      if (c.name() != chosen) continue;
      MVBRDF_ASSIGN_OR_RETURN(mask, g.triangle_samples.MaskOf({c.lights().begin(), c.lights().end()}));
      found = true;
    }
    if (!found) {
      return absl::InvalidArgumentError(
          absl::StrCat("light configuration \"", chosen, "\": the scene has no such configuration"));
    }
  }
  report.set_chosen_configuration(chosen);
  if (plan.Has(Stage::kRefineLights) && !options.light_table.has_value()) {
    MVBRDF_RETURN_IF_ERROR(RefineLightsStage(sequence, g.triangle_samples, options, &report));
    if (report.calibration().lights_refined()) {
      ReconstructOptions o = options;  // the rest with the refined lights
      o.light_table = LightTableOf(report);
      o.calibration = report.calibration();  // the cameras as refined here, not refined again
      g = Gathered();  // pass 1 again with them: free this one first
      return RunReconstruction(sequence, context, o);
    }
  }
  for (const v1::LightConfigurationRow& row : report.light_configurations()) {
    for (const v1::RobustScale& r : row.robust_scales()) *report.add_robust_scales() = r;
  }
  // Frames with their own lights are modelled with exactly those, the others
  // with the configuration (samples::LightSelection).
  const samples::LightSelection selection(mask, samples::OwnLightingFrames(sequence));
  const samples::LightMask all_lights = samples::AllLights(sequence.lights.size());
  g.triangle_samples = samples::SampleSet();  // no longer needed
  if (!reflectance) {
    MVBRDF_RETURN_IF_ERROR(CheckMetricsFinite(report));
    report.set_seconds(Since(start));
    report.set_peak_rss_bytes(PeakRssBytes());
    MVBRDF_RETURN_IF_ERROR(WriteJsonFile(out / "result.json", report));
    return report;
  }

  // Clustering. The thesis clusters each texel's average reflectance, which
  // mixes albedo with shading (a cloth texel under the arm looks as dark as
  // hair). We cluster each texel's albedo estimate sum r / sum G under the
  // chosen configuration instead, weighted by its illumination sum G, and
  // read the seeds as diffuse colours.
  t0 = Clock::now();
  cluster::KMeansInput km_input;
  std::vector<uint32_t> seen_texels;
  // The data's own illumination scale: the mean G of an observation (per
  // channel), for thresholds that must not depend on intensity units.
  glm::dvec3 illumination_sum(0.0);
  double observations = 0.0;
  for (size_t i = 0; i < num_texels; ++i) {
    if (g.texels->texel_count[i] == 0) continue;
    MVBRDF_ASSIGN_OR_RETURN(const glm::dvec3 illumination, g.texels->illumination.Of(static_cast<uint32_t>(i), mask));
    if (!(illumination.x > 0.0 && illumination.y > 0.0 && illumination.z > 0.0)) continue;  // never lit
    seen_texels.push_back(static_cast<uint32_t>(i));
    illumination_sum += illumination;
    observations += g.texels->texel_count[i];
    km_input.points.push_back(glm::vec3(g.texels->texel_sum[i] / illumination));
    km_input.weights.push_back(static_cast<float>((illumination.x + illumination.y + illumination.z) / 3.0));
  }
  g.texels->illumination = TexelIllumination();
  if (seen_texels.empty()) return NothingLit(sequence, *g.texels, chosen, mask);
  const glm::dvec3 typical_illumination = illumination_sum / std::max(observations, 1.0);
  cluster::KMeansOptions km_options;
  for (const v1::MaterialSeed& seed : sequence.scene.material_seeds()) {
    km_options.seeds.push_back(SeedAlbedo(seed));
    km_options.seed_names.push_back(seed.name());
  }
  {
    std::vector<uint32_t> triangle_segment;
    MVBRDF_RETURN_IF_ERROR(
        ReadSegments(sequence, km_options.seed_names, &triangle_segment, &km_input.allowed_clusters));
    if (!triangle_segment.empty()) {
      for (uint32_t texel : seen_texels) {
        const int32_t tri = atlas.triangle_id.at<int32_t>(static_cast<int>(texel / atlas.size),
                                                          static_cast<int>(texel % atlas.size));
        km_input.segment.push_back(tri >= 0 ? triangle_segment[static_cast<size_t>(tri)] : 0u);
      }
    }
  }
  // Automatic k: a cluster of a few outlier texels is not a material; k is
  // chosen without them, they join the nearest cluster and their row says
  // "tiny" (cluster::KMeansOfMaterials). Seeded clusters are kept as given.
  std::vector<bool> tiny;
  MVBRDF_ASSIGN_OR_RETURN(cluster::KMeansResult clusters, cluster::KMeansOfMaterials(km_input, km_options, &tiny));
  const size_t num_clusters = clusters.centres.size();
  // Spatial coherence over the surface (issue #14 item 5; cluster::SmoothLabels).
  report.mutable_clustering()->set_smoothness(options.cluster_smoothness);
  if (options.cluster_smoothness > 0.0) {
    std::vector<int32_t> point_of(num_texels, -1);
    for (size_t i = 0; i < seen_texels.size(); ++i) point_of[seen_texels[i]] = static_cast<int32_t>(i);
    std::vector<std::pair<uint32_t, uint32_t>> edges;
    for (const auto& [a, b] : atlas::BuildTexelEdges(atlas).edges) {
      if (point_of[a] >= 0 && point_of[b] >= 0) edges.emplace_back(point_of[a], point_of[b]);
    }
    cluster::LabelSmoothingOptions smoothing;
    smoothing.smoothness = options.cluster_smoothness;
    MVBRDF_ASSIGN_OR_RETURN(cluster::LabelSmoothingResult smoothed,
                            cluster::SmoothLabels(km_input, clusters.centres, clusters.assignment, edges, smoothing));
    // The smoothing must not take from a cluster every texel that holds a
    // kept Sample (on a tiny atlas it can): its fit would have no data. Then
    // the k-means labels stay, with a warning.
    const TexelReservoir& kept = *g.texels->reservoir;
    std::vector<size_t> with_before(num_clusters, 0), with_after(num_clusters, 0);
    for (size_t i = 0; i < seen_texels.size(); ++i) {
      if (kept.KeptOf(seen_texels[i]) == 0) continue;
      ++with_before[clusters.assignment[i]];
      ++with_after[smoothed.labels[i]];
    }
    size_t emptied = num_clusters;
    for (size_t k = 0; k < num_clusters && emptied == num_clusters; ++k) {
      if (with_before[k] > 0 && with_after[k] == 0) emptied = k;
    }
    if (emptied < num_clusters) {
      report.add_warnings(absl::StrCat("cluster smoothing undone: it left cluster \"",
                                       scene::ShownName(clusters.names[emptied]),
                                       "\" no texel with Samples to fit its BRDF (the k-means labels are used)"));
    } else {
      clusters.assignment = std::move(smoothed.labels);
      std::fill(clusters.sizes.begin(), clusters.sizes.end(), 0);
      for (uint32_t k : clusters.assignment) ++clusters.sizes[k];
      report.mutable_clustering()->set_texels_relabelled(smoothed.relabelled);
      report.mutable_clustering()->set_iterations(static_cast<uint32_t>(smoothed.iterations));
    }
  }
  {
    std::vector<std::string> names;
    for (size_t k = 0; k < num_clusters; ++k) {
      if (tiny[k]) names.push_back(absl::StrCat("\"", scene::ShownName(clusters.names[k]), "\""));
    }
    if (!names.empty()) {
      report.add_warnings(
          absl::StrCat("cluster", names.size() > 1 ? "s " : " ", absl::StrJoin(names, ", "),
                       ": too few texels for a material (under ", cluster::kMinMaterialPoints, " or ",
                       100.0 * cluster::kMinMaterialShare, " % of the ", seen_texels.size(),
                       " seen); k was chosen without them and their texels joined the nearest cluster"));
    }
  }
  std::vector<int32_t> texel_cluster(num_texels, -1);
  std::vector<std::vector<uint32_t>> cluster_texels(num_clusters);
  for (size_t i = 0; i < seen_texels.size(); ++i) {
    texel_cluster[seen_texels[i]] = static_cast<int32_t>(clusters.assignment[i]);
    cluster_texels[clusters.assignment[i]].push_back(seen_texels[i]);
  }
  // Clusters without data for a BRDF fit: the cluster fits take per-pixel
  // Samples, which a texel the atlas resampling saw may lack (seen only at
  // grazing views, or by a camera inside the mesh). A cluster with fewer than
  // max(1, 1 %) of its texels holding a Sample has no data: its texels join
  // the nearest cluster (by centre, among those their segment allows) that
  // has (none allowed: the texel is left unmeasured), with a warning; when
  // such clusters hold kMaxShareWithoutData or more of the seen texels, the
  // job fails naming the largest (its kd, ks and ke would be the fit's initial guess,
  // e.g. an inside-out mesh, whose back faces the cameras skip).
  constexpr double kMaxShareWithoutData = 0.05;
  std::vector<uint8_t> has_data(num_clusters, 0);
  {
    const TexelReservoir& reservoir = *g.texels->reservoir;
    size_t without = 0, largest = num_clusters;
    for (size_t k = 0; k < num_clusters; ++k) {
      size_t with_samples = 0;
      for (uint32_t t : cluster_texels[k]) with_samples += reservoir.KeptOf(t) > 0 ? 1 : 0;
      has_data[k] =
          cluster_texels[k].empty() ||
          static_cast<double>(with_samples) >= std::max(1.0, 0.01 * static_cast<double>(cluster_texels[k].size()));
      if (has_data[k]) continue;
      without += cluster_texels[k].size();
      if (largest == num_clusters || cluster_texels[k].size() > cluster_texels[largest].size()) largest = k;
    }
    if (largest < num_clusters && static_cast<double>(without) >= kMaxShareWithoutData * seen_texels.size()) {
      const size_t k = largest;
      return absl::FailedPreconditionError(absl::StrCat(
          "cluster \"", scene::ShownName(clusters.names[k]), "\" (", cluster_texels[k].size(),
          " texels): no Samples to fit its BRDF, so kd, ks and ke would be the initial guess; the cameras see none of "
          "its texels lit in their images (an inside-out mesh, whose back faces the cameras skip? cameras that see "
          "nothing? lights that reach none of it?)"));
    }
    std::vector<size_t> unmeasured(num_clusters, 0);
    for (size_t i = 0; i < seen_texels.size() && largest < num_clusters; ++i) {
      const uint32_t from = clusters.assignment[i];
      if (has_data[from]) continue;
      size_t best = num_clusters;
      float best_d = 0.0f;
      for (size_t c = 0; c < num_clusters; ++c) {
        if (!has_data[c] || cluster_texels[c].empty()) continue;
        if (!km_input.segment.empty()) {
          const std::vector<uint32_t>& ok = km_input.allowed_clusters[km_input.segment[i]];
          if (std::find(ok.begin(), ok.end(), static_cast<uint32_t>(c)) == ok.end()) continue;
        }
        const glm::vec3 d = clusters.centres[c] - clusters.centres[from];
        if (best == num_clusters || glm::dot(d, d) < best_d) best = c, best_d = glm::dot(d, d);
      }
      // No cluster with data allowed in its segment: left unmeasured (like a
      // texel never seen; the written atlases grow over it).
      texel_cluster[seen_texels[i]] = best == num_clusters ? -1 : static_cast<int32_t>(best);
      if (best == num_clusters) ++unmeasured[from];
    }
    for (size_t k = 0; k < num_clusters; ++k) {
      if (has_data[k]) continue;
      report.add_warnings(
          absl::StrCat("cluster \"", scene::ShownName(clusters.names[k]), "\": ", cluster_texels[k].size(),
                       " texels but no Samples to fit its BRDF: ", cluster_texels[k].size() - unmeasured[k],
                       " joined the nearest cluster with Samples, ", unmeasured[k],
                       " (no such cluster allowed in their segment) are left unmeasured"));
    }
    for (std::vector<uint32_t>& texels : cluster_texels) texels.clear();
    for (uint32_t t : seen_texels) {
      if (texel_cluster[t] >= 0) cluster_texels[static_cast<size_t>(texel_cluster[t])].push_back(t);
    }
  }
  AddStage(&report, "clustering", Since(t0), options);

  // One BRDF per cluster.
  t0 = Clock::now();
  std::vector<fit::PhongRgb> cluster_brdf(num_clusters);
  // A model other than Phong (issue #15): each cluster's fit of it, whose kd
  // also replaces cluster_brdf's (the per-texel kd's fallback and prior).
  // Per cluster its model: options.brdf_model, or with --brdf auto
  // fit::SelectModel's pick from the cluster's Samples.
  std::vector<brdf::Model> cluster_model(num_clusters, options.brdf_model);
  std::vector<std::array<fit::LobeChannel, 3>> cluster_lobe(num_clusters);
  report.set_brdf(options.brdf_auto ? "auto" : brdf::ModelName(options.brdf_model));
  // Robust fits: per cluster the residual scale of per-texel kd (pass 2).
  std::vector<glm::dvec3> texel_sigma(num_clusters, glm::dvec3(0.0));
  // The cluster fits' Samples are per-pixel ones, whose lights are copies
  // per subpixel with a pixel footprint (samples::FootprintLights).
  const samples::LightSelection pixel_selection = samples::FootprintSelection(selection, options.pixel_footprint);
  // Per cluster its BRDF from the kept per-pixel Samples of `reservoir`
  // (pass 1's; issue #18: again with the refined normals' Samples), with its
  // report rows (clusters, Table 6.2's solvers, flags' warnings).
  std::vector<double> cluster_mse(num_clusters, 0.0);  // the one-kd LM fit's, per cluster
  const auto fit_clusters = [&](const std::function<const TexelReservoir&(size_t)>& reservoir_of) -> absl::Status {
    for (size_t k = 0; k < num_clusters; ++k) {
      if (!has_data[k] || tiny[k]) {  // its texels joined another cluster (above)
        v1::ClusterRow* row = report.add_clusters();
        row->set_name(clusters.names[k]);
        row->set_texels(0);
        for (int c = 0; c < 3; ++c) row->add_centre(clusters.centres[k][c]);
        row->add_flags(tiny[k] ? "tiny" : "no_samples");
        continue;
      }
      samples::SampleSet set = samples::MakeSampleSet(samples::FootprintLights(sequence.lights, options.pixel_footprint),
                                                      options.GathersHalfVector());
      // Spread the cap over the cluster's kept Samples, not its texels (most
      // texels keep fewer Samples than they have slots).
      const TexelReservoir& reservoir = reservoir_of(k);
      const std::vector<uint32_t> texels = SpreadOverSamples(cluster_texels[k], options.max_cluster_samples,
                                                             [&](uint32_t t) { return reservoir.KeptOf(t); });
      reservoir.Collect(texels, options.max_cluster_samples, &set);
      fit::PhongFitOptions lm = options.fit;
      lm.solver = fit::Solver::kLevenbergMarquardt;
      // Least squares: measured, a robust cluster fit takes the few highlight
      // Samples for outliers of a scale set by the many diffuse ones and
      // underestimates ks (4-frame misregistered sequence at 320x240: worst ks
      // error 0.68 -> 0.77, kd RMSE 0.084 -> 0.101; 30 frames, cameras 0.3 deg
      // off: 0.75 -> 0.81). So ReconstructOptions::robust does not reach them.
      lm.robust = fit::RobustOptions();
      MVBRDF_ASSIGN_OR_RETURN(const fit::PhongFitResult lm_result, fit::FitPhong(set, {}, pixel_selection, lm));
      v1::ClusterRow* row = report.add_clusters();
      if (options.brdf_auto) {
        fit::ModelSelectionOptions choose;
        choose.fit.max_iterations = lm.max_iterations;
        choose.fit.kd_max = lm.kd_max;
        choose.fit.ks_max = lm.ks_max;
        choose.fit.ke_min = lm.ke_min;
        choose.fit.ke_max = lm.ke_max;
        MVBRDF_ASSIGN_OR_RETURN(const fit::ModelSelection chosen, fit::SelectModel(set, pixel_selection, choose));
        cluster_model[k] = chosen.model;
        for (brdf::Model m : brdf::kModels) {
          v1::ModelChoice* choice = row->add_model_choices();
          choice->set_model(brdf::ModelName(m));
          choice->set_held_out_rmse(chosen.held_out_rmse[static_cast<size_t>(m)]);
          choice->set_seconds(chosen.seconds[static_cast<size_t>(m)]);
        }
        row->set_brdf_reason(chosen.reason);
      }
      const brdf::Model model = cluster_model[k];
      const bool phong = model == brdf::Model::kPhong;
      row->set_brdf(brdf::ModelName(model));
      // No data is no result: the fit's initial guess is not written as one.
      // (A seed that no texel resembles has an empty cluster: flagged, not fatal.)
      if (!cluster_texels[k].empty() && (lm_result.flags() & (fit::kNoSamples | fit::kKdNotIdentifiable))) {
        return absl::FailedPreconditionError(absl::StrCat(
            "cluster \"", scene::ShownName(clusters.names[k]), "\" (", cluster_texels[k].size(),
            " texels): ", lm_result.samples_used == 0 ? "no Samples" : "no Sample lit by the configuration's lights",
            " to fit its BRDF, so kd, ks and ke would be the initial guess; the cameras see none of its texels lit "
            "(an inside-out mesh, whose back faces the cameras skip? cameras that see nothing? lights that reach "
            "none of it?)"));
      }
      cluster_brdf[k] = lm_result.params;
      cluster_mse[k] = lm_result.mse;
      SolverRowFrom(clusters.names[k], lm_result, report.add_solvers());
      // The lobe again with kd free per texel: a single kd per cluster leaves
      // the cluster's texture in the residuals, which the one-kd fit trades for
      // ks and ke; kept per channel where it predicts held-out frames no worse.
      // Measured on the actor sequence (8 cameras x 30 frames, 320x240): clean,
      // cloth ks error 0.156 -> 0.031, ke 0.030 -> 0.007, hair ke 0.042 ->
      // 0.004, kd RMSE 0.0123 -> 0.0122; all perturbation knobs at once, worst
      // ks 0.379 -> 0.398, worst ke 0.496 -> 0.438; 0.9 s for three clusters
      // (clean, before the held-out check was added).
      fit::TexelKdFitOptions lobe_options;
      lobe_options.ke_min = lm.ke_min;
      lobe_options.ke_max = lm.ke_max;
      lobe_options.ks_max = lm.ks_max;
      bool lobe_per_texel_kd = false;
      uint32_t flags = lm_result.flags();
      if (!phong) {
        // The model's own fit (fit::FitLobe) on the same Samples; the Phong
        // fits above stay in the report's solver table (Table 6.2).
        fit::LobeFitOptions lobe_fit;
        lobe_fit.max_iterations = lm.max_iterations;
        lobe_fit.kd_max = lm.kd_max;
        lobe_fit.ks_max = lm.ks_max;
        MVBRDF_ASSIGN_OR_RETURN(const fit::LobeFitResult model_fit,
                                fit::FitLobe(model, set, {}, pixel_selection, lobe_fit));
        cluster_lobe[k] = model_fit.params;
        flags = model_fit.flags();
        // Again with kd free per texel, as the Phong path's FitLobeWithTexelKd
        // below (kept per channel where it predicts held-out frames no worse).
        if (!(flags & fit::kKsKeNotIdentifiable)) {
          fit::LobeTexelKdOptions texel_kd;
          texel_kd.ke_min = lm.ke_min;
          texel_kd.ke_max = lm.ke_max;
          texel_kd.ks_max = lm.ks_max;
          MVBRDF_ASSIGN_OR_RETURN(const fit::LobeTexelKdResult refined,
                                  fit::FitModelLobeWithTexelKd(model, set, pixel_selection, model_fit.params, texel_kd));
          cluster_lobe[k] = refined.params;
          for (bool r : refined.refined) lobe_per_texel_kd |= r;
        }
        if (model == brdf::Model::kGgx) {
          // How far towards grazing the capture saw this lobe: the renderer
          // does not extrapolate its 1 / cos^2 peak past it (docs/models.md).
          const fit::GrazingSupport support = fit::GgxGrazingSupport(set, pixel_selection, cluster_lobe[k]);
          row->set_ggx_grazing_support(support.s);
        }
        for (int c = 0; c < 3; ++c) cluster_brdf[k][c].kd = cluster_lobe[k][c].kd;
      } else if (!(lm_result.flags() & fit::kKsKeNotIdentifiable)) {
        MVBRDF_ASSIGN_OR_RETURN(const fit::TexelKdFitResult lobe,
                                fit::FitLobeWithTexelKd(set, pixel_selection, lm_result.params, lobe_options));
        cluster_brdf[k] = lobe.params;
        for (const fit::TexelKdChannel& c : lobe.channels) lobe_per_texel_kd |= c.refined;
      }
      if (options.diffuse.robust.enabled()) {
        texel_sigma[k] = TexelResidualScale(set, pixel_selection, cluster_brdf[k], options.diffuse);
      }
      if (plan.Has(Stage::kSolverComparison)) {
        // The LM's problem (least squares, as above), so that Table 6.2
        // compares two solvers, not two losses: with options.fit's robust loss
        // Powell ran four IRLS solves (4x the time) of another cost.
        fit::PhongFitOptions powell = lm;
        powell.solver = fit::Solver::kPowell;
        MVBRDF_ASSIGN_OR_RETURN(const fit::PhongFitResult p_result, fit::FitPhong(set, {}, pixel_selection, powell));
        SolverRowFrom(clusters.names[k], p_result, report.add_solvers());
      }
      row->set_name(clusters.names[k]);
      row->set_texels(cluster_texels[k].size());
      row->set_lobe_per_texel_kd(lobe_per_texel_kd);
      for (const std::string& f : FlagNames(flags)) row->add_flags(f);
      if (const std::string w = ClusterFitWarning(clusters.names[k], flags, lm); !w.empty()) {
        report.add_warnings(w);
      }
      for (int c = 0; c < 3; ++c) {
        row->add_centre(clusters.centres[k][c]);
        row->add_kd(cluster_brdf[k][c].kd);
        if (phong) {
          row->add_ks(cluster_brdf[k][c].ks);
          row->add_ke(cluster_brdf[k][c].ke);
        } else if (model == brdf::Model::kGgx) {
          row->add_f0(cluster_lobe[k][c].p[0]);
          row->add_roughness(cluster_lobe[k][c].p[1]);
          row->add_f90_ratio(cluster_lobe[k][c].p[2]);
        } else {
          row->add_ks(cluster_lobe[k][c].p[0]);
          row->add_ke(cluster_lobe[k][c].p[1]);
        }
      }
    }
    return absl::OkStatus();
  };
  int cluster_warnings_begin = report.warnings_size();
  MVBRDF_RETURN_IF_ERROR(fit_clusters([&](size_t) -> const TexelReservoir& { return *g.texels->reservoir; }));
  int cluster_warnings_end = report.warnings_size();
  // Pass 1's shadow atlases, for pass 2; its kept Samples for the normals
  // stage's choice between the fits (issue #18).
  const std::shared_ptr<ShadowAtlasCache> shadow_atlases = g.texels != nullptr ? g.texels->shadow_atlases : nullptr;
  std::shared_ptr<ResampledAtlasCache> resampled_atlases =
      g.texels != nullptr ? g.texels->resampled_atlases : nullptr;
  std::unique_ptr<TexelReservoir> mesh_reservoir =
      plan.Has(Stage::kNormals) && g.texels != nullptr ? std::move(g.texels->reservoir) : nullptr;
  g.texels.reset();
  AddStage(&report, "cluster_fit", Since(t0), options);

  // Each cluster's reflectance as the texel passes read it (texel_shading.h).
  const auto cluster_shading = [&] {
    std::vector<ClusterShading> shading;
    for (size_t k = 0; k < num_clusters; ++k) shading.push_back({cluster_model[k], cluster_brdf[k], cluster_lobe[k]});
    return shading;
  };

  // Issue #18: per-texel normals, which pass 2 then reads its Samples with.
  std::optional<TexelNormals> normals;
  if (plan.Has(Stage::kNormals)) {
    t0 = Clock::now();
    NormalStageInput input;
    input.sequence = &sequence;
    input.context = &context;
    input.atlas = &atlas;
    input.resampler = options.resampler;
    input.shadows = shadow_atlases.get();
    input.atlases = resampled_atlases.get();
    input.assemble = assemble;
    input.texel_cluster = &texel_cluster;
    input.clusters = cluster_shading();
    input.residual_scale = texel_sigma;
    input.robust = options.diffuse.robust;
    input.selection = &selection;
    input.intensity = intensity;
    input.options = options.normals;
    input.progress = options.progress;
    input.cancelled = options.cancelled;
    MVBRDF_ASSIGN_OR_RETURN(normals, RefineTexelNormals(input));
    // The cluster fits again, from per-pixel Samples read with the refined
    // normals (a sharp lobe seen on a bumpy surface looks broad at the mesh's
    // normals). A cluster whose refit explains its Samples no better (the
    // one-kd fit's mean squared error) than the first fit explained its own
    // keeps the first fit and the mesh's normals: on a surface the mesh
    // models, refined normals are noise (measured on the clean actor: hair
    // ks / ke error 0.006 / 0.001 -> 0.36 / 0.24 without this choice).
    const std::vector<double> mesh_mse = cluster_mse;
    MVBRDF_ASSIGN_OR_RETURN(const std::unique_ptr<TexelReservoir> reservoir,
                            GatherPixelSamples(sequence, context, atlas, options, shadow_atlases.get(), normals->m,
                                               normals->refined));
    const auto refit = [&](const std::function<const TexelReservoir&(size_t)>& reservoir_of) -> absl::Status {
      report.clear_clusters();
      report.clear_solvers();
      report.mutable_warnings()->DeleteSubrange(cluster_warnings_begin, cluster_warnings_end - cluster_warnings_begin);
      cluster_warnings_begin = report.warnings_size();
      MVBRDF_RETURN_IF_ERROR(fit_clusters(reservoir_of));
      cluster_warnings_end = report.warnings_size();
      return absl::OkStatus();
    };
    MVBRDF_RETURN_IF_ERROR(refit([&](size_t) -> const TexelReservoir& { return *reservoir; }));
    std::vector<uint8_t> refined_cluster(num_clusters, 1);
    bool any_kept = false;
    for (size_t k = 0; k < num_clusters; ++k) {
      if (mesh_mse[k] > 0.0 && !(cluster_mse[k] < mesh_mse[k])) {
        refined_cluster[k] = 0;
        any_kept = true;
      }
    }
    if (any_kept) {
      for (size_t i = 0; i < num_texels; ++i) {
        if (texel_cluster[i] >= 0 && normals->flags[i] == 0 &&
            !refined_cluster[static_cast<size_t>(texel_cluster[i])]) {
          normals->flags[i] = kNormalClusterNoBetter;
        }
      }
      CountNormals(texel_cluster, &*normals);
      MVBRDF_RETURN_IF_ERROR(refit([&](size_t k) -> const TexelReservoir& {
        return refined_cluster[k] ? *reservoir : *mesh_reservoir;
      }));
    }
    mesh_reservoir.reset();
    v1::NormalReport* row = report.mutable_normals();
    row->set_texels(normals->texels);
    row->set_refined(normals->refined_texels);
    row->set_few_observations(normals->few_observations);
    row->set_coplanar_lights(normals->coplanar);
    row->set_tilt_limit(normals->tilt_limit);
    row->set_not_significant(normals->not_significant);
    row->set_cluster_no_better(normals->cluster_no_better);
    row->set_passes(static_cast<uint32_t>(normals->passes + 1));
    row->set_median_tilt_deg(normals->median_tilt_deg);
    row->set_median_sigma_deg(normals->median_sigma_deg);
    // Texels whose refined normal is no better than the mesh's are an answer
    // (the mesh models them); texels the data cannot constrain are not.
    const uint64_t measured = normals->refined_texels + normals->not_significant + normals->cluster_no_better;
    if (normals->texels > 0 && measured * 2 < normals->texels) {
      report.add_warnings(absl::StrCat("normals: only ", measured, " of ", normals->texels,
                                       " texels could be measured (", normals->few_observations,
                                       " with too few observations, ", normals->coplanar,
                                       " lit from too nearly coplanar directions, ", normals->tilt_limit,
                                       " past the tilt limit); they keep the mesh's normal"));
    }
    AddStage(&report, "normals", Since(t0), options);
  }

  // Pass 2: per-texel kd, observed diffuse per frame, camera errors.
  const std::vector<ClusterShading> shading = cluster_shading();  // as fitted last
  t0 = Clock::now();
  fit::DiffuseAccumulator diffuse(num_texels);
  std::vector<glm::vec3> fallback_kd(num_clusters);
  for (size_t k = 0; k < num_clusters; ++k) {
    fallback_kd[k] = glm::vec3(cluster_brdf[k][0].kd, cluster_brdf[k][1].kd, cluster_brdf[k][2].kd);
  }
  // The running estimate's prior: kd_prior_weight observations at the
  // typical illumination (as the final solve's, with mean G for rms G).
  const glm::dvec3 running_lambda = options.kd_prior_weight * typical_illumination * typical_illumination;
  std::vector<uint64_t> texel_outliers(num_clusters, 0), texel_observations(num_clusters, 0);
  // Table 7.1 with the final kd, from per-(camera, texel) sums:
  // sum (res - kd G)^2 = S_rr - 2 kd S_gr + kd^2 S_gg.
  const bool camera_errors = plan.Has(Stage::kCameraErrors);
  const bool correction = plan.Has(Stage::kCorrection);
  std::vector<glm::dvec3> cam_s_gr, cam_s_gg;
  std::vector<double> cam_s_rr(static_cast<size_t>(num_cameras), 0.0), cam_corr_sq(static_cast<size_t>(num_cameras), 0.0);
  std::vector<uint64_t> cam_count(static_cast<size_t>(num_cameras), 0);
  if (camera_errors) {
    cam_s_gr.assign(num_texels * static_cast<size_t>(num_cameras), glm::dvec3(0.0));
    cam_s_gg.assign(num_texels * static_cast<size_t>(num_cameras), glm::dvec3(0.0));
  }
  std::vector<FoldPart> fold_parts(kAtlasParts);
  for (FoldPart& part : fold_parts) {
    part.outliers.assign(num_clusters, 0);
    part.observations.assign(num_clusters, 0);
    part.s_rr.assign(static_cast<size_t>(num_cameras), 0.0);
    part.count.assign(static_cast<size_t>(num_cameras), 0);
    part.corr_sq.assign(static_cast<size_t>(num_cameras), 0.0);
    part.frame_observations.resize(static_cast<size_t>(num_cameras));
  }
  const std::filesystem::path observed_dir = out / "atlases" / "observed_kd.tmp";
  // Each frame's observed kd until the correction atlases are written: in a
  // temporary file where one can be made (ResampledAtlasCache), else as EXRs
  // in observed_dir.
  // Within what pass 1's cache left of its budget: both together take at
  // most about half the free space.
  std::unique_ptr<ResampledAtlasCache> observed_atlases;
  if (correction) {
    absl::StatusOr<std::unique_ptr<ResampledAtlasCache>> made = ResampledAtlasCache::Create(
        resampled_atlases != nullptr ? resampled_atlases->budget_left() : ResampledAtlasCache::kDefaultBudgetBytes);
    if (made.ok()) observed_atlases = *std::move(made);
  }
  std::vector<int> observed_frames;
  // Per camera: texel observations of the texel pass refused as masked or
  // saturated (every frame, every camera: counted once, here).
  std::vector<resample::Resampler::RefusedObservations> refused(static_cast<size_t>(num_cameras));
  {
    MVBRDF_ASSIGN_OR_RETURN(auto stream,
                            FrameStream::Open(sequence, context, atlas, options.resampler, shadow_atlases.get(),
                                              resampled_atlases.get()));
    if (normals.has_value()) stream->UseNormals(&normals->m, &normals->refined);
    std::vector<glm::vec3> frame_sum(num_texels);
    std::vector<glm::vec3> frame_illumination(num_texels);
    std::vector<uint16_t> frame_count(num_texels);
    std::vector<cv::Mat> frame_atlases(static_cast<size_t>(num_cameras));
    std::future<absl::Status> writing;  // the last frame's correction atlas
    // Camera c's texel Samples of the frame in atlas parts (atlas_parts.h),
    // visit(part, texel, rgb, terms): each texel's sums are one part's, the
    // sums over texels the part's (fold_parts, added in order after the pass).
    const auto for_each_texel = [&](int c, const auto& visit) {
      InAtlasParts([&](int part_index) {
        FoldPart& part = fold_parts[static_cast<size_t>(part_index)];
        samples::ForEachTexelSample(
            frame_atlases[static_cast<size_t>(c)], stream->geometry(), stream->shadows(), sequence.cameras[c],
            sequence.lights, assemble,
            [&](uint32_t texel, const glm::vec3& rgb, const samples::LightTerms& terms) {
              visit(part, texel, rgb, terms);
            },
            AtlasPartRows(part_index, atlas.size));
      });
    };
    for (int t = 0; t < sequence.num_frames; ++t) {
      if (options.progress) options.progress("texel_pass", t, sequence.num_frames);
      MVBRDF_RETURN_IF_ERROR(CheckCancelled(options));
      MVBRDF_RETURN_IF_ERROR(stream->SetFrame(t));
      if (correction || camera_errors) {
        std::fill(frame_sum.begin(), frame_sum.end(), glm::vec3(0.0f));
        std::fill(frame_count.begin(), frame_count.end(), 0);
      }
      for (FoldPart& part : fold_parts) {
        for (std::vector<ErrorObservation>& v : part.frame_observations) v.clear();
      }
      for (int c = 0; c < num_cameras; ++c) {
        MVBRDF_ASSIGN_OR_RETURN(frame_atlases[static_cast<size_t>(c)], stream->ResampledAtlas(c));
        for_each_texel(c, [&](FoldPart& part, uint32_t texel, const glm::vec3& rgb, const samples::LightTerms& terms) {
          const int32_t k = texel_cluster[texel];
          if (k < 0) return;
          glm::vec3 G, specular, phong_sums;
          const ClusterShading& cluster = shading[static_cast<size_t>(k)];
          ShadeTexel(cluster, terms, intensity, selection.Of(t, all_lights), &G, &specular,
                     camera_errors ? &phong_sums : nullptr);
          if (camera_errors) {
            part.frame_observations[static_cast<size_t>(c)].push_back(
                {texel, k, rgb, G, cluster.model == brdf::Model::kPhong ? phong_sums : specular});
          }
          const glm::vec3 res = rgb - specular;
          // Weighted by (n.v)^4: near-grazing observations come from
          // stretched image footprints and smear across silhouettes
          // (sum w G r / sum w G^2, folded in as sqrt(w) = (n.v)^2).
          // Measured kd RMSE on the 12-frame test sequence: unweighted
          // 0.0248, (n.v) 0.0205, (n.v)^2 0.0187, (n.v)^4 0.0170.
          const cv::Vec4f& pos = stream->geometry().position.at<cv::Vec4f>(static_cast<int>(texel / atlas.size),
                                                                           static_cast<int>(texel % atlas.size));
          const cv::Vec4f& nor = stream->geometry().normal.at<cv::Vec4f>(static_cast<int>(texel / atlas.size),
                                                                         static_cast<int>(texel % atlas.size));
          const glm::vec3 view =
              scene::ViewDirection(camera_views[static_cast<size_t>(c)], glm::vec3(pos[0], pos[1], pos[2]));
          const float cos_view = std::max(0.0f, glm::dot(glm::vec3(nor[0], nor[1], nor[2]), view));
          float w = cos_view * cos_view;
          // Robust (issue #14): weighted by the loss at the residual
          // against the texel's running estimate (its kd so far, shrunk
          // to the cluster's like the final solve), in units of the
          // cluster's per-texel residual scale: one streamed pass.
          glm::vec3 wc(w);
          // Before kMinRunningObservations of its own the texel has no
          // estimate to judge by: plain weights (measured, 4-frame
          // sequence at 320x240: judging from the first observation on
          // made kd RMSE 0.087 -> 0.099).
          if (texel_sigma[static_cast<size_t>(k)].x > 0.0 && diffuse.count(texel) >= kMinRunningObservations) {
            const glm::dvec3 running = diffuse.Running(texel, fallback_kd[static_cast<size_t>(k)], running_lambda);
            for (int ch = 0; ch < 3; ++ch) {
              const double u = (res[ch] - running[ch] * G[ch]) / texel_sigma[static_cast<size_t>(k)][ch];
              if (std::fabs(u) > 3.0) ++part.outliers[static_cast<size_t>(k)];
              wc[ch] = w * static_cast<float>(std::sqrt(options.diffuse.robust.Weight(u)));
            }
            part.observations[static_cast<size_t>(k)] += 3;
          }
          diffuse.Add(texel, wc * res, wc * G);
          if (camera_errors) {
            const size_t i = static_cast<size_t>(c) * num_texels + texel;
            cam_s_gr[i] += glm::dvec3(G * res);
            cam_s_gg[i] += glm::dvec3(G * G);
            part.s_rr[static_cast<size_t>(c)] += glm::dot(glm::dvec3(res), glm::dvec3(res));
            ++part.count[static_cast<size_t>(c)];
          }
          if (correction || camera_errors) {
            frame_sum[texel] += res;
            frame_illumination[texel] = G;
            ++frame_count[texel];
          }
        });
      }
      if (!correction && !camera_errors) continue;
      // The frame's observed diffuse albedo kd_o = mean over cameras of
      // (r - s) / G (thesis Fig. 7.3), and the error of rendering with it.
      cv::Mat observed(atlas.size, atlas.size, CV_32FC4, cv::Scalar::all(0));
      for (size_t i = 0; i < num_texels; ++i) {
        if (frame_count[i] == 0) continue;
        const glm::vec3 G = frame_illumination[i];
        cv::Vec4f& o = observed.at<cv::Vec4f>(static_cast<int>(i / atlas.size), static_cast<int>(i % atlas.size));
        bool ok = true;
        for (int ch = 0; ch < 3; ++ch) {
          // min_illumination is on G^2 relative to the typical G^2 (fit::DiffuseOptions).
          const double min_g = std::sqrt(options.diffuse.min_illumination) * typical_illumination[ch];
          if (!(G[ch] > min_g)) ok = false;
        }
        if (!ok) continue;
        const glm::vec3 kd_o = frame_sum[i] / static_cast<float>(frame_count[i]) / G;
        o = {kd_o.x, kd_o.y, kd_o.z, 1.0f};
      }
      if (camera_errors) {
        // The fold's observations, per part in its order (the sums as before).
        for (int c = 0; c < num_cameras; ++c) {
          InAtlasParts([&](int part_index) {
            FoldPart& part = fold_parts[static_cast<size_t>(part_index)];
            for (const ErrorObservation& e : part.frame_observations[static_cast<size_t>(c)]) {
              const cv::Vec4f& o =
                  observed.at<cv::Vec4f>(static_cast<int>(e.texel / atlas.size), static_cast<int>(e.texel % atlas.size));
              const fit::PhongRgb& p = cluster_brdf[static_cast<size_t>(e.cluster)];
              const bool phong = cluster_model[static_cast<size_t>(e.cluster)] == brdf::Model::kPhong;
              for (int ch = 0; ch < 3; ++ch) {
                const double s = phong ? p[ch].ks * e.specular[ch] : e.specular[ch];
                const double predicted = o[3] > 0.5f ? o[ch] * e.illumination[ch] + s : 0.0;
                const double d = o[3] > 0.5f ? e.rgb[ch] - predicted : 0.0;
                part.corr_sq[static_cast<size_t>(c)] += d * d;
              }
            }
          });
        }
      }
      if (correction) {
        // Kept bit for bit in the temporary file (no compression: ~2 ms),
        // else written as an EXR on a thread while the next frame is
        // resampled (~60 ms per 512^2 float EXR); one write in flight at a time.
        if (observed_atlases == nullptr || !observed_atlases->Keep(t, 0, kObservedKey, observed)) {
          if (writing.valid()) MVBRDF_RETURN_IF_ERROR(writing.get());
          writing = std::async(std::launch::async, [file = observed_dir / absl::StrCat(t, ".exr"), observed] {
            return image::WriteExr(file, observed);
          });
        }
        observed_frames.push_back(t);
      }
    }
    if (writing.valid()) MVBRDF_RETURN_IF_ERROR(writing.get());
    for (int c = 0; c < num_cameras; ++c) refused[static_cast<size_t>(c)] = stream->Refused(c);
  }
  // No pass reads the atlases after this one (a worker's TexelStatistics,
  // options.texel_statistics, may still hold the file until its task ends).
  resampled_atlases.reset();
  for (const FoldPart& part : fold_parts) {
    for (size_t k = 0; k < num_clusters; ++k) {
      texel_outliers[k] += part.outliers[k];
      texel_observations[k] += part.observations[k];
    }
    for (size_t c = 0; c < static_cast<size_t>(num_cameras); ++c) {
      cam_s_rr[c] += part.s_rr[c];
      cam_count[c] += part.count[c];
      cam_corr_sq[c] += part.corr_sq[c];
    }
  }
  for (const auto& r : refused) {
    report.set_masked_observations(report.masked_observations() + r.masked);
    report.set_saturated_observations(report.saturated_observations() + r.saturated);
    v1::SampleReliability& reliability = *report.mutable_reliability();
    reliability.set_kept(reliability.kept() + r.kept);
    reliability.set_rejected_edge(reliability.rejected_edge() + r.edge);
    reliability.set_rejected_gradient(reliability.rejected_gradient() + r.gradient);
  }
  std::vector<glm::vec3> fallback(num_texels, glm::vec3(0.0f));
  for (size_t i = 0; i < num_texels; ++i) {
    if (texel_cluster[i] >= 0) {
      const fit::PhongRgb& p = cluster_brdf[static_cast<size_t>(texel_cluster[i])];
      fallback[i] = glm::vec3(p[0].kd, p[1].kd, p[2].kd);
    }
  }
  fit::DiffuseOptions texel_diffuse = options.diffuse;
  texel_diffuse.prior_weight = options.kd_prior_weight;
  const fit::DiffuseSolution kd = diffuse.Solve(texel_diffuse, fallback);
  for (size_t k = 0; k < num_clusters; ++k) {
    if (!(texel_sigma[k].x > 0.0)) continue;
    v1::RobustScale* row = report.add_robust_scales();
    row->set_stage("texel_pass");
    row->set_name(clusters.names[k]);
    row->set_scale((texel_sigma[k].x + texel_sigma[k].y + texel_sigma[k].z) / 3.0);
    row->set_outlier_fraction(texel_observations[k] > 0
                                  ? static_cast<double>(texel_outliers[k]) / static_cast<double>(texel_observations[k])
                                  : 0.0);
  }
  AddStage(&report, "texel_pass", Since(t0), options);

  // Table 7.1.
  if (camera_errors) {
    for (int c = 0; c < num_cameras; ++c) {
      double brdf_sq = cam_s_rr[static_cast<size_t>(c)];
      for (size_t i = 0; i < num_texels; ++i) {
        const size_t j = static_cast<size_t>(c) * num_texels + i;
        const glm::dvec3 k(kd.kd[i]);
        brdf_sq += glm::dot(k * k, cam_s_gg[j]) - 2.0 * glm::dot(k, cam_s_gr[j]);
      }
      v1::CameraErrorRow* row = report.add_cameras();
      row->set_name(sequence.cameras[c].name);
      row->set_samples(cam_count[static_cast<size_t>(c)]);
      row->set_masked_observations(refused[static_cast<size_t>(c)].masked);
      row->set_saturated_observations(refused[static_cast<size_t>(c)].saturated);
      if (cam_count[static_cast<size_t>(c)] == 0) {
        // An error over nothing is not 0: left out, and said loudly.
        report.add_warnings(
            absl::StrCat("camera \"", sequence.cameras[c].name,
                         "\" observed no lit texel in any frame: its errors are absent (is it inside the mesh, behind "
                         "something, or does its lens distortion map the mesh outside the image?)"));
        continue;
      }
      const double n = 3.0 * static_cast<double>(cam_count[static_cast<size_t>(c)]);
      row->set_mse_brdf(std::max(0.0, brdf_sq) / n);
      row->set_mse_correction(cam_corr_sq[static_cast<size_t>(c)] / n);
    }
  }

  // Atlases.
  t0 = Clock::now();
  std::vector<uint8_t> measured(num_texels, 0);
  uint64_t seen = 0, seen10 = 0, fallbacks = 0;
  for (size_t i = 0; i < num_texels; ++i) {
    measured[i] = texel_cluster[i] >= 0 ? 1 : 0;
    if (kd.samples[i] > 0) ++seen;
    if (kd.samples[i] >= 10) ++seen10;
    if (measured[i] && kd.fallback[i]) ++fallbacks;
  }
  report.set_texels_seen(seen);
  report.set_texels_seen_10(seen10);
  report.set_kd_fallback_texels(fallbacks);
  const std::filesystem::path atlases = out / "atlases";
  const cv::Mat kd_atlas = resample::GrowAtlas(Rgba(kd.kd, measured, atlas.size), options.grow_iterations);
  if (plan.Has(Stage::kWriteAtlases)) {
    std::vector<glm::vec3> ks(num_texels), ke(num_texels), p3(num_texels);
    bool any_p3 = false;  // a cluster's model has a third parameter (GGX's f90_ratio)
    cv::Mat cluster_map(atlas.size, atlas.size, CV_32SC1, cv::Scalar(-1));
    cv::Mat confidence(atlas.size, atlas.size, CV_32FC1, cv::Scalar(0));
    cv::Mat texel_model(atlas.size, atlas.size, CV_8UC1, cv::Scalar(kNoModel));
    for (size_t i = 0; i < num_texels; ++i) {
      const int y = static_cast<int>(i / atlas.size), x = static_cast<int>(i % atlas.size);
      confidence.at<float>(y, x) = static_cast<float>(kd.samples[i]);
      if (texel_cluster[i] < 0) continue;
      const size_t k = static_cast<size_t>(texel_cluster[i]);
      const fit::PhongRgb& p = cluster_brdf[k];
      const std::array<fit::LobeChannel, 3>& q = cluster_lobe[k];
      const bool phong = cluster_model[k] == brdf::Model::kPhong;
      texel_model.at<uint8_t>(y, x) = static_cast<uint8_t>(cluster_model[k]);
      ks[i] = phong ? glm::vec3(p[0].ks, p[1].ks, p[2].ks) : glm::vec3(q[0].p[0], q[1].p[0], q[2].p[0]);
      ke[i] = phong ? glm::vec3(p[0].ke, p[1].ke, p[2].ke) : glm::vec3(q[0].p[1], q[1].p[1], q[2].p[1]);
      if (brdf::NumParameters(cluster_model[k]) > 2) {
        p3[i] = glm::vec3(q[0].p[2], q[1].p[2], q[2].p[2]);
        any_p3 = true;
      }
      cluster_map.at<int32_t>(y, x) = texel_cluster[i];
    }
    MVBRDF_RETURN_IF_ERROR(WriteRgbAtlas(atlases / "kd", kd_atlas, 1.0f));
    // The model's two parameters (ks, ke; GGX's f0, roughness), named as it
    // names them; with --brdf auto model-neutral, beside the model atlas.
    const std::array<std::string, 2> names =
        options.brdf_auto ? std::array<std::string, 2>{"parameter_1", "parameter_2"}
                          : std::array<std::string, 2>{brdf::ParameterNames(options.brdf_model)[0],
                                                       brdf::ParameterNames(options.brdf_model)[1]};
    MVBRDF_RETURN_IF_ERROR(WriteRgbAtlas(
        atlases / names[0], resample::GrowAtlas(Rgba(ks, measured, atlas.size), options.grow_iterations), 1.0f));
    const cv::Mat ke_atlas = resample::GrowAtlas(Rgba(ke, measured, atlas.size), options.grow_iterations);
    MVBRDF_RETURN_IF_ERROR(image::WriteExr(atlases / absl::StrCat(names[1], ".exr"), RgbOf(ke_atlas)));
    MVBRDF_RETURN_IF_ERROR(image::WritePngPreview(
        atlases / absl::StrCat(names[1], ".png"), ke_atlas,
        !options.brdf_auto && options.brdf_model == brdf::Model::kGgx ? 1.0f : 1.0f / 100.0f));
    // The third parameter (GGX's f90_ratio), where a cluster's model has one:
    // f90_ratio.exr, or parameter_3.exr beside the model atlas.
    if (any_p3) {
      const std::string name =
          options.brdf_auto ? "parameter_3" : std::string(brdf::ParameterNames(options.brdf_model)[2]);
      MVBRDF_RETURN_IF_ERROR(WriteRgbAtlas(
          atlases / name, resample::GrowAtlas(Rgba(p3, measured, atlas.size), options.grow_iterations),
          static_cast<float>(1.0 / brdf::Ggx::kDielectricRatio)));
    }
    if (options.brdf_auto) {
      // Grown like the parameters, so that filtering at chart edges reads
      // the texel's own model.
      MVBRDF_RETURN_IF_ERROR(WriteModelAtlas(atlases / "model.png", texel_model, options.grow_iterations));
    }
    MVBRDF_RETURN_IF_ERROR(image::WriteExr(atlases / "cluster.exr", cluster_map));
    MVBRDF_RETURN_IF_ERROR(image::WriteExr(atlases / "confidence.exr", confidence));
    cv::Mat cluster_preview(atlas.size, atlas.size, CV_32FC4, cv::Scalar::all(0));
    for (size_t i = 0; i < num_texels; ++i) {
      if (texel_cluster[i] < 0) continue;
      const glm::vec3 centre = clusters.centres[static_cast<size_t>(texel_cluster[i])];
      cluster_preview.at<cv::Vec4f>(static_cast<int>(i / atlas.size), static_cast<int>(i % atlas.size)) = {
          centre.x, centre.y, centre.z, 1.0f};
    }
    MVBRDF_RETURN_IF_ERROR(image::WritePngPreview(atlases / "cluster.png", cluster_preview));
  }
  if (normals.has_value()) {
    MVBRDF_RETURN_IF_ERROR(WriteNormalAtlases(*normals, texel_cluster, atlas.size, options.grow_iterations, atlases));
  }
  // Correction atlases c = kd_o - kd where the frame observed the texel;
  // the frames split among kAtlasParts threads (each frame's file its own).
  std::vector<absl::Status> part_status(kAtlasParts);
  InAtlasParts([&](int part) {
    for (size_t i = static_cast<size_t>(part); i < observed_frames.size(); i += kAtlasParts) {
      part_status[static_cast<size_t>(part)] =
          WriteCorrectionAtlas(observed_atlases.get(), observed_dir, observed_frames[i], sequence, kd.kd, atlas.size,
                               atlases / "correction");
      if (!part_status[static_cast<size_t>(part)].ok()) return;
    }
  });
  for (const absl::Status& status : part_status) MVBRDF_RETURN_IF_ERROR(status);
  observed_atlases.reset();  // its file's space back now
  std::error_code ec;
  std::filesystem::remove_all(observed_dir, ec);
  AddStage(&report, "write_atlases", Since(t0), options);
  MVBRDF_RETURN_IF_ERROR(CheckMetricsFinite(report));

  report.set_seconds(Since(start));
  report.set_peak_rss_bytes(PeakRssBytes());
  MVBRDF_RETURN_IF_ERROR(WriteJsonFile(out / "result.json", report));
  return report;
}

}  // namespace mvbrdf::pipeline
