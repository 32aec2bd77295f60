#include "core/scene/camera_model.h"

#include <cmath>
#include <limits>

namespace mvbrdf::scene {

bool CameraModel::has_distortion() const {
  for (double d : distortion) {
    if (d != 0.0) return true;
  }
  return false;
}

CameraModel Rescaled(const CameraModel& camera, int width, int height) {
  CameraModel scaled = camera;
  const double sx = static_cast<double>(width) / camera.width, sy = static_cast<double>(height) / camera.height;
  scaled.width = width;
  scaled.height = height;
  scaled.fx = camera.fx * sx;
  scaled.fy = camera.fy * sy;
  scaled.pixel_size = camera.pixel_size / sx;  // orthographic (square pixels): u = X / pixel_size + c likewise
  scaled.cx = (camera.cx + 0.5) * sx - 0.5;
  scaled.cy = (camera.cy + 0.5) * sy - 0.5;
  return scaled;
}

CameraModel Supersampled(const CameraModel& camera, int s) {
  return Rescaled(camera, camera.width * s, camera.height * s);
}

glm::dvec3 CameraModel::CenterInWorld() const {
  return -(glm::transpose(cam_from_world_rotation) * cam_from_world_translation);
}

glm::dvec4 CameraModel::ViewOrigin() const {
  if (orthographic()) {
    // -z_cam in world coordinates: minus the third row of R.
    const glm::dmat3& r = cam_from_world_rotation;  // r[col][row]
    return {-r[0][2], -r[1][2], -r[2][2], 0.0};
  }
  return glm::dvec4(CenterInWorld(), 1.0);
}

glm::dvec3 CameraModel::ViewDirection(const glm::dvec3& point_in_world) const {
  const glm::dvec4 o = ViewOrigin();
  return glm::normalize(glm::dvec3(o) - o.w * point_in_world);
}

glm::dvec2 CameraModel::PixelScale() const {
  if (orthographic()) return glm::dvec2(1.0 / pixel_size);
  return {fx, fy};
}

glm::dvec2 CameraModel::NormalizedCoordinates(const glm::dvec3& p) const {
  if (orthographic()) return {p.x, p.y};
  return {p.x / p.z, p.y / p.z};
}

glm::dvec3 CameraModel::CamFromWorld(const glm::dvec3& point_in_world) const {
  return cam_from_world_rotation * point_in_world + cam_from_world_translation;
}

glm::dvec2 CameraModel::Distort(const glm::dvec2& u) const {
  const double k1 = distortion[0], k2 = distortion[1], p1 = distortion[2], p2 = distortion[3];
  const double k3 = distortion[4], k4 = distortion[5], k5 = distortion[6], k6 = distortion[7];
  const double x = u.x, y = u.y;
  const double r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
  const double radial = (1.0 + k1 * r2 + k2 * r4 + k3 * r6) / (1.0 + k4 * r2 + k5 * r4 + k6 * r6);
  return {x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
          y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y};
}

glm::dvec2 CameraModel::Undistort(const glm::dvec2& d) const {
  if (!has_distortion()) return d;
  glm::dvec2 u = d;
  for (int i = 0; i < 20; ++i) {
    const glm::dvec2 err = Distort(u) - d;
    u -= err;
    if (std::abs(err.x) + std::abs(err.y) < 1e-14) break;
  }
  return u;
}

glm::dvec2 CameraModel::Project(const glm::dvec3& point_in_world) const {
  const glm::dvec3 p = CamFromWorld(point_in_world);
  if (!(p.z > 0.0)) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {nan, nan};
  }
  const glm::dvec2 d = Distort(NormalizedCoordinates(p));
  return PixelScale() * d + glm::dvec2(cx, cy);
}

glm::dvec2 CameraModel::ProjectUndistorted(const glm::dvec3& point_in_world) const {
  const glm::dvec3 p = CamFromWorld(point_in_world);
  if (!(p.z > 0.0)) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {nan, nan};
  }
  return PixelScale() * NormalizedCoordinates(p) + glm::dvec2(cx, cy);
}

CameraModel CameraModelFromProto(const v1::Camera& camera) {
  CameraModel m;
  m.name = camera.name();
  m.width = static_cast<int>(camera.width());
  m.height = static_cast<int>(camera.height());
  m.projection = camera.model() == v1::ORTHOGRAPHIC ? Projection::kOrthographic : Projection::kPinhole;
  m.pixel_size = camera.pixel_size();
  m.fx = camera.intrinsics().fx();
  m.fy = camera.intrinsics().fy();
  m.cx = camera.intrinsics().cx();
  m.cy = camera.intrinsics().cy();
  for (int i = 0; i < camera.intrinsics().distortion_size() && i < 8; ++i) m.distortion[i] = camera.intrinsics().distortion(i);
  const auto& r = camera.cam_from_world().rotation();
  if (r.size() == 9) {
    // glm is column-major: m[col][row].
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 3; ++col) m.cam_from_world_rotation[col][row] = r.Get(row * 3 + col);
  }
  const auto& t = camera.cam_from_world().translation();
  if (t.size() == 3) m.cam_from_world_translation = {t.Get(0), t.Get(1), t.Get(2)};
  return m;
}

void CameraModelToProto(const CameraModel& m, v1::Camera* camera) {
  camera->set_name(m.name);
  camera->set_width(static_cast<uint32_t>(m.width));
  camera->set_height(static_cast<uint32_t>(m.height));
  // An unspecified model stays unspecified (the scene files of pinhole
  // cameras keep their form); an orthographic one is written out.
  if (m.orthographic()) {
    camera->set_model(v1::ORTHOGRAPHIC);
  } else if (camera->model() == v1::ORTHOGRAPHIC) {
    camera->set_model(v1::PINHOLE);
  }
  camera->set_pixel_size(m.orthographic() ? m.pixel_size : 0.0);
  auto* in = camera->mutable_intrinsics();
  in->set_fx(m.fx);
  in->set_fy(m.fy);
  in->set_cx(m.cx);
  in->set_cy(m.cy);
  in->clear_distortion();
  if (m.has_distortion()) {
    // Keep 5 coefficients unless the rational model is in use.
    const bool rational = m.distortion[5] != 0.0 || m.distortion[6] != 0.0 || m.distortion[7] != 0.0;
    for (int i = 0; i < (rational ? 8 : 5); ++i) in->add_distortion(m.distortion[i]);
  }
  auto* pose = camera->mutable_cam_from_world();
  pose->clear_rotation();
  pose->clear_translation();
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 3; ++col) pose->add_rotation(m.cam_from_world_rotation[col][row]);
  for (int i = 0; i < 3; ++i) pose->add_translation(m.cam_from_world_translation[i]);
}

}  // namespace mvbrdf::scene
