#include "core/synth/synthesizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <random>
#include <tuple>

#include <glm/gtc/matrix_transform.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "core/atlas/atlas.h"
#include "core/base/draw_order.h"
#include "core/base/files.h"
#include "core/base/proto_json.h"
#include "core/base/status_macros.h"
#include "core/render/phong_renderer.h"
#include "core/scene/fingerprint.h"
#include "core/scene/mesh_loader.h"
#include "core/scene/sequence.h"
#include "core/scene/video_source.h"
#include "core/synth/frame_encoder.h"
#include "core/synth/measured_materials.h"
#include "core/synth/model_materials.h"
#include "core/synth/subject.h"
#include "core/synth/video_writer.h"

namespace mvbrdf::synth {
namespace {

absl::Status CheckRange(absl::string_view flag, double value, double lo, double hi) {
  if (!(value >= lo && value <= hi)) {
    return absl::InvalidArgumentError(absl::StrCat(flag, ": must be in [", lo, ", ", hi, "], got ", value));
  }
  return absl::OkStatus();
}

std::string StripSpaces(absl::string_view s) {
  std::string out;
  for (char c : s) {
    if (c != ' ') out.push_back(c);
  }
  return out;
}

void SetVec3(const glm::vec3& v, google::protobuf::RepeatedField<double>* out) {
  out->Clear();
  for (int i = 0; i < 3; ++i) out->Add(v[i]);
}

// A rotation by `deg` degrees about a random axis and a translation of
// `distance` in a random direction, applied to the camera's pose.
scene::CameraModel PerturbCamera(const scene::CameraModel& camera, double deg, double distance, std::mt19937& rng) {
  if (deg == 0.0 && distance == 0.0) return camera;
  std::normal_distribution<double> n(0.0, 1.0);
  const auto random_unit = [&] {
    return glm::normalize(base::DrawVec3<glm::dvec3>([&] { return n(rng); }));
  };
  scene::CameraModel out = camera;
  const glm::dmat3 delta(glm::rotate(glm::dmat4(1.0), deg * 3.14159265358979 / 180.0, random_unit()));
  out.cam_from_world_rotation = delta * camera.cam_from_world_rotation;
  // Keep the camera centre, then move it by `distance`.
  const glm::dvec3 center = camera.CenterInWorld() + distance * random_unit();
  out.cam_from_world_translation = -(out.cam_from_world_rotation * center);
  return out;
}

// The light as written to the scene: moved by `distance` in a random
// direction (point) or turned by `deg` about a random axis (directional),
// its intensity scaled by 1 + or - `fraction`.
scene::Light PerturbLight(const scene::Light& light, double distance, double deg, double fraction, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const glm::dvec3 random_unit = glm::normalize(base::DrawVec3<glm::dvec3>([&] { return n(rng); }));
  const bool brighter = std::uniform_int_distribution<int>(0, 1)(rng) == 1;
  scene::Light out = light;
  if (light.directional) {
    const glm::dvec3 d = glm::normalize(glm::dvec3(light.direction));
    // An axis perpendicular to the direction, so the turn is `deg`.
    const glm::dvec3 axis = glm::normalize(random_unit - glm::dot(random_unit, d) * d);
    out.direction = glm::vec3(glm::dmat3(glm::rotate(glm::dmat4(1.0), deg * 3.14159265358979 / 180.0, axis)) * d);
  } else {
    out.position = glm::vec3(glm::dvec3(light.position) + distance * random_unit);
  }
  out.intensity = light.intensity * static_cast<float>(brighter ? 1.0 + fraction : 1.0 - fraction);
  return out;
}

// One camera image as a sensor records it: `samples` x `samples` renders
// per pixel (the camera scaled so that each pixel's block of samples covers
// it), distorted at that resolution and averaged in linear light, so that a
// pixel the silhouette crosses holds the mean of what it sees. A distorted
// camera's pinhole image is rendered at kDistortionOversampling or more
// subpixels per sample, so that the warp does not blur what one sample sees.
absl::StatusOr<cv::Mat> RenderPixelAreas(render::PhongRenderer& renderer, const render::Pose& pose,
                                         const scene::CameraModel& camera, int samples) {
  samples = std::max(samples, 1);
  const int oversampling =
      camera.has_distortion() ? (kDistortionOversampling + samples - 1) / samples : 1;
  const scene::CameraModel sampled = scene::Supersampled(camera, samples);
  MVBRDF_ASSIGN_OR_RETURN(render::RenderOutput image,
                          renderer.Render(pose, scene::Supersampled(sampled, oversampling)));
  cv::Mat distorted = ApplyDistortion(image.radiance, sampled, oversampling);
  if (samples == 1) return distorted;
  cv::Mat out;
  cv::resize(distorted, out, cv::Size(camera.width, camera.height), 0, 0, cv::INTER_AREA);
  return out;
}

// Smooth displacement along the normals: geometry the mesh does not model.
scene::FramePositions DisplaceVertices(const scene::MeshTopology& topology, const scene::FramePositions& rest,
                                       const scene::FramePositions& posed, double amplitude, uint32_t seed) {
  if (amplitude == 0.0) return posed;
  const std::vector<glm::vec3> normals = scene::ComputeFileVertexNormals(topology, posed);
  const glm::vec3 offset(0.37f * static_cast<float>(seed % 97), 11.3f, 5.7f);
  scene::FramePositions out(posed.size());
  for (size_t i = 0; i < posed.size(); ++i) {
    out[i] = posed[i] + static_cast<float>(amplitude) * render::ValueNoise(rest[i] * 8.0f + offset) * normals[i];
  }
  return out;
}

}  // namespace

absl::StatusOr<Preset> ParsePreset(absl::string_view name) {
  if (name == "actor") return Preset::kActor;
  if (name == "spot") return Preset::kSpot;
  if (name == "samba") return Preset::kSamba;
  if (name == "sphere") return Preset::kSphere;
  return absl::InvalidArgumentError(
      absl::StrCat("--preset: expected actor, spot, samba or sphere, got \"", name, "\""));
}

const char* PresetName(Preset preset) {
  switch (preset) {
    case Preset::kActor: return "actor";
    case Preset::kSpot: return "spot";
    case Preset::kSamba: return "samba";
    case Preset::kSphere: return "sphere";
  }
  return "?";
}

absl::StatusOr<Lighting> ParseLighting(absl::string_view name) {
  if (name == "studio") return Lighting::kStudio;
  if (name == "olat") return Lighting::kOlat;
  return absl::InvalidArgumentError(absl::StrCat("--lighting: expected studio or olat, got \"", name, "\""));
}

absl::StatusOr<scene::Projection> ParseCameraModel(absl::string_view name) {
  if (name == "pinhole") return scene::Projection::kPinhole;
  if (name == "orthographic") return scene::Projection::kOrthographic;
  return absl::InvalidArgumentError(
      absl::StrCat("--camera-model: expected pinhole or orthographic, got \"", name, "\""));
}

absl::Status SynthOptions::Check() const {
  MVBRDF_RETURN_IF_ERROR(CheckRange("--cameras", num_cameras, 1, 64));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--frames", num_frames, 1, 100000));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--width", width, 16, 8192));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--height", height, 16, 8192));
  if (bit_depth != 8 && bit_depth != 16) {
    return absl::InvalidArgumentError(absl::StrCat("--bit-depth: expected 8 or 16, got ", bit_depth));
  }
  if (bit_depth == 16 && (video_format != VideoFormat::kPng || lossy_video)) {
    return absl::InvalidArgumentError("--bit-depth 16: needs --format png (the video codecs store 8 bits)");
  }
  MVBRDF_RETURN_IF_ERROR(CheckRange("--fps", fps, 0.1, 1000));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--noise", noise_sigma, 0, 255));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--camera-rotation-error", camera_rotation_error_deg, 0, 90));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--camera-translation-error", camera_translation_error, 0, 100));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--vertex-noise", vertex_noise, 0, 1));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--exposure", exposure, 0.01, 100));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--distortion", distortion_k1, -1, 1));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--pixel-samples", pixel_samples, 1, 8));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--normal-detail", normal_detail, 0, 2));
  if (std::max(width, height) * pixel_samples > 16384) {
    return absl::InvalidArgumentError(absl::StrCat("--pixel-samples: ", pixel_samples, " x the image's ",
                                                   std::max(width, height), " pixels exceeds 16384"));
  }
  MVBRDF_RETURN_IF_ERROR(CheckRange("--light-position-error", light_position_error, 0, 1000));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--light-direction-error", light_direction_error_deg, 0, 90));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--light-intensity-error", light_intensity_error, 0, 0.9));
  if (camera_model == scene::Projection::kOrthographic && distortion_k1 != 0.0) {
    return absl::InvalidArgumentError("--distortion: an orthographic camera has no distortion (--camera-model)");
  }
  MVBRDF_RETURN_IF_ERROR(CheckRange("--actor-segments", actor_segments, 6, 256));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--shadow-map-size", shadow_map_size, 64, 8192));
  MVBRDF_RETURN_IF_ERROR(CheckRange("--dome", dome, 0, 1024));
  if (out_dir.empty()) return absl::InvalidArgumentError("--out: required");
  return absl::OkStatus();
}

