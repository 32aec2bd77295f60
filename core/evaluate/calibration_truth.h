// Issue #14: the cameras and lights a run used against the generator's truth
// (`mvbrdf evaluate`, EvaluationReport.cameras and .lights).
//
// Cameras: "before" is the scene's calibration, "after" the camera as used —
// RunReport.calibration.cameras[].camera when cameras_refined, else the
// scene's. Errors: the rotation angle between the two camFromWorld rotations
// (degrees), the distance between the centres (world units), and the mean
// image distance (pixels) between the projections by the true and the
// compared camera of the scene mesh's frame-0 vertices that the true camera
// sees inside its image (occlusion is not considered: the same points for
// both, so it measures the camera alone).
//
// Lights: rows of RunReport.calibration.lights (before = light_before fields,
// after = the light as used: row.light when lights_refined, else before);
// without such rows the scene's lights that the truth names (before = after).
// Position error (point lights, world units); direction error (degrees: a
// directional light's direction, a point light's direction from the mesh's
// centre); intensity relative error, mean over channels, after removing the
// one scale that best maps all compared intensities onto the truth's (least
// squares): intensities are only known up to the gauge that scales every kd
// inversely, so only their ratios are measurable.
#ifndef MVBRDF_CORE_EVALUATE_CALIBRATION_TRUTH_H_
#define MVBRDF_CORE_EVALUATE_CALIBRATION_TRUTH_H_

#include <glm/glm.hpp>
#include <vector>

#include "core/scene/sequence.h"
#include "core/synth/ground_truth.h"
#include "mvbrdf/v1/run_report.pb.h"

namespace mvbrdf::evaluate {

// Rotation angle of a^T b in degrees (0 for equal rotations).
double RotationAngleDeg(const glm::dmat3& a, const glm::dmat3& b);

// Mean pixel distance between truth.Project(p) and other.Project(p) over
// `points` that `truth` sees inside its image; 0 when none.
double MeanReprojectionPx(const scene::CameraModel& truth, const scene::CameraModel& other,
                          const std::vector<glm::vec3>& points);

// Appends report.cameras and report.lights; `sequence` is the run's scene.
void AddCalibrationTruth(const v1::RunReport& run, const synth::GroundTruth& truth, const scene::Sequence& sequence,
                         v1::EvaluationReport* report);

}  // namespace mvbrdf::evaluate

#endif  // MVBRDF_CORE_EVALUATE_CALIBRATION_TRUTH_H_
