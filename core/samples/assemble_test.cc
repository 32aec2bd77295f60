#include "core/samples/assemble.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/atlas/atlas.h"
#include "core/brdf/geometry.h"
#include "core/gl/egl_context.h"
#include "core/render/phong_model.h"
#include "core/resample/resampler.h"
#include "core/scene/mesh.h"

namespace mvbrdf::samples {
namespace {

// A 4 x 4 atlas over the unit square z = 0 (two triangles facing +z), plus a
// reversed copy of the first triangle (facing -z), a zero-area triangle and
// a triangle without a valid mean; one camera above the square, two point
// lights and one directional light.
constexpr int kSize = 4;
constexpr float kTolerance = 1e-6f;  // hand-derived cosines vs the float code

struct Fixture {
  atlas::Atlas atlas;
  scene::FramePositions positions;
  std::vector<resample::TriangleMean> means;
  cv::Mat shadows;
  scene::CameraModel camera;
  std::vector<scene::Light> lights;
};

scene::CameraModel CameraAbove(const glm::dvec3& center) {
  scene::CameraModel camera;
  camera.name = "above";
  camera.width = camera.height = 64;
  camera.fx = camera.fy = 64;
  camera.cx = camera.cy = 31.5;
  // Looking down -z: camera z (forward) = world -z, camera y (down) = world -y.
  camera.cam_from_world_rotation = glm::dmat3(glm::dvec3(1, 0, 0), glm::dvec3(0, -1, 0), glm::dvec3(0, 0, -1));
  camera.cam_from_world_translation = -(camera.cam_from_world_rotation * center);
  return camera;
}

Fixture MakeFixture() {
  Fixture f;
  f.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 0.5f, 0.0f}};
  f.atlas.size = kSize;
  f.atlas.topology.file_triangles = {{0, 1, 2}, {0, 2, 3}, {0, 2, 1}, {4, 4, 1}, {1, 2, 3}};
  f.atlas.topology.triangles = f.atlas.topology.file_triangles;
  // Triangle 0: rows 0-1 (texels 0..7); triangle 1: rows 2-3 (8..15); the
  // others borrow a texel (they are skipped before visibility matters).
  f.atlas.triangle_texels = {{0, 1, 2, 3, 4, 5, 6, 7}, {8, 9, 10, 11, 12, 13, 14, 15}, {0}, {1}, {2}};
  f.means.resize(5);
  for (int t = 0; t < 5; ++t) {
    f.means[t].rgb = glm::vec3(0.1f * (t + 1), 0.2f, 0.3f);
    f.means[t].texels = f.means[t].valid_texels = static_cast<int>(f.atlas.triangle_texels[t].size());
    f.means[t].valid = t != 4;
  }
  // Light 0 visible everywhere; light 1 only on triangle 0 (cleared bits on
  // triangle 1); light 2 on 3 of triangle 1's 8 texels and all of triangle 0.
  f.shadows = cv::Mat(kSize, kSize, CV_16UC1, cv::Scalar(0));
  for (int texel = 0; texel < 16; ++texel) {
    uint16_t bits = 1;
    if (texel < 8) bits |= 2 | 4;
    if (texel == 8 || texel == 11 || texel == 15) bits |= 4;
    f.shadows.at<uint16_t>(texel / kSize, texel % kSize) = bits;
  }
  f.camera = CameraAbove({0.5, 0.5, 3.0});
  scene::Light a;
  a.name = "A";
  a.position = {2.0f, 0.5f, 2.0f};
  a.intensity = {1.0f, 0.9f, 0.8f};
  scene::Light b;
  b.name = "B";
  b.position = {-1.0f, 1.0f, 1.5f};
  scene::Light c;
  c.name = "C";
  c.directional = true;
  c.direction = glm::normalize(glm::vec3(0.0f, -1.0f, 1.0f));
  f.lights = {a, b, c};
  return f;
}

// Dense values of `values` (one per term of t) over `num` lights, 0 where a
// light does not reach.
std::vector<float> Dense(const LightTerms& t, const float* values, size_t num) {
  std::vector<float> dense(num, 0.0f);
  for (size_t j = 0; j < t.count; ++j) dense[t.light[j]] = values[j];
  return dense;
}

glm::vec3 Centre(const Fixture& f, int t) {
  const glm::uvec3 tri = f.atlas.topology.file_triangles[t];
  return (f.positions[tri.x] + f.positions[tri.y] + f.positions[tri.z]) / 3.0f;
}

// Issue #13: an orthographic camera's v is its constant -z axis, here world
// +z (looking down), so h = max(0, R(l).z) = l.z at every point; treating the
// same camera as a pinhole at its centre (v towards (0.5, 0.5, 3)) gives
// another h, and with it another fitted lobe.
TEST(AppendTriangleSamples, OrthographicCameraHasAConstantViewVector) {
  Fixture f = MakeFixture();
  scene::CameraModel ortho = f.camera;
  ortho.projection = scene::Projection::kOrthographic;
  ortho.fx = ortho.fy = 0.0;
  ortho.pixel_size = 1.0 / 64.0;
  SampleSet set = MakeSampleSet(f.lights);
  AppendTriangleSamples(f.means, f.atlas, f.positions, f.shadows, ortho, 0, 0, f.lights, AssembleOptions{}, &set);
  SampleSet as_pinhole = MakeSampleSet(f.lights);
  AppendTriangleSamples(f.means, f.atlas, f.positions, f.shadows, f.camera, 0, 0, f.lights, AssembleOptions{},
                        &as_pinhole);
  ASSERT_EQ(set.size(), 2u);
  ASSERT_EQ(as_pinhole.size(), 2u);
  const glm::vec3 c = Centre(f, 0);
  const glm::vec3 l = glm::normalize(f.lights[0].position - c);  // light A, visible on triangle 0
  const glm::vec3 r(-l.x, -l.y, l.z);                            // R(l) = 2 (l.n) n - l, n = +z
  EXPECT_NEAR(set.h[0], l.z, kTolerance);
  const float pinhole_h = glm::dot(r, glm::normalize(glm::vec3(0.5f, 0.5f, 3.0f) - c));
  EXPECT_NEAR(as_pinhole.h[0], pinhole_h, kTolerance);
  EXPECT_GT(std::abs(set.h[0] - as_pinhole.h[0]), 0.02f);  // measured 0.024: h^40 differs by a factor ~3
  EXPECT_EQ(set.g[0], as_pinhole.g[0]);                    // g does not depend on the camera
}

