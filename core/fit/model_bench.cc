// The model table (issue #15 item 5): every measured material of
// ../shared/data/merl_nbrdf (the MERL database as neural BRDFs) observed on a
// sphere under a dome of directional lights from a few views, each model of
// core/brdf fitted (fit::FitLobe) to some lights and views, and its relighting
// error measured on the others. No analytic model produced these
// observations. Writes one JSON document (scripts/bench-models makes the
// table); not a test: the numbers vary with the sampling.
//
// Observations: for each of `views` directions (elevation 20..60 degrees,
// around the sphere) and each of 40 dome lights (elevation 10..85 degrees, a
// golden-angle spiral), `points` surface normals on the sphere visible from
// the view and lit by the light: r = rho(l, v) n.l in MERL's units (light
// intensity 1), one light per observation (one-light-at-a-time). Training:
// lights 0..29 of views 0..views-2; held out: lights 30..39 from every view,
// and every light from the last view. Error: RMSE of the held-out radiance,
// also relative to the held-out rms radiance; a material's winner is the
// model with the lowest held-out RMSE; "auto" picks per material the model
// with the lowest error on a validation part of the training data (every
// fifth training light and the last training view, held out from a fit to
// the rest, as the test holds out lights and a view), as a reconstruction
// without the truth would.
//
// Usage: model_bench --data merl_nbrdf.json --out models.json [--points N]
//        [--views N] [--materials a,b,...]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "core/base/draw_order.h"
#include "core/brdf/model.h"
#include "core/brdf/nbrdf.h"
#include "core/fit/lobe_fit.h"

namespace {

using mvbrdf::brdf::Model;
constexpr double kPi = 3.14159265358979323846;
constexpr int kLights = 40;
constexpr int kTrainLights = 30;

glm::dvec3 Direction(double elevation, double azimuth) {
  return {std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth), std::sin(elevation)};
}

struct Observation {
  glm::dvec3 n, l, v;
  int light, view;
};

// The observations of one material: the same geometry for every material.
std::vector<Observation> Geometry(int views, int points, uint32_t seed) {
  std::vector<Observation> out;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (int w = 0; w < views; ++w) {
    const glm::dvec3 v = Direction((20.0 + 40.0 * w / std::max(1, views - 1)) * kPi / 180.0, 2.1 * w);
    for (int k = 0; k < kLights; ++k) {
      const glm::dvec3 l = Direction((10.0 + 75.0 * (k + 0.5) / kLights) * kPi / 180.0, golden * k);
      int kept = 0;
      for (int attempt = 0; kept < points && attempt < 50 * points; ++attempt) {
        // A normal on the sphere, half of them near the half vector (the
        // highlight), half uniform over the upper hemisphere.
        glm::dvec3 n;
        if (attempt % 2 == 0) {
          const glm::dvec3 h = glm::normalize(l + v);
          n = glm::normalize(h + 0.35 * mvbrdf::base::DrawVec3<glm::dvec3>([&] { return unit(rng) - 0.5; }));
        } else {
          const double azimuth = 2.0 * kPi * unit(rng);  // drawn first (core/base/draw_order.h)
          n = Direction(std::asin(unit(rng)), azimuth);
        }
        if (glm::dot(n, l) < 0.05 || glm::dot(n, v) < 0.05) continue;
        out.push_back({n, l, v, k, w});
        ++kept;
      }
    }
  }
  return out;
}

bool Training(const Observation& o, int views) { return o.light < kTrainLights && o.view < views - 1; }

// A SampleSet of the chosen observations (one light each, intensity 1).
mvbrdf::samples::SampleSet Samples(const std::vector<Observation>& obs, const std::vector<glm::dvec3>& radiance,
                                   const std::vector<size_t>& which) {
  mvbrdf::samples::SampleSet set;
  set.half_vector = true;
  for (int k = 0; k < kLights; ++k) {
    set.light_names.push_back(absl::StrCat("D", k));
    set.light_intensity.emplace_back(1.0f);
  }
  for (size_t i : which) {
    const Observation& o = obs[i];
    const mvbrdf::brdf::Geometry g = mvbrdf::brdf::GeometryOf(o.n, o.l, o.v);
    const uint16_t light = static_cast<uint16_t>(o.light);
    const float gl = static_cast<float>(g.n_dot_l), h = static_cast<float>(std::max(0.0, g.r_dot_v));
    const float nh = static_cast<float>(g.n_dot_h), vh = static_cast<float>(g.v_dot_h);
    set.AddTerms(static_cast<uint32_t>(i), o.view, 0, glm::vec3(radiance[i]), 1, &light, &gl, &h, nullptr,
                 {static_cast<float>(g.n_dot_v), &nh, &vh});
  }
  return set;
}

// RMSE over the set's samples and channels of the fitted model.
double Rmse(Model model, const mvbrdf::samples::SampleSet& set, const mvbrdf::fit::LobeFitResult& fit) {
  double sse = 0.0;
  const mvbrdf::samples::LightMask all = mvbrdf::samples::LightMask::FirstN(kLights);
  for (size_t i = 0; i < set.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double e = set.reflectance[i][c] - mvbrdf::fit::EvaluateLobe(model, set, i, all, fit.params[c], c);
      sse += e * e;
    }
  }
  return set.size() > 0 ? std::sqrt(sse / (3.0 * set.size())) : 0.0;
}

