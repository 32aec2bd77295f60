#include "core/pipeline/resample_stage.h"

#include <chrono>
#include <cstdio>
#include <memory>
#include <random>

#include "absl/strings/str_cat.h"
#include "core/base/draw_order.h"
#include "core/base/process_stats.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/evaluate/resample_evaluator.h"
#include "core/image/exr.h"
#include "core/pipeline/atlas_figures.h"
#include "core/pipeline/run_scene.h"
#include "core/pipeline/stage_timer.h"
#include "core/resample/atlas_ops.h"
#include "core/scene/atlas_mesh.h"
#include "core/scene/mesh_loader.h"
#include "core/scene/names.h"
#include "core/scene/video_source.h"
#include "core/synth/ground_truth.h"

namespace mvbrdf::pipeline {
namespace {

// One random colour per chart, for people to see the layout.
cv::Mat ChartPreview(const atlas::Atlas& atlas) {
  std::vector<cv::Vec3f> colours;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.15f, 1.0f);
  cv::Mat out(atlas.size, atlas.size, CV_32FC4, cv::Scalar::all(0));
  for (int y = 0; y < atlas.size; ++y) {
    for (int x = 0; x < atlas.size; ++x) {
      const int32_t t = atlas.triangle_id.at<int32_t>(y, x);
      if (t < 0) continue;
      const uint32_t chart = atlas.triangle_chart.empty() ? 0 : atlas.triangle_chart[static_cast<size_t>(t)];
      while (colours.size() <= chart) colours.push_back(base::DrawVec3<cv::Vec3f>([&] { return u(rng); }));
      const cv::Vec3f c = colours[chart];
      out.at<cv::Vec4f>(y, x) = {c[0], c[1], c[2], 1.0f};
    }
  }
  return out;
}

absl::Status WriteAtlas(const std::filesystem::path& stem, const cv::Mat& rgba) {
  image::ExrOptions half;
  half.half = true;
  MVBRDF_RETURN_IF_ERROR(image::WriteExr(stem.string() + ".exr", rgba, half));
  return image::WritePngPreview(stem.string() + ".png", rgba);
}

}  // namespace

absl::Status WriteShadowAtlas(const std::filesystem::path& file, const cv::Mat& shadows) {
  if (shadows.channels() == 1) return image::WriteExr(file, shadows);
  image::ExrOptions options;
  for (int c = 0; c < shadows.channels(); ++c) {
    options.channel_names.push_back(
        absl::StrCat("lights", absl::Dec(16 * c, absl::kZeroPad4), "-", absl::Dec(16 * c + 15, absl::kZeroPad4)));
  }
  return image::WriteExr(file, shadows, options);
}

