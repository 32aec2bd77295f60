// `mvbrdf validate --fix`: repairs what rounding broke in a scene file
// (rotations and light directions written with too few digits), refusing
// what is too far off to be rounding.
#ifndef MVBRDF_CORE_SCENE_SCENE_FIX_H_
#define MVBRDF_CORE_SCENE_SCENE_FIX_H_

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "mvbrdf/v1/scene.pb.h"

namespace mvbrdf::scene {

// The largest max |R*R^T - I| taken as rounding (a rotation written with 3
// significant digits is off by ~1e-3 at most).
inline constexpr double kMaxFixableRotationError = 1e-3;

// Replaces each camera's cam_from_world.rotation by the nearest rotation
// (polar decomposition, R (R^T R)^(-1/2), through the SVD R = U S V^T -> U V^T)
// and scales each directional light's direction to unit length; one line per
// camera or light changed goes to `changes` (what it was before).
// INVALID_ARGUMENT naming the field and the camera or light for a rotation
// with det < 0 (a reflection) or max |R*R^T - I| > kMaxFixableRotationError,
// or a direction of zero length (any other length is only a scale). Fields with the wrong number of values or
// non-finite ones are left for validation to report.
absl::Status FixRounding(v1::Scene* scene, std::vector<std::string>* changes);

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_SCENE_FIX_H_
