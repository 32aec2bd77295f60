#include "core/calibrate/refine_lights.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "ceres/ceres.h"
#include "ceres/manifold.h"
#include "core/calibrate/clustered_covariance.h"
#include "core/samples/assemble.h"
#include "core/scene/camera_model.h"
#include "core/scene/video_source.h"

namespace mvbrdf::calibrate {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kRadToDeg = 57.29577951308232;

// One triangle Sample as the fit sees it: its triangle's slot, the colour,
// the triangle's centre and face normal in the frame's posed mesh, the
// camera's viewpoint (homogeneous, scene::CameraModel::ViewOrigin) and the
// configuration's lights (slots) that reached it when gathered.
struct Observation {
  uint32_t slot = 0;
  uint32_t group = 0;  // the material group (its ks, ke)
  glm::dvec3 rgb{0.0};
  glm::dvec3 x{0.0}, n{0.0};
  glm::dvec4 view{0.0};
  std::vector<int> lights;
};

struct Model {
  int num_lights = 0;                 // K, the configuration's lights
  std::vector<bool> directional;      // per slot
  std::vector<glm::dvec3> intensity;  // the scene's I_k per slot
  bool falloff = false;
  // A point light is its direction d from the subject's centre (the Samples'
  // mean position) at the scene's distance: position = centre + radius d.
  glm::dvec3 centre{0.0};
  std::vector<double> radius;  // per slot (0 for directional lights)
};

// The intensity scale of light slot k from the K - 1 log-scales u (the last
// light's makes their sum 0: geometric mean 1).
template <typename T>
T ScaleOf(const T* u, int k, int num_lights) {
  using std::exp;
  if (num_lights < 2) return T(1.0);
  if (k < num_lights - 1) return exp(u[k]);
  T sum(0.0);
  for (int i = 0; i < num_lights - 1; ++i) sum += u[i];
  return exp(-sum);
}

// Residual of one Sample (RGB): model - observed. Parameter blocks: kd (3),
// ks (3), ke (1), [u (K - 1) when K >= 2], then one block (3) per light of
// the Sample (position, or direction on the unit sphere).
struct SampleResidual {
  const Observation* o;
  const Model* m;
  template <typename T>
  bool operator()(T const* const* p, T* residual) const {
    using std::pow;
    using std::sqrt;
    const T* kd = p[0];
    const T* ks = p[1];
    const T ke = p[2][0];
    const int base = m->num_lights >= 2 ? 4 : 3;
    const T* u = m->num_lights >= 2 ? p[3] : nullptr;
    T f[3] = {T(0.0), T(0.0), T(0.0)};
    for (size_t j = 0; j < o->lights.size(); ++j) {
      const int k = o->lights[j];
      const T* q = p[base + j];
      T l[3];
      T a(1.0);
      if (m->directional[static_cast<size_t>(k)]) {
        const T norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        for (int i = 0; i < 3; ++i) l[i] = q[i] / norm;
      } else {
        const T norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        const double r = m->radius[static_cast<size_t>(k)];
        T d[3];
        for (int i = 0; i < 3; ++i) d[i] = T(m->centre[i]) + T(r) * q[i] / norm - T(o->x[i]);
        const T d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        const T dist = sqrt(d2);
        for (int i = 0; i < 3; ++i) l[i] = d[i] / dist;
        if (m->falloff) a = T(1.0) / d2;
      }
      const T ln = l[0] * o->n[0] + l[1] * o->n[1] + l[2] * o->n[2];
      if (!(ln > T(0.0))) continue;
      // v = scene::ViewDirection(view, x); R(l) = 2 (l.n) n - l.
      glm::dvec3 v = glm::dvec3(o->view) - o->view.w * o->x;
      v = glm::normalize(v);
      const T rv = T(2.0) * ln * glm::dot(o->n, v) - (l[0] * v.x + l[1] * v.y + l[2] * v.z);
      const T s = ScaleOf(u, k, m->num_lights);
      const glm::dvec3& intensity = m->intensity[static_cast<size_t>(k)];
      const bool lit_highlight = rv > T(1e-9);
      const T hk = lit_highlight ? pow(rv, ke) : T(0.0);
      for (int c = 0; c < 3; ++c) f[c] += T(intensity[c]) * s * (kd[c] * ln * a + ks[c] * a * hk);
    }
    for (int c = 0; c < 3; ++c) residual[c] = f[c] - T(o->rgb[c]);
    return true;
  }
};

struct Parameters {
  std::vector<std::array<double, 3>> kd;  // per triangle slot
  // Per material group (triangles nearest to one of the scene's seeds by kd;
  // one group without seeds): the Phong lobes differ by far between
  // materials, and one shared lobe biased the lights.
  std::vector<std::array<double, 3>> ks;
  std::vector<double> ke;
  std::vector<double> u;  // K - 1 log-scales (at least one value, unused when K < 2)
  std::vector<std::array<double, 3>> light;
};

struct Problem {
  std::unique_ptr<ceres::Problem> problem;
  std::vector<double*> light_blocks;
  std::vector<ceres::ResidualBlockId> residuals;  // per observation, in order
};

Problem Build(const std::vector<Observation>& obs, const Model& model, Parameters* p, bool robust, double loss_scale) {
  Problem out;
  out.problem = std::make_unique<ceres::Problem>();
  ceres::Problem& problem = *out.problem;
  for (const Observation& o : obs) {
    auto* cost = new ceres::DynamicAutoDiffCostFunction<SampleResidual, 8>(new SampleResidual{&o, &model});
    std::vector<double*> blocks = {p->kd[o.slot].data(), p->ks[o.group].data(), &p->ke[o.group]};
    cost->AddParameterBlock(3);
    cost->AddParameterBlock(3);
    cost->AddParameterBlock(1);
    if (model.num_lights >= 2) {
      cost->AddParameterBlock(model.num_lights - 1);
      blocks.push_back(p->u.data());
    }
    for (int k : o.lights) {
      cost->AddParameterBlock(3);
      blocks.push_back(p->light[static_cast<size_t>(k)].data());
    }
    cost->SetNumResiduals(3);
    ceres::LossFunction* loss = robust ? new ceres::CauchyLoss(loss_scale) : nullptr;
    out.residuals.push_back(problem.AddResidualBlock(cost, loss, blocks));
  }
  for (size_t g = 0; g < p->ks.size(); ++g) {
    if (!problem.HasParameterBlock(p->ks[g].data())) continue;
    for (int c = 0; c < 3; ++c) problem.SetParameterLowerBound(p->ks[g].data(), c, 0.0);
    problem.SetParameterLowerBound(&p->ke[g], 0, 1.0);
    problem.SetParameterUpperBound(&p->ke[g], 0, 1000.0);
  }
  if (model.num_lights >= 2) {
    for (int k = 0; k < model.num_lights - 1; ++k) {
      problem.SetParameterLowerBound(p->u.data(), k, -3.0);
      problem.SetParameterUpperBound(p->u.data(), k, 3.0);
    }
  }
  for (int k = 0; k < model.num_lights; ++k) {
    double* block = p->light[static_cast<size_t>(k)].data();
    if (!problem.HasParameterBlock(block)) continue;
    out.light_blocks.push_back(block);
    problem.SetManifold(block, new ceres::SphereManifold<3>());
  }
  return out;
}

void SetLightsConstant(const Problem& pb, const Model& model, Parameters* p, bool constant) {
  for (double* b : pb.light_blocks) {
    if (constant)
      pb.problem->SetParameterBlockConstant(b);
    else
      pb.problem->SetParameterBlockVariable(b);
  }
  if (model.num_lights >= 2 && pb.problem->HasParameterBlock(p->u.data())) {
    if (constant)
      pb.problem->SetParameterBlockConstant(p->u.data());
    else
      pb.problem->SetParameterBlockVariable(p->u.data());
  }
}

ceres::Solver::Summary Solve(const Problem& pb, const Parameters& p, int max_iterations) {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.max_num_iterations = max_iterations;
  // One thread: the same result whichever worker (and core count) runs it.
  options.num_threads = 1;
  options.function_tolerance = 1e-10;
  options.parameter_tolerance = 1e-10;
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  std::vector<double*> blocks;
  pb.problem->GetParameterBlocks(&blocks);
  for (double* b : blocks) {
    bool is_kd = false;
    for (const auto& kd : p.kd) is_kd |= b == kd.data();
    ordering->AddElementToGroup(b, is_kd ? 0 : 1);
  }
  options.linear_solver_ordering = ordering;
  ceres::Solver::Summary summary;
  ceres::Solve(options, pb.problem.get(), &summary);
  return summary;
}

std::vector<double> Residuals(const Problem& pb) {
  std::vector<double> r;
  ceres::Problem::EvaluateOptions eval;
  eval.apply_loss_function = false;
  pb.problem->Evaluate(eval, nullptr, &r, nullptr, nullptr);
  return r;
}

void SetVec3(const glm::dvec3& v, google::protobuf::RepeatedField<double>* out) {
  out->Clear();
  for (int i = 0; i < 3; ++i) out->Add(v[i]);
}

}  // namespace

