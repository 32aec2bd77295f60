#include "core/importers/metashape_xml.h"

#include <tinyxml2.h>

#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <system_error>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace mvbrdf::importers {
namespace {

using Mat4 = std::array<double, 16>;

constexpr Mat4 kIdentity = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

Mat4 Multiply(const Mat4& a, const Mat4& b) {
  Mat4 c{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) c[i * 4 + j] += a[i * 4 + k] * b[k * 4 + j];
  return c;
}

class Reader {
 public:
  explicit Reader(std::filesystem::path file) : file_(std::move(file)) {}

  absl::Status Invalid(absl::string_view element, absl::string_view message) const {
    return absl::InvalidArgumentError(absl::StrCat(file_.string(), ": ", element, ": ", message));
  }

  // Whitespace-separated numbers of an element's text, exactly `count` of them.
  absl::StatusOr<std::vector<double>> Numbers(const tinyxml2::XMLElement* e, const std::string& where,
                                              size_t count) const {
    const char* text = e->GetText();
    std::vector<double> values;
    for (absl::string_view part : absl::StrSplit(text ? text : "", absl::ByAnyChar(" \t\r\n"), absl::SkipEmpty())) {
      double v = 0;
      if (!absl::SimpleAtod(part, &v) || !std::isfinite(v)) {
        return Invalid(where, absl::StrCat("\"", part, "\" is not a finite number"));
      }
      values.push_back(v);
    }
    if (values.size() != count) {
      return Invalid(where, absl::StrCat("must hold ", count, " numbers, got ", values.size()));
    }
    return values;
  }

  // An optional child's single number (0 when absent).
  absl::StatusOr<double> Optional(const tinyxml2::XMLElement* parent, const char* name,
                                  const std::string& where) const {
    const tinyxml2::XMLElement* e = parent->FirstChildElement(name);
    if (e == nullptr) return 0.0;
    auto v = Numbers(e, absl::StrCat(where, "/", name), 1);
    if (!v.ok()) return v.status();
    return (*v)[0];
  }

