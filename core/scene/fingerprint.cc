#include "core/scene/fingerprint.h"

#include <cstdint>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace mvbrdf::scene {
namespace {

class Fnv1a64 {
 public:
  void Add(const void* data, size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < size; ++i) {
      hash_ ^= bytes[i];
      hash_ *= 1099511628211ull;
    }
  }
  uint64_t value() const { return hash_; }

 private:
  uint64_t hash_ = 14695981039346656037ull;
};

}  // namespace

v1::SceneFingerprint Fingerprint(const Sequence& sequence) {
  v1::SceneFingerprint out;
  out.set_mesh_vertices(sequence.topology.num_file_vertices);
  out.set_mesh_triangles(sequence.topology.file_triangles.size());
  Fnv1a64 hash;
  for (const glm::uvec3& t : sequence.topology.file_triangles) {
    const uint32_t v[3] = {t.x, t.y, t.z};
    hash.Add(v, sizeof(v));
  }
  for (const glm::vec3& p : sequence.rest_positions) {
    const float v[3] = {p.x, p.y, p.z};
    hash.Add(v, sizeof(v));
  }
  out.set_mesh_hash(absl::StrFormat("%016x", hash.value()));
  for (const v1::Camera& c : sequence.scene.cameras()) *out.add_cameras() = CameraFingerprintOf(c);
  return out;
}

v1::CameraFingerprint CameraFingerprintOf(const v1::Camera& camera) {
  v1::CameraFingerprint f;
  f.set_name(camera.name());
  f.set_width(camera.width());
  f.set_height(camera.height());
  f.set_fx(camera.intrinsics().fx());
  f.set_fy(camera.intrinsics().fy());
  f.set_cx(camera.intrinsics().cx());
  f.set_cy(camera.intrinsics().cy());
  if (camera.model() == v1::ORTHOGRAPHIC) {
    f.set_model(v1::ORTHOGRAPHIC);
    f.set_pixel_size(camera.pixel_size());
  }
  return f;
}

absl::Status CompareFingerprints(const v1::SceneFingerprint& a, const v1::SceneFingerprint& b, absl::string_view a_name,
                                 absl::string_view b_name) {
  auto differ = [&](absl::string_view what, const auto& x, const auto& y) {
    return absl::InvalidArgumentError(absl::StrCat(what, " differ: ", a_name, " has ", x, ", ", b_name, " has ", y,
                                                   " (they are not of the same scene)"));
  };
  if (b.mesh_triangles() != 0 && a.mesh_triangles() != b.mesh_triangles()) {
    return differ("mesh triangle counts", a.mesh_triangles(), b.mesh_triangles());
  }
  if (b.mesh_vertices() != 0 && a.mesh_vertices() != b.mesh_vertices()) {
    return differ("mesh vertex counts", a.mesh_vertices(), b.mesh_vertices());
  }
  if (!b.mesh_hash().empty() && a.mesh_hash() != b.mesh_hash()) {
    return differ("meshes (frame 0's positions or triangles)", absl::StrCat("fingerprint ", a.mesh_hash()),
                  absl::StrCat("fingerprint ", b.mesh_hash()));
  }
  if (b.cameras_size() == 0) return absl::OkStatus();
  if (a.cameras_size() != b.cameras_size()) return differ("camera counts", a.cameras_size(), b.cameras_size());
  for (int i = 0; i < a.cameras_size(); ++i) {
    const v1::CameraFingerprint& x = a.cameras(i);
    const v1::CameraFingerprint& y = b.cameras(i);
    const std::string which = absl::StrCat("cameras[", i, "] ");
    if (x.name() != y.name()) {
      return differ(which + "names", absl::StrCat("\"", x.name(), "\""), absl::StrCat("\"", y.name(), "\""));
    }
    const std::string named = absl::StrCat("camera \"", x.name(), "\": ");
    if (x.width() != y.width() || x.height() != y.height()) {
      return differ(named + "image sizes", absl::StrCat(x.width(), "x", x.height()),
                    absl::StrCat(y.width(), "x", y.height()));
    }
    const auto model_name = [](const v1::CameraFingerprint& c) {
      return c.model() == v1::ORTHOGRAPHIC ? "orthographic" : "pinhole";
    };
    if (std::string(model_name(x)) != model_name(y)) {
      return differ(named + "camera models", model_name(x), model_name(y));
    }
    if (x.pixel_size() != y.pixel_size()) return differ(named + "pixel sizes", x.pixel_size(), y.pixel_size());
    if (x.fx() != y.fx() || x.fy() != y.fy() || x.cx() != y.cx() || x.cy() != y.cy()) {
      return differ(named + "intrinsics (fx, fy, cx, cy)",
                    absl::StrFormat("(%g, %g, %g, %g)", x.fx(), x.fy(), x.cx(), x.cy()),
                    absl::StrFormat("(%g, %g, %g, %g)", y.fx(), y.fy(), y.cx(), y.cy()));
    }
  }
  return absl::OkStatus();
}

}  // namespace mvbrdf::scene
