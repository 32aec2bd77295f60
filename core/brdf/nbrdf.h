// Measured materials as neural BRDFs: the 100 isotropic materials of the MERL
// database (Matusik et al., SIGGRAPH 2003) as the 6-21-21-3 networks Sztrajman
// et al. fitted to them ("Neural BRDF Representation and Importance
// Sampling", CGF 2021), from ../shared/data/merl_nbrdf/merl_nbrdf.json. Ground
// truth no analytic model produced; its GLSL twin is shaders/nbrdf.glsl
// (nbrdf_glsl_test.cc compares them), its reference
// ../shared/data/merl_nbrdf/nbrdf_reference.py (nbrdf_test.cc's probe table).
//
// In the local shading frame (z = the unit normal; wi the unit direction to
// the light, wo to the viewer, both with z > 0):
//
//   h = normalize(wi + wo), theta_h, phi_h its polar angles,
//   d = normalize(Ry(-theta_h) Rz(-phi_h) wi)    (wi in the half-vector frame;
//                                                  Rusinkiewicz 1998),
//   x = (sin theta_h, 0, cos theta_h, d.x, d.y, d.z),
//   a1 = relu(x W1 + b1),  a2 = relu(a1 W2 + b2),
//   rho = max(exp(a2 W3 + b3) - 1, 0)        (x a row vector, W [in][out]),
//
// rho the BRDF in 1/sr, linear RGB, in MERL's calibrated units (the networks
// were trained on the data already scaled by (1/1500, 1.15/1500, 1.66/1500)).
// Radiance under a light of intensity I from wi: L = rho max(0, wi.z) I.
// The fit is in log space (relative errors, largest at grazing angles);
// mirror-like materials (chrome) peak at several hundred 1/sr and more.
//
// Conventions that matter:
// - wi is towards the light: the networks are not exactly reciprocal
//   (swapping wi and wo changes rho by 0.2-2 % at the median).
// - Isotropy: x holds no phi_h, and rotating wi and wo about the normal
//   rotates h and wi alike, so d and rho do not depend on the tangent frame
//   (EvaluateWorld may pick any; nbrdf_test.cc checks it to 1e-9).
// - The one exception, h = n exactly (theta_h = 0: a mirror configuration):
//   phi_h is undefined there, and the networks are not isotropic about it:
//   rho depends on the azimuth of wi relative to the phi_h chosen (measured:
//   phi_h = 0 against pi / 2 changes rho by up to 28 %, blue-acrylic at
//   theta = 75 deg). phi_h is atan2(h.y, h.x) with atan2(0, 0) = 0, as in
//   the reference; so the value at an exact mirror configuration follows
//   rounding residues in h.x and h.y (and the tangent frame). Near it rho is
//   continuous in theta_h > 0 but its limit depends on the side h comes from.
#ifndef MVBRDF_CORE_BRDF_NBRDF_H_
#define MVBRDF_CORE_BRDF_NBRDF_H_

#include <array>
#include <filesystem>
#include <glm/glm.hpp>
#include <map>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace mvbrdf::brdf {

// One material: the weights of its network, in doubles (the JSON holds
// float32 values printed to 7 digits; doubles evaluate them as the numpy
// reference does). Immutable after construction; any thread may call.
class NeuralBrdf {
 public:
  static constexpr int kInputs = 6, kHidden = 21, kOutputs = 3;
  // The packed layout, shared with shaders/nbrdf.glsl: W1 [6][21] row-major
  // (input-major: element (i, j) at i * 21 + j), b1 [21], W2 [21][21], b2
  // [21], W3 [21][3], b3 [3]; offsets below, 675 numbers in all.
  static constexpr int kW1 = 0;
  static constexpr int kB1 = kW1 + kInputs * kHidden;
  static constexpr int kW2 = kB1 + kHidden;
  static constexpr int kB2 = kW2 + kHidden * kHidden;
  static constexpr int kW3 = kB2 + kHidden;
  static constexpr int kB3 = kW3 + kHidden * kOutputs;
  static constexpr int kNumWeights = kB3 + kOutputs;  // 675

  NeuralBrdf() = default;  // all weights 0: rho = 0 everywhere
  explicit NeuralBrdf(const std::array<double, kNumWeights>& weights) : weights_(weights) {}

  // rho(wi, wo) in 1/sr (RGB) for unit vectors (not checked) in the local
  // frame (z = normal); 0 where wi.z <= 0 or wo.z <= 0.
  glm::dvec3 Evaluate(const glm::dvec3& wi, const glm::dvec3& wo) const;

  // The same from the unit normal n, the unit direction to the light l and
  // to the viewer v, in any one frame (world): a tangent frame around n of
  // this function's choosing (the networks are isotropic, see above); 0 where
  // n.l <= 0 or n.v <= 0.
  glm::dvec3 EvaluateWorld(const glm::dvec3& n, const glm::dvec3& l, const glm::dvec3& v) const;

  const std::array<double, kNumWeights>& weights() const { return weights_; }
  // The weights as floats in the packed layout: one material's block of the
  // std430 float array shaders/nbrdf.glsl reads.
  std::vector<float> GlslWeights() const;

 private:
  std::array<double, kNumWeights> weights_{};
};

// Every material of a merl_nbrdf.json file ({"materials": {NAME: [3 layers,
// each {"kernel": [in][out], "bias": [out]}]}}; other top-level keys, such as
// "format", are ignored), by name. Errors name the file, the material, the
// layer and field, and what was expected
// ("merl_nbrdf.json: materials.chrome[1].kernel: expected 21 rows (a 21x21
// kernel, [inputs][outputs]), got 20").
absl::StatusOr<std::map<std::string, NeuralBrdf>> LoadNeuralBrdfs(const std::filesystem::path& json);

// One material of such a file; NOT_FOUND for an unknown name, naming a few
// known ones (those holding the name asked for first).
absl::StatusOr<NeuralBrdf> LoadNeuralBrdf(const std::filesystem::path& json, absl::string_view name);

}  // namespace mvbrdf::brdf

#endif  // MVBRDF_CORE_BRDF_NBRDF_H_
