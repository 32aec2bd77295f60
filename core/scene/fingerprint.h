// What identifies a scene's input to a reconstruction (frame 0's mesh as
// loaded, the cameras' names, sizes and intrinsics), so that a ground truth
// or a result of another scene is told apart from the right one.
#ifndef MVBRDF_CORE_SCENE_FINGERPRINT_H_
#define MVBRDF_CORE_SCENE_FINGERPRINT_H_

#include "absl/status/status.h"
#include "core/scene/sequence.h"
#include "mvbrdf/v1/scene.pb.h"

namespace mvbrdf::scene {

v1::SceneFingerprint Fingerprint(const Sequence& sequence);

// A camera's part of the fingerprint: name, size and intrinsics.
v1::CameraFingerprint CameraFingerprintOf(const v1::Camera& camera);

// OK when `b` describes the same mesh and cameras as `a`; else
// INVALID_ARGUMENT naming the first difference, `a_name` and `b_name` saying
// which is which ("the run", "the truth"). Fields `b` lacks (an older file)
// are not compared.
absl::Status CompareFingerprints(const v1::SceneFingerprint& a, const v1::SceneFingerprint& b, absl::string_view a_name,
                                 absl::string_view b_name);

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_FINGERPRINT_H_