TEST(MakeSampleSet, CopiesNamesAndIntensities) {
  const Fixture f = MakeFixture();
  const SampleSet set = MakeSampleSet(f.lights);
  EXPECT_EQ(set.light_names, (std::vector<std::string>{"A", "B", "C"}));
  EXPECT_EQ(set.light_intensity[0], glm::vec3(1.0f, 0.9f, 0.8f));
  EXPECT_EQ(set.size(), 0u);
}

TEST(AppendTriangleSamples, CosinesVisibilityAndSkips) {
  const Fixture f = MakeFixture();
  SampleSet set = MakeSampleSet(f.lights);
  AppendTriangleSamples(f.means, f.atlas, f.positions, f.shadows, f.camera, /*camera_index=*/2, /*frame=*/7, f.lights,
                        AssembleOptions{}, &set);
  // Triangle 2 faces away from the camera, 3 has zero area, 4 no valid mean.
  ASSERT_EQ(set.size(), 2u);
  EXPECT_EQ(set.element, (std::vector<uint32_t>{0, 1}));
  EXPECT_EQ(set.frame, (std::vector<uint16_t>{7, 7}));
  EXPECT_EQ(set.camera, (std::vector<uint8_t>{2, 2}));
  EXPECT_EQ(set.reflectance[1], f.means[1].rgb);
  EXPECT_TRUE(set.falloff.empty());

  const glm::vec3 n(0, 0, 1), eye(0.5f, 0.5f, 3.0f);
  // Visibility: light 1 not on triangle 1; light 2 on 3/8 < 0.5 of it.
  const bool visible[2][3] = {{true, true, true}, {true, false, false}};
  for (int i = 0; i < 2; ++i) {
    const glm::vec3 c = Centre(f, i);
    for (int k = 0; k < 3; ++k) {
      const render::LightCosines ref = render::ComputeLightCosines(f.lights[k], c, n, eye, false);
      EXPECT_EQ(set.GOf(i, k), visible[i][k] ? ref.g : 0.0f) << i << " " << k;
      EXPECT_EQ(set.HOf(i, k), visible[i][k] ? ref.h : 0.0f) << i << " " << k;
      // By hand: l = normalize(L - c) (or the direction), g = l.z; R = 2 g n - l, h = R.v.
      const glm::vec3 l = f.lights[k].directional ? f.lights[k].direction : glm::normalize(f.lights[k].position - c);
      const glm::vec3 v = glm::normalize(eye - c);
      const glm::vec3 r(-l.x, -l.y, l.z);
      EXPECT_NEAR(ref.g, l.z, kTolerance);
      EXPECT_NEAR(ref.h, std::max(0.0f, glm::dot(r, v)), kTolerance);
    }
  }
  EXPECT_GT(set.GOf(0, 1), 0.0f);  // light B lights triangle 0...
  EXPECT_EQ(set.GOf(1, 1), 0.0f);  // ...but is shadowed on triangle 1
  EXPECT_EQ(set.HOf(1, 1), 0.0f);
  // Compact: triangle 1 holds only light A (B and C shadowed).
  EXPECT_EQ(set.TermsEnd(1) - set.TermsBegin(1), 1u);
  // Illumination of triangle 0 by {A, B}: I_A g_A + I_B g_B.
  const glm::vec3 e = set.Illumination(0, *set.MaskOf({"A", "B"}));
  EXPECT_FLOAT_EQ(e.g, 0.9f * set.GOf(0, 0) + set.GOf(0, 1));
}

// Issue #15 item 2: a half-vector set stores n.v per Sample and n.h, v.h per
// term, as core/brdf/geometry.h defines them from the directions; n.l is
// g / a and h stays R(l).v. Point and directional lights, with fall-off.
TEST(AppendTriangleSamples, HalfVectorGeometryMatchesTheDirections) {
  const Fixture f = MakeFixture();
  SampleSet set = MakeSampleSet(f.lights, /*half_vector=*/true);
  AssembleOptions options;
  options.inverse_square_falloff = true;
  AppendTriangleSamples(f.means, f.atlas, f.positions, f.shadows, f.camera, 0, 0, f.lights, options, &set);
  ASSERT_EQ(set.size(), 2u);
  ASSERT_EQ(set.n_dot_v.size(), 2u);
  ASSERT_EQ(set.n_dot_h.size(), set.num_terms());
  ASSERT_EQ(set.v_dot_h.size(), set.num_terms());
  const glm::dvec3 n(0, 0, 1), eye(0.5, 0.5, 3.0);
  size_t checked = 0;
  for (size_t i = 0; i < set.size(); ++i) {
    const glm::dvec3 c(Centre(f, static_cast<int>(set.element[i])));
    const glm::dvec3 v = glm::normalize(eye - c);
    for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
      const scene::Light& light = f.lights[set.light[j]];
      const glm::dvec3 l = light.directional ? glm::normalize(glm::dvec3(light.direction))
                                             : glm::normalize(glm::dvec3(light.position) - c);
      const brdf::Geometry geometry = brdf::GeometryOf(n, l, v);
      EXPECT_NEAR(set.n_dot_v[i], geometry.n_dot_v, 1e-6);
      EXPECT_NEAR(set.g[j] / set.TermFalloff(j), geometry.n_dot_l, 1e-6);
      EXPECT_NEAR(set.h[j], std::max(0.0, geometry.r_dot_v), 1e-6);
      EXPECT_NEAR(set.n_dot_h[j], geometry.n_dot_h, 1e-6);
      EXPECT_NEAR(set.v_dot_h[j], geometry.v_dot_h, 1e-6);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 4u);  // triangle 0: A, B, C; triangle 1: A
  // The same Samples without the geometry: identical otherwise.
  SampleSet plain = MakeSampleSet(f.lights);
  AppendTriangleSamples(f.means, f.atlas, f.positions, f.shadows, f.camera, 0, 0, f.lights, options, &plain);
  EXPECT_TRUE(plain.n_dot_v.empty() && plain.n_dot_h.empty() && plain.v_dot_h.empty());
  EXPECT_EQ(plain.g, set.g);
  EXPECT_EQ(plain.h, set.h);
  EXPECT_EQ(plain.falloff, set.falloff);
}