double Rms(const mvbrdf::samples::SampleSet& set) {
  double s = 0.0;
  for (const glm::vec3& r : set.reflectance) s += glm::dot(glm::dvec3(r), glm::dvec3(r));
  return set.size() > 0 ? std::sqrt(s / (3.0 * set.size())) : 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string data, out, only;
  int points = 12, views = 4;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--data")) data = argv[i + 1];
    else if (!std::strcmp(argv[i], "--out")) out = argv[i + 1];
    else if (!std::strcmp(argv[i], "--points")) points = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--views")) views = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--materials")) only = argv[i + 1];
    else {
      std::fprintf(stderr, "model_bench: unknown option %s\n", argv[i]);
      return 2;
    }
  }
  if (data.empty() || out.empty() || points < 1 || views < 2) {
    std::fprintf(stderr, "usage: model_bench --data merl_nbrdf.json --out FILE [--points N] [--views N >= 2] "
                         "[--materials a,b]\n");
    return 2;
  }
  auto materials = mvbrdf::brdf::LoadNeuralBrdfs(data);
  if (!materials.ok()) {
    std::fprintf(stderr, "model_bench: %s\n", std::string(materials.status().message()).c_str());
    return 4;
  }
  std::vector<std::string> names;
  if (only.empty()) {
    for (const auto& [name, brdf] : *materials) names.push_back(name);
  } else {
    names = absl::StrSplit(only, ',');
  }
  const std::vector<Observation> obs = Geometry(views, points, 7);
  std::vector<size_t> train, validate, fit_part, held_out;
  for (size_t i = 0; i < obs.size(); ++i) {
    if (Training(obs[i], views)) {
      train.push_back(i);
      // Validation held out like the test: other lights and another view.
      (obs[i].light % 5 == 4 || obs[i].view == views - 2 ? validate : fit_part).push_back(i);
    } else {
      held_out.push_back(i);
    }
  }
  std::ofstream json(out);
  json << "{\n  \"observations\": {\"training\": " << train.size() << ", \"heldOut\": " << held_out.size()
       << ", \"views\": " << views << ", \"lights\": " << kLights << "},\n  \"materials\": [\n";
  bool first = true;
  for (const std::string& name : names) {
    auto it = materials->find(name);
    if (it == materials->end()) {
      std::fprintf(stderr, "model_bench: unknown material %s\n", name.c_str());
      return 3;
    }
    std::vector<glm::dvec3> radiance(obs.size());
    for (size_t i = 0; i < obs.size(); ++i) {
      radiance[i] = it->second.EvaluateWorld(obs[i].n, obs[i].l, obs[i].v) * glm::dot(obs[i].n, obs[i].l);
    }
    const auto train_set = Samples(obs, radiance, train), test_set = Samples(obs, radiance, held_out);
    const auto fit_set = Samples(obs, radiance, fit_part), validate_set = Samples(obs, radiance, validate);
    const double rms = Rms(test_set);
    json << (first ? "" : ",\n") << "    {\"name\": \"" << name << "\", \"heldOutRms\": " << rms << ", \"models\": [";
    first = false;
    double best = 1e300, best_validation = 1e300, auto_error = 0.0;
    std::string winner, auto_choice;
    bool first_model = true;
    for (Model model : mvbrdf::brdf::kModels) {
      const auto t0 = std::chrono::steady_clock::now();
      auto fit = mvbrdf::fit::FitLobe(model, train_set, {}, mvbrdf::samples::LightMask::FirstN(kLights), {});
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      auto part = mvbrdf::fit::FitLobe(model, fit_set, {}, mvbrdf::samples::LightMask::FirstN(kLights), {});
      if (!fit.ok() || !part.ok()) {
        std::fprintf(stderr, "model_bench: %s %s: %s\n", name.c_str(), mvbrdf::brdf::ModelName(model),
                     std::string((fit.ok() ? part.status() : fit.status()).message()).c_str());
        return 1;
      }
      const double error = Rmse(model, test_set, *fit), validation = Rmse(model, validate_set, *part);
      if (error < best) best = error, winner = mvbrdf::brdf::ModelName(model);
      if (validation < best_validation) {
        best_validation = validation;
        auto_choice = mvbrdf::brdf::ModelName(model);
        auto_error = error;
      }
      json << (first_model ? "" : ", ") << "{\"model\": \"" << mvbrdf::brdf::ModelName(model)
           << "\", \"heldOutRmse\": " << error << ", \"relativeRmse\": " << (rms > 0 ? error / rms : 0.0)
           << ", \"trainingRmse\": " << Rmse(model, train_set, *fit) << ", \"validationRmse\": " << validation
           << ", \"fitSeconds\": " << seconds << ", \"kd\": [" << fit->params[0].kd << ", " << fit->params[1].kd
           << ", " << fit->params[2].kd << "], \"p0\": [" << fit->params[0].p[0] << ", " << fit->params[1].p[0]
           << ", " << fit->params[2].p[0] << "], \"p1\": [" << fit->params[0].p[1] << ", " << fit->params[1].p[1]
           << ", " << fit->params[2].p[1] << "], \"p2\": [" << fit->params[0].p[2] << ", " << fit->params[1].p[2]
           << ", " << fit->params[2].p[2] << "]}";
      first_model = false;
    }
    json << "], \"winner\": \"" << winner << "\", \"auto\": \"" << auto_choice << "\", \"autoHeldOutRmse\": "
         << auto_error << "}";
    std::fprintf(stderr, "%-28s winner %-12s auto %-12s\n", name.c_str(), winner.c_str(), auto_choice.c_str());
  }
  json << "\n  ]\n}\n";
  return json.good() ? 0 : 4;
}
