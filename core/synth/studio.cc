#include "core/synth/studio.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/scene/video_source.h"

namespace mvbrdf::synth {
namespace {

// cam_from_world rotation of a camera at `eye` looking at `target` with world
// y up, in OpenCV axes (x right, y down, z forward).
glm::dmat3 LookAt(const glm::dvec3& eye, const glm::dvec3& target) {
  const glm::dvec3 z = glm::normalize(target - eye);
  // x = down x z is "right" for a camera whose y axis points down.
  const glm::dvec3 x = glm::normalize(glm::cross(glm::dvec3(0.0, -1.0, 0.0), z));
  const glm::dvec3 y = glm::cross(z, x);
  // Rows of cam_from_world are the camera axes in world coordinates.
  return glm::transpose(glm::dmat3(x, y, z));
}

}  // namespace

std::vector<scene::Light> MakeDomeLights(int n, float intensity) {
  std::vector<scene::Light> lights;
  const double golden_angle = 3.14159265358979 * (3.0 - std::sqrt(5.0));
  const int digits = std::max(3, static_cast<int>(std::to_string(std::max(n - 1, 0)).size()));
  for (int i = 0; i < n; ++i) {
    // Heights uniform in (0, 1): equal solid angle per light.
    const double y = (i + 0.5) / n;
    const double r = std::sqrt(std::max(0.0, 1.0 - y * y));
    const double phi = golden_angle * i;
    scene::Light light;
    const std::string number = std::to_string(i);  // at most `digits` long
    light.name = "D" + std::string(static_cast<size_t>(digits) - number.size(), '0') + number;
    light.directional = true;
    light.direction = glm::normalize(glm::vec3(glm::dvec3(r * std::cos(phi), y, r * std::sin(phi))));
    light.intensity = glm::vec3(intensity);
    lights.push_back(light);
  }
  return lights;
}

std::string ConfigurationName(const std::vector<std::string>& lights) {
  std::string name;
  for (const std::string& l : lights) {
    if (!name.empty()) name += ",";
    name += l;
  }
  return name;
}

Studio MakeStudio(const StudioOptions& options, const SubjectBounds& subject) {
  Studio studio;
  const glm::dvec3 lo(subject.min), hi(subject.max);
  const glm::dvec3 center = 0.5 * (lo + hi);
  const double height = hi.y - lo.y;
  const double half_width = 0.5 * std::max(hi.x - lo.x, hi.z - lo.z);
  const double fov = options.vertical_fov_deg * 3.14159265358979 / 180.0;
  const double fy = 0.5 * options.height / std::tan(0.5 * fov);
  // Far enough that the subject's height fills ~85% of the frame, and
  // never inside the subject.
  const double radius = std::max(0.5 * height / 0.85 / std::tan(0.5 * fov) + half_width, 2.0 * half_width + 0.5);

  for (int i = 0; i < options.num_cameras; ++i) {
    const double angle = 2.0 * 3.14159265358979 * i / options.num_cameras;
    const glm::dvec3 eye(center.x + radius * std::sin(angle), center.y + 0.15 * height,
                         center.z + radius * std::cos(angle));
    scene::CameraModel cam;
    cam.name = "cam" + std::to_string(i);
    cam.width = options.width;
    cam.height = options.height;
    cam.fx = fy;
    cam.fy = fy;
    cam.cx = 0.5 * options.width - 0.5;
    cam.cy = 0.5 * options.height - 0.5;
    cam.distortion[0] = options.distortion_k1;
    if (options.projection == scene::Projection::kOrthographic) {
      cam.projection = scene::Projection::kOrthographic;
      cam.pixel_size = glm::length(center - eye) / fy;
      cam.fx = cam.fy = 0.0;
      cam.distortion[0] = 0.0;
    }
    cam.cam_from_world_rotation = LookAt(eye, center);
    cam.cam_from_world_translation = -(cam.cam_from_world_rotation * eye);
    studio.cameras.push_back(cam);
  }

  // Ceiling lights on a 3x3 grid, 1.2 m above the subject, 1.5 m apart
  // (scaled with the subject so that Spot and the actor see the same layout).
  const float ceiling = static_cast<float>(hi.y + 0.7 * height);
  const float spacing = static_cast<float>(0.85 * height);
  const struct {
    const char* name;
    float east, north;
  } grid[] = {{"C", 0, 0},  {"N", 0, 1},  {"E", 1, 0},   {"W", -1, 0}, {"S", 0, -1},
              {"NE", 1, 1}, {"NW", -1, 1}, {"SE", 1, -1}, {"SW", -1, -1}};
  for (const auto& g : grid) {
    scene::Light light;
    light.name = g.name;
    light.position = glm::vec3(static_cast<float>(center.x) + spacing * g.east, ceiling,
                               static_cast<float>(center.z) - spacing * g.north);
    light.intensity = glm::vec3(options.light_intensity);
    studio.lights.push_back(light);
  }
  const std::vector<std::vector<std::string>> configs = {
      {"C"},
      {"N", "E", "W", "S"},
      {"NE", "NW", "SE", "SW"},
      {"NE", "NW", "SE", "SW", "C"},
      {"NE", "NW", "SE", "SW", "N", "S"},
      {"NE", "NW", "SE", "SW", "E", "W"},
      {"N", "E", "W", "S", "NE", "NW", "SE", "SW"},
      {"N", "E", "W", "S", "NE", "NW", "SE", "SW", "C"},
  };
  for (const auto& c : configs) studio.configurations.push_back({ConfigurationName(c), c});
  return studio;
}

std::vector<StudioMaterial> StudioMaterials() {
  const auto linear = [](glm::ivec3 s) {
    return glm::vec3(scene::SrgbToLinear(s.x / 255.0f), scene::SrgbToLinear(s.y / 255.0f),
                     scene::SrgbToLinear(s.z / 255.0f));
  };
  std::vector<StudioMaterial> m(3);
  m[0].name = "cloth";
  m[0].seed_srgb8 = {144, 71, 72};
  m[0].kd = {linear(m[0].seed_srgb8), 0.25f, 7.0f, {0.0f, 0.0f, 0.0f}};
  m[0].ks = glm::vec3(0.04f);
  m[0].ke = glm::vec3(4.0f);
  m[1].name = "skin";
  m[1].seed_srgb8 = {160, 135, 109};
  m[1].kd = {linear(m[1].seed_srgb8), 0.12f, 11.0f, {17.3f, 5.1f, 9.7f}};
  m[1].ks = glm::vec3(0.12f);
  m[1].ke = glm::vec3(16.0f);
  m[1].ior = 1.4f;  // skin (F0 0.028)
  m[2].name = "hair";
  m[2].seed_srgb8 = {76, 74, 67};
  m[2].kd = {linear(m[2].seed_srgb8), 0.3f, 23.0f, {3.3f, 41.0f, 12.9f}};
  m[2].ks = glm::vec3(0.25f);
  m[2].ke = glm::vec3(40.0f);
  m[2].ior = 1.55f;  // keratin (F0 0.047)
  return m;
}

}  // namespace mvbrdf::synth
