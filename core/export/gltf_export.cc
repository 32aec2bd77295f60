#include "core/export/gltf_export.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <glm/gtc/quaternion.hpp>
#include <opencv2/imgcodecs.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/brdf/ggx.h"
#include "core/brdf/ggx_equivalent.h"
#include "core/export/export_input.h"
#include "core/image/exr.h"
#include "core/pipeline/normal_stage.h"
#include "core/scene/tangent_frames.h"
#include "core/base/version.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::exporter {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

// Appends bytes to the model's one buffer as a new buffer view (4-byte
// aligned); returns the view's index.
int AddView(tinygltf::Model* model, const void* data, size_t bytes, int target) {
  std::vector<unsigned char>& buffer = model->buffers[0].data;
  while (buffer.size() % 4 != 0) buffer.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buffer.size();
  view.byteLength = bytes;
  if (target != 0) view.target = target;
  const auto* p = static_cast<const unsigned char*>(data);
  buffer.insert(buffer.end(), p, p + bytes);
  model->bufferViews.push_back(view);
  return static_cast<int>(model->bufferViews.size() - 1);
}

int AddVec3Accessor(tinygltf::Model* model, const std::vector<glm::vec3>& v, bool bounds) {
  tinygltf::Accessor a;
  a.bufferView = AddView(model, v.data(), v.size() * sizeof(glm::vec3), kArrayBuffer);
  a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  a.type = TINYGLTF_TYPE_VEC3;
  a.count = v.size();
  if (bounds) {
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (const glm::vec3& x : v) lo = glm::min(lo, x), hi = glm::max(hi, x);
    a.minValues = {lo.x, lo.y, lo.z};
    a.maxValues = {hi.x, hi.y, hi.z};
  }
  model->accessors.push_back(a);
  return static_cast<int>(model->accessors.size() - 1);
}

// A vertex attribute of `count` elements of `components` floats (glTF type
// `type`, e.g. TINYGLTF_TYPE_VEC2), without bounds.
int AddFloatAccessor(tinygltf::Model* model, const void* data, size_t count, int type, size_t components) {
  tinygltf::Accessor a;
  a.bufferView = AddView(model, data, count * components * sizeof(float), kArrayBuffer);
  a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  a.type = type;
  a.count = count;
  model->accessors.push_back(a);
  return static_cast<int>(model->accessors.size() - 1);
}

// A PNG image in the buffer, and a texture reading it with the one sampler.
absl::StatusOr<int> AddPngTexture(tinygltf::Model* model, const cv::Mat& bgr_or_gray, const std::string& name) {
  std::vector<unsigned char> png;
  if (!cv::imencode(".png", bgr_or_gray, png)) return absl::InternalError(absl::StrCat("encoding ", name, " as PNG"));
  tinygltf::Image image;
  image.name = name;
  image.mimeType = "image/png";
  image.bufferView = AddView(model, png.data(), png.size(), 0);
  model->images.push_back(image);
  tinygltf::Texture texture;
  texture.name = name;
  texture.sampler = 0;
  texture.source = static_cast<int>(model->images.size() - 1);
  model->textures.push_back(texture);
  return static_cast<int>(model->textures.size() - 1);
}

tinygltf::Value Object(std::initializer_list<std::pair<const std::string, tinygltf::Value>> members) {
  return tinygltf::Value(tinygltf::Value::Object(members));
}

std::vector<double> Quaternion(const glm::dmat3& rotation) {
  const glm::dquat q = glm::normalize(glm::quat_cast(rotation));
  return {q.x, q.y, q.z, q.w};
}

// The textures of the material, per texel of the run's atlases.
struct MaterialTextures {
  cv::Mat base_color;         // CV_8UC3 BGR, sRGB
  cv::Mat metallic_roughness; // CV_8UC3 BGR, linear: G roughness, B metallic 0
  cv::Mat specular;           // CV_8UC4 BGRA: RGB specularColor / colour_factor (sRGB), A specularFactor (linear)
  cv::Mat confidence;         // CV_8UC1
  double scale = 1.0;
  // specularColorFactor (all three): 1, or above 1 where a lobe's F90 / F0 is
  // below a dielectric's 25 (specularColor = 25 / (F90 / F0) there), so that
  // the texture stays in [0, 1].
  double colour_factor = 1.0;
  double clipped_fraction = 0.0;
};