absl::StatusOr<v1::ResampleReport> RunResampleStage(const scene::Sequence& sequence, gl::EglContext& context,
                                                    const ResampleStageOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  StageTimer timer;
  v1::ResampleReport report;
  // Relative to resample.json's directory, as result.json's (run_scene.h).
  report.set_scene(options.out_dir.empty() ? sequence.scene_file.string()
                                           : SceneRelativeTo(sequence.scene_file, options.out_dir));
  report.set_frames(static_cast<uint32_t>(sequence.num_frames));
  report.set_gl_renderer(context.Describe());
  report.set_grow_iterations(static_cast<uint32_t>(options.grow_iterations));
  report.set_min_valid_fraction(options.min_valid_fraction);
  for (const scene::Light& l : sequence.lights) report.add_shadow_lights(l.name);
  const std::filesystem::path& out = options.out_dir;

  // The atlas, once, from the rest pose.
  atlas::Atlas atlas;
  {
    const auto t0 = std::chrono::steady_clock::now();
    MVBRDF_ASSIGN_OR_RETURN(atlas, atlas::BuildAtlas(sequence.topology, sequence.rest_positions, options.atlas));
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    timer.Add("atlas", seconds);
    SetAtlasFigures(atlas, seconds, report.mutable_atlas());
  }
  if (options.save != SaveFrames::kNone) {
    StageTimer::Scope t(&timer, "write");
    MVBRDF_RETURN_IF_ERROR(scene::WriteAtlasMesh(out / "atlas", atlas.topology, sequence));
    MVBRDF_RETURN_IF_ERROR(image::WriteExr(out / "atlas" / "triangle_id.exr", atlas.triangle_id));
    MVBRDF_RETURN_IF_ERROR(image::WritePngPreview(out / "atlas" / "charts.png", ChartPreview(atlas)));
  }

  MVBRDF_ASSIGN_OR_RETURN(auto resampler, resample::Resampler::Create(context, atlas, sequence.cameras,
                                                                      sequence.lights, options.resampler));
  std::vector<std::unique_ptr<scene::VideoSource>> videos;
  for (int c = 0; c < static_cast<int>(sequence.cameras.size()); ++c) {
    MVBRDF_ASSIGN_OR_RETURN(auto video, scene::VideoSource::Open(sequence.scene.cameras(c), sequence.scene_dir,
                                                                 sequence.frames, sequence.num_frames,
                                                                 absl::StrCat("scene.cameras[", c, "]")));
    videos.push_back(std::move(video));
  }

  // Ground truth, when the scene is a synthetic bundle.
  std::unique_ptr<evaluate::ResampleEvaluator> evaluator;
  const std::filesystem::path truth_file = sequence.scene_dir / "ground_truth" / "truth.json";
  if (options.evaluate && std::filesystem::exists(truth_file)) {
    MVBRDF_ASSIGN_OR_RETURN(const synth::GroundTruth truth, synth::GroundTruth::Load(truth_file));
    MVBRDF_ASSIGN_OR_RETURN(evaluator, evaluate::ResampleEvaluator::Create(context, truth, atlas,
                                                                           sequence.rest_positions, options.resampler));
  }
  report.set_has_ground_truth(evaluator != nullptr);

  std::vector<evaluate::ResampleTally> tallies(sequence.cameras.size());
  for (int t = 0; t < sequence.num_frames; ++t) {
    if (options.progress) options.progress("resample", t, sequence.num_frames);
    const bool save = options.save == SaveFrames::kAll || (options.save == SaveFrames::kFirst && t == 0);
    char frame_name[32];
    std::snprintf(frame_name, sizeof(frame_name), "%04d", sequence.AbsoluteFrame(t));
    const std::filesystem::path frame_dir = out / "frames" / frame_name;
    if (save) report.add_saved_frames(frame_name);

    scene::FramePositions positions;
    {
      StageTimer::Scope s(&timer, "mesh");
      MVBRDF_ASSIGN_OR_RETURN(positions, sequence.LoadFrame(t));
    }
    {
      StageTimer::Scope s(&timer, "geometry");
      MVBRDF_RETURN_IF_ERROR(resampler->SetFrame(positions));
    }
    {
      StageTimer::Scope s(&timer, "shadows");
      MVBRDF_ASSIGN_OR_RETURN(const cv::Mat shadows, resampler->ShadowAtlas());
      if (save) MVBRDF_RETURN_IF_ERROR(WriteShadowAtlas(frame_dir / "shadows.exr", shadows));
    }
    resample::GeometryAtlas geometry;
    if (evaluator != nullptr || save) {
      StageTimer::Scope s(&timer, "geometry_readback");
      MVBRDF_ASSIGN_OR_RETURN(geometry, resampler->Geometry());
    }
    if (save) {
      StageTimer::Scope s(&timer, "write");
      MVBRDF_RETURN_IF_ERROR(image::WriteExr(frame_dir / "position.exr", geometry.position));
      MVBRDF_RETURN_IF_ERROR(image::WriteExr(frame_dir / "normal.exr", geometry.normal));
    }
    if (evaluator != nullptr) {
      MVBRDF_RETURN_IF_ERROR(
          evaluator->SetFrame(positions, static_cast<uint32_t>(sequence.AbsoluteFrame(t))));
    }

    for (size_t c = 0; c < sequence.cameras.size(); ++c) {
      cv::Mat frame;
      {
        StageTimer::Scope s(&timer, "decode");
        MVBRDF_ASSIGN_OR_RETURN(frame, videos[c]->ReadFrame(t));
      }
      cv::Mat resampled;
      {
        StageTimer::Scope s(&timer, "resample");
        MVBRDF_ASSIGN_OR_RETURN(resampled, resampler->ResampleCamera(static_cast<int>(c), frame));
      }
      if (evaluator != nullptr) {
        StageTimer::Scope s(&timer, "evaluate");
        MVBRDF_ASSIGN_OR_RETURN(const evaluate::ResampleTally tally,
                                evaluator->Evaluate(static_cast<int>(c), resampled, geometry));
        tallies[c].Add(tally);
      } else {
        tallies[c].Add(evaluate::CountValid(resampled, atlas));
      }
      std::vector<resample::TriangleMean> means;
      {
        StageTimer::Scope s(&timer, "average");
        means = resample::AverageTriangles(resampled, atlas, options.min_valid_fraction);
      }
      if (save) {
        const std::string& name = sequence.cameras[c].name;
        cv::Mat averaged, grown;
        {
          StageTimer::Scope s(&timer, "grow");
          averaged = resample::AveragedAtlas(means, atlas);
          grown = resample::GrowAtlas(resampled, options.grow_iterations);
        }
        StageTimer::Scope s(&timer, "write");
        // File names from camera names only through FileNameFor: never outside frame_dir.
        for (const auto& [suffix, image] :
             {std::pair<const char*, const cv::Mat*>{"", &resampled}, {"_averaged", &averaged}, {"_grown", &grown}}) {
          MVBRDF_ASSIGN_OR_RETURN(const std::filesystem::path stem, scene::FileNameFor(frame_dir, name, suffix));
          MVBRDF_RETURN_IF_ERROR(WriteAtlas(stem, *image));
        }
      }
    }
  }

  if (options.progress) options.progress("resample", sequence.num_frames, sequence.num_frames);
  evaluate::ResampleTally overall;
  for (size_t c = 0; c < tallies.size(); ++c) {
    v1::CameraFigures* f = report.add_cameras();
    f->set_name(sequence.cameras[c].name);
    tallies[c].ToFigures(evaluator != nullptr, f);
    overall.Add(tallies[c]);
  }
  report.mutable_overall()->set_name("overall");
  overall.ToFigures(evaluator != nullptr, report.mutable_overall());
  timer.ToProto(report.mutable_stages());
  const double gpu_seconds = timer.Seconds("geometry") + timer.Seconds("shadows") + timer.Seconds("resample");
  const double atlases = static_cast<double>(sequence.num_frames) * static_cast<double>(sequence.cameras.size());
  report.set_atlases_per_second(gpu_seconds > 0.0 ? atlases / gpu_seconds : 0.0);
  report.set_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  report.set_peak_rss_bytes(PeakRssBytes());
  MVBRDF_RETURN_IF_ERROR(WriteJsonFile(out / "resample.json", report));
  return report;
}

}  // namespace mvbrdf::pipeline