TEST(AppendTriangleSamples, VisibleFractionThreshold) {
  const Fixture f = MakeFixture();
  for (float fraction : {0.3f, 0.375f, 0.4f, 1.0f}) {
    AssembleOptions options;
    options.min_visible_fraction = fraction;
    SampleSet set = MakeSampleSet(f.lights);
    AppendTriangleSamples(f.means, f.atlas, f.positions, f.shadows, f.camera, 0, 0, f.lights, options, &set);
    ASSERT_EQ(set.size(), 2u);
    // Light 2 on triangle 1 is visible on exactly 3/8 of its texels.
    EXPECT_EQ(set.GOf(1, 2) > 0.0f, fraction <= 0.375f) << fraction;
    EXPECT_GT(set.GOf(0, 2), 0.0f);  // 8/8 always
  }
}

TEST(AppendTriangleSamples, BackFacingFromBelow) {
  Fixture f = MakeFixture();
  f.camera = CameraAbove({0.5, 0.5, -3.0});  // below the square: only the reversed triangle faces it
  SampleSet set = MakeSampleSet(f.lights);
  AppendTriangleSamples(f.means, f.atlas, f.positions, f.shadows, f.camera, 0, 0, f.lights, AssembleOptions{}, &set);
  ASSERT_EQ(set.size(), 1u);
  EXPECT_EQ(set.element[0], 2u);
  // Every light is above the plane, so nothing lights the downward face.
  for (int k = 0; k < 3; ++k) EXPECT_EQ(set.GOf(0, k), 0.0f);
  EXPECT_EQ(set.num_terms(), 0u);  // nothing reaches it: no terms at all
}

TEST(AppendTriangleSamples, InverseSquareFalloffFoldedIntoG) {
  const Fixture f = MakeFixture();
  AssembleOptions options;
  options.inverse_square_falloff = true;
  SampleSet set = MakeSampleSet(f.lights);
  AppendTriangleSamples(f.means, f.atlas, f.positions, f.shadows, f.camera, 0, 0, f.lights, options, &set);
  ASSERT_EQ(set.size(), 2u);
  ASSERT_EQ(set.falloff.size(), set.num_terms());
  ASSERT_EQ(set.TermsEnd(0) - set.TermsBegin(0), 3u);  // triangle 0: every light
  const glm::vec3 c = Centre(f, 0), n(0, 0, 1), eye(0.5f, 0.5f, 3.0f);
  for (int k = 0; k < 3; ++k) {
    const render::LightCosines plain = render::ComputeLightCosines(f.lights[k], c, n, eye, false);
    const render::LightCosines ref = render::ComputeLightCosines(f.lights[k], c, n, eye, true);
    const float d2 = f.lights[k].directional ? 1.0f : glm::dot(f.lights[k].position - c, f.lights[k].position - c);
    EXPECT_EQ(set.light[k], k);
    EXPECT_FLOAT_EQ(set.TermFalloff(k), 1.0f / d2) << k;
    EXPECT_EQ(set.g[k], plain.g * ref.attenuation) << k;
    EXPECT_EQ(set.h[k], plain.h) << k;  // h is not scaled; the fitter applies a to h^ke
  }
  EXPECT_EQ(set.TermFalloff(2), 1.0f);  // directional: no fall-off
}

// Per-texel assembly over the same square: every texel of the 4 x 4 atlas at
// its centre's position, normal +z, except one uncovered texel, one invalid
// resampled texel and one texel with a downward normal.
TEST(ForEachTexelSample, MatchesTheModelPerTexel) {
  const Fixture f = MakeFixture();
  cv::Mat resampled(kSize, kSize, CV_32FC4, cv::Scalar(0.25, 0.5, 0.75, 1.0));
  resample::GeometryAtlas geometry;
  geometry.position = cv::Mat(kSize, kSize, CV_32FC4);
  geometry.normal = cv::Mat(kSize, kSize, CV_32FC4, cv::Scalar(0, 0, 1, 1));
  for (int row = 0; row < kSize; ++row) {
    for (int column = 0; column < kSize; ++column) {
      geometry.position.at<cv::Vec4f>(row, column) =
          cv::Vec4f((column + 0.5f) / kSize, 1.0f - (row + 0.5f) / kSize, 0.0f, 1.0f);
    }
  }
  geometry.position.at<cv::Vec4f>(0, 3)[3] = 0.0f;               // texel 3: uncovered
  resampled.at<cv::Vec4f>(1, 1)[3] = 0.0f;                       // texel 5: not seen by the camera
  geometry.normal.at<cv::Vec4f>(2, 2) = cv::Vec4f(0, 0, -1, 1);  // texel 10: faces away
  resampled.at<cv::Vec4f>(3, 0) = cv::Vec4f(0.1f, 0.2f, 0.3f, 1.0f);

  std::map<uint32_t, std::vector<float>> seen;
  AssembleOptions options;
  options.inverse_square_falloff = true;
  ForEachTexelSample(resampled, geometry, f.shadows, f.camera, f.lights, options,
                     [&](uint32_t texel, const glm::vec3& rgb, const LightTerms& t) {
                       EXPECT_EQ(seen.count(texel), 0u);
                       std::vector<float>& row = seen[texel];
                       row = {rgb.r, rgb.g, rgb.b};
                       const std::vector<float> g = Dense(t, t.g, 3), h = Dense(t, t.h, 3), a = Dense(t, t.falloff, 3);
                       for (int k = 0; k < 3; ++k) row.insert(row.end(), {g[k], h[k], a[k]});
                     });
  ASSERT_EQ(seen.size(), 13u);
  for (uint32_t skipped : {3u, 5u, 10u}) EXPECT_EQ(seen.count(skipped), 0u) << skipped;
  EXPECT_EQ(seen[12][0], 0.1f);
  EXPECT_EQ(seen[12][2], 0.3f);
  const glm::vec3 eye(0.5f, 0.5f, 3.0f), n(0, 0, 1);
  for (const auto& [texel, row] : seen) {
    const cv::Vec4f p = geometry.position.at<cv::Vec4f>(texel / kSize, texel % kSize);
    const glm::vec3 point(p[0], p[1], p[2]);
    const uint16_t bits = f.shadows.at<uint16_t>(texel / kSize, texel % kSize);
    for (int k = 0; k < 3; ++k) {
      const render::LightCosines ref = render::ComputeLightCosines(f.lights[k], point, n, eye, true);
      const bool visible = (bits >> k) & 1;
      EXPECT_EQ(row[3 + 3 * k], visible ? ref.g * ref.attenuation : 0.0f) << texel << " " << k;
      EXPECT_EQ(row[4 + 3 * k], visible ? ref.h : 0.0f) << texel << " " << k;
      EXPECT_EQ(row[5 + 3 * k], visible ? ref.attenuation : 0.0f) << texel << " " << k;
    }
  }
  EXPECT_EQ(seen[9][3 + 3], 0.0f);  // light 1 shadowed on texel 9

  // Without fall-off.
  int count = 0;
  ForEachTexelSample(resampled, geometry, f.shadows, f.camera, f.lights, AssembleOptions{},
                     [&](uint32_t texel, const glm::vec3&, const LightTerms& t) {
                       const cv::Vec4f p = geometry.position.at<cv::Vec4f>(texel / kSize, texel % kSize);
                       const render::LightCosines ref =
                           render::ComputeLightCosines(f.lights[0], glm::vec3(p[0], p[1], p[2]), n, eye, false);
                       EXPECT_EQ(Dense(t, t.g, 3)[0], ref.g);
                       EXPECT_EQ(Dense(t, t.h, 3)[0], ref.h);
                       EXPECT_FALSE(t.any_falloff);
                       ++count;
                     });
  EXPECT_EQ(count, 13);
}