MaterialTextures Convert(const pipeline::RunAtlases& a) {
  const int rows = a.kd.rows, cols = a.kd.cols;
  // Per texel: the GGX lobe (F0 and F90 per channel, one roughness) and kd.
  std::vector<glm::dvec3> f0(static_cast<size_t>(rows * cols)), f90(f0.size());
  std::vector<double> roughness(f0.size());
  std::vector<double> f90_observed, diffuse_observed;
  double confidence_max = 0.0;
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      const size_t i = static_cast<size_t>(y * cols + x);
      const brdf::Model model = a.ModelAt(x, y);
      const cv::Vec3f p1 = a.p1.at<cv::Vec3f>(y, x), p2 = a.p2.at<cv::Vec3f>(y, x);
      const cv::Vec3f p3 = a.p3.empty() ? cv::Vec3f::all(static_cast<float>(brdf::Ggx::kDielectricRatio))
                                        : a.p3.at<cv::Vec3f>(y, x);
      double r = 0.0;
      for (int c = 0; c < 3; ++c) {
        const brdf::ParameterVector g = brdf::GgxEquivalent(model, {p1[c], p2[c], p3[c]});
        f0[i][c] = std::isfinite(g[0]) ? std::max(0.0, g[0]) : 0.0;
        f90[i][c] = f0[i][c] * (std::isfinite(g[2]) && g[2] >= 1.0 ? g[2] : brdf::Ggx::kDielectricRatio);
        r += g[1] / 3.0;
      }
      roughness[i] = r;
      const float conf = a.confidence.at<float>(y, x);
      confidence_max = std::max(confidence_max, static_cast<double>(conf));
      if (conf > 0.0f) {
        const cv::Vec3f kd = a.kd.at<cv::Vec3f>(y, x);
        f90_observed.push_back(std::max({f90[i].x, f90[i].y, f90[i].z}));
        diffuse_observed.push_back(kPi * std::max({kd[0], kd[1], kd[2]}));
      }
    }
  }
  MaterialTextures t;
  const double f90_top = Quantile(f90_observed, 0.999), diffuse_top = Quantile(diffuse_observed, 0.999);
  t.scale = 1.0 / std::max({f90_top, diffuse_top, 1e-12});
  t.base_color.create(rows, cols, CV_8UC3);
  t.metallic_roughness.create(rows, cols, CV_8UC3);
  t.specular.create(rows, cols, CV_8UC4);
  t.confidence.create(rows, cols, CV_8UC1);
  // glTF's F0 = 0.04 specularColor specularFactor (ior 1.5), F90 =
  // specularFactor: specularColor = F0 / (0.04 F90) per channel.
  constexpr double kIorF0 = 1.0 / brdf::Ggx::kDielectricRatio;
  const auto colour_of = [&](size_t i, int c) {
    const double top = std::max({f90[i].x, f90[i].y, f90[i].z});
    return top > 0.0 ? f0[i][c] / (kIorF0 * top) : 0.0;
  };
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      const size_t i = static_cast<size_t>(y * cols + x);
      if (a.confidence.at<float>(y, x) <= 0.0f) continue;
      for (int c = 0; c < 3; ++c) t.colour_factor = std::max(t.colour_factor, colour_of(i, c));
    }
  }
  size_t clipped = 0;
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      const size_t i = static_cast<size_t>(y * cols + x);
      const double top = std::max({f90[i].x, f90[i].y, f90[i].z}) * t.scale;
      const double factor = std::min(1.0, top);
      const cv::Vec3f kd = a.kd.at<cv::Vec3f>(y, x);
      bool clip = top > 1.0;
      cv::Vec3b base, colour;
      for (int c = 0; c < 3; ++c) {
        // glTF's diffuse weight head on, 1 - F0 (absolute: F0 scale, as the
        // specular textures say it), against ggx.h's 1 - F0 / F90.
        const double ratio = f0[i][c] > 0.0 ? f90[i][c] / f0[i][c] : brdf::Ggx::kDielectricRatio;
        const double gltf_weight = 1.0 - std::min(1.0, kIorF0 * colour_of(i, c)) * factor;
        const double diffuse_gain = gltf_weight > 0.0 ? (1.0 - 1.0 / ratio) / gltf_weight : 0.0;
        const double b = kPi * std::max(0.0f, kd[c]) * t.scale * diffuse_gain;
        clip |= b > 1.0;
        base[2 - c] = Srgb8(b);
        colour[2 - c] = Srgb8(colour_of(i, c) / t.colour_factor);
      }
      if (clip && a.confidence.at<float>(y, x) > 0.0f) ++clipped;
      t.base_color.at<cv::Vec3b>(y, x) = base;
      t.metallic_roughness.at<cv::Vec3b>(y, x) = cv::Vec3b(0, Linear8(roughness[i]), 0);
      t.specular.at<cv::Vec4b>(y, x) = cv::Vec4b(colour[0], colour[1], colour[2], Linear8(factor));
      t.confidence.at<uint8_t>(y, x) =
          Linear8(confidence_max > 0.0 ? a.confidence.at<float>(y, x) / confidence_max : 0.0);
    }
  }
  t.clipped_fraction =
      f90_observed.empty() ? 0.0 : static_cast<double>(clipped) / static_cast<double>(f90_observed.size());
  return t;
}

