#include "core/render/shadow_maps.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <limits>

#include "core/base/status_macros.h"
#include "core/gl/gl_api.h"
#include "core/gl/shader_program.h"

namespace mvbrdf::render {
namespace {

// Uniform locations (layout(location = ...) in shaders/shadow.vert and
// shadow_point.frag).
constexpr GLint kClipFromWorldLocation = 0;
constexpr GLint kLightPositionLocation = 1;
constexpr GLint kInverseRangeLocation = 2;

using internal::kCubeFaces;
using internal::SphereReachesFace;

}  // namespace

namespace internal {

// Whether a sphere (centre relative to the light) reaches into the 90-degree
// frustum of the cube face looking along `axis`: outside any of its four side
// planes (through the light) it does not, and the face's map holds no mesh.
// Conservative (a sphere near a frustum's edge may count as inside).
bool SphereReachesFace(const glm::vec3& centre, float radius, const glm::vec3& axis, const glm::vec3& up) {
  const glm::vec3 side = glm::cross(axis, up);
  for (const glm::vec3& across : {side, -side, up, -up}) {
    // Inward normal of the plane through the light containing axis + across
    // (unnormalised by sqrt(2): compare against radius * sqrt(2)).
    if (glm::dot(centre, axis - across) < -radius * 1.41421356f) return false;
  }
  return true;
}

// Per axis: the tangents from the light to the sphere's circle in that
// axis's plane bound x / z (z along `axis`).
FaceRect SphereRectOnFace(const glm::vec3& centre, float radius, const glm::vec3& axis, const glm::vec3& up, int size) {
  const glm::vec3 s = glm::normalize(glm::cross(axis, up));  // glm::lookAt's side: window x
  const glm::vec3 u = glm::cross(s, axis);                    // and its up: window y
  const double cz = glm::dot(centre, axis);
  const double r = radius;
  if (!(cz > -r)) return FaceRect{};  // behind the face
  const auto bounds = [&](double c) -> std::array<double, 2> {
    if (!(cz > r)) return {-1.0, 1.0};
    const double root = r * std::sqrt(std::max(0.0, c * c + cz * cz - r * r));
    const double denominator = cz * cz - r * r;
    return {(c * cz - root) / denominator, (c * cz + root) / denominator};
  };
  const std::array<double, 2> bx = bounds(glm::dot(centre, s)), by = bounds(glm::dot(centre, u));
  const auto pixels = [size](const std::array<double, 2>& b, int* begin, int* length) {
    const double lo = std::clamp(b[0], -1.0, 1.0), hi = std::clamp(b[1], -1.0, 1.0);
    const int first = std::max(0, static_cast<int>(std::floor((lo + 1.0) * 0.5 * size)) - 2);
    const int last = std::min(size, static_cast<int>(std::ceil((hi + 1.0) * 0.5 * size)) + 2);
    *begin = first;
    *length = std::max(0, last - first);
  };
  FaceRect rect;
  pixels(bx, &rect.x, &rect.w);
  pixels(by, &rect.y, &rect.h);
  if (rect.w == 0 || rect.h == 0) rect = FaceRect{};
  return rect;
}

}  // namespace internal

namespace {

// Depth texture array: `target` GL_TEXTURE_CUBE_MAP_ARRAY (layers = 6 per
// light) or GL_TEXTURE_2D_ARRAY. Nearest lookups, no compare mode.
gl::Texture CreateShadowArray(GLenum target, int size, int layers) {
  gl::Texture texture = gl::CreateTexture(target);
  glTextureStorage3D(texture.id(), 1, GL_DEPTH_COMPONENT32F, size, size, layers);
  glTextureParameteri(texture.id(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(texture.id(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTextureParameteri(texture.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(texture.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glTextureParameteri(texture.id(), GL_TEXTURE_COMPARE_MODE, GL_NONE);
  return texture;
}

}  // namespace

BoundingSphere ComputeBoundingSphere(const std::vector<glm::vec3>& points) {
  BoundingSphere sphere;
  if (points.empty()) return sphere;
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
  for (const glm::vec3& p : points) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  sphere.center = 0.5f * (lo + hi);
  float r2 = 0.0f;
  for (const glm::vec3& p : points) {
    const glm::vec3 d = p - sphere.center;
    r2 = std::max(r2, glm::dot(d, d));
  }
  sphere.radius = std::sqrt(r2);
  return sphere;
}

absl::StatusOr<std::unique_ptr<ShadowMaps>> ShadowMaps::Create(int size) {
  std::unique_ptr<ShadowMaps> maps(new ShadowMaps());
  maps->size_ = size;
  MVBRDF_ASSIGN_OR_RETURN(maps->point_program_, gl::BuildProgram({{GL_VERTEX_SHADER, "shadow.vert", {}},
                                                                  {GL_FRAGMENT_SHADER, "shadow_point.frag", {}}}));
  MVBRDF_ASSIGN_OR_RETURN(
      maps->directional_program_,
      gl::BuildProgram({{GL_VERTEX_SHADER, "shadow.vert", {}}, {GL_FRAGMENT_SHADER, "shadow_directional.frag", {}}}));
  maps->framebuffer_ = gl::CreateFramebuffer();
  glNamedFramebufferDrawBuffer(maps->framebuffer_.id(), GL_NONE);
  glNamedFramebufferReadBuffer(maps->framebuffer_.id(), GL_NONE);
  MVBRDF_RETURN_IF_ERROR(maps->Allocate({}));
  return maps;
}

ShadowMaps::~ShadowMaps() = default;

absl::Status ShadowMaps::Allocate(const std::vector<scene::Light>& lights) {
  int num_point = 0, num_directional = 0;
  for (const scene::Light& light : lights) (light.directional ? num_directional : num_point)++;
  // Until a light of a kind is drawn its array is a one-texel placeholder (never looked up).
  if (!point_maps_ || num_cubes_ < num_point) {
    point_maps_ = CreateShadowArray(GL_TEXTURE_CUBE_MAP_ARRAY, num_point > 0 ? size_ : 1, 6 * std::max(num_point, 1));
    num_cubes_ = num_point;
  }
  if (!directional_maps_ || num_directional_ < num_directional) {
    directional_maps_ = CreateShadowArray(GL_TEXTURE_2D_ARRAY, num_directional > 0 ? size_ : 1,
                                          std::max(num_directional, 1));
    num_directional_ = num_directional;
  }
  return gl::CheckGlError("allocating shadow maps");
}

absl::Status ShadowMaps::Render(const std::vector<scene::Light>& lights, const BoundingSphere& bounds,
                                absl::FunctionRef<void()> draw_mesh) {
  MVBRDF_RETURN_IF_ERROR(Allocate(lights));
  // The maps cover the bounding sphere with a little room, so that nothing of
  // the mesh is clipped by a light's far plane or a map's border (relative
  // room: the world's scale is the caller's).
  const float radius = bounds.radius * 1.01f + 1e-6f * glm::length(bounds.center) + 1e-30f;
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
  glViewport(0, 0, size_, size_);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glDisable(GL_CULL_FACE);  // both sides of every triangle cast shadows
  glDisable(GL_BLEND);

  int point_layer = 0, directional_layer = 0;
  light_shadows_.assign(lights.size(), LightShadow{});
  for (size_t k = 0; k < lights.size(); ++k) {
    const scene::Light& light = lights[k];
    LightShadow& out = light_shadows_[k];
    out.shadow_from_world = glm::mat4(1.0f);
    if (!light.directional) {
      out.position = glm::vec4(light.position, 1.0f);
      const float range = glm::length(light.position - bounds.center) + radius;
      // The perspective near plane only clips; depth is the distance written
      // by shadow_point.frag, divided by the range.
      const float near_plane = range * 1e-4f;
      // Angle of one texel at the face centre (the largest on the face).
      out.shadow = glm::vec4(static_cast<float>(point_layer), range, 2.0f / size_, 0.0f);
      glProgramUniform3fv(point_program_.id(), kLightPositionLocation, 1, glm::value_ptr(light.position));
      glProgramUniform1f(point_program_.id(), kInverseRangeLocation, 1.0f / range);
      glUseProgram(point_program_.id());
      const glm::mat4 projection = glm::perspective(glm::radians(90.0f), 1.0f, near_plane, range);
      for (int face = 0; face < 6; ++face) {
        const glm::mat4 view = glm::lookAt(light.position, light.position + kCubeFaces[face][0], kCubeFaces[face][1]);
        const glm::mat4 clip_from_world = projection * view;
        glProgramUniformMatrix4fv(point_program_.id(), kClipFromWorldLocation, 1, GL_FALSE,
                                  glm::value_ptr(clip_from_world));
        glNamedFramebufferTextureLayer(framebuffer_.id(), GL_DEPTH_ATTACHMENT, point_maps_.id(), 0,
                                       6 * point_layer + face);
        // A face that cannot see the mesh's sphere is neither cleared nor
        // drawn (a light outside the mesh sees it in one to three faces: the
        // mesh's vertices are not processed six times), and of the others
        // only the sphere's rectangle: no lookup lands elsewhere (clearing
        // every face whole was two thirds of the maps' time on llvmpipe).
        const glm::vec3 centre = bounds.center - light.position;
        if (!SphereReachesFace(centre, radius, kCubeFaces[face][0], kCubeFaces[face][1])) continue;
        const internal::FaceRect rect =
            internal::SphereRectOnFace(centre, radius, kCubeFaces[face][0], kCubeFaces[face][1], size_);
        if (rect.w == 0) continue;
        glEnable(GL_SCISSOR_TEST);
        glScissor(rect.x, rect.y, rect.w, rect.h);
        glClear(GL_DEPTH_BUFFER_BIT);
        draw_mesh();
        glDisable(GL_SCISSOR_TEST);
      }
      ++point_layer;
    } else {
      const glm::vec3 l = glm::normalize(light.direction);
      out.position = glm::vec4(l, 0.0f);
      // Orthographic view along -l fitted to the bounding sphere: depth 0 at
      // the sphere's near side, 1 at its far side (2 * radius further).
      const glm::vec3 eye = bounds.center + l * radius;
      const glm::vec3 up = std::abs(l.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
      const glm::mat4 view = glm::lookAt(eye, bounds.center, up);
      const glm::mat4 projection = glm::ortho(-radius, radius, -radius, radius, 0.0f, 2.0f * radius);
      const glm::mat4 clip_from_world = projection * view;
      // Clip space [-1, 1]^3 -> texture coordinates and window depth [0, 1]^3.
      const glm::mat4 unit_from_clip =
          glm::translate(glm::mat4(1.0f), glm::vec3(0.5f)) * glm::scale(glm::mat4(1.0f), glm::vec3(0.5f));
      out.shadow_from_world = unit_from_clip * clip_from_world;
      out.shadow = glm::vec4(static_cast<float>(directional_layer), 2.0f * radius, 2.0f * radius / size_, 0.0f);
      glProgramUniformMatrix4fv(directional_program_.id(), kClipFromWorldLocation, 1, GL_FALSE,
                                glm::value_ptr(clip_from_world));
      glUseProgram(directional_program_.id());
      glNamedFramebufferTextureLayer(framebuffer_.id(), GL_DEPTH_ATTACHMENT, directional_maps_.id(), 0,
                                     directional_layer);
      glClear(GL_DEPTH_BUFFER_BIT);
      draw_mesh();
      ++directional_layer;
    }
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glUseProgram(0);
  glBindVertexArray(0);
  return gl::CheckGlError("rendering shadow maps");
}

}  // namespace mvbrdf::render
