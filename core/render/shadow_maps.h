// Per-light shadow maps of a posed mesh, shared by the renderer
// (core/render/phong_renderer.cc) and the resampler's shadow atlas
// (core/resample/resampler.cc) so that both see the same shadows:
//
//   point light k:       six faces of a cube-map array layer (cube
//                        `layer`), each texel the distance from the light to
//                        the nearest surface divided by `range`
//                        (shaders/shadow_point.frag), world units / range.
//   directional light k: one layer of a 2D array, an orthographic view along
//                        -direction fitted to the mesh's bounding sphere;
//                        depth 0 at the sphere's near side, 1 at its far side
//                        (shaders/shadow_directional.frag).
//
// Both arrays hold DEPTH_COMPONENT32F, nearest lookups, no compare mode: the
// consumers' shaders compare against distances themselves. Every triangle
// casts shadows from both sides (no culling).
//
// Ownership and threading: a ShadowMaps owns its GL objects (programs,
// textures, framebuffer); create, use and destroy it on the thread where the
// context that was current at Create is current, before that context dies.
#ifndef MVBRDF_CORE_RENDER_SHADOW_MAPS_H_
#define MVBRDF_CORE_RENDER_SHADOW_MAPS_H_

#include <array>
#include <glm/glm.hpp>
#include <memory>
#include <vector>

#include "absl/functional/function_ref.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/gl/gl_objects.h"
#include "core/scene/light.h"

namespace mvbrdf::render {

// World units.
struct BoundingSphere {
  glm::vec3 center{0.0f};
  float radius = 0.0f;
};

// Centre of the axis-aligned bounding box, radius to the furthest point
// (not the minimal sphere). Empty: centre 0, radius 0.
BoundingSphere ComputeBoundingSphere(const std::vector<glm::vec3>& points);

namespace internal {

// Cube-map faces in GL layer order (+X, -X, +Y, -Y, +Z, -Z): view direction
// and the up vector that makes glm::lookAt match the cube-map (s, t) axes.
inline constexpr std::array<std::array<glm::vec3, 2>, 6> kCubeFaces = {{
    {glm::vec3(1, 0, 0), glm::vec3(0, -1, 0)},
    {glm::vec3(-1, 0, 0), glm::vec3(0, -1, 0)},
    {glm::vec3(0, 1, 0), glm::vec3(0, 0, 1)},
    {glm::vec3(0, -1, 0), glm::vec3(0, 0, -1)},
    {glm::vec3(0, 0, 1), glm::vec3(0, -1, 0)},
    {glm::vec3(0, 0, -1), glm::vec3(0, -1, 0)},
}};

// Whether a sphere (centre relative to the light, world units) reaches into
// the 90-degree frustum of the cube face looking along `axis`: a face it does
// not reach is neither cleared nor drawn. Conservative (a sphere near a
// frustum's edge may count as reaching it).
bool SphereReachesFace(const glm::vec3& centre, float radius, const glm::vec3& axis, const glm::vec3& up);

// The window rectangle (pixels, GL's origin at the bottom left) of a size^2
// cube face looking along `axis` (`up` as for glm::lookAt, a 90-degree
// perspective) that holds the projection of a sphere (centre relative to the
// light, world units), with two texels of room: a lookup towards a point
// inside the sphere lands in it, so only it needs clearing before the mesh is
// drawn. The whole face where the sphere reaches the plane of the light (its
// projection is unbounded); empty (w = h = 0) where it misses the face or
// lies behind it.
struct FaceRect {
  int x = 0, y = 0, w = 0, h = 0;
};
FaceRect SphereRectOnFace(const glm::vec3& centre, float radius, const glm::vec3& axis, const glm::vec3& up, int size);

}  // namespace internal

// What a shader needs to look light k up in the maps; the std140 layout of
// the first three members of the shaders' light structs
// (shaders/phong.frag GpuLight has the intensity in between).
struct LightShadow {
  // Point light: (position, 1), world units. Directional: (unit direction
  // towards the light, 0).
  glm::vec4 position{0.0f};
  // x: layer (cube index for point lights, 2D layer for directional lights);
  // y: world length of depth 1 (range for point lights, 2 * radius for
  // directional ones); z: point: angle of one texel at a face centre
  // (2 / size, radians), directional: world size of one texel; w: 0.
  glm::vec4 shadow{0.0f};
  // Directional lights: world -> (s, t, depth) in [0, 1]^3 of the map.
  // Point lights: identity (the lookup is by direction).
  glm::mat4 shadow_from_world{1.0f};
};

class ShadowMaps {
 public:
  // `size`: texels per cube face and per directional map side, in [1, 8192]
  // (checked by the callers' options). Both arrays start as one-texel
  // placeholders, so that a sampler always has a texture; Render allocates
  // them as its lights need (the driver fills a new array with zeros, ~24 MiB
  // per 1024^2 cube: on llvmpipe that was half of a small run's time).
  static absl::StatusOr<std::unique_ptr<ShadowMaps>> Create(int size);
  ShadowMaps(const ShadowMaps&) = delete;
  ShadowMaps& operator=(const ShadowMaps&) = delete;
  ~ShadowMaps();

  // Renders one map per light of `lights` (at most as many as the caller's
  // shaders hold; directional directions non-zero, checked by the callers)
  // for a mesh within `bounds`, calling `draw_mesh` once per cube face or
  // directional map with the shadow program bound and the mesh's positions
  // at attribute 0 to be drawn (the callback binds its vertex array and
  // draws). Reallocates the arrays when they have fewer layers than the
  // point or directional lights need (they never shrink; an array with no light of its kind drawn yet stays a
  // one-texel placeholder). Changes the framebuffer, viewport, depth and cull state;
  // leaves the default framebuffer, program 0 and vertex array 0 bound, and the scissor test off.
  // A point light's map holds this mesh only where `bounds` projects (internal::SphereRectOnFace); its other
  // texels keep what an earlier Render left: look up only directions towards points inside `bounds`.
  absl::Status Render(const std::vector<scene::Light>& lights, const BoundingSphere& bounds,
                      absl::FunctionRef<void()> draw_mesh);

  // Per light of the last Render, in its order.
  const std::vector<LightShadow>& light_shadows() const { return light_shadows_; }
  // GL_TEXTURE_CUBE_MAP_ARRAY, 6 layers per point light.
  const gl::Texture& point_maps() const { return point_maps_; }
  // GL_TEXTURE_2D_ARRAY, one layer per directional light.
  const gl::Texture& directional_maps() const { return directional_maps_; }

 private:
  ShadowMaps() = default;
  // (Re)allocates the arrays unless they already have the layers `lights` need.
  absl::Status Allocate(const std::vector<scene::Light>& lights);

  int size_ = 0;
  gl::Program point_program_;
  gl::Program directional_program_;
  int num_cubes_ = 0;        // allocated in point_maps_ (0: a one-texel placeholder)
  int num_directional_ = 0;  // allocated in directional_maps_ (0: a one-texel placeholder)
  gl::Texture point_maps_;
  gl::Texture directional_maps_;
  gl::Framebuffer framebuffer_;  // depth attachment only, re-attached per face / map
  std::vector<LightShadow> light_shadows_;
};

}  // namespace mvbrdf::render

#endif  // MVBRDF_CORE_RENDER_SHADOW_MAPS_H_
