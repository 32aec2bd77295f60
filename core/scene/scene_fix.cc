#include "core/scene/scene_fix.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace mvbrdf::scene {
namespace {

// A rotation this close to orthonormal (double rounding) is left bit for bit.
constexpr double kOrthonormalAsItIs = 1e-12;

std::string Num(double v) { return absl::StrFormat("%.2g", v); }

bool AllFinite(const google::protobuf::RepeatedField<double>& values) {
  return std::all_of(values.begin(), values.end(), [](double v) { return std::isfinite(v); });
}

}  // namespace

absl::Status FixRounding(v1::Scene* scene, std::vector<std::string>* changes) {
  for (int c = 0; c < scene->cameras_size(); ++c) {
    v1::Camera* camera = scene->mutable_cameras(c);
    auto* rotation = camera->mutable_cam_from_world()->mutable_rotation();
    if (rotation->size() != 9 || !AllFinite(*rotation)) continue;
    const std::string field =
        absl::StrCat("scene.cameras[", c, "].cam_from_world.rotation (camera \"", camera->name(), "\")");
    cv::Matx33d r(rotation->data());
    const cv::Matx33d rrt = r * r.t();
    double error = 0.0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) error = std::max(error, std::abs(rrt(i, j) - (i == j ? 1.0 : 0.0)));
    if (!(error <= kMaxFixableRotationError)) {
      return absl::InvalidArgumentError(absl::StrCat(field, ": max |R*R^T - I| is ", Num(error),
                                                     ", too far from a rotation to be rounding (--fix repairs up to ",
                                                     Num(kMaxFixableRotationError), ")"));
    }
    const double det = cv::determinant(r);
    if (error <= kOrthonormalAsItIs && det > 0.0) continue;
    if (det < 0.0) {
      return absl::InvalidArgumentError(absl::StrCat(field, ": determinant ", Num(det),
                                                     " < 0, a reflection, not a rotation (--fix cannot repair)"));
    }
    cv::Matx33d u, vt;
    cv::Matx31d w;
    cv::SVD::compute(r, w, u, vt);
    const cv::Matx33d fixed = u * vt;
    double moved = 0.0;
    for (int i = 0; i < 9; ++i) {
      moved = std::max(moved, std::abs(fixed.val[i] - r.val[i]));
      rotation->Set(i, fixed.val[i]);
    }
    if (moved > 0.0) {
      changes->push_back(absl::StrCat("camera ", camera->name(), ": rotation made orthonormal (max |R*R^T - I| was ",
                                      Num(error), ", entries moved by at most ", Num(moved), ")"));
    }
  }
  for (int l = 0; l < scene->lights_size(); ++l) {
    v1::Light* light = scene->mutable_lights(l);
    auto* d = light->mutable_direction();
    if (d->size() != 3 || !AllFinite(*d)) continue;
    const std::string field = absl::StrCat("scene.lights[", l, "].direction (light \"", light->name(), "\")");
    const double length = std::sqrt(d->Get(0) * d->Get(0) + d->Get(1) * d->Get(1) + d->Get(2) * d->Get(2));
    if (length == 0.0) {
      return absl::InvalidArgumentError(absl::StrCat(field, ": has zero length, no direction to renormalise"));
    }
    if (std::abs(length - 1.0) <= 1e-15) continue;  // unit length to double rounding
    for (int i = 0; i < 3; ++i) d->Set(i, d->Get(i) / length);
    changes->push_back(absl::StrCat("light ", light->name(), ": direction renormalised (length was ",
                                    absl::StrFormat("%.9g", length), ")"));
  }
  return absl::OkStatus();
}

}  // namespace mvbrdf::scene