absl::StatusOr<SynthResult> Synthesize(const SynthOptions& options, gl::EglContext& context) {
  const auto start = std::chrono::steady_clock::now();
  MVBRDF_RETURN_IF_ERROR(options.Check());
  Subject subject;
  switch (options.preset) {
    case Preset::kActor: subject = MakeActorSubject(options.actor_segments, options.fps); break;
    case Preset::kSpot: { MVBRDF_ASSIGN_OR_RETURN(subject, MakeSpotSubject(options.data_dir)); break; }
    case Preset::kSamba: { MVBRDF_ASSIGN_OR_RETURN(subject, MakeSambaSubject(options.data_dir)); break; }
    case Preset::kSphere: subject = MakeSphereSubject(); break;
  }
  if (subject.max_frames > 0 && options.num_frames > subject.max_frames) {
    return absl::InvalidArgumentError(absl::StrCat("--frames: the ", subject.preset, " preset has ", subject.max_frames,
                                                   " frames, got ", options.num_frames));
  }

  // Normal detail is read in the tangent frames of UVs (issue #18): a
  // subject without them gets an atlas's, which its meshes then carry.
  if (options.normal_detail > 0.0 && !subject.topology.has_uvs()) {
    MVBRDF_ASSIGN_OR_RETURN(const atlas::Atlas uv_atlas,
                            atlas::BuildAtlas(subject.topology, subject.rest_positions, atlas::AtlasOptions()));
    subject.topology = uv_atlas.topology;
  }

  std::vector<std::optional<MeasuredMaterial>> measured(subject.materials.size());
  if (!options.materials.empty()) {
    std::vector<std::string> slots;
    for (const StudioMaterial& m : subject.materials) slots.push_back(m.name);
    MVBRDF_ASSIGN_OR_RETURN(measured, ResolveMeasuredMaterials(options.materials, slots,
                                                               options.merl_file.empty()
                                                                   ? DefaultMerlFile(options.data_dir)
                                                                   : options.merl_file));
  }

  SubjectBounds bounds{subject.rest_positions.front(), subject.rest_positions.front()};
  for (const glm::vec3& p : subject.rest_positions) {
    bounds.min = glm::min(bounds.min, p);
    bounds.max = glm::max(bounds.max, p);
  }
  StudioOptions studio_options;
  studio_options.num_cameras = options.num_cameras;
  studio_options.width = options.width;
  studio_options.height = options.height;
  studio_options.distortion_k1 = options.distortion_k1;
  studio_options.projection = options.camera_model;
  Studio studio = MakeStudio(studio_options, bounds);
  const bool olat = options.lighting == Lighting::kOlat;
  std::string wanted = StripSpaces(options.configuration);
  if (options.dome > 0) {
    // The dome replaces the ceiling lights; its one configuration is the
    // lights asked for ("all" or names; every light with olat).
    std::vector<scene::Light> dome = MakeDomeLights(options.dome, 0.8f);
    Studio::Configuration config;
    if (wanted.empty() || wanted == "all" || olat) {
      config.name = "all";
      for (const scene::Light& l : dome) config.lights.push_back(l.name);
    } else {
      for (absl::string_view name : absl::StrSplit(wanted, ',')) {
        const auto it = std::find_if(dome.begin(), dome.end(), [&](const scene::Light& l) { return l.name == name; });
        if (it == dome.end()) {
          return absl::InvalidArgumentError(absl::StrCat("--config: no dome light \"", name, "\"; expected \"all\" or ",
                                                         dome.front().name, " .. ", dome.back().name));
        }
        if (std::find(config.lights.begin(), config.lights.end(), it->name) != config.lights.end()) {
          return absl::InvalidArgumentError(absl::StrCat("--config: dome light \"", name, "\" named twice"));
        }
        config.lights.push_back(it->name);
      }
      config.name = ConfigurationName(config.lights);
    }
    const int on = olat ? 1 : static_cast<int>(config.lights.size());
    const float intensity = 0.8f / std::max(1.0f, static_cast<float>(on) / 4.0f);
    for (scene::Light& l : dome) l.intensity = glm::vec3(intensity);
    studio.lights = std::move(dome);
    studio.configurations = {config};
    wanted = config.name;
  } else if (wanted.empty()) {
    wanted = "NE,NW,SE,SW";
  }
  const Studio::Configuration* active = nullptr;
  for (const auto& c : studio.configurations) {
    if (c.name == wanted) active = &c;
  }
  if (active == nullptr) {
    std::vector<std::string> names;
    for (const auto& c : studio.configurations) names.push_back(c.name);
    return absl::InvalidArgumentError(absl::StrCat("--config: unknown configuration \"", options.configuration,
                                                   "\"; expected one of: ", absl::StrJoin(names, " | ")));
  }
  std::vector<scene::Light> active_lights;
  for (const std::string& name : active->lights) {
    for (const scene::Light& l : studio.lights) {
      if (l.name == name) active_lights.push_back(l);
    }
  }
  // The lights of frame t.
  const auto frame_lights = [&](int t) -> std::vector<scene::Light> {
    if (!olat) return active_lights;
    return {studio.lights[static_cast<size_t>(t) % studio.lights.size()]};
  };
  if (olat) active_lights = studio.lights;  // every light lights some frame

  // Each measured material's exposure (MeasuredGain): like the slot's
  // analytic material, or its highlights under the brightest light unclipped.
  std::vector<double> measured_gain(subject.materials.size(), 1.0);
  float brightest = 0.0f;
  for (const scene::Light& l : active_lights) {
    brightest = std::max({brightest, l.intensity.x, l.intensity.y, l.intensity.z});
  }
  for (size_t k = 0; k < measured.size(); ++k) {
    if (!measured[k]) continue;
    const glm::vec3& base = subject.materials[k].kd.base;
    const bool highlights = options.measured_exposure == SynthOptions::MeasuredExposure::kHighlights;
    measured_gain[k] = MeasuredGain(measured[k]->brdf, (base.x + base.y + base.z) / 3.0, highlights ? brightest : 0.0);
  }

  std::mt19937 rng(options.seed);
  // Cameras as rendered (truth) and as written to the scene (perturbed).
  std::vector<scene::CameraModel> scene_cameras;
  for (const auto& cam : studio.cameras) {
    scene_cameras.push_back(
        PerturbCamera(cam, options.camera_rotation_error_deg, options.camera_translation_error, rng));
  }

  // The renderer draws the true materials.
  render::RenderMesh render_mesh;
  render_mesh.triangles = subject.topology.triangles;
  render_mesh.uvs = subject.topology.uvs;
  render_mesh.rest_positions = scene::ToRenderVertices(subject.topology, subject.rest_positions);
  render_mesh.triangle_material = subject.triangle_material;
  render::RendererOptions renderer_options;
  renderer_options.shadow_map_size = options.shadow_map_size;
  renderer_options.brdf_model = options.brdf;
  MVBRDF_ASSIGN_OR_RETURN(auto renderer, render::PhongRenderer::Create(context, render_mesh, renderer_options));
  std::vector<render::ProceduralMaterial> materials;
  std::vector<brdf::NeuralBrdf> measured_brdfs;
  for (size_t i = 0; i < subject.materials.size(); ++i) {
    const StudioMaterial& m = subject.materials[i];
    render::ProceduralMaterial pm;
    pm.kd = m.kd;
    pm.kd_from_texture = !subject.kd_texture.empty();
    std::tie(pm.ks, pm.ke) = ModelParametersOf(options.brdf, m);
    if (measured[i]) {
      pm.measured = static_cast<int>(measured_brdfs.size());
      pm.measured_gain = static_cast<float>(measured_gain[i]);
      pm.kd_from_texture = false;
      measured_brdfs.push_back(measured[i]->brdf);
    }
    materials.push_back(pm);
  }
  MVBRDF_RETURN_IF_ERROR(renderer->SetMeasuredBrdfs(measured_brdfs));
  MVBRDF_RETURN_IF_ERROR(renderer->SetProceduralMaterials(materials));
  render::NormalDetail detail;
  if (options.normal_detail > 0.0) {
    detail.amplitude = static_cast<float>(options.normal_detail);
    detail.wavelength = static_cast<float>(kNormalDetailWavelength * 0.5 * glm::length(bounds.max - bounds.min));
    MVBRDF_RETURN_IF_ERROR(renderer->SetNormalDetail(detail));
  }
  if (!subject.kd_texture.empty()) {
    MVBRDF_RETURN_IF_ERROR(renderer->SetKdTexture(subject.kd_texture));
  }
  if (!olat) MVBRDF_RETURN_IF_ERROR(renderer->SetLights(active_lights));

  const std::filesystem::path out = options.out_dir;
  std::error_code ec;
  std::filesystem::create_directories(out / "meshes", ec);
  std::filesystem::create_directories(out / "ground_truth", ec);
  if (ec) return ErrnoStatus(ec.value(), "cannot create output directory", out.string());

  const VideoCodec codec = options.lossy_video ? VideoCodec::kMpeg4Lossy
                           : options.video_format == VideoFormat::kPng ? VideoCodec::kPngSequence
                                                                       : VideoCodec::kFfv1;
  std::vector<std::unique_ptr<FrameSink>> sinks;
  for (const auto& cam : studio.cameras) {
    MVBRDF_ASSIGN_OR_RETURN(auto sink, FrameSink::Open(out / "videos" / cam.name, out, codec, options.width,
                                                       options.height, options.fps, 0));
    sinks.push_back(std::move(sink));
  }

  const std::string mesh_pattern = "meshes/mesh_%04d.obj";
  EncodeOptions encode;
  encode.exposure = options.exposure;
  encode.noise_sigma = options.noise_sigma;
  for (int t = 0; t < options.num_frames; ++t) {
    MVBRDF_ASSIGN_OR_RETURN(scene::FramePositions posed, subject.pose(t));
    MVBRDF_RETURN_IF_ERROR(
        scene::WriteObj(out / FormatFramePattern(mesh_pattern, t), subject.topology, posed));
    const scene::FramePositions rendered =
        DisplaceVertices(subject.topology, subject.rest_positions, posed, options.vertex_noise, options.seed);
    const std::vector<glm::vec3> normals = scene::ComputeFileVertexNormals(subject.topology, rendered);
    render::Pose pose;
    pose.positions = scene::ToRenderVertices(subject.topology, rendered);
    pose.normals = scene::ToRenderVertices(subject.topology, normals);
    if (olat) MVBRDF_RETURN_IF_ERROR(renderer->SetLights(frame_lights(t)));
    for (size_t c = 0; c < studio.cameras.size(); ++c) {
      MVBRDF_ASSIGN_OR_RETURN(const cv::Mat image,
                              RenderPixelAreas(*renderer, pose, studio.cameras[c], options.pixel_samples));
      MVBRDF_RETURN_IF_ERROR(sinks[c]->Write(EncodeSrgb(image, encode, options.bit_depth, rng)));
    }
  }
  for (auto& sink : sinks) MVBRDF_RETURN_IF_ERROR(sink->Close());

  // The scene: what a user of real data would have.
  v1::Scene scene;
  scene.set_name(absl::StrCat("synthetic ", subject.preset, " (seed ", options.seed, ")"));
  scene.mutable_mesh()->set_path(mesh_pattern);
  scene.mutable_frames()->set_first(0);
  scene.mutable_frames()->set_count(static_cast<uint32_t>(options.num_frames));
  scene.mutable_frames()->set_fps(options.fps);
  for (size_t c = 0; c < scene_cameras.size(); ++c) {
    v1::Camera* cam = scene.add_cameras();
    scene::CameraModelToProto(scene_cameras[c], cam);
    cam->mutable_video()->set_path(sinks[c]->scene_path());
    cam->mutable_video()->set_encoding(v1::SRGB);
    cam->mutable_video()->set_bit_depth(static_cast<uint32_t>(options.bit_depth));
  }
  // The lights as written (perturbed; truth.lights are the rendered ones).
  std::mt19937 light_rng(options.seed ^ 0x9e3779b9u);
  const bool perturb_lights = options.light_position_error > 0.0 || options.light_direction_error_deg > 0.0 ||
                              options.light_intensity_error > 0.0;
  for (const scene::Light& rendered : studio.lights) {
    const scene::Light l = perturb_lights ? PerturbLight(rendered, options.light_position_error,
                                                         options.light_direction_error_deg,
                                                         options.light_intensity_error, light_rng)
                                          : rendered;
    v1::Light* light = scene.add_lights();
    light->set_name(l.name);
    if (l.directional) {
      SetVec3(l.direction, light->mutable_direction());
    } else {
      SetVec3(l.position, light->mutable_position());
    }
    SetVec3(l.intensity, light->mutable_intensity());
  }
  for (const auto& c : studio.configurations) {
    v1::LightConfiguration* config = scene.add_light_configurations();
    config->set_name(c.name);
    for (const std::string& l : c.lights) config->add_lights(l);
  }
  std::vector<v1::FrameLighting> frame_lighting;
  if (olat) {
    for (int t = 0; t < options.num_frames; ++t) {
      v1::FrameLighting fl;
      fl.set_frame(static_cast<uint32_t>(t));  // scene.frames.first is 0
      for (const scene::Light& l : frame_lights(t)) fl.add_lights(l.name);
      *scene.add_frame_lighting() = fl;
      frame_lighting.push_back(std::move(fl));
    }
  }
  for (size_t k = 0; k < subject.materials.size(); ++k) {
    const StudioMaterial& m = subject.materials[k];
    v1::MaterialSeed* seed = scene.add_material_seeds();
    seed->set_name(m.name);
    if (measured[k]) {
      // The measured material's own diffuse colour, in the data's units.
      const glm::dvec3 rgb = measured_gain[k] * DiffuseColour(measured[k]->brdf);
      for (int i = 0; i < 3; ++i) seed->add_linear_rgb(rgb[i]);
    } else {
      for (int i = 0; i < 3; ++i) seed->add_srgb8(static_cast<uint32_t>(m.seed_srgb8[i]));
    }
  }
  if (!subject.segment_names.empty()) {
    std::string lines;
    for (uint32_t s : subject.triangle_segment) absl::StrAppend(&lines, subject.segment_names[s], "\n");
    MVBRDF_RETURN_IF_ERROR(WriteStringToFile(out / "segments.txt", lines));
    scene.set_segmentation_path("segments.txt");
    for (size_t s = 0; s < subject.segment_names.size(); ++s) {
      std::vector<bool> used(subject.materials.size(), false);
      for (size_t t = 0; t < subject.triangle_segment.size(); ++t) {
        if (subject.triangle_segment[t] == s) used[subject.triangle_material[t]] = true;
      }
      v1::SegmentMaterials* sm = scene.add_segment_materials();
      sm->set_segment(subject.segment_names[s]);
      for (size_t m = 0; m < used.size(); ++m) {
        if (used[m]) sm->add_materials(subject.materials[m].name);
      }
    }
  }
  const std::filesystem::path scene_file = out / "scene.json";
  MVBRDF_RETURN_IF_ERROR(WriteJsonFile(scene_file, scene));

  // The truth: what was rendered.
  SynthResult result;
  v1::GroundTruth& truth = result.truth;
  truth.set_preset(subject.preset);
  truth.set_seed(options.seed);
  truth.set_active_configuration(olat ? std::string(scene::kPerFrameLighting) : active->name);
  for (const v1::FrameLighting& fl : frame_lighting) *truth.add_frame_lighting() = fl;
  for (const scene::Light& l : active_lights) {
    v1::Light* light = truth.add_lights();
    light->set_name(l.name);
    if (l.directional) {
      SetVec3(l.direction, light->mutable_direction());
    } else {
      SetVec3(l.position, light->mutable_position());
    }
    SetVec3(l.intensity, light->mutable_intensity());
  }
  truth.set_inverse_square_falloff(renderer_options.inverse_square_falloff);
  for (const auto& cam : studio.cameras) scene::CameraModelToProto(cam, truth.add_cameras());
  for (size_t k = 0; k < subject.materials.size(); ++k) {
    const StudioMaterial& m = subject.materials[k];
    v1::Material* mat = truth.add_materials();
    mat->set_name(m.name);
    if (measured[k]) {
      mat->set_measured(measured[k]->name);
      for (float w : measured[k]->brdf.GlslWeights()) mat->add_measured_weights(w);
      mat->set_measured_gain(measured_gain[k]);
      continue;
    }
    SetVec3(m.kd.base, mat->mutable_kd()->mutable_base());
    mat->mutable_kd()->set_amplitude(m.kd.amplitude);
    mat->mutable_kd()->set_frequency(m.kd.frequency);
    SetVec3(m.kd.offset, mat->mutable_kd()->mutable_offset());
    if (!subject.kd_texture.empty()) mat->set_kd_texture_path("kd_texture.png");
    const auto [p0, p1] = ModelParametersOf(options.brdf, m);
    if (options.brdf == brdf::Model::kGgx) {
      SetVec3(p0, mat->mutable_f0());
      SetVec3(p1, mat->mutable_roughness());
    } else {
      SetVec3(p0, mat->mutable_ks());
      SetVec3(p1, mat->mutable_ke());
    }
  }
  truth.set_brdf(brdf::ModelName(options.brdf));
  if (!subject.kd_texture.empty()) {
    std::filesystem::copy_file(subject.kd_texture_file, out / "ground_truth" / "kd_texture.png",
                               std::filesystem::copy_options::overwrite_existing, ec);
    if (ec) return absl::InternalError(absl::StrCat("cannot copy ", subject.kd_texture_file.string(), ": ", ec.message()));
  }
  for (uint32_t m : subject.triangle_material) truth.add_triangle_materials(m);
  v1::Perturbations* p = truth.mutable_perturbations();
  p->set_sensor_noise_sigma(options.noise_sigma);
  p->set_camera_rotation_error_deg(options.camera_rotation_error_deg);
  p->set_camera_translation_error(options.camera_translation_error);
  p->set_vertex_noise(options.vertex_noise);
  p->set_lossy_video(options.lossy_video);
  p->set_exposure(options.exposure);
  p->set_light_position_error(options.light_position_error);
  p->set_light_intensity_error(options.light_intensity_error);
  p->set_light_direction_error_deg(options.light_direction_error_deg);
  p->set_pixel_samples(static_cast<uint32_t>(options.pixel_samples));
  if (detail.amplitude > 0.0f) {
    v1::NormalDetail* d = truth.mutable_normal_detail();
    d->set_amplitude(detail.amplitude);
    d->set_wavelength(detail.wavelength);
    for (int i = 0; i < 3; ++i) {
      d->add_d1(detail.d1[i]);
      d->add_d2(detail.d2[i]);
    }
  }
  truth.set_shadow_map_size(static_cast<uint32_t>(options.shadow_map_size));
  {
    // The scene as `mvbrdf run` will read it (the mesh as parsed back from
    // the written file), for `mvbrdf evaluate` to check a run is of it.
    scene::LoadOptions quick;
    quick.check_all_frames = false;
    quick.probe_videos = false;
    absl::StatusOr<scene::Sequence> written = scene::LoadSequence(scene_file, quick);
    if (!written.ok()) return written.status();
    *truth.mutable_scene() = scene::Fingerprint(*written);
  }
  MVBRDF_RETURN_IF_ERROR(WriteJsonFile(out / "ground_truth" / "truth.json", truth));

  result.scene_file = scene_file;
  result.num_triangles = static_cast<int>(subject.topology.triangles.size());
  result.frames_rendered = options.num_frames * options.num_cameras;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace mvbrdf::synth
