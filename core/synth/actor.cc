#include "core/synth/actor.h"

#include <array>
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

namespace mvbrdf::synth {
namespace {

constexpr uint32_t kCloth = 0;
constexpr uint32_t kSkin = 1;
constexpr uint32_t kHair = 2;  // also the dark shoes

enum Part : int {
  kHips, kTorso, kNeck, kHead,
  kLeftUpperArm, kLeftLowerArm, kLeftHand,
  kRightUpperArm, kRightLowerArm, kRightHand,
  kLeftUpperLeg, kLeftLowerLeg, kLeftFoot,
  kRightUpperLeg, kRightLowerLeg, kRightFoot,
  kNumParts
};

struct PartSpec {
  const char* name;
  int parent;            // -1 for the root
  glm::vec3 joint;       // joint position relative to the parent's joint (rest pose, metres)
  glm::vec3 center;      // ellipsoid centre relative to the own joint
  glm::vec3 radii;       // ellipsoid semi-axes
  uint32_t material;
  const char* segment;
};

// The rest pose: arms hanging, legs straight, all joint frames axis-aligned.
const std::array<PartSpec, kNumParts>& Parts() {
  static const std::array<PartSpec, kNumParts> parts = {{
      {"hips", -1, {0.0f, 0.95f, 0.0f}, {0.0f, 0.0f, 0.0f}, {0.17f, 0.12f, 0.11f}, kCloth, "torso"},
      {"torso", kHips, {0.0f, 0.05f, 0.0f}, {0.0f, 0.25f, 0.0f}, {0.18f, 0.28f, 0.11f}, kCloth, "torso"},
      {"neck", kTorso, {0.0f, 0.52f, 0.0f}, {0.0f, 0.05f, 0.0f}, {0.05f, 0.07f, 0.05f}, kSkin, "head"},
      {"head", kNeck, {0.0f, 0.10f, 0.0f}, {0.0f, 0.02f, 0.0f}, {0.09f, 0.115f, 0.10f}, kSkin, "head"},
      {"left_upper_arm", kTorso, {0.21f, 0.45f, 0.0f}, {0.0f, -0.15f, 0.0f}, {0.05f, 0.16f, 0.05f}, kCloth, "arms"},
      {"left_lower_arm", kLeftUpperArm, {0.0f, -0.30f, 0.0f}, {0.0f, -0.13f, 0.0f}, {0.04f, 0.14f, 0.04f}, kSkin, "arms"},
      {"left_hand", kLeftLowerArm, {0.0f, -0.27f, 0.0f}, {0.0f, -0.07f, 0.0f}, {0.03f, 0.07f, 0.045f}, kSkin, "arms"},
      {"right_upper_arm", kTorso, {-0.21f, 0.45f, 0.0f}, {0.0f, -0.15f, 0.0f}, {0.05f, 0.16f, 0.05f}, kCloth, "arms"},
      {"right_lower_arm", kRightUpperArm, {0.0f, -0.30f, 0.0f}, {0.0f, -0.13f, 0.0f}, {0.04f, 0.14f, 0.04f}, kSkin, "arms"},
      {"right_hand", kRightLowerArm, {0.0f, -0.27f, 0.0f}, {0.0f, -0.07f, 0.0f}, {0.03f, 0.07f, 0.045f}, kSkin, "arms"},
      {"left_upper_leg", kHips, {0.09f, -0.05f, 0.0f}, {0.0f, -0.21f, 0.0f}, {0.075f, 0.23f, 0.075f}, kCloth, "legs"},
      {"left_lower_leg", kLeftUpperLeg, {0.0f, -0.42f, 0.0f}, {0.0f, -0.20f, 0.0f}, {0.055f, 0.22f, 0.055f}, kCloth, "legs"},
      {"left_foot", kLeftLowerLeg, {0.0f, -0.42f, 0.0f}, {0.0f, -0.02f, 0.06f}, {0.045f, 0.035f, 0.11f}, kHair, "legs"},
      {"right_upper_leg", kHips, {-0.09f, -0.05f, 0.0f}, {0.0f, -0.21f, 0.0f}, {0.075f, 0.23f, 0.075f}, kCloth, "legs"},
      {"right_lower_leg", kRightUpperLeg, {0.0f, -0.42f, 0.0f}, {0.0f, -0.20f, 0.0f}, {0.055f, 0.22f, 0.055f}, kCloth, "legs"},
      {"right_foot", kRightLowerLeg, {0.0f, -0.42f, 0.0f}, {0.0f, -0.02f, 0.06f}, {0.045f, 0.035f, 0.11f}, kHair, "legs"},
  }};
  return parts;
}

glm::mat4 RotX(float a) { return glm::rotate(glm::mat4(1.0f), a, glm::vec3(1, 0, 0)); }
glm::mat4 RotY(float a) { return glm::rotate(glm::mat4(1.0f), a, glm::vec3(0, 1, 0)); }
glm::mat4 RotZ(float a) { return glm::rotate(glm::mat4(1.0f), a, glm::vec3(0, 0, 1)); }

// Joint rotations of the dance cycle at phase `p` (radians).
std::array<glm::mat4, kNumParts> JointRotations(float p) {
  std::array<glm::mat4, kNumParts> r;
  r.fill(glm::mat4(1.0f));
  const auto wave = [](float x) { return 0.5f + 0.5f * std::sin(x); };  // in [0,1]
  r[kHips] = RotY(0.35f * std::sin(p));
  r[kTorso] = RotX(0.10f * std::sin(2.0f * p)) * RotZ(0.06f * std::sin(p));
  r[kHead] = RotY(0.35f * std::sin(p + 1.0f)) * RotX(0.1f * std::sin(2.0f * p + 0.3f));
  // Arms: abduction about z (outwards), swing about x, elbow flexion forwards.
  r[kLeftUpperArm] = RotZ(0.25f + 0.55f * wave(p)) * RotX(0.5f * std::sin(p));
  r[kRightUpperArm] = RotZ(-(0.25f + 0.55f * wave(p + 3.14159f))) * RotX(-0.5f * std::sin(p));
  r[kLeftLowerArm] = RotX(-(0.3f + 0.7f * wave(p + 0.5f)));
  r[kRightLowerArm] = RotX(-(0.3f + 0.7f * wave(p + 3.64f)));
  r[kLeftHand] = RotZ(0.2f * std::sin(2.0f * p));
  r[kRightHand] = RotZ(-0.2f * std::sin(2.0f * p));
  // Legs: hip swing and knee flexion backwards.
  r[kLeftUpperLeg] = RotX(0.35f * std::sin(p)) * RotZ(0.05f);
  r[kRightUpperLeg] = RotX(-0.35f * std::sin(p)) * RotZ(-0.05f);
  r[kLeftLowerLeg] = RotX(0.15f + 0.35f * wave(p + 1.5f));
  r[kRightLowerLeg] = RotX(0.15f + 0.35f * wave(p + 4.64f));
  r[kLeftFoot] = RotX(-0.15f * wave(p + 1.5f));
  r[kRightFoot] = RotX(-0.15f * wave(p + 4.64f));
  return r;
}

// World-from-joint transforms of every part at phase `p`, plus a root sway.
std::array<glm::mat4, kNumParts> PartTransforms(float p) {
  const auto& parts = Parts();
  const auto rot = JointRotations(p);
  std::array<glm::mat4, kNumParts> world;
  const glm::vec3 sway(0.10f * std::sin(p), 0.02f * std::sin(2.0f * p), 0.05f * std::sin(0.5f * p));
  for (int i = 0; i < kNumParts; ++i) {
    const PartSpec& s = parts[i];
    const glm::mat4 parent = s.parent < 0 ? glm::translate(glm::mat4(1.0f), sway) : world[s.parent];
    world[i] = parent * glm::translate(glm::mat4(1.0f), s.joint) * rot[i];
  }
  return world;
}

}  // namespace

Actor MakeActor(const ActorOptions& options) {
  Actor actor;
  actor.options = options;
  const auto& parts = Parts();
  const int segments = std::max(options.segments, 6);
  const int rings = std::max(segments / 2, 3);
  const auto rest = PartTransforms(0.0f);

  for (int pi = 0; pi < kNumParts; ++pi) {
    const PartSpec& s = parts[pi];
    uint32_t segment_index = 0;
    for (; segment_index < actor.segment_names.size(); ++segment_index) {
      if (actor.segment_names[segment_index] == s.segment) break;
    }
    if (segment_index == actor.segment_names.size()) actor.segment_names.emplace_back(s.segment);

    // Ellipsoid vertices: north pole, (rings - 1) rings of `segments`, south pole.
    const uint32_t base = static_cast<uint32_t>(actor.vertex_local.size());
    const auto add_vertex = [&](const glm::vec3& unit) {
      actor.vertex_part.push_back(static_cast<uint32_t>(pi));
      actor.vertex_local.push_back(s.center + unit * s.radii);
    };
    add_vertex({0.0f, 1.0f, 0.0f});
    for (int r = 1; r < rings; ++r) {
      const float theta = 3.14159265f * static_cast<float>(r) / static_cast<float>(rings);
      for (int k = 0; k < segments; ++k) {
        const float phi = 2.0f * 3.14159265f * static_cast<float>(k) / static_cast<float>(segments);
        add_vertex({std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)});
      }
    }
    add_vertex({0.0f, -1.0f, 0.0f});
    const uint32_t south = static_cast<uint32_t>(actor.vertex_local.size()) - 1;
    const auto ring_vertex = [&](int r, int k) {
      return base + 1 + static_cast<uint32_t>((r - 1) * segments + (k % segments));
    };
    std::vector<glm::uvec3> tris;
    for (int k = 0; k < segments; ++k) tris.emplace_back(base, ring_vertex(1, k), ring_vertex(1, k + 1));
    for (int r = 1; r < rings - 1; ++r) {
      for (int k = 0; k < segments; ++k) {
        tris.emplace_back(ring_vertex(r, k), ring_vertex(r + 1, k), ring_vertex(r + 1, k + 1));
        tris.emplace_back(ring_vertex(r, k), ring_vertex(r + 1, k + 1), ring_vertex(r, k + 1));
      }
    }
    for (int k = 0; k < segments; ++k) tris.emplace_back(south, ring_vertex(rings - 1, k + 1), ring_vertex(rings - 1, k));

    for (glm::uvec3 t : tris) {
      // Orient counter-clockwise seen from outside.
      const glm::vec3 a = actor.vertex_local[t.x], b = actor.vertex_local[t.y], c = actor.vertex_local[t.z];
      if (glm::dot(glm::cross(b - a, c - a), (a + b + c) / 3.0f - s.center) < 0.0f) std::swap(t.y, t.z);
      actor.topology.file_triangles.push_back(t);
      actor.triangle_segment.push_back(segment_index);
      uint32_t material = s.material;
      if (pi == kHead) {
        // Hair: the top and the back of the head, in the part's rest frame.
        const glm::vec3 centroid = (a + b + c) / 3.0f - s.center;
        const glm::vec3 u = centroid / s.radii;
        if (u.y > 0.35f || (u.z < -0.3f && u.y > -0.5f)) material = kHair;
      }
      actor.triangle_material.push_back(material);
    }
  }

  const uint32_t n = static_cast<uint32_t>(actor.vertex_local.size());
  actor.topology.num_file_vertices = n;
  actor.topology.triangles = actor.topology.file_triangles;
  actor.topology.render_to_file_vertex.resize(n);
  for (uint32_t i = 0; i < n; ++i) actor.topology.render_to_file_vertex[i] = i;
  actor.rest_positions.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    actor.rest_positions[i] = glm::vec3(rest[actor.vertex_part[i]] * glm::vec4(actor.vertex_local[i], 1.0f));
  }
  return actor;
}

scene::FramePositions Actor::Pose(double seconds) const {
  const float phase = static_cast<float>(2.0 * 3.14159265358979 * seconds / options.cycle_seconds);
  const auto world = PartTransforms(phase);
  scene::FramePositions out(vertex_local.size());
  for (size_t i = 0; i < out.size(); ++i) out[i] = glm::vec3(world[vertex_part[i]] * glm::vec4(vertex_local[i], 1.0f));
  return out;
}

}  // namespace mvbrdf::synth
