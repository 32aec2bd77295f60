#include "core/fit/model_selection.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/fit/lobe_texel_kd_fit.h"

namespace mvbrdf::fit {
namespace {

constexpr size_t kMinSamples = 20;

// Held-out RMSE of `fit` with kd per texel re-solved from the training
// Samples: r ~ kd D + S, D and S the model's diffuse illumination and
// specular radiance at the fitted lobe (EvaluateLobe at kd 0 and 1), shrunk
// towards the fit's kd by one pseudo-observation at the training Samples'
// mean D^2 (as the texel pass's kd prior): a texel whose training Samples
// barely light it (D ~ 0 at a terminator) would otherwise get any kd, and
// one such texel's held-out error swamps every model's alike (measured:
// held-out RMSE 1.30 for all three on a pixel-integrated capture's felt,
// against 0.06).
double HeldOutRmse(brdf::Model model, const samples::SampleSet& set, const samples::LightSelection& lights,
                   const LobeFitResult& fit, const std::vector<uint32_t>& training,
                   const std::vector<uint32_t>& held_out) {
  struct Sums {
    glm::dvec3 dr{0.0}, dd{0.0};
  };
  std::unordered_map<uint32_t, Sums> texel;
  const auto parts = [&](size_t i, int c, double* d, double* s) {
    LobeChannel p = fit.params[static_cast<size_t>(c)];
    p.kd = 0.0;
    *s = EvaluateLobe(model, set, i, lights, p, c);
    p.kd = 1.0;
    *d = EvaluateLobe(model, set, i, lights, p, c) - *s;
  };
  glm::dvec3 prior(0.0);  // the training Samples' mean D^2 per channel
  for (uint32_t i : training) {
    Sums& sums = texel[set.element[i]];
    for (int c = 0; c < 3; ++c) {
      double d, s;
      parts(i, c, &d, &s);
      sums.dr[c] += d * (set.reflectance[i][c] - s);
      sums.dd[c] += d * d;
      prior[c] += d * d;
    }
  }
  if (!training.empty()) prior /= static_cast<double>(training.size());
  double sse = 0.0;
  for (uint32_t i : held_out) {
    const auto it = texel.find(set.element[i]);
    for (int c = 0; c < 3; ++c) {
      double d, s;
      parts(i, c, &d, &s);
      const double fitted = fit.params[static_cast<size_t>(c)].kd;
      double kd = fitted;
      if (it != texel.end() && it->second.dd[c] + prior[c] > 0.0) {
        kd = std::max(0.0, (it->second.dr[c] + prior[c] * fitted) / (it->second.dd[c] + prior[c]));
      }
      const double e = set.reflectance[i][c] - (kd * d + s);
      sse += e * e;
    }
  }
  return std::sqrt(sse / (3.0 * static_cast<double>(held_out.size())));
}

// The Samples `indices` of `set` as a set of their own.
samples::SampleSet SubsetOf(const samples::SampleSet& set, const std::vector<uint32_t>& indices) {
  samples::SampleSet out;
  out.light_names = set.light_names;
  out.light_intensity = set.light_intensity;
  out.half_vector = set.half_vector;
  for (uint32_t i : indices) {
    const size_t b = set.TermsBegin(i), e = set.TermsEnd(i);
    out.element.push_back(set.element[i]);
    out.frame.push_back(set.frame[i]);
    out.camera.push_back(set.camera[i]);
    out.reflectance.push_back(set.reflectance[i]);
    out.light.insert(out.light.end(), set.light.begin() + b, set.light.begin() + e);
    out.g.insert(out.g.end(), set.g.begin() + b, set.g.begin() + e);
    out.h.insert(out.h.end(), set.h.begin() + b, set.h.begin() + e);
    if (!set.falloff.empty()) out.falloff.insert(out.falloff.end(), set.falloff.begin() + b, set.falloff.begin() + e);
    if (set.half_vector) {
      out.n_dot_v.push_back(set.n_dot_v[i]);
      out.n_dot_h.insert(out.n_dot_h.end(), set.n_dot_h.begin() + b, set.n_dot_h.begin() + e);
      out.v_dot_h.insert(out.v_dot_h.end(), set.v_dot_h.begin() + b, set.v_dot_h.begin() + e);
    }
    out.offset.push_back(out.light.size());
  }
  return out;
}

}  // namespace

absl::StatusOr<ModelSelection> SelectModel(const samples::SampleSet& set, const samples::LightSelection& lights,
                                           const ModelSelectionOptions& options) {
  if (!set.half_vector) {
    return absl::FailedPreconditionError("SelectModel: the Samples lack the half-vector geometry");
  }
  if (options.frame_period < 2) {
    return absl::InvalidArgumentError(absl::StrCat("frame_period: must be >= 2, got ", options.frame_period));
  }
  ModelSelection out;
  out.held_out_rmse.fill(std::numeric_limits<double>::infinity());
  int held_out_camera = options.held_out_camera;
  if (held_out_camera < 0) {
    for (uint8_t c : set.camera) held_out_camera = std::max(held_out_camera, static_cast<int>(c));
  }
  std::vector<uint32_t> training, held_out;
  for (size_t i = 0; i < set.size(); ++i) {
    const bool out_of_fit = set.camera[i] == held_out_camera ||
                            set.frame[i] % options.frame_period == options.frame_period - 1;
    (out_of_fit ? held_out : training).push_back(static_cast<uint32_t>(i));
  }
  out.training = training.size();
  out.held_out = held_out.size();
  if (training.size() < kMinSamples || held_out.size() < kMinSamples) {
    out.reason = absl::StrCat("too few Samples to judge by (", training.size(), " training, ", held_out.size(),
                              " held out; ", kMinSamples, " each needed): phong kept");
    return out;
  }
  // Each model fitted as the pipeline fits it: the cluster's lobe
  // (FitLobe), then refitted with kd free per texel (FitModelLobeWithTexelKd).
  const samples::SampleSet training_set = SubsetOf(set, training);
  LobeTexelKdOptions texel_kd;
  texel_kd.ke_min = options.fit.ke_min;
  texel_kd.ke_max = options.fit.ke_max;
  texel_kd.ks_max = options.fit.ks_max;
  texel_kd.ratio_prior_sigma = options.fit.ratio_prior_sigma;
  for (brdf::Model model : brdf::kModels) {
    const auto t0 = std::chrono::steady_clock::now();
    absl::StatusOr<LobeFitResult> fit = FitLobe(model, training_set, {}, lights, options.fit);
    if (fit.ok() && !(fit->flags() & kKsKeNotIdentifiable)) {
      absl::StatusOr<LobeTexelKdResult> refined =
          FitModelLobeWithTexelKd(model, training_set, lights, fit->params, texel_kd);
      if (refined.ok()) fit->params = refined->params;
    }
    const size_t m = static_cast<size_t>(model);
    out.seconds[m] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!fit.ok()) continue;
    out.held_out_rmse[m] = HeldOutRmse(model, set, lights, *fit, training, held_out);
  }
  const double phong = out.held_out_rmse[static_cast<size_t>(brdf::Model::kPhong)];
  brdf::Model best = brdf::Model::kPhong;
  for (brdf::Model model : brdf::kModels) {
    if (out.held_out_rmse[static_cast<size_t>(model)] < out.held_out_rmse[static_cast<size_t>(best)]) best = model;
  }
  const double best_rmse = out.held_out_rmse[static_cast<size_t>(best)];
  if (best != brdf::Model::kPhong && std::isfinite(phong) && !(best_rmse < (1.0 - options.margin) * phong)) {
    out.reason = absl::StrFormat("phong kept: %s's held-out RMSE %.4g is within %.0f %% of phong's %.4g",
                                 brdf::ModelName(best), best_rmse, 100.0 * options.margin, phong);
    best = brdf::Model::kPhong;
  } else if (best == brdf::Model::kPhong) {
    out.reason = absl::StrFormat("phong: the lowest held-out RMSE, %.4g", phong);
  } else {
    out.reason = absl::StrFormat("%s: held-out RMSE %.4g vs phong's %.4g (%+.0f %%)", brdf::ModelName(best), best_rmse,
                                 phong, 100.0 * (best_rmse / phong - 1.0));
  }
  out.model = best;
  return out;
}

}  // namespace mvbrdf::fit
