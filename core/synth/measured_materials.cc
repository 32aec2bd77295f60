#include "core/synth/measured_materials.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "absl/strings/ascii.h"

namespace mvbrdf::synth {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The unit direction of polar angle theta and azimuth phi (degrees), z up.
glm::dvec3 Direction(double theta_deg, double phi_deg) {
  const double t = theta_deg * kPi / 180.0, p = phi_deg * kPi / 180.0;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

}  // namespace

absl::StatusOr<std::vector<std::optional<MeasuredMaterial>>> ResolveMeasuredMaterials(
    const std::string& spec, const std::vector<std::string>& slots, const std::filesystem::path& merl_file) {
  std::vector<std::optional<std::string>> names(slots.size());
  std::vector<bool> given(slots.size(), false);
  size_t next = 0;
  for (absl::string_view raw : absl::StrSplit(spec, ',')) {
    const std::string entry(absl::StripAsciiWhitespace(raw));
    if (entry.empty()) return absl::InvalidArgumentError(absl::StrCat("--materials: empty entry in \"", spec, "\""));
    size_t slot = next;
    std::string name = entry;
    if (const size_t eq = entry.find('='); eq != std::string::npos) {
      const std::string slot_name(absl::StripAsciiWhitespace(entry.substr(0, eq)));
      name = std::string(absl::StripAsciiWhitespace(entry.substr(eq + 1)));
      const auto it = std::find(slots.begin(), slots.end(), slot_name);
      if (it == slots.end()) {
        return absl::InvalidArgumentError(absl::StrCat("--materials: \"", entry, "\": no material slot \"", slot_name,
                                                       "\" in this preset (its slots: ", absl::StrJoin(slots, ", "),
                                                       ")"));
      }
      slot = static_cast<size_t>(it - slots.begin());
    } else if (slot >= slots.size()) {
      return absl::InvalidArgumentError(absl::StrCat("--materials: \"", entry, "\": the preset has ", slots.size(),
                                                     " material slots (", absl::StrJoin(slots, ", "),
                                                     "), all taken by earlier entries"));
    }
    if (given[slot]) {
      return absl::InvalidArgumentError(
          absl::StrCat("--materials: \"", entry, "\": slot \"", slots[slot], "\" is given twice"));
    }
    given[slot] = true;
    next = slot + 1;
    if (name != "-") names[slot] = name;
  }
  std::vector<std::optional<MeasuredMaterial>> out(slots.size());
  bool any = false;
  for (const auto& n : names) any |= n.has_value();
  if (!any) return out;
  if (merl_file.empty()) {
    return absl::InvalidArgumentError(
        "--materials: no merl_nbrdf.json (the measured materials) found: give --merl-file FILE or set "
        "MVBRDF_MERL_NBRDF");
  }
  for (size_t s = 0; s < slots.size(); ++s) {
    if (!names[s]) continue;
    absl::StatusOr<brdf::NeuralBrdf> b = brdf::LoadNeuralBrdf(merl_file, *names[s]);
    if (!b.ok()) {
      return absl::Status(b.status().code(), absl::StrCat("--materials: slot \"", slots[s], "\": ", b.status().message()));
    }
    out[s] = MeasuredMaterial{*names[s], *b};
  }
  return out;
}

std::filesystem::path DefaultMerlFile(const std::filesystem::path& data_dir) {
  if (const char* env = std::getenv("MVBRDF_MERL_NBRDF"); env != nullptr && *env != '\0') return env;
  std::error_code ec;
  for (const std::filesystem::path& p :
       {data_dir / "merl_nbrdf" / "merl_nbrdf.json",
        std::filesystem::path("..") / "shared" / "data" / "merl_nbrdf" / "merl_nbrdf.json"}) {
    if (!p.empty() && std::filesystem::is_regular_file(p, ec)) return p;
  }
  return {};
}

glm::dvec3 DiffuseColour(const brdf::NeuralBrdf& brdf) {
  // Light and view 90 to 180 degrees apart in azimuth at moderate elevations:
  // the half vector stays >= ~35 degrees from the normal (off the highlight).
  std::vector<double> per_channel[3];
  for (double ti : {40.0, 55.0}) {
    for (double to : {40.0, 55.0}) {
      for (double dphi : {90.0, 135.0, 180.0}) {
        const glm::dvec3 rho = brdf.Evaluate(Direction(ti, 0.0), Direction(to, dphi));
        for (int c = 0; c < 3; ++c) per_channel[c].push_back(rho[c]);
      }
    }
  }
  glm::dvec3 out;
  for (int c = 0; c < 3; ++c) {
    std::vector<double>& v = per_channel[c];
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    out[c] = v[v.size() / 2];
  }
  return out;
}

double DirectionalAlbedo(const brdf::NeuralBrdf& brdf) {
  constexpr int kRings = 48, kSectors = 96;
  const double s = std::sqrt(0.5);
  const glm::dvec3 wi(s, 0.0, s);
  glm::dvec3 sum(0.0);
  // Cosine-weighted: sin^2 theta uniform in [0, 1), phi uniform; the
  // estimator of the albedo is pi rho at each point.
  for (int r = 0; r < kRings; ++r) {
    const double sin_theta = std::sqrt((r + 0.5) / kRings);
    const double cos_theta = std::sqrt(1.0 - sin_theta * sin_theta);
    for (int k = 0; k < kSectors; ++k) {
      const double phi = 2.0 * kPi * (k + 0.5) / kSectors;
      sum += brdf.Evaluate(wi, {sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta});
    }
  }
  const glm::dvec3 albedo = kPi * sum / static_cast<double>(kRings * kSectors);
  return (albedo.x + albedo.y + albedo.z) / 3.0;
}

double PeakReflectance(const brdf::NeuralBrdf& brdf) {
  glm::dvec3 peak(0.0);
  for (int ti = 0; ti <= 85; ti += 5) {
    const glm::dvec3 wi = Direction(ti, 180.0);
    // Views over the hemisphere (fabrics peak at grazing, not at the mirror
    // direction), and at and near the mirror direction (sharp lobes).
    for (int to = 0; to <= 85; to += 5) {
      for (int po = 0; po < 360; po += 15) peak = glm::max(peak, brdf.Evaluate(wi, Direction(to, po)) * wi.z);
    }
    for (double d : {0.0, 0.5, 1.0, 2.0}) {
      for (double po : {0.0, 90.0, 180.0, 270.0}) {
        const glm::dvec3 mirror = Direction(ti, 0.0);
        const glm::dvec3 off = d > 0.0 ? glm::normalize(mirror + std::tan(d * kPi / 180.0) *
                                                                      glm::dvec3(std::cos(po * kPi / 180.0) * mirror.z,
                                                                                 std::sin(po * kPi / 180.0),
                                                                                 -std::cos(po * kPi / 180.0) * mirror.x))
                                       : mirror;
        if (off.z > 0.0) peak = glm::max(peak, brdf.Evaluate(wi, off) * wi.z);
      }
    }
  }
  return (peak.x + peak.y + peak.z) / 3.0;
}

double MeasuredGain(const brdf::NeuralBrdf& brdf, double kd_mean, double brightest_light) {
  if (brightest_light > 0.0) {
    const double peak = PeakReflectance(brdf) * brightest_light;
    return peak > 0.0 ? 0.9 / peak : 1.0;
  }
  const double albedo = DirectionalAlbedo(brdf);
  if (!(albedo > 0.0)) return 16.0;
  return std::clamp(kPi * kd_mean / albedo, 0.25, 16.0);
}

}  // namespace mvbrdf::synth