// The scene's extent: its mesh's bounding box centre and diagonal.
std::pair<glm::dvec3, double> Extent(const std::vector<glm::vec3>& positions) {
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (const glm::vec3& p : positions) lo = glm::min(lo, glm::dvec3(p)), hi = glm::max(hi, glm::dvec3(p));
  return {0.5 * (lo + hi), glm::length(hi - lo)};
}

void AddCamera(tinygltf::Model* model, const scene::CameraModel& camera, const glm::dvec3& centre, double diagonal) {
  tinygltf::Camera c;
  c.name = camera.name;
  const glm::dvec3 position = camera.CenterInWorld();
  const double distance = glm::length(position - centre);
  const double znear = std::max(1e-6 * std::max(diagonal, 1e-12), 0.5 * std::max(distance - diagonal, 0.01 * distance));
  const double zfar = 2.0 * (distance + diagonal) + znear;
  if (camera.orthographic()) {
    c.type = "orthographic";
    c.orthographic.xmag = 0.5 * camera.width * camera.pixel_size;
    c.orthographic.ymag = 0.5 * camera.height * camera.pixel_size;
    c.orthographic.znear = 0.0;
    c.orthographic.zfar = zfar;
  } else {
    c.type = "perspective";
    c.perspective.yfov = 2.0 * std::atan(0.5 * camera.height / camera.fy);
    c.perspective.aspectRatio = (camera.width / camera.fx) / (camera.height / camera.fy);
    c.perspective.znear = znear;
    c.perspective.zfar = zfar;
  }
  // glTF's principal point is the image centre; the scene's may not be.
  c.extras = Object({{"mvbrdf", Object({{"width", tinygltf::Value(camera.width)},
                                        {"height", tinygltf::Value(camera.height)},
                                        {"fx", tinygltf::Value(camera.fx)},
                                        {"fy", tinygltf::Value(camera.fy)},
                                        {"cx", tinygltf::Value(camera.cx)},
                                        {"cy", tinygltf::Value(camera.cy)}})}});
  model->cameras.push_back(c);
  tinygltf::Node node;
  node.name = camera.name;
  node.camera = static_cast<int>(model->cameras.size() - 1);
  // World from glTF camera: the scene camera's axes with y and z flipped.
  const glm::dmat3 world_from_cam = glm::transpose(camera.cam_from_world_rotation);
  node.rotation = Quaternion(world_from_cam * glm::dmat3(1, 0, 0, 0, -1, 0, 0, 0, -1));
  node.translation = {position.x, position.y, position.z};
  model->nodes.push_back(node);
}

