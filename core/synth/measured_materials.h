// `mvbrdf synth --materials` (issue #15): which of a preset's material slots
// are drawn with a measured material (a MERL neural BRDF, core/brdf/nbrdf.h)
// instead of the preset's analytic one.
#ifndef MVBRDF_CORE_SYNTH_MEASURED_MATERIALS_H_
#define MVBRDF_CORE_SYNTH_MEASURED_MATERIALS_H_

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "absl/status/statusor.h"
#include "core/brdf/nbrdf.h"

namespace mvbrdf::synth {

struct MeasuredMaterial {
  std::string name;  // the MERL material, e.g. "blue-fabric"
  brdf::NeuralBrdf brdf;
};

// `spec`: comma-separated entries, each `SLOT=NAME` (SLOT one of `slots`, the
// preset's material names, e.g. cloth, skin, hair) or a bare NAME for the
// next slot in order; `-` leaves a slot analytic. `merl_file` is a
// merl_nbrdf.json. Returns one entry per slot (nullopt: analytic). Errors
// name the entry and what was expected (an unknown slot, a slot given twice,
// more names than slots, an unknown material with the known ones nearest it).
absl::StatusOr<std::vector<std::optional<MeasuredMaterial>>> ResolveMeasuredMaterials(
    const std::string& spec, const std::vector<std::string>& slots, const std::filesystem::path& merl_file);

// The merl_nbrdf.json to use when none is given: $MVBRDF_MERL_NBRDF, else
// ../shared/data/merl_nbrdf/merl_nbrdf.json from the working directory or
// the repository's data dir `data_dir`'s merl_nbrdf/ when they exist; empty
// when none does.
std::filesystem::path DefaultMerlFile(const std::filesystem::path& data_dir);

// A measured material's diffuse colour in the data's units (radiance per
// unit n.l I, i.e. rho): per channel the median of rho over a few light and
// view directions far from the mirror direction. The clustering's seed
// colour (scene.json material_seeds linear_rgb).
glm::dvec3 DiffuseColour(const brdf::NeuralBrdf& brdf);

// The directional albedo of the material lit from 45 degrees (the fraction
// of the light's energy it reflects, mean over channels): cosine-weighted
// stratified quadrature over the view hemisphere.
double DirectionalAlbedo(const brdf::NeuralBrdf& brdf);

// The largest rho(wi, wo) wi.z of the material (mean over channels of the
// channel maxima), over light elevations 0-85 degrees and views over the
// hemisphere (5 x 15 degree steps) and at and near the mirror direction: its
// brightest response per unit intensity.
double PeakReflectance(const brdf::NeuralBrdf& brdf);

// The synthesizer's exposure per material: the gain that gives the measured
// material the directional albedo of a Lambertian kd (the slot's analytic
// material's mean kd in the project's units, L = kd n.l I: albedo pi kd),
// clamped to [1/4, 16], so that a dark fabric is not a few code values (its
// highlights may clip, as a glossy surface's do in a capture exposed for the
// diffuse). With `brightest_light` > 0 instead the gain that keeps its peak
// highlight under that intensity at 0.9: nothing clips (glossy materials
// then need 16-bit frames for their diffuse).
double MeasuredGain(const brdf::NeuralBrdf& brdf, double kd_mean, double brightest_light = 0.0);

}  // namespace mvbrdf::synth

#endif  // MVBRDF_CORE_SYNTH_MEASURED_MATERIALS_H_