// Issue #13: the lights on in each frame come from scene.frame_lighting
// (absolute frame numbers), every light where a frame has no entry.
TEST(FrameLightMasks, OwnLightsPerFrameAndAllElsewhere) {
  scene::Sequence sequence;
  sequence.lights = MakeFixture().lights;  // A, B, C
  sequence.num_frames = 3;
  sequence.scene.mutable_frames()->set_first(5);
  sequence.scene.mutable_frames()->set_count(3);
  sequence.frames = scene::SelectedFrames(sequence.scene.frames());
  v1::FrameLighting* fl = sequence.scene.add_frame_lighting();
  fl->set_frame(6);
  fl->add_lights("C");
  fl->add_lights("A");
  sequence.scene.add_frame_lighting()->set_frame(7);  // a dark frame
  EXPECT_EQ(FrameLightMasks(sequence),
            (std::vector<LightMask>{LightMask::FromBits(0b111u), LightMask::FromBits(0b101u), LightMask()}));
  EXPECT_EQ(AllLights(3), LightMask::FromBits(0b111u));
  EXPECT_EQ(AllLights(16), LightMask::FromBits(0xffffu));
  EXPECT_EQ(MaxLightsOn(FrameLightMasks(sequence), 3), 3u);
  EXPECT_FALSE(sequence.every_frame_lit_own());
  sequence.scene.add_frame_lighting()->set_frame(5);
  EXPECT_TRUE(sequence.every_frame_lit_own());
}

// A light off in its frame lights nothing: its shadow bits are cleared, so
// the texel Samples' g and h of it are 0, those of the lights on unchanged.
TEST(ApplyLightMask, LightsOffGiveZeroTermsOthersUnchanged) {
  const Fixture f = MakeFixture();
  resample::GeometryAtlas geometry;
  geometry.position = cv::Mat(kSize, kSize, CV_32FC4);
  geometry.normal = cv::Mat(kSize, kSize, CV_32FC4, cv::Scalar(0, 0, 1, 0));
  for (int r = 0; r < kSize; ++r) {
    for (int c = 0; c < kSize; ++c) {
      geometry.position.at<cv::Vec4f>(r, c) = {(c + 0.5f) / kSize, (r + 0.5f) / kSize, 0, 1};
    }
  }
  const cv::Mat resampled(kSize, kSize, CV_32FC4, cv::Scalar(0.2, 0.2, 0.2, 1));
  const auto rows = [&](const cv::Mat& shadows) {
    std::vector<float> g, h;
    ForEachTexelSample(resampled, geometry, shadows, f.camera, f.lights, AssembleOptions{},
                       [&](uint32_t, const glm::vec3&, const LightTerms& t) {
                         const std::vector<float> gr = Dense(t, t.g, 3), hr = Dense(t, t.h, 3);
                         g.insert(g.end(), gr.begin(), gr.end());
                         h.insert(h.end(), hr.begin(), hr.end());
                       });
    return std::make_pair(g, h);
  };
  cv::Mat all = f.shadows.clone();
  ApplyLightMask(AllLights(3), 3, &all);
  EXPECT_EQ(cv::countNonZero(all != f.shadows), 0);  // no-op: the studio path is untouched
  cv::Mat only_a = f.shadows.clone();
  ApplyLightMask(LightMask::FromBits(0b001u), 3, &only_a);
  const auto [g_all, h_all] = rows(f.shadows);
  const auto [g_a, h_a] = rows(only_a);
  ASSERT_EQ(g_all.size(), 16u * 3u);
  ASSERT_EQ(g_a.size(), g_all.size());
  bool some_b_or_c = false;
  for (size_t i = 0; i < g_all.size(); ++i) {
    if (i % 3 == 0) {
      EXPECT_EQ(g_a[i], g_all[i]);
      EXPECT_EQ(h_a[i], h_all[i]);
    } else {
      EXPECT_EQ(g_a[i], 0.0f);
      EXPECT_EQ(h_a[i], 0.0f);
      some_b_or_c |= g_all[i] > 0.0f;
    }
  }
  EXPECT_TRUE(some_b_or_c);  // the fixture lights some texels by B or C
}

// Issue #13: more lights than the 16 bits of one channel. The shadow atlas
// is CV_16UC(ceil(L / 16)), light k = bit k % 16 of channel k / 16; every
// assembler must read lights >= 16 from it, and a Sample holds only the
// lights that reach it.
std::vector<scene::Light> ManyLights(int count) {
  std::vector<scene::Light> lights;
  for (int k = 0; k < count; ++k) {
    scene::Light l;
    l.name = "L" + std::to_string(k);
    // Point lights on a ring above the square, all facing it.
    const float angle = 6.2831853f * static_cast<float>(k) / static_cast<float>(count);
    l.position = {0.5f + 2.0f * std::cos(angle), 0.5f + 2.0f * std::sin(angle), 1.0f + 0.01f * static_cast<float>(k)};
    l.intensity = glm::vec3(1.0f + 0.001f * static_cast<float>(k));
    lights.push_back(l);
  }
  return lights;
}