  // A <transform> with rotation (9), translation (3), scale (1), each
  // optional: the 4x4 similarity s R | t.
  absl::StatusOr<Mat4> Similarity(const tinyxml2::XMLElement* transform, const std::string& where) const {
    std::vector<double> r = {1, 0, 0, 0, 1, 0, 0, 0, 1}, t = {0, 0, 0};
    double s = 1.0;
    if (const auto* e = transform->FirstChildElement("rotation")) {
      auto v = Numbers(e, where + "/rotation", 9);
      if (!v.ok()) return v.status();
      r = *v;
    }
    if (const auto* e = transform->FirstChildElement("translation")) {
      auto v = Numbers(e, where + "/translation", 3);
      if (!v.ok()) return v.status();
      t = *v;
    }
    if (const auto* e = transform->FirstChildElement("scale")) {
      auto v = Numbers(e, where + "/scale", 1);
      if (!v.ok()) return v.status();
      s = (*v)[0];
      if (!(s > 0.0)) return Invalid(where + "/scale", absl::StrCat("must be positive, got ", s));
    }
    Mat4 m = kIdentity;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) m[i * 4 + j] = s * r[i * 3 + j];
      m[i * 4 + 3] = t[i];
    }
    return m;
  }

  struct Sensor {
    uint32_t width = 0, height = 0;
    v1::Intrinsics intrinsics;
  };

  absl::StatusOr<Sensor> ReadSensor(const tinyxml2::XMLElement* sensor, const std::string& where) const {
    if (const char* type = sensor->Attribute("type"); type != nullptr && std::strcmp(type, "frame") != 0) {
      return Invalid(where, absl::StrCat("type \"", type, "\": only frame (pinhole) sensors are supported"));
    }
    const tinyxml2::XMLElement* calibration = nullptr;
    for (const auto* c = sensor->FirstChildElement("calibration"); c; c = c->NextSiblingElement("calibration")) {
      const char* cls = c->Attribute("class");
      if (cls != nullptr && std::strcmp(cls, "adjusted") == 0) {
        calibration = c;
        break;
      }
      if (calibration == nullptr) calibration = c;
    }
    if (calibration == nullptr) return Invalid(where, "has no <calibration> (the sensor was not calibrated)");
    const std::string cwhere = where + "/calibration";
    Sensor out;
    const tinyxml2::XMLElement* resolution = calibration->FirstChildElement("resolution");
    if (resolution == nullptr) resolution = sensor->FirstChildElement("resolution");
    if (resolution == nullptr) return Invalid(where, "has no <resolution width=.. height=..>");
    unsigned w = 0, h = 0;
    if (resolution->QueryUnsignedAttribute("width", &w) != tinyxml2::XML_SUCCESS || w == 0 ||
        resolution->QueryUnsignedAttribute("height", &h) != tinyxml2::XML_SUCCESS || h == 0) {
      return Invalid(where + "/resolution", "width and height must be positive whole numbers");
    }
    out.width = w;
    out.height = h;
    const tinyxml2::XMLElement* f_element = calibration->FirstChildElement("f");
    if (f_element == nullptr) return Invalid(cwhere, "has no <f> (focal length in pixels)");
    auto f = Numbers(f_element, cwhere + "/f", 1);
    if (!f.ok()) return f.status();
    std::map<std::string, double> p;
    for (const char* name : {"cx", "cy", "b1", "b2", "k1", "k2", "k3", "k4", "p1", "p2", "p3", "p4"}) {
      auto v = Optional(calibration, name, cwhere);
      if (!v.ok()) return v.status();
      p[name] = *v;
    }
    for (const auto& [name, why] :
         std::map<std::string, const char*>{{"b2", "skew; mvbrdf's cameras have none"},
                                            {"k4", "an r^8 radial term; mvbrdf takes OpenCV's model, which has none"},
                                            {"p3", "a higher tangential term; OpenCV's model has none"},
                                            {"p4", "a higher tangential term; OpenCV's model has none"}}) {
      if (p[name] != 0.0) return Invalid(cwhere + "/" + name, absl::StrCat("must be 0 (", why, "), got ", p[name]));
    }
    const double fx = (*f)[0] + p["b1"], fy = (*f)[0];
    if (!(fx > 0.0) || !(fy > 0.0)) return Invalid(cwhere + "/f", "f and f + b1 must be positive");
    out.intrinsics.set_fx(fx);
    out.intrinsics.set_fy(fy);
    // Metashape measures from the image's corner, with cx, cy offsets from
    // its centre; mvbrdf's (0,0) is the top-left pixel's centre.
    out.intrinsics.set_cx(0.5 * w + p["cx"] - 0.5);
    out.intrinsics.set_cy(0.5 * h + p["cy"] - 0.5);
    // OpenCV's p1 is Metashape's p2 and the other way round.
    if (p["k1"] != 0 || p["k2"] != 0 || p["p1"] != 0 || p["p2"] != 0 || p["k3"] != 0) {
      for (double v : {p["k1"], p["k2"], p["p2"], p["p1"]}) out.intrinsics.add_distortion(v);
      if (p["k3"] != 0) out.intrinsics.add_distortion(p["k3"]);
    }
    return out;
  }

  absl::StatusOr<std::vector<v1::Camera>> Read(std::vector<std::string>* warnings) {
    std::error_code ec;
    if (!std::filesystem::exists(file_, ec)) {
      return absl::NotFoundError(absl::StrCat(file_.string(), ": no such file"));
    }
    tinyxml2::XMLDocument doc;
    if (doc.LoadFile(file_.string().c_str()) != tinyxml2::XML_SUCCESS) {
      return absl::InvalidArgumentError(absl::StrCat(file_.string(), ": not readable as XML: ", doc.ErrorStr()));
    }
    const tinyxml2::XMLElement* root = doc.RootElement();
    if (root == nullptr || std::strcmp(root->Name(), "document") != 0) {
      return Invalid(absl::StrCat("<", root ? root->Name() : "", ">"),
                     "unknown root element; a Metashape camera export has <document>");
    }
    const tinyxml2::XMLElement* chunk = root->FirstChildElement("chunk");
    if (chunk == nullptr) return Invalid("document", "has no <chunk>");
    if (chunk->NextSiblingElement("chunk") != nullptr) {
      return Invalid("document", "has more than one <chunk>; export the cameras of one chunk");
    }

    Mat4 world_from_chunk = kIdentity;
    if (const auto* t = chunk->FirstChildElement("transform")) {
      auto m = Similarity(t, "chunk/transform");
      if (!m.ok()) return m.status();
      world_from_chunk = *m;
    }
    std::map<std::string, Mat4> chunk_from_component;
    if (const auto* components = chunk->FirstChildElement("components")) {
      for (const auto* c = components->FirstChildElement("component"); c; c = c->NextSiblingElement("component")) {
        const char* id = c->Attribute("id");
        const std::string where = absl::StrCat("chunk/components/component[id=", id ? id : "", "]");
        Mat4 m = kIdentity;
        if (const auto* t = c->FirstChildElement("transform")) {
          auto s = Similarity(t, where + "/transform");
          if (!s.ok()) return s.status();
          m = *s;
        }
        chunk_from_component[id ? id : ""] = m;
      }
    }
    std::map<std::string, Sensor> sensors;
    if (const auto* list = chunk->FirstChildElement("sensors")) {
      for (const auto* s = list->FirstChildElement("sensor"); s; s = s->NextSiblingElement("sensor")) {
        const char* id = s->Attribute("id");
        const std::string where = absl::StrCat("chunk/sensors/sensor[id=", id ? id : "", "]");
        auto sensor = ReadSensor(s, where);
        if (!sensor.ok()) return sensor.status();
        sensors[id ? id : ""] = *std::move(sensor);
      }
    }
    const tinyxml2::XMLElement* camera_list = chunk->FirstChildElement("cameras");
    if (camera_list == nullptr) return Invalid("chunk", "has no <cameras>");
    std::vector<const tinyxml2::XMLElement*> elements;
    for (const auto* e = camera_list->FirstChildElement(); e; e = e->NextSiblingElement()) {
      if (std::strcmp(e->Name(), "camera") == 0) {
        elements.push_back(e);
      } else if (std::strcmp(e->Name(), "group") == 0) {
        for (const auto* c = e->FirstChildElement("camera"); c; c = c->NextSiblingElement("camera"))
          elements.push_back(c);
      }
    }
    std::vector<v1::Camera> cameras;
    std::set<std::string> names;
    for (const tinyxml2::XMLElement* e : elements) {
      const char* label = e->Attribute("label");
      const char* id = e->Attribute("id");
      const std::string where = absl::StrCat("chunk/cameras/camera[label=", label ? label : "", "]");
      if (label == nullptr || *label == '\0') {
        return Invalid(absl::StrCat("chunk/cameras/camera[id=", id ? id : "", "]"), "has no label (the camera's name)");
      }
      const char* sensor_id = e->Attribute("sensor_id");
      auto sensor = sensors.find(sensor_id ? sensor_id : "");
      if (sensor == sensors.end()) {
        return Invalid(where,
                       absl::StrCat("sensor_id \"", sensor_id ? sensor_id : "", "\" names no sensor in chunk/sensors"));
      }
      const tinyxml2::XMLElement* transform = e->FirstChildElement("transform");
      if (transform == nullptr) {
        if (warnings) warnings->push_back(absl::StrCat(where, ": no transform (not aligned); left out"));
        continue;
      }
      auto t = Numbers(transform, where + "/transform", 16);
      if (!t.ok()) return t.status();
      Mat4 chunk_from_camera;
      std::copy(t->begin(), t->end(), chunk_from_camera.begin());
      if (chunk_from_camera[12] != 0 || chunk_from_camera[13] != 0 || chunk_from_camera[14] != 0 ||
          chunk_from_camera[15] != 1) {
        return Invalid(where + "/transform", "the last row must be 0 0 0 1");
      }
      if (const char* component = e->Attribute("component_id")) {
        auto c = chunk_from_component.find(component);
        if (c == chunk_from_component.end()) {
          return Invalid(where,
                         absl::StrCat("component_id \"", component, "\" names no component in chunk/components"));
        }
        chunk_from_camera = Multiply(c->second, chunk_from_camera);
      }
      const Mat4 m = Multiply(world_from_chunk, chunk_from_camera);
      const double det = m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
                         m[2] * (m[4] * m[9] - m[5] * m[8]);
      if (!(det > 0.0)) {
        return Invalid(where + "/transform",
                       absl::StrCat("world-from-camera has determinant ", det, " (must be a rotation, det > 0)"));
      }
      const double scale = std::cbrt(det);
      v1::Camera camera;
      camera.set_name(label);
      camera.set_model(v1::PINHOLE);
      camera.set_width(sensor->second.width);
      camera.set_height(sensor->second.height);
      *camera.mutable_intrinsics() = sensor->second.intrinsics;
      // cam_from_world = (world_from_camera)^-1: R = A^T / s, t = -R c.
      v1::CamFromWorld* pose = camera.mutable_cam_from_world();
      std::array<double, 9> r{};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) r[i * 3 + j] = m[j * 4 + i] / scale;
      for (double v : r) pose->add_rotation(v);
      for (int i = 0; i < 3; ++i) {
        pose->add_translation(-(r[i * 3] * m[3] + r[i * 3 + 1] * m[7] + r[i * 3 + 2] * m[11]));
      }
      if (!names.insert(label).second) {
        return Invalid(where, "label given to two cameras (camera names must be unique)");
      }
      cameras.push_back(std::move(camera));
    }
    if (cameras.empty()) return Invalid("chunk/cameras", "holds no aligned camera (none has a transform)");
    return cameras;
  }

 private:
  std::filesystem::path file_;
};

}  // namespace

absl::StatusOr<std::vector<v1::Camera>> ReadMetashapeCameras(const std::filesystem::path& xml,
                                                             std::vector<std::string>* warnings) {
  return Reader(xml).Read(warnings);
}

}  // namespace mvbrdf::importers
