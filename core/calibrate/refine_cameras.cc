// Camera refinement: per camera 6 DoF (optionally focal scale and k1) from
// the video, by Ceres over `options.frames` frames spread over the sequence:
//   - a silhouette term (silhouette_term.h) pairs the mesh's outer occluding
//     contour with the image's intensity edge, ICP-style (the pairs are found
//     again at each outer iteration), anchoring every camera to the mesh;
//   - a photometric term (photometric_term.h): textured surface points seen by
//     two or more cameras have one consensus colour (a parameter); in the
//     solve only with options.photometric (off by default, measured below);
//     the cross-camera consistency is reported before and after either way;
//   - weak priors to the calibration (kPriorPixels) for what neither sees
//     (e.g. the centre along the view axis).
// Residuals are whitened by their MAD scale and taken through a Cauchy loss;
// everything is in pixels or relative, so world and intensity units do not
// matter. The covariance of the camera blocks (the consensus colours held)
// gives the sigmas.
#include "core/calibrate/refine_cameras.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <atomic>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/calibrate/camera_parameterisation.h"
#include "core/calibrate/depth_map.h"
#include "core/calibrate/photometric_term.h"
#include "core/calibrate/silhouette_term.h"
#include "core/scene/camera_model.h"
#include "core/scene/video_source.h"