// Texel t sees light (7 t + 20) % L and light L - 1 (the last bit of the last
// channel); texel 5 also sees light 16 (bit 0 of channel 1).
std::vector<size_t> VisibleAt(int texel, int num_lights) {
  std::vector<size_t> v = {static_cast<size_t>((7 * texel + 20) % num_lights), static_cast<size_t>(num_lights - 1)};
  if (texel == 5) v.push_back(16);
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

cv::Mat ManyLightShadows(int num_lights) {
  cv::Mat shadows(kSize, kSize, ShadowAtlasType(num_lights), cv::Scalar::all(0));
  for (int texel = 0; texel < kSize * kSize; ++texel) {
    for (size_t k : VisibleAt(texel, num_lights)) SetShadowBit(&shadows, texel / kSize, texel % kSize, k);
  }
  return shadows;
}

TEST(ShadowAtlas, ChannelsAndBits) {
  EXPECT_EQ(ShadowChannels(0), 1);
  EXPECT_EQ(ShadowChannels(16), 1);
  EXPECT_EQ(ShadowChannels(17), 2);
  EXPECT_EQ(ShadowChannels(40), 3);
  EXPECT_EQ(ShadowChannels(256), 16);
  EXPECT_EQ(ShadowAtlasType(3), CV_16UC1);
  EXPECT_EQ(ShadowAtlasType(40), CV_16UC3);
  cv::Mat shadows = ManyLightShadows(40);
  EXPECT_TRUE(ShadowBit(shadows, 1, 1, 16));                        // texel 5
  EXPECT_EQ((shadows.at<cv::Vec<uint16_t, 3>>(1, 1)[1] & 1u), 1u);  // bit 0 of channel 1
  EXPECT_TRUE(ShadowBit(shadows, 0, 0, 39));                        // bit 7 of channel 2
  EXPECT_EQ((shadows.at<cv::Vec<uint16_t, 3>>(0, 0)[2]), 1u << 7);
  EXPECT_FALSE(ShadowBit(shadows, 0, 0, 38));
}

TEST(ForEachTexelSample, LightsBeyondSixteenFromChannels) {
  const Fixture f = MakeFixture();
  resample::GeometryAtlas geometry;
  geometry.position = cv::Mat(kSize, kSize, CV_32FC4);
  geometry.normal = cv::Mat(kSize, kSize, CV_32FC4, cv::Scalar(0, 0, 1, 1));
  for (int row = 0; row < kSize; ++row) {
    for (int column = 0; column < kSize; ++column) {
      geometry.position.at<cv::Vec4f>(row, column) =
          cv::Vec4f((column + 0.5f) / kSize, 1.0f - (row + 0.5f) / kSize, 0.0f, 1.0f);
    }
  }
  const cv::Mat resampled(kSize, kSize, CV_32FC4, cv::Scalar(0.25, 0.5, 0.75, 1.0));
  const glm::vec3 eye(0.5f, 0.5f, 3.0f), n(0, 0, 1);
  for (int num_lights : {40, 256}) {
    const std::vector<scene::Light> lights = ManyLights(num_lights);
    cv::Mat shadows = ManyLightShadows(num_lights);
    int visits = 0;
    ForEachTexelSample(resampled, geometry, shadows, f.camera, lights, AssembleOptions{},
                       [&](uint32_t texel, const glm::vec3&, const LightTerms& t) {
                         ++visits;
                         const std::vector<size_t> expected = VisibleAt(static_cast<int>(texel), num_lights);
                         ASSERT_EQ(t.count, expected.size()) << num_lights << " lights, texel " << texel;
                         const cv::Vec4f p = geometry.position.at<cv::Vec4f>(texel / kSize, texel % kSize);
                         for (size_t j = 0; j < t.count; ++j) {
                           EXPECT_EQ(t.light[j], expected[j]);
                           const render::LightCosines ref = render::ComputeLightCosines(
                               lights[t.light[j]], glm::vec3(p[0], p[1], p[2]), n, eye, false);
                           EXPECT_EQ(t.g[j], ref.g);
                           EXPECT_EQ(t.h[j], ref.h);
                         }
                       });
    EXPECT_EQ(visits, kSize * kSize);

    // An OLAT frame: only light 16 is on; every other bit is cleared, in
    // every channel.
    LightMask on;
    on.Set(16);
    ApplyLightMask(on, static_cast<size_t>(num_lights), &shadows);
    for (int texel = 0; texel < kSize * kSize; ++texel) {
      for (size_t k = 0; k < static_cast<size_t>(num_lights); ++k) {
        EXPECT_EQ(ShadowBit(shadows, texel / kSize, texel % kSize, k), k == 16 && texel == 5) << texel << " " << k;
      }
    }
  }
}

TEST(AppendTriangleSamples, LightsBeyondSixteenFromChannels) {
  Fixture f = MakeFixture();
  constexpr int kLights = 40;
  f.lights = ManyLights(kLights);
  // Triangle 0 (texels 0-7): light 33 on all texels, light 17 on 3 of 8
  // (below the default half); triangle 1: light 2 and light 39.
  f.shadows = cv::Mat(kSize, kSize, ShadowAtlasType(kLights), cv::Scalar::all(0));
  for (int texel = 0; texel < 16; ++texel) {
    const int row = texel / kSize, column = texel % kSize;
    if (texel < 8) SetShadowBit(&f.shadows, row, column, 33);
    if (texel < 3) SetShadowBit(&f.shadows, row, column, 17);
    if (texel >= 8) {
      SetShadowBit(&f.shadows, row, column, 2);
      SetShadowBit(&f.shadows, row, column, 39);
    }
  }
  SampleSet set = MakeSampleSet(f.lights);
  AppendTriangleSamples(f.means, f.atlas, f.positions, f.shadows, f.camera, 0, 0, f.lights, AssembleOptions{}, &set);
  ASSERT_EQ(set.size(), 2u);
  EXPECT_EQ(set.offset, (std::vector<uint64_t>{0, 1, 3}));
  EXPECT_EQ(set.light, (std::vector<uint16_t>{33, 2, 39}));
  const glm::vec3 eye(0.5f, 0.5f, 3.0f), n(0, 0, 1);
  for (size_t j = 0; j < set.num_terms(); ++j) {
    const size_t i = j == 0 ? 0 : 1;
    const render::LightCosines ref = render::ComputeLightCosines(f.lights[set.light[j]], Centre(f, i), n, eye, false);
    EXPECT_EQ(set.g[j], ref.g);
    EXPECT_EQ(set.h[j], ref.h);
  }
}

// Per-pixel Samples over the square seen from above: every pixel that shows
// it (with its four neighbours), with the lights of its texel's channels.
TEST(ForEachPixelSample, LightsBeyondSixteenFromChannels) {
  const Fixture f = MakeFixture();
  constexpr int kLights = 256;
  const std::vector<scene::Light> lights = ManyLights(kLights);
  const cv::Mat shadows = ManyLightShadows(kLights);
  resample::CameraSurface surface;
  surface.position_texel = cv::Mat(f.camera.height, f.camera.width, CV_32FC4, cv::Scalar::all(0));
  surface.normal = cv::Mat(f.camera.height, f.camera.width, CV_32FC4, cv::Scalar(0, 0, 1, 0));
  surface.cx = f.camera.cx;
  surface.cy = f.camera.cy;
  for (int y = 0; y < f.camera.height; ++y) {
    for (int x = 0; x < f.camera.width; ++x) {
      // The camera 3 above the plane, fx = 64: a pixel spans 3/64 units.
      const float wx = 0.5f + static_cast<float>(x - f.camera.cx) * 3.0f / 64.0f;
      const float wy = 0.5f - static_cast<float>(y - f.camera.cy) * 3.0f / 64.0f;
      if (wx < 0.0f || wx >= 1.0f || wy < 0.0f || wy >= 1.0f) continue;
      const int column = static_cast<int>(wx * kSize), row = static_cast<int>((1.0f - wy) * kSize);
      surface.position_texel.at<cv::Vec4f>(y, x) = {wx, wy, 0.0f, static_cast<float>(row * kSize + column + 1)};
    }
  }
  const cv::Mat frame(f.camera.height, f.camera.width, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5));
  int pixels = 0;
  std::set<uint32_t> texels;
  ForEachPixelSample(frame, surface, shadows, f.camera, lights, AssembleOptions{}, 0.0,
                     [&](uint32_t texel, const glm::vec3&, const LightTerms& t) {
                       ++pixels;
                       texels.insert(texel);
                       const std::vector<size_t> expected = VisibleAt(static_cast<int>(texel), kLights);
                       ASSERT_EQ(t.count, expected.size()) << "texel " << texel;
                       for (size_t j = 0; j < t.count; ++j) EXPECT_EQ(t.light[j], expected[j]);
                     });
  EXPECT_GT(pixels, 100);
  EXPECT_EQ(texels.size(), 16u);

  // With a 2 x 2 footprint the same pixels, each light as four copies
  // (FootprintLights: light k's are 4k..4k+3, ascending) whose g and a are a
  // quarter of the subpixel's, so that they sum to about the centre's (the
  // plane's g varies little over a pixel) and a's to 1; h per subpixel.
  const std::vector<scene::Light> copies = FootprintLights(lights, 2);
  ASSERT_EQ(copies.size(), 4u * kLights);
  EXPECT_EQ(copies[4 * 7 + 3].name, lights[7].name);
  int footprint_pixels = 0;
  ForEachPixelSample(
      frame, surface, shadows, f.camera, lights, AssembleOptions{}, 0.0,
      [&](uint32_t texel, const glm::vec3&, const LightTerms& t) {
        ++footprint_pixels;
        const std::vector<size_t> expected = VisibleAt(static_cast<int>(texel), kLights);
        ASSERT_EQ(t.count, 4 * expected.size()) << "texel " << texel;
        for (size_t j = 0; j < t.count; ++j) {
          EXPECT_EQ(t.light[j], 4 * expected[j / 4] + j % 4);
          EXPECT_FLOAT_EQ(t.falloff[j], 0.25f);
        }
        for (size_t i = 0; i + 3 < t.count; i += 4) {
          const float g = t.g[i] + t.g[i + 1] + t.g[i + 2] + t.g[i + 3];
          EXPECT_NEAR(g, 4.0f * t.g[i], 0.05f * g);
          EXPECT_NE(t.h[i], t.h[i + 3]);  // the subpixels see the light's mirror direction differently
        }
      },
      2);
  EXPECT_EQ(footprint_pixels, pixels);
  // The selection of light 5 is that of its four copies.
  LightMask five;
  five.Set(5);
  const LightSelection widened = FootprintSelection(LightSelection(five), 2);
  for (size_t k = 0; k < 4u * kLights; ++k) EXPECT_EQ(widened.config.Test(k), k >= 20 && k < 24) << k;
}

