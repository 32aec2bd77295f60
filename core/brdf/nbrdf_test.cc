// NeuralBrdf against its reference: the probe table of
// ../shared/data/merl_nbrdf/nbrdf_reference.py, the tangent-frame invariance
// the isotropic networks promise, and the loader's errors.
#include "core/brdf/nbrdf.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <glm/glm.hpp>
#include <iostream>
#include <random>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/draw_order.h"
#include "core/base/files.h"

namespace mvbrdf::brdf {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Against numpy in float64 on the same decimal weights: rounding, expm1
// against exp - 1, and the 11 digits the table keeps. Measured worst:
// 4.7e-11 relative.
constexpr double kReferenceTolerance = 1e-4;  // relative
// Rotating wi and wo about the normal, or n, l and v together: double
// rounding only. Measured worst: 1.9e-13 relative.
constexpr double kFrameTolerance = 1e-9;  // relative

// Like the other tests on ../shared/data (mesh_loader_test.cc,
// synthesizer_test.cc), skipped where the checkout has none.
const std::filesystem::path kNbrdfJson = std::filesystem::path(MVBRDF_SHARED_DATA_DIR) / "merl_nbrdf/merl_nbrdf.json";

#define MVBRDF_SKIP_WITHOUT_NBRDF_DATA()                                                             \
  if (!std::filesystem::exists(kNbrdfJson)) {                                                        \
    GTEST_SKIP() << "shared test data not found: " << kNbrdfJson << " (../shared/data/merl_nbrdf/)"; \
  }

// nbrdf_reference.py's direction(): degrees, sin/cos exactly as numpy and
// math compute them (math.radians is x * (pi / 180)), so that the mirror
// probes (phi 0 and 180) carry the same h.y = sin(pi) rounding residue and
// hence the same phi_h = atan2(6e-17, 0) = pi / 2 (nbrdf.h: at h = n the
// networks are not isotropic, and the table records that choice).
glm::dvec3 Direction(double theta_deg, double phi_deg) {
  const double t = theta_deg * (kPi / 180.0), p = phi_deg * (kPi / 180.0);
  return glm::dvec3(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
}

struct Probe {
  const char* material;
  double theta_i, phi_i, theta_o, phi_o;  // degrees
  double rho[3];                          // 1/sr, RGB
};

// `nbrdf_reference.py`'s PROBES x its 6 default materials, printed with 11
// digits: rho(mats[n], direction(ti, pi), direction(to, po)) with '%.10e'.
constexpr Probe kProbes[] = {
    {"blue-acrylic", 0, 0, 0, 0, {1.6424249933e+01, 1.3558464116e+01, 1.3611604614e+01}},
    {"blue-acrylic", 30, 0, 30, 180, {2.0803021054e+01, 1.8882579087e+01, 1.9528889819e+01}},
    {"blue-acrylic", 60, 0, 60, 180, {7.9777065375e+01, 8.2301850356e+01, 8.8963116405e+01}},
    {"blue-acrylic", 45, 0, 0, 0, {3.8791648827e-03, 1.1554078913e-02, 3.4192626773e-02}},
    {"blue-acrylic", 30, 0, 30, 90, {3.8710052184e-03, 1.1760486198e-02, 3.4567367075e-02}},
    {"blue-acrylic", 75, 0, 75, 180, {8.3351776873e+02, 6.6978178379e+02, 6.2798819690e+02}},
    {"gold-metallic-paint", 0, 0, 0, 0, {4.5562524943e-01, 3.4357506257e-01, 1.2584520973e-01}},
    {"gold-metallic-paint", 30, 0, 30, 180, {5.4972666129e-01, 3.9073234376e-01, 1.1526925617e-01}},
    {"gold-metallic-paint", 60, 0, 60, 180, {9.0585256891e-01, 6.0818636687e-01, 2.3593032236e-01}},
    {"gold-metallic-paint", 45, 0, 0, 0, {3.0086114583e-02, 2.1249865352e-02, 7.8739202330e-03}},
    {"gold-metallic-paint", 30, 0, 30, 90, {3.1495547117e-02, 2.1256565250e-02, 7.6023105202e-03}},
    {"gold-metallic-paint", 75, 0, 75, 180, {1.7716302536e+00, 1.5151152379e+00, 1.2978365209e+00}},
    {"white-fabric", 0, 0, 0, 0, {1.1710654667e-01, 8.3324663025e-02, 5.1029854427e-02}},
    {"white-fabric", 30, 0, 30, 180, {1.1228818100e-01, 7.7893912492e-02, 4.9101322610e-02}},
    {"white-fabric", 60, 0, 60, 180, {1.4745487544e-01, 1.1020204170e-01, 8.4787896329e-02}},
    {"white-fabric", 45, 0, 0, 0, {1.0309116736e-01, 7.1762230355e-02, 4.6284895178e-02}},
    {"white-fabric", 30, 0, 30, 90, {1.0605830125e-01, 7.2704345780e-02, 4.6634067679e-02}},
    {"white-fabric", 75, 0, 75, 180, {2.3373540111e-01, 1.9133875073e-01, 1.6222810796e-01}},
    {"chrome", 0, 0, 0, 0, {4.6071491351e+02, 4.8404292144e+02, 4.8043626470e+02}},
    {"chrome", 30, 0, 30, 180, {5.6911805821e+02, 6.0024990865e+02, 5.9317445545e+02}},
    {"chrome", 60, 0, 60, 180, {8.7521177630e+02, 9.8416337604e+02, 9.7759355965e+02}},
    {"chrome", 45, 0, 0, 0, {1.0126344686e-03, 8.9586193663e-04, 9.8997104185e-04}},
    {"chrome", 30, 0, 30, 90, {1.0552195431e-03, 9.2737846148e-04, 1.0144598490e-03}},
    {"chrome", 75, 0, 75, 180, {1.3911350016e+03, 1.9003751763e+03, 2.1786480439e+03}},
    {"pink-felt", 0, 0, 0, 0, {1.0859976938e-01, 7.8778539897e-02, 6.1136707495e-02}},
    {"pink-felt", 30, 0, 30, 180, {1.1292523341e-01, 8.1820965499e-02, 6.7972931207e-02}},
    {"pink-felt", 60, 0, 60, 180, {1.6450992866e-01, 1.3507289636e-01, 1.2471537124e-01}},
    {"pink-felt", 45, 0, 0, 0, {9.9984583854e-02, 7.1455458213e-02, 5.9897949534e-02}},
    {"pink-felt", 30, 0, 30, 90, {1.0393106168e-01, 7.2969265694e-02, 6.2198620173e-02}},
    {"pink-felt", 75, 0, 75, 180, {3.9767664796e-01, 3.7893991103e-01, 3.7058983510e-01}},
    {"red-plastic", 0, 0, 0, 0, {1.0208489728e-01, 3.1558163876e-02, 2.1892582552e-02}},
    {"red-plastic", 30, 0, 30, 180, {1.1696027586e-01, 4.3250220280e-02, 3.3051637265e-02}},
    {"red-plastic", 60, 0, 60, 180, {2.9568343941e-01, 2.2415047529e-01, 2.0401505015e-01}},
    {"red-plastic", 45, 0, 0, 0, {8.4633070522e-02, 1.6553055264e-02, 6.7256360176e-03}},
    {"red-plastic", 30, 0, 30, 90, {8.5559566558e-02, 1.6583274423e-02, 6.5919376416e-03}},
    {"red-plastic", 75, 0, 75, 180, {1.1683984860e+00, 1.0445862527e+00, 1.0130501443e+00}},
};

glm::dvec3 RandomUpperDirection(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  while (true) {
    glm::dvec3 d = base::DrawVec3<glm::dvec3>([&] { return normal(rng); });
    d.z = std::abs(d.z);
    if (glm::length(d) > 1e-3 && d.z > 0.05 * glm::length(d)) return glm::normalize(d);
  }
}

double RelativeError(const glm::dvec3& a, const glm::dvec3& b) {
  double worst = 0.0;
  for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(a[c] - b[c]) / std::max(std::abs(b[c]), 1e-300));
  return worst;
}

// A network with every weight 0 but b3 = log(1 + rho): rho everywhere.
NeuralBrdf Constant(const glm::dvec3& rho) {
  std::array<double, NeuralBrdf::kNumWeights> w{};
  for (int c = 0; c < 3; ++c) w[NeuralBrdf::kB3 + c] = std::log1p(rho[c]);
  return NeuralBrdf(w);
}

TEST(NeuralBrdfTest, MatchesTheReferenceProbes) {
  MVBRDF_SKIP_WITHOUT_NBRDF_DATA();
  const auto materials = LoadNeuralBrdfs(kNbrdfJson);
  ASSERT_TRUE(materials.ok()) << materials.status();
  double worst = 0.0;
  for (const Probe& p : kProbes) {
    const auto found = materials->find(p.material);
    ASSERT_NE(found, materials->end()) << p.material;
    const glm::dvec3 rho = found->second.Evaluate(Direction(p.theta_i, p.phi_i), Direction(p.theta_o, p.phi_o));
    const glm::dvec3 expected(p.rho[0], p.rho[1], p.rho[2]);
    const double error = RelativeError(rho, expected);
    worst = std::max(worst, error);
    EXPECT_LT(error, kReferenceTolerance)
        << p.material << " wi (" << p.theta_i << ", " << p.phi_i << ") wo (" << p.theta_o << ", " << p.phi_o
        << "): rho " << rho.x << " " << rho.y << " " << rho.z;
  }
  std::cout << "worst relative error against nbrdf_reference.py: " << worst << "\n";
}

TEST(NeuralBrdfTest, DoesNotDependOnTheTangentFrame) {
  MVBRDF_SKIP_WITHOUT_NBRDF_DATA();
  const auto materials = LoadNeuralBrdfs(kNbrdfJson);
  ASSERT_TRUE(materials.ok()) << materials.status();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> angle(0.0, 2.0 * kPi);
  double worst = 0.0;
  for (const char* name : {"chrome", "blue-acrylic", "white-fabric", "gold-metallic-paint"}) {
    const NeuralBrdf& brdf = materials->at(name);
    for (int i = 0; i < 200; ++i) {
      const glm::dvec3 wi = RandomUpperDirection(rng), wo = RandomUpperDirection(rng);
      const glm::dvec3 rho = brdf.Evaluate(wi, wo);
      // The local frame's x axis turned by alpha about the normal.
      const double alpha = angle(rng), c = std::cos(alpha), s = std::sin(alpha);
      const auto rotate_z = [&](const glm::dvec3& w) { return glm::dvec3(c * w.x - s * w.y, s * w.x + c * w.y, w.z); };
      const double local_error = RelativeError(brdf.Evaluate(rotate_z(wi), rotate_z(wo)), rho);
      // Through EvaluateWorld: n, l and v rotated together by a random
      // rotation, so EvaluateWorld's tangent frame around the rotated n is
      // not the rotated frame of (0, 0, 1).
      const glm::dvec3 axis = glm::normalize(base::DrawVec3<glm::dvec3>([&] { return angle(rng); }) - kPi);
      const double beta = angle(rng);
      const auto rotate = [&](const glm::dvec3& w) {  // Rodrigues
        return w * std::cos(beta) + glm::cross(axis, w) * std::sin(beta) +
               axis * glm::dot(axis, w) * (1.0 - std::cos(beta));
      };
      const glm::dvec3 n = rotate(glm::dvec3(0, 0, 1));
      const double world_error = RelativeError(brdf.EvaluateWorld(n, rotate(wi), rotate(wo)), rho);
      worst = std::max({worst, local_error, world_error});
      EXPECT_LT(local_error, kFrameTolerance) << name << " case " << i << " alpha " << alpha;
      EXPECT_LT(world_error, kFrameTolerance) << name << " case " << i;
    }
  }
  std::cout << "worst relative change between tangent frames: " << worst << "\n";
}

TEST(NeuralBrdfTest, IsZeroBelowTheHorizon) {
  const NeuralBrdf brdf = Constant(glm::dvec3(0.5, 1.0, 2.0));
  const glm::dvec3 up(0, 0, 1), below = glm::normalize(glm::dvec3(1, 0, -0.1));
  EXPECT_LT(RelativeError(brdf.Evaluate(up, up), glm::dvec3(0.5, 1.0, 2.0)), 1e-15);
  EXPECT_EQ(brdf.Evaluate(below, up), glm::dvec3(0.0));
  EXPECT_EQ(brdf.Evaluate(up, below), glm::dvec3(0.0));
  EXPECT_EQ(brdf.EvaluateWorld(glm::dvec3(0, 0, -1), up, up), glm::dvec3(0.0));
  // A normal along -z (the tangent frame's special case) sees the same.
  EXPECT_LT(RelativeError(brdf.EvaluateWorld(glm::dvec3(0, 0, -1), -up, -up), glm::dvec3(0.5, 1.0, 2.0)), 1e-15);
}

TEST(NeuralBrdfTest, LoadsAllHundredMaterials) {
  MVBRDF_SKIP_WITHOUT_NBRDF_DATA();
  const auto start = std::chrono::steady_clock::now();
  const auto materials = LoadNeuralBrdfs(kNbrdfJson);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(materials.ok()) << materials.status();
  std::cout << "LoadNeuralBrdfs: " << materials->size() << " materials in " << seconds * 1e3 << " ms\n";
  EXPECT_EQ(materials->size(), 100u);
  // Every material reflects something finite somewhere.
  const glm::dvec3 wi = Direction(30, 0), wo = Direction(40, 160);
  for (const auto& [name, brdf] : *materials) {
    const glm::dvec3 rho = brdf.Evaluate(wi, wo);
    EXPECT_TRUE(std::isfinite(rho.x) && std::isfinite(rho.y) && std::isfinite(rho.z)) << name;
    EXPECT_GT(rho.x + rho.y + rho.z, 0.0) << name;
  }
  const auto chrome = LoadNeuralBrdf(kNbrdfJson, "chrome");
  ASSERT_TRUE(chrome.ok()) << chrome.status();
  EXPECT_EQ(chrome->weights(), materials->at("chrome").weights());
  EXPECT_EQ(chrome->GlslWeights().size(), static_cast<size_t>(NeuralBrdf::kNumWeights));
}

TEST(NeuralBrdfTest, UnknownMaterialNamesSomeKnownOnes) {
  MVBRDF_SKIP_WITHOUT_NBRDF_DATA();
  const auto brdf = LoadNeuralBrdf(kNbrdfJson, "chrom");
  ASSERT_FALSE(brdf.ok());
  EXPECT_EQ(brdf.status().code(), absl::StatusCode::kNotFound);
  const std::string message(brdf.status().message());
  EXPECT_NE(message.find("merl_nbrdf.json"), std::string::npos) << message;
  EXPECT_NE(message.find("\"chrom\""), std::string::npos) << message;
  EXPECT_NE(message.find("(100 materials: chrome, chrome-steel, alum-bronze, "), std::string::npos) << message;
}

// A one-material file with the layers as `layers` (JSON text), written to a
// temporary directory.
class NeuralBrdfLoadErrorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           absl::StrCat("nbrdf_test_", ::testing::UnitTest::GetInstance()->current_test_info()->name(), "_",
                        std::random_device()());
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  // Layer JSON {"kernel": rows x cols, "bias": cols} of zeros.
  static std::string Layer(int rows, int cols, int bias) {
    std::string row = "[";
    for (int j = 0; j < cols; ++j) absl::StrAppend(&row, j > 0 ? "," : "", "0");
    row += "]";
    std::string kernel = "[";
    for (int i = 0; i < rows; ++i) absl::StrAppend(&kernel, i > 0 ? "," : "", row);
    kernel += "]";
    std::string b = "[";
    for (int j = 0; j < bias; ++j) absl::StrAppend(&b, j > 0 ? "," : "", "0");
    b += "]";
    return absl::StrCat("{\"kernel\":", kernel, ",\"bias\":", b, "}");
  }