namespace mvbrdf::calibrate {
namespace {

constexpr int kOuterIterations = 6;
constexpr int kPointsPerCamera = 300;  // photometric points per camera and frame
// The photometric term in the solve (options.photometric, --refine-photometric).
// Measured (8 cameras x 8 frames, mean reprojection error against the true
// cameras, px): rot 0.032 without, 0.030 with; clean 0.030 / 0.031; all knobs
// 0.168 / 0.242, and 3.5x the time. The silhouettes alone are as good there
// (the synthetic actor's texture is weak at 320x240, and its highlights move
// between views), so it is off by default; the consistency is still measured
// (residual_before/after).
// 1-sigma of the priors to the calibration, as image displacements (pixels):
// weak for the rotation and the intrinsics; strong for the centre, which
// the images hardly see (a lateral move is nearly a rotation: at the
// subject's distance D a move d shifts the image by f d / D, and the
// parallax telling them apart is that times the subject's depth over D),
// so it stays put unless the data insist.
constexpr double kPriorPixels = 2.0;
constexpr double kCentrePriorPixels = 0.25;
constexpr double kCauchyScale = 2.0;      // of the whitened residuals
constexpr double kSmoothingPixels = 1.0;  // Gaussian sigma of the image the edges are searched in
// AUTO uses the refined cameras when some camera moves the visible surface by
// more than this in the image (pixels; the clean synthetic studio refines to
// below a third of it) and by more than kDecisionSigmas of its own uncertainty.
constexpr double kDecisionPixels = 0.3;
constexpr double kDecisionSigmas = 3.0;
constexpr double kPi = 3.14159265358979323846;

double MadScale(std::vector<double> r, double floor) {
  if (r.empty()) return floor;
  for (double& v : r) v = std::abs(v);
  std::nth_element(r.begin(), r.begin() + static_cast<long>(r.size() / 2), r.end());
  return std::max(1.4826 * r[r.size() / 2], floor);
}

struct PriorResidual {
  double weight;  // pixels per parameter unit / kPriorPixels
  template <typename T>
  bool operator()(const T* p, T* residual) const {
    for (int k = 0; k < 3; ++k) residual[k] = p[k] * weight;
    return true;
  }
};

struct IntrinsicsPrior {
  double focal_weight, k1_weight;
  template <typename T>
  bool operator()(const T* p, T* residual) const {
    residual[0] = p[0] * focal_weight;
    residual[1] = p[1] * k1_weight;
    return true;
  }
};

// Mean image displacement of the visible surface points between two cameras.
double MeanDisplacement(const scene::CameraModel& a, const scene::CameraModel& b,
                        const std::vector<glm::dvec3>& points) {
  double sum = 0;
  for (const glm::dvec3& x : points) sum += glm::length(a.Project(x) - b.Project(x));
  return points.empty() ? 0.0 : sum / static_cast<double>(points.size());
}

// Threads reading the refinement frames' videos (decoding, 2 cores: ~2x).
constexpr int kReadThreads = 2;

absl::StatusOr<std::vector<RefinementFrame>> ReadFrames(const scene::Sequence& sequence, const std::vector<int>& frames,
                                                        const CameraRefinementOptions& options) {
  std::vector<RefinementFrame> out(frames.size());
  for (size_t f = 0; f < frames.size(); ++f) {
    MVBRDF_ASSIGN_OR_RETURN(out[f].positions, sequence.LoadFrame(frames[f]));
  }
  const int num_cameras = static_cast<int>(sequence.cameras.size());
  for (RefinementFrame& frame : out) {
    frame.rgb.resize(static_cast<size_t>(num_cameras));
    frame.smoothed.resize(static_cast<size_t>(num_cameras));
  }
  // Each camera's video read to its last refinement frame (the frames are
  // spread over the sequence: a video is decoded frame by frame up to it,
  // VideoSource), the cameras split between kReadThreads threads. Only the
  // calling thread asks options.cancelled (a worker's callback reads state
  // its own thread writes); the others see its answer.
  std::atomic<bool> cancelled{false};
  const auto is_cancelled = [&](int part) {
    if (part == 0 && options.cancelled && options.cancelled()) cancelled = true;
    return cancelled.load();
  };
  const auto read_camera = [&](int part, int c) -> absl::Status {
    MVBRDF_ASSIGN_OR_RETURN(auto video,
                            scene::VideoSource::Open(sequence.scene.cameras(c), sequence.scene_dir, sequence.frames,
                                                     sequence.num_frames, absl::StrCat("scene.cameras[", c, "]")));
    for (size_t f = 0; f < frames.size(); ++f) {
      if (is_cancelled(part)) return absl::CancelledError("camera refinement cancelled");
      MVBRDF_ASSIGN_OR_RETURN(cv::Mat image, video->ReadFrame(frames[f]));
      cv::Mat rgb = cv::max(image, 0.0f);  // masked and saturated pixels: dark
      cv::Mat grey;
      cv::transform(rgb, grey, cv::Matx13f(1.0f / 3, 1.0f / 3, 1.0f / 3));
      cv::Mat smoothed;
      cv::GaussianBlur(grey, smoothed, cv::Size(0, 0), kSmoothingPixels);
      out[f].rgb[static_cast<size_t>(c)] = rgb.isContinuous() ? rgb : rgb.clone();
      out[f].smoothed[static_cast<size_t>(c)] = smoothed;
    }
    return absl::OkStatus();
  };
  std::vector<absl::Status> status(kReadThreads);
  const auto read_part = [&](int part) {
    for (int c = part; c < num_cameras && status[static_cast<size_t>(part)].ok(); c += kReadThreads) {
      status[static_cast<size_t>(part)] = read_camera(part, c);
    }
  };
  std::vector<std::thread> others;
  for (int part = 1; part < kReadThreads; ++part) others.emplace_back(read_part, part);
  read_part(0);
  for (std::thread& t : others) t.join();
  // Part 0's error first (its first camera is camera 0), then part 1's.
  for (const absl::Status& s : status) MVBRDF_RETURN_IF_ERROR(s);
  if (is_cancelled(0)) return absl::CancelledError("camera refinement cancelled");
  return out;
}

}  // namespace

absl::StatusOr<v1::CalibrationReport> RefineCameras(const scene::Sequence& sequence, gl::EglContext& context,
                                                    const CameraRefinementOptions& options) {
  (void)context;  // visibility is a CPU z-buffer (depth_map.h)
  const auto start = std::chrono::steady_clock::now();
  v1::CalibrationReport report;
  report.set_cameras_mode(options.mode == v1::REFINEMENT_ON ? "on" : "auto");
  report.set_cameras_refined(false);
  const auto keep_all = [&](const std::string& why) {
    report.set_cameras_decision(why);
    for (const scene::CameraModel& camera : sequence.cameras) {
      v1::CameraRefinementRow* row = report.add_cameras();
      row->set_name(camera.name);
      scene::CameraModelToProto(camera, row->mutable_camera());
    }
  };
  const int num_cameras = static_cast<int>(sequence.cameras.size());
  for (const scene::CameraModel& camera : sequence.cameras) {
    if (camera.orthographic()) {
      keep_all("kept the calibration: orthographic cameras are not refined");
      return report;
    }
  }
  if (num_cameras == 0 || sequence.num_frames == 0) {
    keep_all("kept the calibration: no cameras or frames");
    return report;
  }

  // Frames spread over the sequence.
  const int k = std::clamp(options.frames, 1, sequence.num_frames);
  std::vector<int> frame_index;
  for (int i = 0; i < k; ++i) {
    const int t = k == 1 ? 0 : static_cast<int>(std::lround(i * (sequence.num_frames - 1.0) / (k - 1.0)));
    if (frame_index.empty() || frame_index.back() != t) frame_index.push_back(t);
  }
  report.set_frames_used(static_cast<uint32_t>(frame_index.size()));
  MVBRDF_ASSIGN_OR_RETURN(std::vector<RefinementFrame> frames, ReadFrames(sequence, frame_index, options));

  std::vector<glm::uvec3> triangles;
  {
    std::vector<bool> zero(sequence.topology.file_triangles.size(), false);
    for (uint32_t t : sequence.topology.zero_area_triangles) zero[t] = true;
    for (size_t t = 0; t < zero.size(); ++t) {
      if (!zero[t]) triangles.push_back(sequence.topology.file_triangles[t]);
    }
  }
  const MeshEdges edges = BuildMeshEdges(triangles);
  // Foreground masks, the background told from the mesh at the calibration.
  std::vector<std::vector<cv::Mat>> masks(frames.size());
  std::vector<std::vector<double>> levels(frames.size());
  for (size_t f = 0; f < frames.size(); ++f) {
    for (int c = 0; c < num_cameras; ++c) {
      const DepthMap depth = RenderDepth(sequence.cameras[static_cast<size_t>(c)], triangles, frames[f].positions);
      cv::Mat covered(depth.height, depth.width, CV_8U);
      for (int y = 0; y < depth.height; ++y) {
        for (int x = 0; x < depth.width; ++x) covered.at<uint8_t>(y, x) = depth.Covered(x, y) ? 255 : 0;
      }
      cv::Mat grey;
      cv::transform(frames[f].rgb[static_cast<size_t>(c)], grey, cv::Matx13f(1.0f / 3, 1.0f / 3, 1.0f / 3));
      masks[f].push_back(ForegroundMask(grey, covered, kSmoothingPixels));
      std::vector<float> inside;
      for (int y = 0; y < depth.height; ++y) {
        for (int x = 0; x < depth.width; ++x) {
          if (depth.Covered(x, y)) inside.push_back(grey.at<float>(y, x));
        }
      }
      double level = 0;
      if (!inside.empty()) {
        std::nth_element(inside.begin(), inside.begin() + static_cast<long>(inside.size() / 2), inside.end());
        level = inside[inside.size() / 2];
      }
      levels[f].push_back(level);
    }
  }

  // Each camera's distance to the subject (the centre offsets' unit).
  glm::dvec3 centroid(0.0);
  for (const glm::vec3& p : frames[0].positions) centroid += glm::dvec3(p);
  centroid /= static_cast<double>(std::max<size_t>(1, frames[0].positions.size()));
  std::vector<double> distance(static_cast<size_t>(num_cameras));
  std::vector<PinholeBase> base(static_cast<size_t>(num_cameras));
  for (int c = 0; c < num_cameras; ++c) {
    const scene::CameraModel& camera = sequence.cameras[static_cast<size_t>(c)];
    distance[static_cast<size_t>(c)] = std::max(glm::length(camera.CenterInWorld() - centroid), 1e-9);
    base[static_cast<size_t>(c)] = PinholeBase::FromCamera(camera, distance[static_cast<size_t>(c)]);
  }

  // Images for the bicubic interpolation (the Grid2D keeps a pointer).
  std::vector<std::vector<std::unique_ptr<ImageGrid>>> grids(frames.size());
  std::vector<std::vector<std::unique_ptr<ImageInterpolator>>> interpolators(frames.size());
  for (size_t f = 0; f < frames.size(); ++f) {
    for (int c = 0; c < num_cameras; ++c) {
      const cv::Mat& rgb = frames[f].rgb[static_cast<size_t>(c)];
      grids[f].push_back(std::make_unique<ImageGrid>(rgb.ptr<float>(0), 0, rgb.rows, 0, rgb.cols));
      interpolators[f].push_back(std::make_unique<ImageInterpolator>(*grids[f].back()));
    }
  }

  std::vector<CameraOffsets> offsets(static_cast<size_t>(num_cameras));
  const auto current_cameras = [&] {
    std::vector<scene::CameraModel> cams;
    for (int c = 0; c < num_cameras; ++c) {
      cams.push_back(ApplyOffsets(sequence.cameras[static_cast<size_t>(c)], distance[static_cast<size_t>(c)],
                                  offsets[static_cast<size_t>(c)]));
    }
    return cams;
  };

  std::vector<uint64_t> observations(static_cast<size_t>(num_cameras), 0);
  std::unique_ptr<ceres::Problem> problem;
  std::vector<std::array<double, 3>> colours;
  double edge_bias = 0;  // pixels (SilhouetteResidual)
  for (int iteration = 0; iteration < kOuterIterations; ++iteration) {
    if (options.cancelled && options.cancelled()) return absl::CancelledError("camera refinement cancelled");
    const std::vector<scene::CameraModel> cams = current_cameras();
    std::vector<std::vector<ContourObservation>> contour(static_cast<size_t>(num_cameras));
    std::vector<std::pair<int, SurfacePoint>> points;  // frame, point
    for (size_t f = 0; f < frames.size(); ++f) {
      std::vector<DepthMap> depth;
      for (int c = 0; c < num_cameras; ++c) {
        depth.push_back(RenderDepth(cams[static_cast<size_t>(c)], triangles, frames[f].positions));
        const auto found =
            FindContourObservations(cams[static_cast<size_t>(c)], edges, triangles, frames[f].positions, depth.back(),
                                    masks[f][static_cast<size_t>(c)], frames[f].smoothed[static_cast<size_t>(c)],
                                    levels[f][static_cast<size_t>(c)]);
        contour[static_cast<size_t>(c)].insert(contour[static_cast<size_t>(c)].end(), found.begin(), found.end());
      }
      if (options.photometric)
        for (SurfacePoint& sp : TexturedSurfacePoints(cams, depth, triangles, frames[f].positions, frames[f].smoothed,
                                                      2, 0.25, kPointsPerCamera)) {
          points.emplace_back(static_cast<int>(f), std::move(sp));
        }
    }
    // Consensus colours at the current cameras, and the residual scales.
    colours.clear();
    std::vector<size_t> used;
    std::vector<double> photometric_residuals, colour_levels;
    for (size_t i = 0; i < points.size(); ++i) {
      const auto& [f, sp] = points[i];
      std::array<double, 3> mean{0, 0, 0};
      std::vector<std::array<double, 3>> values;
      for (int c : sp.cameras) {
        const glm::dvec2 uv = cams[static_cast<size_t>(c)].Project(sp.point);
        std::array<double, 3> v;
        interpolators[static_cast<size_t>(f)][static_cast<size_t>(c)]->Evaluate(uv.y, uv.x, v.data());
        for (int ch = 0; ch < 3; ++ch) mean[static_cast<size_t>(ch)] += v[static_cast<size_t>(ch)] / sp.cameras.size();
        values.push_back(v);
      }
      for (const auto& v : values) {
        for (int ch = 0; ch < 3; ++ch)
          photometric_residuals.push_back(v[static_cast<size_t>(ch)] - mean[static_cast<size_t>(ch)]);
      }
      colour_levels.push_back((mean[0] + mean[1] + mean[2]) / 3.0);
      colours.push_back(mean);
      used.push_back(i);
    }
    const double level = colour_levels.empty() ? 1.0 : MadScale(colour_levels, 1e-12) / 1.4826;
    const double photometric_scale = MadScale(photometric_residuals, 1e-3 * level);
    std::vector<double> contour_residuals;
    for (int c = 0; c < num_cameras; ++c) {
      for (const ContourObservation& o : contour[static_cast<size_t>(c)]) {
        contour_residuals.push_back(glm::dot(o.normal, cams[static_cast<size_t>(c)].Project(o.point) - o.target));
      }
    }
    const double contour_scale = MadScale(contour_residuals, 0.05);
    if (!options.photometric) {
      used.clear();
      colours.clear();
    }

    problem = std::make_unique<ceres::Problem>();
    ceres::LossFunction* loss = new ceres::CauchyLoss(kCauchyScale);
    ceres::Problem::Options unused;
    (void)unused;
    std::fill(observations.begin(), observations.end(), 0);
    for (int c = 0; c < num_cameras; ++c) {
      CameraOffsets& o = offsets[static_cast<size_t>(c)];
      for (const ContourObservation& obs : contour[static_cast<size_t>(c)]) {
        problem->AddResidualBlock(new ceres::AutoDiffCostFunction<SilhouetteResidual, 1, 3, 3, 2, 1>(
                                      new SilhouetteResidual{&base[static_cast<size_t>(c)], obs, 1.0 / contour_scale}),
                                  loss, o.rotation.data(), o.centre.data(), o.intrinsics.data(), &edge_bias);
      }
      observations[static_cast<size_t>(c)] += contour[static_cast<size_t>(c)].size();
    }
    for (size_t j = 0; j < used.size(); ++j) {
      const auto& [f, sp] = points[used[j]];
      for (int c : sp.cameras) {
        CameraOffsets& o = offsets[static_cast<size_t>(c)];
        problem->AddResidualBlock(
            new ceres::AutoDiffCostFunction<PhotometricResidual, 3, 3, 3, 2, 3>(new PhotometricResidual{
                &base[static_cast<size_t>(c)], interpolators[static_cast<size_t>(f)][static_cast<size_t>(c)].get(),
                sp.point, 1.0 / photometric_scale}),
            loss, o.rotation.data(), o.centre.data(), o.intrinsics.data(), colours[j].data());
        observations[static_cast<size_t>(c)] += 1;
      }
    }
    ceres::LossFunction* no_loss = nullptr;
    for (int c = 0; c < num_cameras; ++c) {
      CameraOffsets& o = offsets[static_cast<size_t>(c)];
      const scene::CameraModel& camera = sequence.cameras[static_cast<size_t>(c)];
      const double f = 0.5 * (camera.fx + camera.fy);
      problem->AddResidualBlock(
          new ceres::AutoDiffCostFunction<PriorResidual, 3, 3>(new PriorResidual{f / kPriorPixels}), no_loss,
          o.rotation.data());
      problem->AddResidualBlock(
          new ceres::AutoDiffCostFunction<PriorResidual, 3, 3>(new PriorResidual{f / kCentrePriorPixels}), no_loss,
          o.centre.data());
      const double half_diagonal = 0.5 * std::hypot(camera.width, camera.height);
      const double r2 = std::pow(half_diagonal / f, 2);
      problem->AddResidualBlock(new ceres::AutoDiffCostFunction<IntrinsicsPrior, 2, 2>(new IntrinsicsPrior{
                                    half_diagonal / kPriorPixels, half_diagonal * r2 / kPriorPixels}),
                                no_loss, o.intrinsics.data());
      if (!options.focal && !options.distortion) {
        problem->SetParameterBlockConstant(o.intrinsics.data());
      } else if (!options.focal || !options.distortion) {
        problem->SetManifold(o.intrinsics.data(), new ceres::SubsetManifold(2, {options.focal ? 1 : 0}));
      }
    }
    ceres::Solver::Options solver;
    solver.linear_solver_type = ceres::DENSE_SCHUR;
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (auto& colour : colours) ordering->AddElementToGroup(colour.data(), 0);
    if (problem->HasParameterBlock(&edge_bias)) {
      ordering->AddElementToGroup(&edge_bias, 1);
      // A focal length common to all cameras dilates every silhouette as
      // the bias does: with the focal length free the bias is held at 0.
      if (options.focal) problem->SetParameterBlockConstant(&edge_bias);
    }
    for (CameraOffsets& o : offsets) {
      ordering->AddElementToGroup(o.rotation.data(), 1);
      ordering->AddElementToGroup(o.centre.data(), 1);
      ordering->AddElementToGroup(o.intrinsics.data(), 1);
    }
    solver.linear_solver_ordering = ordering;
    solver.max_num_iterations = 15;
    // One thread: the same cameras on every path and worker (the service's
    // gather and --direct agreed only to 1e-15 with options.threads).
    solver.num_threads = 1;
    solver.logging_type = ceres::SILENT;
    std::vector<CameraOffsets> before = offsets;
    ceres::Solver::Summary summary;
    ceres::Solve(solver, problem.get(), &summary);
    // Converged when no camera moves the image by more than 0.01 px more.
    double moved = 0;
    const std::vector<scene::CameraModel> after = current_cameras();
    for (int c = 0; c < num_cameras; ++c) {
      const scene::CameraModel prev = ApplyOffsets(sequence.cameras[static_cast<size_t>(c)],
                                                   distance[static_cast<size_t>(c)], before[static_cast<size_t>(c)]);
      std::vector<glm::dvec3> sample;
      for (const auto& obs : contour[static_cast<size_t>(c)]) sample.push_back(obs.point);
      moved = std::max(moved, MeanDisplacement(prev, after[static_cast<size_t>(c)], sample));
    }
    if (moved < 0.01) break;
  }

  // Covariance of the camera blocks with the consensus colours held.
  for (auto& colour : colours) problem->SetParameterBlockConstant(colour.data());
  ceres::Covariance::Options covariance_options;
  covariance_options.algorithm_type = ceres::DENSE_SVD;
  covariance_options.null_space_rank = -1;
  covariance_options.num_threads = 1;
  ceres::Covariance covariance(covariance_options);
  std::vector<std::pair<const double*, const double*>> blocks;
  for (CameraOffsets& o : offsets) {
    blocks.emplace_back(o.rotation.data(), o.rotation.data());
    blocks.emplace_back(o.centre.data(), o.centre.data());
  }
  const bool have_covariance = covariance.Compute(blocks, problem.get());

  const std::vector<scene::CameraModel> refined = current_cameras();
  std::vector<uint64_t> before_count, after_count;
  const std::vector<double> residual_before = ConsistencyRms(sequence.cameras, triangles, frames, &before_count);
  const std::vector<double> residual_after = ConsistencyRms(refined, triangles, frames, &after_count);
  // The visible surface points of each camera at the calibration.
  std::vector<std::vector<glm::dvec3>> visible(static_cast<size_t>(num_cameras));
  for (const RefinementFrame& frame : frames) {
    std::vector<DepthMap> depth;
    for (const auto& camera : sequence.cameras) depth.push_back(RenderDepth(camera, triangles, frame.positions));
    for (const SurfacePoint& sp : VisibleSurfacePoints(sequence.cameras, depth, triangles, frame.positions, 4, 1)) {
      for (int c : sp.cameras) visible[static_cast<size_t>(c)].push_back(sp.point);
    }
  }

  double worst_change = 0, worst_sigmas = 0;
  std::string worst_name;
  for (int c = 0; c < num_cameras; ++c) {
    const scene::CameraModel& camera = sequence.cameras[static_cast<size_t>(c)];
    const scene::CameraModel& r = refined[static_cast<size_t>(c)];
    const CameraOffsets& o = offsets[static_cast<size_t>(c)];
    v1::CameraRefinementRow* row = report.add_cameras();
    row->set_name(camera.name);
    row->set_rotation_change_deg(RotationAngleDeg(r, camera));
    row->set_centre_change(glm::length(r.CenterInWorld() - camera.CenterInWorld()));
    row->set_focal_change(r.fx / camera.fx - 1.0);
    row->set_k1_change(r.distortion[0] - camera.distortion[0]);
    double rotation_sigma = 0, centre_sigma = 0;
    if (have_covariance) {
      double cr[9], cc[9];
      covariance.GetCovarianceBlock(o.rotation.data(), o.rotation.data(), cr);
      covariance.GetCovarianceBlock(o.centre.data(), o.centre.data(), cc);
      rotation_sigma = std::sqrt(std::max(0.0, cr[0] + cr[4] + cr[8])) * 180.0 / kPi;
      centre_sigma = std::sqrt(std::max(0.0, cc[0] + cc[4] + cc[8])) * distance[static_cast<size_t>(c)];
    }
    row->set_rotation_sigma_deg(rotation_sigma);
    row->set_centre_sigma(centre_sigma);
    const double change = MeanDisplacement(r, camera, visible[static_cast<size_t>(c)]);
    row->set_reprojection_change_px(change);
    row->set_residual_before(residual_before[static_cast<size_t>(c)]);
    row->set_residual_after(residual_after[static_cast<size_t>(c)]);
    row->set_observations(observations[static_cast<size_t>(c)]);
    scene::CameraModelToProto(r, row->mutable_camera());
    // The change against its uncertainty, in pixels: the rotation sigma as
    // an image displacement.
    const double sigma_px = rotation_sigma * kPi / 180.0 * 0.5 * (camera.fx + camera.fy);
    const double sigmas = sigma_px > 0 ? change / sigma_px : std::numeric_limits<double>::infinity();
    if (change > worst_change) {
      worst_change = change;
      worst_sigmas = sigmas;
      worst_name = camera.name;
    }
  }
  double rms_before = 0, rms_after = 0;
  for (int c = 0; c < num_cameras; ++c) {
    rms_before += residual_before[static_cast<size_t>(c)] / num_cameras;
    rms_after += residual_after[static_cast<size_t>(c)] / num_cameras;
  }
  const bool off = worst_change > kDecisionPixels && worst_sigmas > kDecisionSigmas;
  const std::string numbers = absl::StrFormat(
      "largest image change %.3f px (%s, %.1f sigma; threshold %.2f px and %.0f sigma), photometric rms %.4g -> %.4g",
      worst_change, worst_name, worst_sigmas, kDecisionPixels, kDecisionSigmas, rms_before, rms_after);
  if (options.mode == v1::REFINEMENT_ON) {
    report.set_cameras_refined(true);
    report.set_cameras_decision(absl::StrCat("refined (--refine-cameras on): ", numbers));
  } else if (off) {
    report.set_cameras_refined(true);
    report.set_cameras_decision(absl::StrCat("refined: the calibration is off; ", numbers));
  } else {
    report.set_cameras_decision(absl::StrCat("kept the calibration: it agrees with the images; ", numbers));
  }
  report.set_cameras_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return report;
}

absl::Status ApplyCameraRefinement(const v1::CalibrationReport& report, scene::Sequence* sequence) {
  if (!report.cameras_refined()) return absl::OkStatus();
  for (const v1::CameraRefinementRow& row : report.cameras()) {
    bool found = false;
    for (size_t i = 0; i < sequence->cameras.size(); ++i) {
      if (sequence->cameras[i].name != row.name()) continue;
      found = true;
      scene::CameraModel refined = scene::CameraModelFromProto(row.camera());
      if (refined.width != sequence->cameras[i].width || refined.height != sequence->cameras[i].height) {
        return absl::InvalidArgumentError(absl::StrCat("calibration.cameras[", row.name(), "]: size changed"));
      }
      // The video and the rest of the scene's camera stay the scene's.
      v1::Camera* scene_camera = sequence->scene.mutable_cameras(static_cast<int>(i));
      *scene_camera->mutable_intrinsics() = row.camera().intrinsics();
      *scene_camera->mutable_cam_from_world() = row.camera().cam_from_world();
      sequence->cameras[i] = scene::CameraModelFromProto(*scene_camera);
    }
    if (!found) {
      return absl::InvalidArgumentError(
          absl::StrCat("calibration.cameras: \"", row.name(), "\" is no camera of the scene"));
    }
  }
  return absl::OkStatus();
}

}  // namespace mvbrdf::calibrate