// A distorted pixel's ray meets the pinhole surface maps between their
// centres: the surface there is interpolated on a smooth piece (closer than
// the nearest centre's), and left at the nearest across a depth step.
TEST(SurfaceBetween, InterpolatesSmoothSurfacesAndKeepsTheNearestAcrossSteps) {
  constexpr int kMap = 8;
  resample::CameraSurface surface;
  surface.position_texel = cv::Mat(kMap, kMap, CV_32FC4, cv::Scalar::all(0));
  surface.normal = cv::Mat(kMap, kMap, CV_32FC4, cv::Scalar::all(0));
  // A sphere of radius 1 seen from +z, 0.1 units per pixel: position and
  // normal as functions of the (sub)pixel.
  const auto position_at = [](double x, double y) {
    const double wx = 0.1 * (x - 3.5), wy = 0.1 * (y - 3.5);
    return glm::dvec3(wx, wy, std::sqrt(1.0 - wx * wx - wy * wy));
  };
  for (int y = 0; y < kMap; ++y) {
    for (int x = 0; x < kMap; ++x) {
      const glm::dvec3 p = position_at(x, y);
      surface.position_texel.at<cv::Vec4f>(y, x) = {static_cast<float>(p.x), static_cast<float>(p.y),
                                                    static_cast<float>(p.z), 1.0f};
      surface.normal.at<cv::Vec4f>(y, x) = {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z),
                                            0.0f};
    }
  }
  const auto nearest = [&](double px, double py, glm::vec3* point, glm::vec3* normal) {
    const cv::Vec4f& q = surface.position_texel.at<cv::Vec4f>(static_cast<int>(std::lround(py)),
                                                             static_cast<int>(std::lround(px)));
    *point = glm::vec3(q[0], q[1], q[2]);
    *normal = *point;  // a unit sphere's normal is its position
  };
  for (const auto& [px, py] : {std::pair{3.3, 4.45}, std::pair{2.5, 2.5}, std::pair{5.1, 1.9}}) {
    glm::vec3 point, normal;
    nearest(px, py, &point, &normal);
    const glm::dvec3 truth = position_at(px, py);
    const double before = glm::length(glm::dvec3(point) - truth);
    assemble_internal::SurfaceBetween(surface, px, py, &point, &normal);
    const double after = glm::length(glm::dvec3(point) - truth);
    // Bilinear on a curved surface: second order in the spacing (0.003
    // here), against the nearest centre's first-order 0.01-0.05.
    EXPECT_GT(before, 0.01) << px << ", " << py;
    EXPECT_LT(after, 0.003) << px << ", " << py;
    EXPECT_LT(after, before / 4.0) << px << ", " << py;
    EXPECT_LT(glm::length(glm::dvec3(glm::normalize(normal)) - truth), 0.003) << px << ", " << py;
  }
  // A step: the right half of the map 0.5 units further away (another
  // surface behind the silhouette of the first).
  for (int y = 0; y < kMap; ++y) {
    for (int x = 4; x < kMap; ++x) surface.position_texel.at<cv::Vec4f>(y, x)[2] -= 0.5f;
  }
  glm::vec3 point, normal;
  nearest(3.4, 2.2, &point, &normal);
  const glm::vec3 kept = point;
  assemble_internal::SurfaceBetween(surface, 3.4, 2.2, &point, &normal);
  EXPECT_EQ(point, kept);
  // Off the map or on a pixel without surface: kept as well.
  surface.position_texel.at<cv::Vec4f>(1, 1)[3] = 0.0f;
  nearest(1.2, 1.3, &point, &normal);
  const glm::vec3 kept2 = point;
  assemble_internal::SurfaceBetween(surface, 1.2, 1.3, &point, &normal);
  EXPECT_EQ(point, kept2);
  assemble_internal::SurfaceBetween(surface, 7.2, 1.3, &point, &normal);
  EXPECT_EQ(point, kept2);
}