  // The status of loading {"materials": {"m": [layers]}}.
  absl::Status Load(const std::string& layers) {
    const std::filesystem::path file = dir_ / "nbrdf.json";
    EXPECT_TRUE(WriteStringToFile(file, absl::StrCat("{\"materials\":{\"m\":[", layers, "]}}")).ok());
    return LoadNeuralBrdfs(file).status();
  }

  std::filesystem::path dir_;
};

TEST_F(NeuralBrdfLoadErrorTest, AWellFormedFileLoads) {
  EXPECT_TRUE(Load(absl::StrCat(Layer(6, 21, 21), ",", Layer(21, 21, 21), ",", Layer(21, 3, 3))).ok());
}

TEST_F(NeuralBrdfLoadErrorTest, ErrorsNameTheFileTheFieldAndWhatWasExpected) {
  const std::string l1 = Layer(6, 21, 21), l2 = Layer(21, 21, 21), l3 = Layer(21, 3, 3);
  const struct {
    std::string layers, expected;
  } cases[] = {
      {absl::StrCat(l1, ",", l2), "materials.m: expected a list of 3 layers (a 6-21-21-3 network), got 2"},
      {absl::StrCat(Layer(5, 21, 21), ",", l2, ",", l3),
       "materials.m[0].kernel: expected 6 rows (a 6x21 kernel, [inputs][outputs]), got 5"},
      {absl::StrCat(l1, ",", Layer(21, 20, 21), ",", l3),
       "materials.m[1].kernel[0]: expected 21 numbers (a 21x21 kernel, [inputs][outputs]), got 20"},
      {absl::StrCat(l1, ",", l2, ",", Layer(21, 3, 4)), "materials.m[2].bias: expected 3 numbers, got 4"},
      {absl::StrCat(l1, ",", l2, ",", "{\"kernel\":[]}"), "materials.m[2].bias: missing"},
      {absl::StrCat(l1, ",", l2, ",", "{\"kernel\":[],\"bias\":[],\"activation\":\"relu\"}"),
       "materials.m[2].activation: unknown key"},
      {absl::StrCat("{\"kernel\":[[\"1\"]],\"bias\":[]},", l2, ",", l3), "materials.m[0].kernel: expected 6 rows"},
      {absl::StrCat(l1, ",", l2, ",", "[]"), "materials.m[2]: expected an object {\"kernel\", \"bias\"}"},
  };
  for (const auto& c : cases) {
    const absl::Status status = Load(c.layers);
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << status;
    EXPECT_NE(status.message().find("nbrdf.json: "), absl::string_view::npos) << status;
    EXPECT_NE(status.message().find(c.expected), absl::string_view::npos) << status << "\nexpected: " << c.expected;
  }
}

TEST_F(NeuralBrdfLoadErrorTest, ANonNumberIsNamed) {
  std::string l1 = Layer(6, 21, 21);
  l1.replace(l1.find("[[0,") + 2, 1, "\"x\"");
  const absl::Status status = Load(absl::StrCat(l1, ",", Layer(21, 21, 21), ",", Layer(21, 3, 3)));
  EXPECT_NE(status.message().find("materials.m[0].kernel[0][0]: expected a finite number"), absl::string_view::npos)
      << status;
}

TEST_F(NeuralBrdfLoadErrorTest, NoMaterialsObjectIsAnError) {
  const std::filesystem::path file = dir_ / "nbrdf.json";
  ASSERT_TRUE(WriteStringToFile(file, "{\"format\":\"x\"}").ok());
  const absl::Status status = LoadNeuralBrdfs(file).status();
  EXPECT_NE(status.message().find("nbrdf.json: materials: expected an object"), absl::string_view::npos) << status;
  EXPECT_EQ(LoadNeuralBrdfs(dir_ / "missing.json").status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace mvbrdf::brdf
