#include "core/fit/fit_test_util.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include "core/base/draw_order.h"

namespace mvbrdf::fit::testing {
namespace {

using Rng = std::mt19937_64;

glm::dvec3 RandomUnit(Rng &rng) {
  std::normal_distribution<double> normal;
  for (;;) {
    const glm::dvec3 v = base::DrawVec3<glm::dvec3>([&] { return normal(rng); });
    const double length = glm::length(v);
    if (length > 1e-6) return v / length;
  }
}

// A unit vector perpendicular to `d`.
glm::dvec3 RandomPerpendicular(const glm::dvec3 &d, Rng &rng) {
  for (;;) {
    const glm::dvec3 u = RandomUnit(rng);
    const glm::dvec3 t = u - glm::dot(u, d) * d;
    const double length = glm::length(t);
    if (length > 1e-3) return t / length;
  }
}

// A direction at cosine c from n.
glm::dvec3 AtCosine(const glm::dvec3 &n, double c, Rng &rng) {
  return c * n + std::sqrt(std::max(0.0, 1.0 - c * c)) * RandomPerpendicular(n, rng);
}

glm::dvec3 UpperHemisphere(const glm::dvec3 &n, double max_cosine, Rng &rng) {
  std::uniform_real_distribution<double> uniform(0.02, 1.0);
  if (max_cosine < 1.0) return AtCosine(n, max_cosine * uniform(rng), rng);
  glm::dvec3 u = RandomUnit(rng);
  if (glm::dot(u, n) < 0.0) u = -u;
  return u;
}

// R(l) = 2 (l.n) n - l (NOTES.md).
glm::dvec3 Reflect(const glm::dvec3 &l, const glm::dvec3 &n) { return 2.0 * glm::dot(l, n) * n - l; }

}  // namespace

PhongRgb MakePhong(const glm::dvec3 &kd, const glm::dvec3 &ks, const glm::dvec3 &ke) {
  PhongRgb p;
  for (int c = 0; c < 3; ++c) p[c] = PhongChannel{kd[c], ks[c], ke[c]};
  return p;
}

std::string ToString(const PhongRgb &p) {
  std::ostringstream out;
  out.precision(9);
  for (int c = 0; c < 3; ++c) out << (c ? " | " : "") << p[c].kd << " " << p[c].ks << " " << p[c].ke;
  return out.str();
}

glm::dvec3 ModelValue(const samples::SampleSet &set, size_t i, const samples::LightMask &mask, const PhongRgb &p,
                      const glm::vec3 &kd) {
  glm::dvec3 f(0.0);
  for (size_t j = set.TermsBegin(i); j < set.TermsEnd(i); ++j) {
    const int k = set.light[j];
    if (!mask.Test(static_cast<size_t>(k))) continue;
    const double g = set.g[j];
    const double h = set.h[j];
    if (!(g > 0.0)) continue;
    for (int c = 0; c < 3; ++c) {
      const double spec = h > 0.0 ? std::pow(h, p[c].ke) : 0.0;
      f[c] += set.light_intensity[k][c] * (kd[c] * g + p[c].ks * spec);
    }
  }
  return f;
}

samples::SampleSet MakeSamples(const PhongRgb &truth, const GeneratorOptions &options,
                               const std::vector<glm::vec3> &kd_of_element) {
  Rng rng(options.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal;
  const int num_lights = options.num_lights;
  const samples::LightMask mask =
      options.true_mask.Any() ? options.true_mask : samples::LightMask::FirstN(static_cast<size_t>(num_lights));
  double max_ke = 1.0;
  for (const PhongChannel &p : truth) max_ke = std::max(max_ke, p.ke);
  const double spread = options.highlight_spread > 0.0 ? options.highlight_spread : 1.5 / std::sqrt(max_ke);

  samples::SampleSet set;
  for (int k = 0; k < num_lights; ++k) {
    set.light_names.push_back("L" + std::to_string(k));
    set.light_intensity.push_back(options.intensity);
  }
  std::vector<float> g(num_lights), h(num_lights);
  std::vector<glm::dvec3> l(num_lights);
  for (size_t i = 0; i < options.num_samples; ++i) {
    // Redrawn from scratch when no view keeps every h below max_highlight
    // (the lights' highlight cones can cover the whole hemisphere).
    for (bool accepted = false; !accepted;) {
      const glm::dvec3 n = RandomUnit(rng);
      for (int k = 0; k < num_lights; ++k) {
        if (options.max_light_cosine < 1.0 || uniform(rng) < 0.85) {
          l[k] = UpperHemisphere(n, options.max_light_cosine, rng);
        } else {
          l[k] = RandomUnit(rng);
        }
      }
      std::vector<int> lit;
      for (int k = 0; k < num_lights; ++k) {
        if (glm::dot(l[k], n) > 0.0) lit.push_back(k);
      }
      glm::dvec3 v = UpperHemisphere(n, options.max_view_cosine, rng);
      if (!lit.empty() && uniform(rng) < options.highlight_fraction) {
        const int j = lit[std::min(lit.size() - 1, static_cast<size_t>(uniform(rng) * lit.size()))];
        const glm::dvec3 mirror = Reflect(l[j], n);
        for (int attempt = 0; attempt < 20; ++attempt) {
          const double angle = std::fabs(normal(rng)) * spread;
          const glm::dvec3 candidate = std::cos(angle) * mirror + std::sin(angle) * RandomPerpendicular(mirror, rng);
          const double cosine = glm::dot(candidate, n);
          if (cosine > 0.0 && cosine <= options.max_view_cosine) {
            v = candidate;
            break;
          }
        }
      }
      for (int attempt = 0;; ++attempt) {
        bool too_bright = false;
        for (int k = 0; k < num_lights; ++k) {
          const double cos_light = glm::dot(l[k], n);
          g[k] = cos_light > 0.0 ? static_cast<float>(cos_light) : 0.0f;
          const double cos_highlight = glm::dot(Reflect(l[k], n), v);
          h[k] = g[k] > 0.0f && cos_highlight > 0.0 ? static_cast<float>(std::min(1.0, cos_highlight)) : 0.0f;
          too_bright = too_bright || h[k] > options.max_highlight;
        }
        if (!too_bright) {
          accepted = true;
          break;
        }
        if (attempt > 100) break;
        v = UpperHemisphere(n, options.max_view_cosine, rng);
      }
    }
    const uint32_t element = static_cast<uint32_t>(i % options.num_elements);
    set.Add(element, 0, 0, glm::vec3(0.0f), g.data(), h.data());
  }
  // Reflectances from the stored cosines.
  glm::dvec3 mean(0.0);
  std::vector<glm::dvec3> values(set.size());
  for (size_t i = 0; i < set.size(); ++i) {
    const glm::vec3 kd =
        kd_of_element.empty() ? glm::vec3(truth[0].kd, truth[1].kd, truth[2].kd) : kd_of_element[set.element[i]];
    values[i] = ModelValue(set, i, mask, truth, kd);
    mean += values[i] / static_cast<double>(set.size());
  }
  for (size_t i = 0; i < set.size(); ++i) {
    glm::dvec3 r = values[i];
    if (options.noise > 0.0) {
      for (int c = 0; c < 3; ++c) r[c] += options.noise * mean[c] * normal(rng);
    }
    if (options.clip > 0.0) r = glm::clamp(r, 0.0, options.clip);
    set.reflectance[i] = glm::vec3(r);
  }
  return set;
}

samples::SampleSet MakeManyLightSamples(const PhongRgb &truth, int num_lights, int lights_on, size_t num_samples,
                                        uint32_t num_elements, const std::vector<glm::vec3> &kd_of_element,
                                        uint64_t seed) {
  Rng rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal;
  samples::SampleSet set;
  for (int k = 0; k < num_lights; ++k) {
    set.light_names.push_back("L" + std::to_string(k));
    set.light_intensity.emplace_back(0.5f + 0.01f * static_cast<float>(k % 100), 1.0f,
                                     1.5f - 0.004f * static_cast<float>(k % 200));
  }
  double max_ke = 1.0;
  for (const PhongChannel &p : truth) max_ke = std::max(max_ke, p.ke);
  const double spread = 1.5 / std::sqrt(max_ke);
  const int on = std::min(lights_on, num_lights);
  const int stride = std::max(1, num_lights / std::max(on, 1));
  std::vector<uint16_t> lights(static_cast<size_t>(on));
  std::vector<float> g(static_cast<size_t>(on)), h(static_cast<size_t>(on));
  for (size_t i = 0; i < num_samples; ++i) {
    for (int m = 0; m < on; ++m) {
      lights[static_cast<size_t>(m)] = static_cast<uint16_t>((i + static_cast<size_t>(m * stride)) % num_lights);
    }
    std::sort(lights.begin(), lights.end());
    lights.erase(std::unique(lights.begin(), lights.end()), lights.end());
    const glm::dvec3 n = RandomUnit(rng);
    std::vector<glm::dvec3> l(lights.size());
    for (glm::dvec3 &d : l) d = UpperHemisphere(n, 0.95, rng);
    glm::dvec3 v = UpperHemisphere(n, 1.0, rng);
    if (uniform(rng) < 0.5) {
      const glm::dvec3 mirror = Reflect(l[0], n);
      for (int attempt = 0; attempt < 20; ++attempt) {
        const double angle = std::fabs(normal(rng)) * spread;
        const glm::dvec3 candidate = std::cos(angle) * mirror + std::sin(angle) * RandomPerpendicular(mirror, rng);
        if (glm::dot(candidate, n) > 0.0) {
          v = candidate;
          break;
        }
      }
    }
    for (size_t m = 0; m < lights.size(); ++m) {
      g[m] = static_cast<float>(glm::dot(l[m], n));
      h[m] = static_cast<float>(std::clamp(glm::dot(Reflect(l[m], n), v), 0.0, 1.0));
    }
    set.AddTerms(static_cast<uint32_t>(i % num_elements), 0, 0, glm::vec3(0.0f), lights.size(), lights.data(), g.data(),
                 h.data());
  }
  const samples::LightMask all = samples::LightMask::FirstN(static_cast<size_t>(num_lights));
  for (size_t i = 0; i < set.size(); ++i) {
    const glm::vec3 kd =
        kd_of_element.empty() ? glm::vec3(truth[0].kd, truth[1].kd, truth[2].kd) : kd_of_element[set.element[i]];
    set.reflectance[i] = glm::vec3(ModelValue(set, i, all, truth, kd));
  }
  return set;
}

namespace {

constexpr double kPi = 3.14159265358979323846;

glm::dvec3 Direction(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

}  // namespace

samples::SampleSet RenderLobeSamples(const LobeTruth& truth, int num_samples, double noise, uint32_t seed,
                                     double intensity_scale, int texels, double texture) {
  samples::SampleSet set;
  set.half_vector = true;
  for (int k = 0; k < 6; ++k) {
    set.light_names.push_back("L" + std::to_string(k));
    set.light_intensity.push_back(glm::vec3(1.0f + 0.2f * k, 1.1f, 0.9f + 0.1f * k) *
                                  static_cast<float>(intensity_scale));
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const glm::dvec3 n(0, 0, 1);
  for (int i = 0; i < num_samples; ++i) {
    const double azimuth = 2 * kPi * unit(rng);  // drawn first (core/base/draw_order.h)
    const glm::dvec3 v = Direction(std::acos(1.0 - 0.7 * unit(rng)), azimuth);
    const glm::dvec3 mirror = 2.0 * v.z * n - v;
    std::vector<uint16_t> light;
    std::vector<float> g, h, nh, vh;
    glm::dvec3 rgb(0.0);
    for (int k = 0; k < 6; ++k) {
      if (unit(rng) < 0.33) continue;
      glm::dvec3 l;
      if (k % 2 == 0) {  // near the mirror direction: within ~25 degrees
        l = glm::normalize(mirror + 0.45 * base::DrawVec3<glm::dvec3>([&] { return gauss(rng); }));
      } else {
        const double azimuth_l = 2 * kPi * unit(rng);  // drawn first, as above
        l = Direction(std::acos(1.0 - 0.9 * unit(rng)), azimuth_l);
      }
      const brdf::Geometry geometry = brdf::GeometryOf(n, l, v);
      if (!(geometry.n_dot_l > 0.01)) continue;
      brdf::Geometry clamped = geometry;
      clamped.r_dot_v = std::max(0.0, geometry.r_dot_v);
      light.push_back(static_cast<uint16_t>(k));
      g.push_back(static_cast<float>(geometry.n_dot_l));
      h.push_back(static_cast<float>(clamped.r_dot_v));
      nh.push_back(static_cast<float>(geometry.n_dot_h));
      vh.push_back(static_cast<float>(geometry.v_dot_h));
    }
    samples::HalfVectorTerms hv{static_cast<float>(v.z), nh.data(), vh.data()};
    const uint32_t element = static_cast<uint32_t>(texels > 0 ? i % texels : i);
    const int frame = texels > 0 ? i / texels : 0;
    set.AddTerms(element, frame, static_cast<uint8_t>(i % 4), glm::vec3(0.0f), light.size(), light.data(), g.data(), h.data(), nullptr, hv);
    for (int c = 0; c < 3; ++c) {
      LobeChannel p = truth.params[c];
      if (texels > 0) p.kd *= 1.0 + texture * std::sin(2.3 * element);
      const double f = EvaluateLobe(truth.model, set, set.size() - 1, samples::LightMask::FirstN(6), p, c);
      rgb[c] = f * (1.0 + noise * gauss(rng));
    }
    set.reflectance.back() = glm::vec3(rgb);
  }
  return set;
}


}  // namespace mvbrdf::fit::testing