// A distorted camera's pixel rays, and a footprint's subpixel rays, meet the
// pinhole surface maps between their centres. Where the maps carry the drawn
// triangles (Resampler::Surface of a distorted camera, or of any pinhole one
// with ResamplerOptions::surface_triangles), ForEachPixelSample reads the
// surface on the ray's own triangle: a sphere's normals (through the light
// cosines g) as a CPU ray cast over every triangle finds them, where
// interpolating between the map's centres (SurfaceBetween, the maps without
// triangles) is off by far more.
TEST(ForEachPixelSample, RaysBetweenMapCentresReadTheSurfaceOnTheirRay) {
  // A UV sphere of radius 1 at the origin, no UVs (the atlas is built).
  constexpr int kStacks = 10, kSlices = 20;
  scene::MeshTopology topology;
  scene::FramePositions positions;
  const auto vertex = [&](int i, int j) { return static_cast<uint32_t>(i * (kSlices + 1) + j); };
  for (int i = 0; i <= kStacks; ++i) {
    for (int j = 0; j <= kSlices; ++j) {
      const double theta = M_PI * i / kStacks, phi = 2.0 * M_PI * (j % kSlices) / kSlices;
      positions.emplace_back(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
    }
  }
  for (int i = 0; i < kStacks; ++i) {
    for (int j = 0; j < kSlices; ++j) {
      const uint32_t a = vertex(i, j), b = vertex(i + 1, j), c = vertex(i + 1, j + 1), d = vertex(i, j + 1);
      if (i > 0) topology.triangles.emplace_back(a, b, d);
      if (i + 1 < kStacks) topology.triangles.emplace_back(b, c, d);
    }
  }
  topology.file_triangles = topology.triangles;
  topology.num_file_vertices = static_cast<uint32_t>(positions.size());
  for (uint32_t v = 0; v < topology.num_file_vertices; ++v) topology.render_to_file_vertex.push_back(v);
  atlas::AtlasOptions atlas_options;
  atlas_options.size = 256;
  auto atlas = atlas::BuildAtlas(topology, positions, atlas_options);
  ASSERT_TRUE(atlas.ok()) << atlas.status();
  // Seen from 4 units up the z axis with a barrel lens, the sphere filling
  // the middle of a small image (a pixel ~0.06 units on it).
  scene::CameraModel camera;
  camera.width = 96;
  camera.height = 72;
  camera.fx = camera.fy = 70.0;
  camera.cx = 47.3;
  camera.cy = 35.6;
  camera.cam_from_world_rotation = glm::dmat3(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0);
  camera.cam_from_world_translation = {0.0, 0.0, 4.0};
  camera.distortion = {-0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  std::vector<scene::Light> lights(3);
  const glm::vec3 to_light[3] = {glm::normalize(glm::vec3(1.0f, 0.3f, 1.0f)),
                                 glm::normalize(glm::vec3(-0.5f, 1.0f, 1.0f)),
                                 glm::normalize(glm::vec3(0.2f, -1.0f, 0.8f))};
  for (int k = 0; k < 3; ++k) {
    lights[static_cast<size_t>(k)].directional = true;
    lights[static_cast<size_t>(k)].direction = to_light[k];
  }
  auto context = gl::EglContext::Create(gl::EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok()) << context.status();
  // The pixel in each frame value, every light visible everywhere.
  cv::Mat frame(camera.height, camera.width, CV_32FC3);
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) frame.at<cv::Vec3f>(y, x) = {static_cast<float>(x), static_cast<float>(y), 0};
  }
  cv::Mat shadows(256, 256, ShadowAtlasType(lights.size()), cv::Scalar::all(7));
  // The truth (its own ray-triangle test, independent of the code under
  // test): the nearest triangle the ray through video (sub)pixel (x, y)
  // crosses, its vertex normals (as the resampler computes them) there.
  const std::vector<glm::vec3> normals = scene::ComputeFileVertexNormals(topology, positions);
  const auto truth_normal = [&](const scene::CameraModel& cam, double x, double y) -> std::optional<glm::dvec3> {
    const glm::dvec3 centre = cam.CenterInWorld();
    const glm::dvec2 u = cam.Undistort({(x - cam.cx) / cam.fx, (y - cam.cy) / cam.fy});
    const glm::dvec3 dir = glm::transpose(cam.cam_from_world_rotation) * glm::dvec3(u, 1.0);
    double best = std::numeric_limits<double>::infinity();
    std::optional<glm::dvec3> n;
    for (const glm::uvec3& t : topology.triangles) {
      const glm::dvec3 p0(positions[t[0]]), e1 = glm::dvec3(positions[t[1]]) - p0, e2 = glm::dvec3(positions[t[2]]) - p0;
      const glm::dvec3 q = glm::cross(dir, e2), r = centre - p0, k = glm::cross(r, e1);
      const double det = glm::dot(e1, q), b1 = glm::dot(r, q) / det, b2 = glm::dot(dir, k) / det;
      const double s = glm::dot(e2, k) / det;
      if (b1 < 0.0 || b2 < 0.0 || b1 + b2 > 1.0 || !(s > 0.0) || s >= best) continue;
      best = s;
      n = glm::normalize((1.0 - b1 - b2) * glm::dvec3(normals[t[0]]) + b1 * glm::dvec3(normals[t[1]]) +
                         b2 * glm::dvec3(normals[t[2]]));
    }
    return n;
  };
  // The worst light cosine error over the Samples of `cam` with `footprint`
  // x `footprint` subpixels (light copy k F^2 + s: subpixel s of light k, g
  // divided by F^2), from its surface maps as the resampler gives them
  // (on_ray) and without the triangle maps (between).
  struct Errors {
    double on_ray = 0.0, between = 0.0;
    int pixels = 0, between_pixels = 0;
    int terms = 0, off = 0;  // light terms on rays, those more than 1e-5 off
  };
  const auto measure = [&](const scene::CameraModel& cam, int footprint, resample::ResamplerOptions options) {
    Errors e;
    auto resampler = resample::Resampler::Create(**context, *atlas, {cam}, lights, options);
    EXPECT_TRUE(resampler.ok()) << resampler.status();
    if (!resampler.ok()) return e;
    EXPECT_TRUE((*resampler)->SetFrame(positions).ok());
    auto surface = (*resampler)->Surface(0);
    EXPECT_TRUE(surface.ok()) << surface.status();
    if (!surface.ok()) return e;
    EXPECT_FALSE(surface->triangle.empty());
    EXPECT_NE(surface->triangles, nullptr);
    const int subpixels = footprint * footprint;
    const auto worst = [&](const resample::CameraSurface& maps, int* pixels, int* terms_seen, int* off) {
      double w = 0.0;
      ForEachPixelSample(
          frame, maps, shadows, cam, lights, AssembleOptions{}, 0.0,
          [&](uint32_t, const glm::vec3& rgb, const LightTerms& terms) {
            ++*pixels;
            for (size_t j = 0; j < terms.count; ++j) {
              const int k = terms.light[j] / subpixels, sub = terms.light[j] % subpixels;
              const double dx = (sub % footprint + 0.5) / footprint - 0.5, dy = (sub / footprint + 0.5) / footprint - 0.5;
              const std::optional<glm::dvec3> n = truth_normal(cam, rgb[0] + dx, rgb[1] + dy);
              ASSERT_TRUE(n.has_value());
              // A subpixel facing away takes the centre's surface (ForEachPixelSample).
              const glm::dvec2 u = cam.Undistort({(rgb[0] + dx - cam.cx) / cam.fx, (rgb[1] + dy - cam.cy) / cam.fy});
              const glm::dvec3 to_camera = -glm::transpose(cam.cam_from_world_rotation) * glm::dvec3(u, 1.0);
              if (glm::dot(*n, to_camera) < 0.02 * glm::length(to_camera)) continue;
              const double g = std::max(0.0, glm::dot(*n, glm::dvec3(to_light[k]))) / subpixels;
              const double error = std::abs(terms.g[j] - g) * subpixels;
              w = std::max(w, error);
              ++*terms_seen;
              if (error > 1e-5) ++*off;
            }
          },
          footprint);
      return w;
    };
    int between_terms = 0, between_off = 0;
    e.on_ray = worst(*surface, &e.pixels, &e.terms, &e.off);
    resample::CameraSurface interpolated = *surface;
    interpolated.triangles.reset();
    e.between = worst(interpolated, &e.between_pixels, &between_terms, &between_off);
    return e;
  };
  // A distorted camera: its pixel centres' rays.
  const Errors distorted = measure(camera, 1, {});
  // An undistorted one with 2 x 2 subpixels (--pixel-footprint 2): the
  // subpixels' rays, with ResamplerOptions::surface_triangles.
  scene::CameraModel pinhole = camera;
  pinhole.distortion.assign(8, 0.0);
  resample::ResamplerOptions with_triangles;
  with_triangles.surface_triangles = true;
  const Errors footprint = measure(pinhole, 2, with_triangles);
  for (const auto& [name, e] : {std::pair{"distorted pixels", distorted}, std::pair{"2 x 2 subpixels", footprint}}) {
    std::printf("%s: worst light cosine error %.2e on their rays (%d of %d terms over 1e-5), %.2e interpolated "
                "(%d pixels)\n", name, e.on_ray, e.off, e.terms, e.between, e.pixels);
    EXPECT_GT(e.pixels, 800) << name;
    EXPECT_EQ(e.between_pixels, e.pixels) << name;
    // Float corners and normals (measured ~1e-7) against 0.035-0.072
    // interpolated; a ray none of whose 5 x 5 triangles it crosses falls back
    // to the interpolation (measured: 2 of 10,036 subpixel terms, 6.8e-3).
    EXPECT_LE(e.off, e.terms / 1000) << name;
    EXPECT_LT(e.on_ray, 0.25 * e.between) << name;
    EXPECT_GT(e.between, 1e-2) << name;
  }
}

}  // namespace
}  // namespace mvbrdf::samples