void AddLight(tinygltf::Model* model, const scene::Light& light, double scale) {
  tinygltf::Light l;
  l.name = light.name;
  const double top = std::max({light.intensity.x, light.intensity.y, light.intensity.z});
  l.intensity = top / scale;
  l.color = top > 0.0 ? std::vector<double>{light.intensity.x / top, light.intensity.y / top, light.intensity.z / top}
                      : std::vector<double>{1.0, 1.0, 1.0};
  l.type = light.directional ? "directional" : "point";
  model->lights.push_back(l);
  tinygltf::Node node;
  node.name = light.name;
  if (light.directional) {
    // glTF's directional light shines along its node's -z: +z towards the light.
    const glm::dvec3 z = glm::normalize(glm::dvec3(light.direction));
    const glm::dvec3 helper = std::abs(z.y) < 0.9 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0);
    const glm::dvec3 x = glm::normalize(glm::cross(helper, z));
    node.rotation = Quaternion(glm::dmat3(x, glm::cross(z, x), z));
  } else {
    node.translation = {light.position.x, light.position.y, light.position.z};
  }
  node.extensions["KHR_lights_punctual"] =
      Object({{"light", tinygltf::Value(static_cast<int>(model->lights.size() - 1))}});
  model->nodes.push_back(node);
}

