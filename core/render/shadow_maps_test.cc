// The rectangle of a cube face that ShadowMaps clears and draws: every point
// inside the sphere projects into it on the face GL's cube-map lookup picks
// for its direction (through the same glm::lookAt / glm::perspective view as
// the maps are drawn with), and it is not the whole face where the sphere is
// small and far.
#include "core/render/shadow_maps.h"
#include "core/base/draw_order.h"
#include "core/gl/egl_context.h"
#include "core/gl/gl_api.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <random>

namespace mvbrdf::render {
namespace {

// GL's cube-map faces (+X, -X, +Y, -Y, +Z, -Z) as the maps are drawn: axis
// and lookAt up vector.
constexpr const auto& kFaces = internal::kCubeFaces;

constexpr int kSize = 1024;

// Window position (pixels) of `p` (relative to the light) on face f.
glm::dvec2 Window(const glm::vec3& p, int f) {
  const glm::mat4 clip_from_world = glm::perspective(glm::radians(90.0f), 1.0f, 1e-3f, 1e3f) *
                                    glm::lookAt(glm::vec3(0.0f), kFaces[f][0], kFaces[f][1]);
  const glm::vec4 clip = clip_from_world * glm::vec4(p, 1.0f);
  return (glm::dvec2(clip.x, clip.y) / static_cast<double>(clip.w) + 1.0) * 0.5 * static_cast<double>(kSize);
}

// The face a lookup along `p` reads: its largest component.
int FaceOf(const glm::vec3& p) {
  const glm::vec3 a = glm::abs(p);
  if (a.x >= a.y && a.x >= a.z) return p.x > 0 ? 0 : 1;
  if (a.y >= a.z) return p.y > 0 ? 2 : 3;
  return p.z > 0 ? 4 : 5;
}

TEST(ShadowMapsTest, EveryPointOfTheSphereProjectsIntoItsFacesRectangle) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  std::uniform_real_distribution<float> log_scale(-3.0f, 3.0f);
  int checked = 0;
  for (int sphere = 0; sphere < 300; ++sphere) {
    // Scales from 1e-3 to 1e3 world units; the light outside the sphere,
    // near it (the projection's widest) or far.
    const float scale = std::pow(10.0f, log_scale(rng));
    const float radius = scale * (0.05f + 0.5f * (unit(rng) + 1.0f));
    glm::vec3 direction = base::DrawVec3<glm::vec3>([&] { return unit(rng); });
    if (glm::length(direction) < 1e-3f) direction = glm::vec3(1, 0, 0);
    const float distance = radius * (1.02f + 20.0f * (unit(rng) + 1.0f) * (unit(rng) + 1.0f));
    const glm::vec3 centre = glm::normalize(direction) * distance;
    std::array<internal::FaceRect, 6> rects;
    for (int f = 0; f < 6; ++f)
      rects[f] = internal::SphereRectOnFace(centre, radius, kFaces[f][0], kFaces[f][1], kSize);
    for (int i = 0; i < 400; ++i) {
      glm::vec3 offset = base::DrawVec3<glm::vec3>([&] { return unit(rng); });
      if (glm::length(offset) > 1.0f) continue;
      // The surface of the sphere too (the extremes).
      if (i % 2 == 0 && glm::length(offset) > 0.0f) offset = glm::normalize(offset);
      const glm::vec3 p = centre + radius * offset;
      const int f = FaceOf(p);
      const glm::dvec2 w = Window(p, f);
      const internal::FaceRect& r = rects[f];
      ASSERT_GT(r.w, 0) << "sphere " << sphere << " face " << f;
      // The face is drawn at all (a face the sphere does not reach keeps what
      // an earlier frame left).
      ASSERT_TRUE(internal::SphereReachesFace(centre, radius, kFaces[f][0], kFaces[f][1]))
          << "sphere " << sphere << " face " << f;
      // The texel a nearest lookup reads (clamped to the face).
      const int x = std::clamp(static_cast<int>(std::floor(w.x)), 0, kSize - 1);
      const int y = std::clamp(static_cast<int>(std::floor(w.y)), 0, kSize - 1);
      EXPECT_TRUE(x >= r.x && x < r.x + r.w && y >= r.y && y < r.y + r.h)
          << "sphere " << sphere << " (centre " << centre.x << " " << centre.y << " " << centre.z << ", radius "
          << radius << ") face " << f << ": texel " << x << " " << y << " outside " << r.x << " " << r.y << " " << r.w
          << "x" << r.h;
      ++checked;
    }
  }
  EXPECT_GT(checked, 50000);
}

TEST(ShadowMapsTest, ASmallFarSphereClearsAFractionOfItsFaceAndTheOthersNothing) {
  // Radius 1 at distance 10 along +Z: tan of the half angle 0.1005, so about
  // 10 % of the face's width (+2 texels each side).
  const glm::vec3 centre(0.0f, 0.0f, 10.0f);
  const internal::FaceRect r = internal::SphereRectOnFace(centre, 1.0f, kFaces[4][0], kFaces[4][1], kSize);
  EXPECT_NEAR(r.w, 0.1005 * kSize + 4, 3);
  EXPECT_NEAR(r.h, 0.1005 * kSize + 4, 3);
  EXPECT_NEAR(r.x + 0.5 * r.w, 0.5 * kSize, 1.0);
  EXPECT_EQ(internal::SphereRectOnFace(centre, 1.0f, kFaces[5][0], kFaces[5][1], kSize).w, 0);
  // The light inside the sphere: every face whole.
  for (int f = 0; f < 6; ++f) {
    const internal::FaceRect whole =
        internal::SphereRectOnFace(glm::vec3(0.1f, 0.0f, 0.0f), 1.0f, kFaces[f][0], kFaces[f][1], kSize);
    EXPECT_EQ(whole.w, kSize);
    EXPECT_EQ(whole.h, kSize);
  }
}


// Width and layers (six per cube) of a shadow array's level 0.
std::array<int, 2> WidthAndLayers(const gl::Texture& texture) {
  int width = 0, layers = 0;
  glGetTextureLevelParameteriv(texture.id(), 0, GL_TEXTURE_WIDTH, &width);
  glGetTextureLevelParameteriv(texture.id(), 0, GL_TEXTURE_DEPTH, &layers);
  return {width, layers};
}

TEST(ShadowMapsTest, ArraysAreAllocatedAsTheDrawnLightsNeedAndNeverShrink) {
  auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok()) << context.status();
  auto maps = ShadowMaps::Create(64);
  ASSERT_TRUE(maps.ok()) << maps.status();
  using Size = std::array<int, 2>;
  EXPECT_EQ(WidthAndLayers((*maps)->point_maps()), (Size{1, 6}));  // placeholders until a light is drawn
  EXPECT_EQ(WidthAndLayers((*maps)->directional_maps()), (Size{1, 1}));
  scene::Light point;
  point.position = glm::vec3(0.0f, 0.0f, 5.0f);
  scene::Light sun;
  sun.directional = true;
  const BoundingSphere bounds{glm::vec3(0.0f), 1.0f};
  int draws = 0;
  ASSERT_TRUE((*maps)->Render({point}, bounds, [&draws] { ++draws; }).ok());  // an OLAT frame: one cube
  EXPECT_EQ(WidthAndLayers((*maps)->point_maps()), (Size{64, 6}));
  EXPECT_EQ(WidthAndLayers((*maps)->directional_maps()), (Size{1, 1}));
  ASSERT_TRUE((*maps)->Render({point, point, sun}, bounds, [&draws] { ++draws; }).ok());
  EXPECT_EQ(WidthAndLayers((*maps)->point_maps()), (Size{64, 12}));
  EXPECT_EQ(WidthAndLayers((*maps)->directional_maps()), (Size{64, 1}));
  ASSERT_TRUE((*maps)->Render({point}, bounds, [&draws] { ++draws; }).ok());
  EXPECT_EQ(WidthAndLayers((*maps)->point_maps()), (Size{64, 12}));
  EXPECT_GT(draws, 0);
  EXPECT_EQ(glGetError(), static_cast<GLenum>(GL_NO_ERROR));
}

}  // namespace
}  // namespace mvbrdf::render
