// The procedural "actor": an articulated figure built from ellipsoids (head,
// neck, torso, hips, upper and lower arms and legs, hands, feet), animated
// with a simple dance cycle. It needs no outside data, so a fresh clone can
// generate, test and demo complete sequences.
//
// World frame: metres, y up, the actor faces +z and stands on y = 0 near the
// origin, about 1.75 m tall. Connectivity is fixed; each part is a closed
// ellipsoid mesh posed rigidly per frame (parts overlap at the joints, like a
// tracked template mesh whose clothes are not modelled).
#ifndef MVBRDF_CORE_SYNTH_ACTOR_H_
#define MVBRDF_CORE_SYNTH_ACTOR_H_

#include <string>
#include <vector>

#include "core/scene/mesh.h"

namespace mvbrdf::synth {

struct ActorOptions {
  // Tessellation: segments around each part's long axis; rings are derived.
  // 24 gives ~7k triangles, 48 ~28k (the thesis's mesh had ~26k).
  int segments = 24;
  // Seconds per dance cycle.
  double cycle_seconds = 2.0;
};

struct Actor {
  scene::MeshTopology topology;  // no UVs
  scene::FramePositions rest_positions;
  // Per triangle: body segment name index into `segment_names`.
  std::vector<uint32_t> triangle_segment;
  std::vector<std::string> segment_names;
  // Per triangle: material index 0 = cloth, 1 = skin, 2 = hair (see
  // StudioMaterials()).
  std::vector<uint32_t> triangle_material;

  // Positions of the file vertices at time `seconds`.
  scene::FramePositions Pose(double seconds) const;

  // Internal rig: per file vertex, its part and its position in the part's
  // local frame.
  std::vector<uint32_t> vertex_part;
  std::vector<glm::vec3> vertex_local;
  ActorOptions options;
};

Actor MakeActor(const ActorOptions& options = {});

}  // namespace mvbrdf::synth

#endif  // MVBRDF_CORE_SYNTH_ACTOR_H_