// The tracked motion as morph targets of `primitive` (one per frame: its
// offsets from the rest pose) and an animation of `mesh`'s weights showing
// frame t alone from t / fps on; the mesh node is node 0.
absl::Status AddMotion(tinygltf::Model* model, const scene::Sequence& sequence, const scene::MeshTopology& topology,
                       const std::vector<glm::vec3>& rest, const std::vector<glm::vec3>& rest_normals,
                       tinygltf::Primitive* primitive, tinygltf::Mesh* mesh) {
  const int n = sequence.num_frames;
  // Positions and normals per frame, and the weights' keys: n x n floats.
  const double bytes = static_cast<double>(n) * static_cast<double>(rest.size()) * 24.0 + 4.0 * n * n;
  if (bytes > 1.5 * (1u << 30)) {
    return absl::ResourceExhaustedError(
        absl::StrCat("--animation: ", n, " frames of ", rest.size(), " vertices need ", std::lround(bytes / (1 << 20)),
                     " MiB, beyond a GLB's practical size (1.5 GiB); export a frame range's scene instead"));
  }
  tinygltf::Value::Array names;
  for (int t = 0; t < n; ++t) {
    std::vector<glm::vec3> p, nrm;
    MVBRDF_RETURN_IF_ERROR(PoseOf(sequence, topology, t, &p, &nrm));
    for (size_t i = 0; i < p.size(); ++i) p[i] -= rest[i], nrm[i] -= rest_normals[i];
    primitive->targets.push_back(
        {{"POSITION", AddVec3Accessor(model, p, true)}, {"NORMAL", AddVec3Accessor(model, nrm, false)}});
    names.push_back(tinygltf::Value(absl::StrFormat("frame %04d", sequence.AbsoluteFrame(t))));
  }
  mesh->weights.assign(static_cast<size_t>(n), 0.0);
  mesh->extras = Object({{"targetNames", tinygltf::Value(names)}});
  const double fps = sequence.scene.frames().fps();
  std::vector<float> times(static_cast<size_t>(n)), weights(static_cast<size_t>(n) * static_cast<size_t>(n), 0.0f);
  for (int t = 0; t < n; ++t) {
    times[static_cast<size_t>(t)] = static_cast<float>(t / fps);
    weights[static_cast<size_t>(t) * static_cast<size_t>(n) + static_cast<size_t>(t)] = 1.0f;
  }
  tinygltf::Accessor input;
  input.bufferView = AddView(model, times.data(), times.size() * sizeof(float), 0);
  input.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  input.type = TINYGLTF_TYPE_SCALAR;
  input.count = times.size();
  input.minValues = {times.front()};
  input.maxValues = {times.back()};
  model->accessors.push_back(input);
  tinygltf::Accessor output;
  output.bufferView = AddView(model, weights.data(), weights.size() * sizeof(float), 0);
  output.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  output.type = TINYGLTF_TYPE_SCALAR;
  output.count = weights.size();
  model->accessors.push_back(output);
  tinygltf::Animation animation;
  animation.name = "tracked motion";
  tinygltf::AnimationSampler sampler;
  sampler.input = static_cast<int>(model->accessors.size() - 2);
  sampler.output = static_cast<int>(model->accessors.size() - 1);
  sampler.interpolation = "STEP";
  animation.samplers.push_back(sampler);
  tinygltf::AnimationChannel channel;
  channel.sampler = 0;
  channel.target_node = 0;
  channel.target_path = "weights";
  animation.channels.push_back(channel);
  model->animations.push_back(animation);
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<GltfExportSummary> ExportGltf(const std::filesystem::path& run_dir, const scene::Sequence& sequence,
                                             const std::filesystem::path& out, const GltfExportOptions& options) {
  const std::string ext = out.extension().string();
  if (ext != ".glb" && ext != ".gltf") {
    return absl::InvalidArgumentError(
        absl::StrCat("--out: expected a file ending in .glb or .gltf, got \"", out.string(), "\""));
  }
  const bool binary = ext == ".glb";
  if (options.animation && options.frame >= 0) {
    return absl::InvalidArgumentError("--animation: the animation starts from the rest pose; leave out --frame");
  }
  MVBRDF_ASSIGN_OR_RETURN(const ExportInput in, ReadExportInput(run_dir, sequence, options.frame));
  const v1::RunReport& run = in.run;
  const atlas::Atlas& atlas = in.atlas;
  const pipeline::RunAtlases& atlases = in.atlases;
  const std::vector<glm::vec3>& vertices = in.vertices;
  const std::vector<glm::vec3>& normals = in.normals;
  std::vector<glm::vec2> uvs = atlas.topology.uvs;
  for (glm::vec2& uv : uvs) uv.y = 1.0f - uv.y;  // glTF: v = 0 at the image's first row
  std::vector<uint32_t> indices;
  indices.reserve(3 * atlas.topology.triangles.size());
  for (const glm::uvec3& t : atlas.topology.triangles) indices.insert(indices.end(), {t.x, t.y, t.z});

  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = absl::StrCat("mvbrdf ", std::string(MvbrdfVersion()));
  model.buffers.resize(1);
  model.samplers.resize(1);
  model.samplers[0].magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  model.samplers[0].minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  model.samplers[0].wrapS = model.samplers[0].wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;

  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  primitive.attributes["POSITION"] = AddVec3Accessor(&model, vertices, true);
  primitive.attributes["NORMAL"] = AddVec3Accessor(&model, normals, false);
  primitive.attributes["TEXCOORD_0"] = AddFloatAccessor(&model, uvs.data(), uvs.size(), TINYGLTF_TYPE_VEC2, 2);
  {
    tinygltf::Accessor a;
    a.bufferView = AddView(&model, indices.data(), indices.size() * sizeof(uint32_t), kElementArrayBuffer);
    a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    a.type = TINYGLTF_TYPE_SCALAR;
    a.count = indices.size();
    model.accessors.push_back(a);
    primitive.indices = static_cast<int>(model.accessors.size() - 1);
  }
  // Issue #18: a run with refined normals exports them as the normal texture,
  // with the tangents they were fitted in (scene/tangent_frames.h: glTF's
  // convention, B = w (N x T) towards increasing v, "up" in the image).
  const std::filesystem::path normal_file = run_dir / "atlases" / "normal.exr";
  int normal_texture = -1;
  if (std::filesystem::exists(normal_file)) {
    MVBRDF_ASSIGN_OR_RETURN(const image::ExrImage normal, image::ReadExr(normal_file));
    if (normal.image.type() != CV_32FC3 || normal.image.size() != atlases.kd.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat(normal_file.string(), ": expected an RGB image of the kd atlas's size"));
    }
    MVBRDF_ASSIGN_OR_RETURN(normal_texture,
                            AddPngTexture(&model, pipeline::EncodeNormalMap(normal.image), "normal"));
    const std::vector<glm::vec4> tangents =
        scene::VertexTangents(atlas.topology.triangles, vertices, normals, atlas.topology.uvs);
    primitive.attributes["TANGENT"] =
        AddFloatAccessor(&model, tangents.data(), tangents.size(), TINYGLTF_TYPE_VEC4, 4);
  }
  primitive.material = 0;
  tinygltf::Mesh mesh;
  if (options.animation) {
    MVBRDF_RETURN_IF_ERROR(AddMotion(&model, sequence, atlas.topology, vertices, normals, &primitive, &mesh));
  }

  const MaterialTextures textures = Convert(atlases);
  MVBRDF_ASSIGN_OR_RETURN(const int base_color, AddPngTexture(&model, textures.base_color, "baseColor"));
  MVBRDF_ASSIGN_OR_RETURN(const int metallic_roughness,
                          AddPngTexture(&model, textures.metallic_roughness, "metallicRoughness"));
  MVBRDF_ASSIGN_OR_RETURN(const int specular, AddPngTexture(&model, textures.specular, "specular"));
  MVBRDF_ASSIGN_OR_RETURN(const int confidence, AddPngTexture(&model, textures.confidence, "confidence"));
  tinygltf::Material material;
  material.name = "reconstruction";
  material.pbrMetallicRoughness.baseColorTexture.index = base_color;
  material.pbrMetallicRoughness.metallicRoughnessTexture.index = metallic_roughness;
  material.pbrMetallicRoughness.metallicFactor = 1.0;  // x the texture's B = 0
  material.pbrMetallicRoughness.roughnessFactor = 1.0;
  if (normal_texture >= 0) material.normalTexture.index = normal_texture;
  tinygltf::Value::Object specular_extension = {
      {"specularTexture", Object({{"index", tinygltf::Value(specular)}})},
      {"specularColorTexture", Object({{"index", tinygltf::Value(specular)}})}};
  if (textures.colour_factor > 1.0) {  // lobes flatter than a dielectric's (ggx.h's f90_ratio below 25)
    const tinygltf::Value k(textures.colour_factor);
    specular_extension["specularColorFactor"] = tinygltf::Value(tinygltf::Value::Array{k, k, k});
  }
  material.extensions["KHR_materials_specular"] = tinygltf::Value(specular_extension);
  material.extras = Object({{"mvbrdf", Object({{"confidenceTexture", tinygltf::Value(confidence)},
                                               {"brdf", tinygltf::Value(run.brdf().empty() ? "phong" : run.brdf())}})}});
  model.materials.push_back(material);
  model.extensionsUsed.push_back("KHR_materials_specular");

  mesh.name = "reconstruction";
  mesh.primitives.push_back(primitive);
  model.meshes.push_back(mesh);
  tinygltf::Node mesh_node;
  mesh_node.name = "reconstruction";
  mesh_node.mesh = 0;
  model.nodes.push_back(mesh_node);

  const auto [centre, diagonal] = Extent(vertices);
  for (const scene::CameraModel& camera : sequence.cameras) AddCamera(&model, camera, centre, diagonal);
  for (const scene::Light& light : sequence.lights) AddLight(&model, light, textures.scale);
  if (!sequence.lights.empty()) model.extensionsUsed.push_back("KHR_lights_punctual");

  tinygltf::Scene scene;
  scene.name = "mvbrdf";
  for (size_t i = 0; i < model.nodes.size(); ++i) scene.nodes.push_back(static_cast<int>(i));
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  model.asset.extras =
      Object({{"mvbrdf", Object({{"scale", tinygltf::Value(textures.scale)},
                                 {"frame", tinygltf::Value(options.frame)},
                                 {"inverseSquareFalloff",
                                  tinygltf::Value(sequence.scene.lighting().inverse_square_falloff())}})}});

  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToFile(&model, out.string(), /*embedImages=*/true, /*embedBuffers=*/true,
                                   /*prettyPrint=*/!binary, binary)) {
    return absl::UnavailableError(absl::StrCat(out.string(), ": could not be written"));
  }
  GltfExportSummary summary;
  summary.scale = textures.scale;
  summary.vertices = static_cast<int>(vertices.size());
  summary.triangles = static_cast<int>(atlas.topology.triangles.size());
  summary.cameras = static_cast<int>(sequence.cameras.size());
  summary.lights = static_cast<int>(sequence.lights.size());
  summary.texture_size = atlases.kd.cols;
  summary.morph_targets = options.animation ? sequence.num_frames : 0;
  summary.clipped_fraction = textures.clipped_fraction;
  for (const scene::Light& light : sequence.lights) {
    summary.point_lights_without_falloff |=
        !light.directional && !sequence.scene.lighting().inverse_square_falloff();
  }
  return summary;
}

}  // namespace mvbrdf::exporter