absl::Status RefineLights(const scene::Sequence& sequence, const samples::SampleSet& triangles,
                          const std::vector<std::string>& configuration, const LightRefinementOptions& options,
                          v1::CalibrationReport* report) {
  const auto start = Clock::now();
  report->set_lights_mode(options.mode == v1::REFINEMENT_ON ? "on" : "auto");
  report->set_lights_refined(false);
  report->clear_lights();
  const auto finish = [&](const std::string& decision) {
    report->set_lights_decision(decision);
    report->set_lights_seconds(std::chrono::duration<double>(Clock::now() - start).count());
    return absl::OkStatus();
  };

  // The configuration's lights: slot -> index among the Samples' (= the scene's) lights.
  Model model;
  model.falloff = options.inverse_square_falloff;
  std::vector<int> light_of_slot;
  std::vector<int> slot_of_light(static_cast<size_t>(triangles.num_lights()), -1);
  for (const std::string& name : configuration) {
    const auto it = std::find(triangles.light_names.begin(), triangles.light_names.end(), name);
    const int s = sequence.FindLight(name);
    if (it == triangles.light_names.end() || s < 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("light refinement: configuration light \"", name, "\" is no light of the scene's Samples"));
    }
    const int k = static_cast<int>(it - triangles.light_names.begin());
    slot_of_light[static_cast<size_t>(k)] = static_cast<int>(light_of_slot.size());
    light_of_slot.push_back(s);
    const scene::Light& light = sequence.lights[static_cast<size_t>(s)];
    model.directional.push_back(light.directional);
    model.intensity.push_back(glm::dvec3(light.intensity));
  }
  model.num_lights = static_cast<int>(light_of_slot.size());
  if (model.num_lights == 0) return finish("no lights in the configuration");

  // Triangles with at least 3 lit Samples of frames lit by the configuration.
  const std::vector<uint8_t> own = samples::OwnLightingFrames(sequence);
  const auto usable = [&](size_t i) {
    const size_t f = triangles.frame[i];
    if (f < own.size() && own[f] != 0) return false;
    for (size_t j = triangles.TermsBegin(i); j < triangles.TermsEnd(i); ++j) {
      if (slot_of_light[triangles.light[j]] >= 0 && std::isfinite(triangles.g[j])) return true;
    }
    return false;
  };
  const size_t num_triangles = sequence.topology.file_triangles.size();
  std::vector<uint32_t> count(num_triangles, 0);
  for (size_t i = 0; i < triangles.size(); ++i) {
    if (triangles.element[i] < num_triangles && usable(i)) ++count[triangles.element[i]];
  }
  std::vector<uint32_t> candidates;
  for (size_t t = 0; t < num_triangles; ++t) {
    if (count[t] >= 3) candidates.push_back(static_cast<uint32_t>(t));
  }
  if (candidates.size() < 10) {
    return finish(absl::StrCat("too few triangles with 3 lit Samples (", candidates.size(), " of at least 10)"));
  }
  std::vector<int32_t> slot_of_triangle(num_triangles, -1);
  std::vector<uint32_t> chosen;
  const size_t wanted = std::max<size_t>(10, options.max_triangles);
  for (size_t i = 0; i < wanted && i < candidates.size(); ++i) {
    // Evenly spread over the candidates (all of them when few).
    const size_t c = candidates.size() <= wanted ? i : (i * candidates.size()) / wanted;
    slot_of_triangle[candidates[c]] = static_cast<int32_t>(chosen.size());
    chosen.push_back(candidates[c]);
  }

  // Geometry: the chosen triangles' centres and face normals per frame, as
  // samples::AppendTriangleSamples computes them.
  std::map<int, std::vector<std::pair<glm::vec3, glm::vec3>>> geometry;  // frame -> per slot (centre, normal)
  for (size_t i = 0; i < triangles.size(); ++i) {
    if (triangles.element[i] < num_triangles && slot_of_triangle[triangles.element[i]] >= 0 && usable(i)) {
      geometry[triangles.frame[i]];
    }
  }
  for (auto& [frame, per_slot] : geometry) {
    if (options.cancelled && options.cancelled()) return absl::CancelledError("light refinement cancelled");
    if (frame >= sequence.num_frames) {
      return absl::InvalidArgumentError(
          absl::StrCat("light refinement: Sample of frame ", frame, " beyond the ", sequence.num_frames, " frames"));
    }
    absl::StatusOr<scene::FramePositions> positions = sequence.LoadFrame(frame);
    if (!positions.ok()) return positions.status();
    per_slot.resize(chosen.size());
    for (size_t s = 0; s < chosen.size(); ++s) {
      const glm::uvec3& tri = sequence.topology.file_triangles[chosen[s]];
      if (tri.x >= positions->size() || tri.y >= positions->size() || tri.z >= positions->size()) {
        return absl::InvalidArgumentError(absl::StrCat("light refinement: frame ", frame, " does not cover the mesh"));
      }
      const glm::vec3 p0 = (*positions)[tri.x], p1 = (*positions)[tri.y], p2 = (*positions)[tri.z];
      const glm::vec3 cross = glm::cross(p1 - p0, p2 - p0);
      const float length = glm::length(cross);
      per_slot[s] = {(p0 + p1 + p2) / 3.0f, length > 0.0f ? cross / length : glm::vec3(0.0f)};
    }
  }
  std::vector<Observation> obs;
  for (size_t i = 0; i < triangles.size(); ++i) {
    if (triangles.element[i] >= num_triangles) continue;
    const int32_t slot = slot_of_triangle[triangles.element[i]];
    if (slot < 0 || !usable(i) || triangles.camera[i] >= sequence.cameras.size()) continue;
    const auto& [centre, normal] = geometry[triangles.frame[i]][static_cast<size_t>(slot)];
    if (glm::dot(normal, normal) == 0.0f) continue;
    Observation o;
    o.slot = static_cast<uint32_t>(slot);
    o.rgb = glm::dvec3(triangles.reflectance[i]);
    if (!std::isfinite(o.rgb.x + o.rgb.y + o.rgb.z)) continue;
    o.x = glm::dvec3(centre);
    o.n = glm::dvec3(normal);
    o.view = sequence.cameras[triangles.camera[i]].ViewOrigin();
    for (size_t j = triangles.TermsBegin(i); j < triangles.TermsEnd(i); ++j) {
      const int s = slot_of_light[triangles.light[j]];
      if (s >= 0 && std::isfinite(triangles.g[j])) o.lights.push_back(s);
    }
    obs.push_back(std::move(o));
  }

  // Initial values: the scene's lights; per triangle the diffuse least
  // squares kd = sum r G / sum G^2; ks a tenth of the albedo scale, ke 10.
  Parameters p;
  p.kd.assign(chosen.size(), {0.0, 0.0, 0.0});
  p.u.assign(static_cast<size_t>(std::max(1, model.num_lights - 1)), 0.0);
  for (const Observation& o : obs) model.centre += o.x / static_cast<double>(std::max<size_t>(1, obs.size()));
  for (int k = 0; k < model.num_lights; ++k) {
    const scene::Light& light = sequence.lights[static_cast<size_t>(light_of_slot[static_cast<size_t>(k)])];
    const glm::dvec3 to = glm::dvec3(light.position) - model.centre;
    model.radius.push_back(light.directional ? 0.0 : glm::length(to));
    if (!light.directional && !(model.radius.back() > 0.0)) {
      return finish(absl::StrCat("light \"", light.name, "\" lies at the subject's centre"));
    }
    const glm::dvec3 q = glm::normalize(light.directional ? glm::dvec3(light.direction) : to);
    p.light.push_back({q.x, q.y, q.z});
  }
  {
    std::vector<glm::dvec3> rg(chosen.size(), glm::dvec3(0.0)), gg(chosen.size(), glm::dvec3(0.0));
    glm::dvec3 r2(0.0), g2(0.0);
    for (const Observation& o : obs) {
      glm::dvec3 illumination(0.0);
      for (int k : o.lights) {
        scene::Light light;
        light.directional = model.directional[static_cast<size_t>(k)];
        const auto& q = p.light[static_cast<size_t>(k)];
        light.position = light.direction = glm::vec3(q[0], q[1], q[2]);
        const glm::dvec3 qd(q[0], q[1], q[2]);
        glm::dvec3 l = light.directional ? qd : model.centre + model.radius[static_cast<size_t>(k)] * qd - o.x;
        const double d2 = glm::dot(l, l);
        l /= std::sqrt(d2);
        const double a = model.falloff && !light.directional ? 1.0 / d2 : 1.0;
        illumination += model.intensity[static_cast<size_t>(k)] * std::max(0.0, glm::dot(l, o.n)) * a;
      }
      rg[o.slot] += o.rgb * illumination;
      gg[o.slot] += illumination * illumination;
      r2 += o.rgb * o.rgb;
      g2 += illumination * illumination;
    }
    for (size_t s = 0; s < chosen.size(); ++s) {
      for (int c = 0; c < 3; ++c) p.kd[s][static_cast<size_t>(c)] = gg[s][c] > 0.0 ? rg[s][c] / gg[s][c] : 0.0;
    }
    std::array<double, 3> ks0{};
    for (int c = 0; c < 3; ++c) ks0[static_cast<size_t>(c)] = g2[c] > 0.0 ? 0.1 * std::sqrt(r2[c] / g2[c]) : 0.0;
    // Material groups: the nearest seed (as the clustering reads seeds).
    std::vector<glm::dvec3> seeds;
    for (const v1::MaterialSeed& seed : sequence.scene.material_seeds()) {
      glm::dvec3 albedo(0.0);
      for (int c = 0; c < 3; ++c) {
        albedo[c] = seed.linear_rgb_size() > c ? seed.linear_rgb(c)
                    : seed.srgb8_size() > c    ? scene::SrgbToLinear(static_cast<float>(seed.srgb8(c)) / 255.0f)
                                               : 0.0;
      }
      seeds.push_back(albedo);
    }
    const size_t groups = std::max<size_t>(1, seeds.size());
    p.ks.assign(groups, ks0);
    p.ke.assign(groups, 10.0);
    std::vector<uint32_t> group_of_slot(chosen.size(), 0);
    for (size_t s = 0; s < chosen.size() && seeds.size() > 1; ++s) {
      const glm::dvec3 kd(p.kd[s][0], p.kd[s][1], p.kd[s][2]);
      for (size_t g = 1; g < seeds.size(); ++g) {
        if (glm::distance(kd, seeds[g]) < glm::distance(kd, seeds[group_of_slot[s]])) {
          group_of_slot[s] = static_cast<uint32_t>(g);
        }
      }
    }
    for (Observation& o : obs) o.group = group_of_slot[o.slot];
  }

  // A: least squares at the scene's lights, for the residuals' scale.
  double scale = 0.0;
  {
    Problem a = Build(obs, model, &p, false, 0.0);
    SetLightsConstant(a, model, &p, true);
    const ceres::Solver::Summary s = Solve(a, p, options.max_iterations);
    if (!s.IsSolutionUsable()) return finish(absl::StrCat("the fit at the scene's lights failed: ", s.message));
    std::vector<double> r = Residuals(a);
    for (double& v : r) v = std::abs(v);
    std::nth_element(r.begin(), r.begin() + static_cast<long>(r.size() / 2), r.end());
    scale = 1.4826 * r[r.size() / 2];
    double rms = 0.0;
    for (const Observation& o : obs) rms += glm::dot(o.rgb, o.rgb);
    rms = std::sqrt(rms / (3.0 * static_cast<double>(obs.size())));
    scale = std::max(scale, 1e-6 * rms);
    if (!(scale > 0.0)) return finish("the Samples are all zero");
  }
  if (options.cancelled && options.cancelled()) return absl::CancelledError("light refinement cancelled");
  // B: the robust fit at the scene's lights (cost before), then C: the lights free (cost after).
  const double loss_scale = 2.5 * scale;  // 3 channels per residual block
  Problem b = Build(obs, model, &p, true, loss_scale);
  SetLightsConstant(b, model, &p, true);
  const ceres::Solver::Summary before = Solve(b, p, options.max_iterations);
  if (!before.IsSolutionUsable()) return finish(absl::StrCat("the robust fit failed: ", before.message));
  if (options.cancelled && options.cancelled()) return absl::CancelledError("light refinement cancelled");
  SetLightsConstant(b, model, &p, false);
  const ceres::Solver::Summary after = Solve(b, p, options.max_iterations);
  if (!after.IsSolutionUsable()) return finish(absl::StrCat("the light refinement did not converge: ", after.message));
  const double cost_before = before.final_cost, cost_after = after.final_cost;

  // Covariance of the lights: kd free, ks and ke held.
  for (size_t g = 0; g < p.ks.size(); ++g) {
    if (!b.problem->HasParameterBlock(p.ks[g].data())) continue;
    b.problem->SetParameterBlockConstant(p.ks[g].data());
    b.problem->SetParameterBlockConstant(&p.ke[g]);
  }
  // A triangle no light reaches any more at the refined lights has a kd the
  // data do not determine (a zero Jacobian column): held, as ks and ke.
  {
    std::vector<uint32_t> lit(chosen.size(), 0);
    for (const Observation& o : obs) {
      for (int k : o.lights) {
        const auto& q = p.light[static_cast<size_t>(k)];
        const glm::dvec3 d = glm::normalize(glm::dvec3(q[0], q[1], q[2]));
        const glm::dvec3 l = model.directional[static_cast<size_t>(k)]
                                 ? d
                                 : glm::normalize(model.centre + model.radius[static_cast<size_t>(k)] * d - o.x);
        if (glm::dot(l, o.n) > 0.0) ++lit[o.slot];
      }
    }
    for (size_t t = 0; t < chosen.size(); ++t) {
      if (lit[t] == 0 && b.problem->HasParameterBlock(p.kd[t].data())) {
        b.problem->SetParameterBlockConstant(p.kd[t].data());
      }
    }
  }
  // Their covariance: clustered by triangle (clustered_covariance.h; Ceres's
  // own, scaled by the residuals' variance, was ~9x too small on clean data).
  std::vector<double*> interest = b.light_blocks;
  if (model.num_lights >= 2) interest.push_back(p.u.data());
  std::vector<std::vector<ceres::ResidualBlockId>> clusters(chosen.size());
  for (size_t i = 0; i < obs.size(); ++i) clusters[obs[i].slot].push_back(b.residuals[i]);
  const absl::StatusOr<ClusteredCovarianceResult> clustered = ClusteredCovariance(*b.problem, interest, clusters);
  const SymmetricMatrix* covariance = clustered.ok() ? &clustered->covariance : nullptr;
  bool identifiable = covariance != nullptr && covariance->size > 0 &&
                      std::all_of(covariance->values.begin(), covariance->values.end(),
                                  [](double v) { return std::isfinite(v); });
  // Where each block of interest lies in the covariance (-1: held).
  std::map<const double*, int> column;
  if (clustered.ok()) {
    for (size_t i = 0; i < interest.size(); ++i) {
      if (clustered->offset[i] >= 0) column[interest[i]] = clustered->offset[i];
    }
  }
  std::vector<double> cu;
  if (identifiable && model.num_lights >= 2) {
    const int n = model.num_lights - 1;
    const auto it = column.find(p.u.data());
    identifiable = it != column.end();
    if (identifiable) {
      cu.resize(static_cast<size_t>(n * n));
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) cu[static_cast<size_t>(i * n + j)] = (*covariance)(it->second + i, it->second + j);
      }
    }
  }

  // Rows.
  double most_significant = 0.0;
  std::string most_name;
  for (int k = 0; k < model.num_lights; ++k) {
    const size_t ks = static_cast<size_t>(k);
    const scene::Light& light = sequence.lights[static_cast<size_t>(light_of_slot[ks])];
    v1::LightRefinementRow* row = report->add_lights();
    row->set_name(light.name);
    const glm::dvec3 d(p.light[ks][0], p.light[ks][1], p.light[ks][2]);
    const glm::dvec3 q = light.directional ? d : model.centre + model.radius[ks] * glm::normalize(d);
    double sigma2 = std::numeric_limits<double>::infinity();
    double* blk = p.light[ks].data();
    if (identifiable && column.count(blk) != 0) {
      // The direction's (radians^2: the unit vector's covariance, J C J^T
      // through the sphere's Plus at the solution); a point light moves radius
      // times that.
      double plus[6];  // 3 x 2, row-major
      const double norm = std::sqrt(blk[0] * blk[0] + blk[1] * blk[1] + blk[2] * blk[2]);
      if (b.problem->GetManifold(blk)->PlusJacobian(blk, plus)) {
        const int o = column.at(blk);
        double trace = 0.0;  // of J C J^T
        for (int r = 0; r < 3; ++r) {
          for (int i = 0; i < 2; ++i) {
            for (int j = 0; j < 2; ++j) trace += plus[r * 2 + i] * (*covariance)(o + i, o + j) * plus[r * 2 + j];
          }
        }
        sigma2 = trace / (norm * norm) * (light.directional ? 1.0 : model.radius[ks] * model.radius[ks]);
      }
    }
    double change = 0.0, sigma = std::sqrt(sigma2);
    v1::Light* used = row->mutable_light();
    used->set_name(light.name);
    if (light.directional) {
      const glm::dvec3 d0 = glm::normalize(glm::dvec3(light.direction)), d1 = glm::normalize(q);
      SetVec3(d0, row->mutable_direction_before());
      SetVec3(d1, row->mutable_direction_after());
      change = std::acos(std::clamp(glm::dot(d0, d1), -1.0, 1.0));
      row->set_direction_change_deg(change * kRadToDeg);
      row->set_direction_sigma_deg(sigma * kRadToDeg);
      SetVec3(d1, used->mutable_direction());
    } else {
      SetVec3(glm::dvec3(light.position), row->mutable_position_before());
      SetVec3(q, row->mutable_position_after());
      change = glm::length(q - glm::dvec3(light.position));
      row->set_position_change(change);
      row->set_position_sigma(sigma);
      SetVec3(q, used->mutable_position());
    }
    double log_scale = 0.0, log_sigma = 0.0;
    if (model.num_lights >= 2) {
      const int n = model.num_lights - 1;
      double var = 0.0, sum = 0.0;
      if (k < n) {
        log_scale = p.u[ks];
        var = cu.empty() ? 0.0 : cu[ks * static_cast<size_t>(n) + ks];
      } else {
        for (int i = 0; i < n; ++i) sum += p.u[static_cast<size_t>(i)];
        log_scale = -sum;
        for (double v : cu) var += v;
      }
      log_sigma = identifiable ? std::sqrt(var) : std::numeric_limits<double>::infinity();
    }
    const glm::dvec3 i0(light.intensity), i1 = i0 * std::exp(log_scale);
    SetVec3(i0, row->mutable_intensity_before());
    SetVec3(i1, row->mutable_intensity_after());
    SetVec3(i1, used->mutable_intensity());
    row->set_intensity_rel_sigma(log_sigma);
    double z = change > 0.0 ? change / sigma : 0.0;
    if (log_sigma > 0.0) z = std::max(z, std::abs(log_scale) / log_sigma);
    if (!std::isfinite(sigma) || !std::isfinite(log_sigma)) identifiable = false;
    if (z > most_significant) most_significant = z, most_name = light.name;
  }

  const double improvement = cost_before > 0.0 ? (cost_before - cost_after) / cost_before : 0.0;
  const std::string figures = absl::StrFormat(
      "%zu triangles, %zu Samples; robust cost %.6g -> %.6g (%.2f %% lower); the most changed "
      "light (%s) moved %.2f sigma",
      chosen.size(), obs.size(), cost_before, cost_after, 100.0 * improvement, most_name, most_significant);
  if (!identifiable) {
    return finish(
        absl::StrCat("the scene's lights are kept: the lights are not identifiable from the Samples (the "
                     "covariance is singular or not finite); ",
                     figures));
  }
  if (options.mode == v1::REFINEMENT_ON) {
    report->set_lights_refined(true);
    return finish(absl::StrCat("refined lights used (--refine-lights on); ", figures));
  }
  if (improvement < kMinImprovement) {
    return finish(absl::StrCat("the scene's lights are kept: the fit improves by less than ", 100.0 * kMinImprovement,
                               " %; ", figures));
  }
  if (most_significant < kMinSignificance) {
    return finish(absl::StrCat("the scene's lights are kept: no light changed by ", kMinSignificance,
                               " sigma or more; ", figures));
  }
  report->set_lights_refined(true);
  return finish(absl::StrCat("refined lights used: the fit improves by ", 100.0 * kMinImprovement,
                             " % or more and a light changed by ", kMinSignificance, " sigma or more; ", figures));
}

