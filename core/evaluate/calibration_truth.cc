#include "core/evaluate/calibration_truth.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

namespace mvbrdf::evaluate {
namespace {

constexpr double kPi = 3.14159265358979323846;

double AngleDeg(glm::dvec3 a, glm::dvec3 b) {
  const double la = glm::length(a), lb = glm::length(b);
  if (!(la > 0.0) || !(lb > 0.0)) return 0.0;
  const double c = std::clamp(glm::dot(a, b) / (la * lb), -1.0, 1.0);
  return std::acos(c) * 180.0 / kPi;
}

std::optional<scene::Light> LightFromProto(const v1::Light& l) {
  scene::Light out;
  out.name = l.name();
  if (l.position_size() == 3) {
    out.position = glm::vec3(l.position(0), l.position(1), l.position(2));
  } else if (l.direction_size() == 3) {
    out.directional = true;
    out.direction = glm::normalize(glm::vec3(l.direction(0), l.direction(1), l.direction(2)));
  } else {
    return std::nullopt;
  }
  if (l.intensity_size() == 3) out.intensity = glm::vec3(l.intensity(0), l.intensity(1), l.intensity(2));
  return out;
}

// The light of a refinement row before refinement (its *_before fields).
scene::Light LightBefore(const v1::LightRefinementRow& row, const scene::Light& fallback) {
  scene::Light out = fallback;
  out.name = row.name();
  if (row.position_before_size() == 3) {
    out.directional = false;
    out.position = glm::vec3(row.position_before(0), row.position_before(1), row.position_before(2));
  } else if (row.direction_before_size() == 3) {
    out.directional = true;
    out.direction =
        glm::normalize(glm::vec3(row.direction_before(0), row.direction_before(1), row.direction_before(2)));
  }
  if (row.intensity_before_size() == 3) {
    out.intensity = glm::vec3(row.intensity_before(0), row.intensity_before(1), row.intensity_before(2));
  }
  return out;
}

struct LightPair {
  std::string name;
  scene::Light truth, before, after;
  double position_sigma = 0.0;
};

// sum t e / sum e^2 over every channel of every pair (1 when degenerate).
double CommonScale(const std::vector<LightPair>& pairs, bool after) {
  double te = 0.0, ee = 0.0;
  for (const LightPair& p : pairs) {
    const glm::dvec3 e(after ? p.after.intensity : p.before.intensity);
    const glm::dvec3 t(p.truth.intensity);
    te += glm::dot(t, e);
    ee += glm::dot(e, e);
  }
  return ee > 0.0 && te > 0.0 ? te / ee : 1.0;
}

double IntensityError(const scene::Light& light, const scene::Light& truth, double scale) {
  double sum = 0.0;
  for (int c = 0; c < 3; ++c) {
    sum += std::abs(scale * light.intensity[c] - truth.intensity[c]) / std::max(1e-12, double(truth.intensity[c]));
  }
  return sum / 3.0;
}

double DirectionError(const scene::Light& light, const scene::Light& truth, const glm::dvec3& centre) {
  const auto dir = [&](const scene::Light& l) {
    return l.directional ? glm::dvec3(l.direction) : glm::dvec3(l.position) - centre;
  };
  return AngleDeg(dir(light), dir(truth));
}

}  // namespace

double RotationAngleDeg(const glm::dmat3& a, const glm::dmat3& b) {
  const glm::dmat3 r = glm::transpose(a) * b;
  const double c = std::clamp((r[0][0] + r[1][1] + r[2][2] - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) * 180.0 / kPi;
}

double MeanReprojectionPx(const scene::CameraModel& truth, const scene::CameraModel& other,
                          const std::vector<glm::vec3>& points) {
  double sum = 0.0;
  size_t n = 0;
  for (const glm::vec3& p : points) {
    const glm::dvec2 t = truth.Project(glm::dvec3(p));
    const glm::dvec2 o = other.Project(glm::dvec3(p));
    if (!std::isfinite(t.x) || !std::isfinite(t.y) || !std::isfinite(o.x) || !std::isfinite(o.y)) continue;
    if (t.x < -0.5 || t.y < -0.5 || t.x > truth.width - 0.5 || t.y > truth.height - 0.5) continue;
    sum += glm::length(t - o);
    ++n;
  }
  return n > 0 ? sum / static_cast<double>(n) : 0.0;
}

void AddCalibrationTruth(const v1::RunReport& run, const synth::GroundTruth& truth, const scene::Sequence& sequence,
                         v1::EvaluationReport* report) {
  const v1::CalibrationReport& calibration = run.calibration();
  const std::vector<scene::CameraModel> true_cameras = truth.Cameras();
  for (const scene::CameraModel& t : true_cameras) {
    const scene::CameraModel* before = nullptr;
    for (const scene::CameraModel& c : sequence.cameras) {
      if (c.name == t.name) before = &c;
    }
    if (before == nullptr) continue;
    scene::CameraModel after = *before;
    if (calibration.cameras_refined()) {
      for (const v1::CameraRefinementRow& row : calibration.cameras()) {
        if (row.name() == t.name && row.has_camera()) after = scene::CameraModelFromProto(row.camera());
      }
    }
    v1::CameraTruthRow* row = report->add_cameras();
    row->set_name(t.name);
    row->set_rotation_error_deg_before(RotationAngleDeg(before->cam_from_world_rotation, t.cam_from_world_rotation));
    row->set_rotation_error_deg_after(RotationAngleDeg(after.cam_from_world_rotation, t.cam_from_world_rotation));
    row->set_centre_error_before(glm::length(before->CenterInWorld() - t.CenterInWorld()));
    row->set_centre_error_after(glm::length(after.CenterInWorld() - t.CenterInWorld()));
    row->set_reprojection_error_px_before(MeanReprojectionPx(t, *before, sequence.rest_positions));
    row->set_reprojection_error_px_after(MeanReprojectionPx(t, after, sequence.rest_positions));
  }

  const std::vector<scene::Light> true_lights = truth.ActiveLights();
  const auto true_light = [&](const std::string& name) -> const scene::Light* {
    for (const scene::Light& l : true_lights) {
      if (l.name == name) return &l;
    }
    return nullptr;
  };
  std::vector<LightPair> pairs;
  for (const v1::LightRefinementRow& row : calibration.lights()) {
    const scene::Light* t = true_light(row.name());
    if (t == nullptr) continue;
    const int k = sequence.FindLight(row.name());
    LightPair p;
    p.name = row.name();
    p.truth = *t;
    p.before = LightBefore(row, k >= 0 ? sequence.lights[static_cast<size_t>(k)] : *t);
    p.after = p.before;
    if (calibration.lights_refined() && row.has_light()) {
      if (std::optional<scene::Light> used = LightFromProto(row.light()); used.has_value()) p.after = *used;
    }
    p.position_sigma = row.position_sigma();
    pairs.push_back(std::move(p));
  }
  if (calibration.lights_size() == 0) {
    for (const scene::Light& l : sequence.lights) {
      const scene::Light* t = true_light(l.name);
      if (t == nullptr) continue;
      pairs.push_back({l.name, *t, l, l, 0.0});
    }
  }
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (const glm::vec3& p : sequence.rest_positions) {
    lo = glm::min(lo, glm::dvec3(p));
    hi = glm::max(hi, glm::dvec3(p));
  }
  const glm::dvec3 centre = sequence.rest_positions.empty() ? glm::dvec3(0.0) : 0.5 * (lo + hi);
  const double scale_before = CommonScale(pairs, false), scale_after = CommonScale(pairs, true);
  for (const LightPair& p : pairs) {
    v1::LightTruthRow* row = report->add_lights();
    row->set_name(p.name);
    if (!p.truth.directional) {
      row->set_position_error_before(glm::length(glm::dvec3(p.before.position - p.truth.position)));
      row->set_position_error_after(glm::length(glm::dvec3(p.after.position - p.truth.position)));
    }
    row->set_direction_error_deg_before(DirectionError(p.before, p.truth, centre));
    row->set_direction_error_deg_after(DirectionError(p.after, p.truth, centre));
    row->set_intensity_rel_error_before(IntensityError(p.before, p.truth, scale_before));
    row->set_intensity_rel_error_after(IntensityError(p.after, p.truth, scale_after));
    row->set_position_sigma(p.position_sigma);
  }
}

}  // namespace mvbrdf::evaluate