absl::Status ApplyLightRefinement(const v1::CalibrationReport& report, scene::Sequence* sequence) {
  if (!report.lights_refined()) return absl::OkStatus();
  for (const v1::LightRefinementRow& row : report.lights()) {
    const int k = sequence->FindLight(row.name());
    if (k < 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("calibration.lights: \"", row.name(), "\" is no light of the scene"));
    }
    scene::Light& light = sequence->lights[static_cast<size_t>(k)];
    v1::Light* scene_light = sequence->scene.mutable_lights(k);
    const v1::Light& used = row.light();
    const auto read3 = [&](const google::protobuf::RepeatedField<double>& v,
                           const char* field) -> absl::StatusOr<glm::vec3> {
      if (v.size() != 3 || !std::isfinite(v[0] + v[1] + v[2])) {
        return absl::InvalidArgumentError(
            absl::StrCat("calibration.lights[", row.name(), "].light.", field, ": expected 3 finite values"));
      }
      return glm::vec3(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]));
    };
    if (light.directional) {
      absl::StatusOr<glm::vec3> d = read3(used.direction(), "direction");
      if (!d.ok()) return d.status();
      light.direction = glm::normalize(*d);
      *scene_light->mutable_direction() = used.direction();
    } else {
      absl::StatusOr<glm::vec3> q = read3(used.position(), "position");
      if (!q.ok()) return q.status();
      light.position = *q;
      *scene_light->mutable_position() = used.position();
    }
    absl::StatusOr<glm::vec3> i = read3(used.intensity(), "intensity");
    if (!i.ok()) return i.status();
    light.intensity = *i;
    *scene_light->mutable_intensity() = used.intensity();
  }
  return absl::OkStatus();
}

void CopyLightRefinement(const v1::CalibrationReport& from, v1::CalibrationReport* to) {
  to->set_lights_mode(from.lights_mode());
  to->set_lights_refined(from.lights_refined());
  to->set_lights_decision(from.lights_decision());
  *to->mutable_lights() = from.lights();
  to->set_lights_seconds(from.lights_seconds());
}

}  // namespace mvbrdf::calibrate
