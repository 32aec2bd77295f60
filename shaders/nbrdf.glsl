// The neural BRDFs of core/brdf/nbrdf.h (the MERL materials as 6-21-21-3
// networks), the GLSL twin of NeuralBrdf::Evaluate: the same formulas in the
// same order, in float. core/brdf/nbrdf_glsl_test.cc checks it against the CPU.
//
//   h = normalize(wi + wo), theta_h, phi_h its polar angles (phi_h = 0 at h = n),
//   d = normalize(Ry(-theta_h) Rz(-phi_h) wi),
//   x = (sin theta_h, 0, cos theta_h, d.x, d.y, d.z),
//   rho = max(exp(relu(relu(x W1 + b1) W2 + b2) W3 + b3) - 1, 0)   (RGB, 1/sr)
//
// The weights: a std430 float array (NbrdfWeights below), one block of
// kNbrdfNumWeights = 675 floats per material, material m's block at
// m * 675, each in NeuralBrdf's packed layout (NeuralBrdf::GlslWeights()):
// W1 [6][21] input-major (element (i, j) at i * 21 + j), b1 [21], W2 [21][21],
// b2 [21], W3 [21][3], b3 [3]. The including shader chooses the buffer's
// binding: `#define NBRDF_WEIGHTS_BINDING 3` before `#include "nbrdf.glsl"`.

#ifndef NBRDF_WEIGHTS_BINDING
#error "nbrdf.glsl: #define NBRDF_WEIGHTS_BINDING (the weights' SSBO binding) before including it"
#endif

layout(std430, binding = NBRDF_WEIGHTS_BINDING) readonly buffer NbrdfWeights { float nbrdf_weights[]; };

const int kNbrdfInputs = 6;
const int kNbrdfHidden = 21;
const int kNbrdfW1 = 0;
const int kNbrdfB1 = kNbrdfW1 + kNbrdfInputs * kNbrdfHidden;
const int kNbrdfW2 = kNbrdfB1 + kNbrdfHidden;
const int kNbrdfB2 = kNbrdfW2 + kNbrdfHidden * kNbrdfHidden;
const int kNbrdfW3 = kNbrdfB2 + kNbrdfHidden;
const int kNbrdfB3 = kNbrdfW3 + kNbrdfHidden * 3;
const int kNbrdfNumWeights = kNbrdfB3 + 3;  // 675

// The loops run over a layer's outputs, each output's sum over its inputs
// inside, and the second layer feeds the third as it goes (no a2 array):
// llvmpipe compiles this in ~1 s, input-major loops over two arrays in ~16 s.
// The sums are in the CPU's order (bias, then inputs in ascending order).
//
// rho(wi, wo) of material `material` (its block in NbrdfWeights), in 1/sr,
// for unit vectors in the local frame (z = normal, wi to the light, wo to
// the viewer); 0 where wi.z <= 0 or wo.z <= 0.
vec3 NbrdfEvalMaterial(int material, vec3 wi, vec3 wo) {
  if (!(wi.z > 0.0) || !(wo.z > 0.0)) return vec3(0.0);
  int base = material * kNbrdfNumWeights;
  vec3 h = normalize(wi + wo);
  float sin_theta = length(h.xy), cos_theta = h.z;
  vec2 phi = sin_theta > 0.0 ? h.xy / sin_theta : vec2(1.0, 0.0);  // (cos, sin) of phi_h
  vec3 u = vec3(phi.x * wi.x + phi.y * wi.y, -phi.y * wi.x + phi.x * wi.y, wi.z);
  vec3 d = normalize(vec3(cos_theta * u.x - sin_theta * u.z, u.y, sin_theta * u.x + cos_theta * u.z));
  float x[6] = float[6](sin_theta, 0.0, cos_theta, d.x, d.y, d.z);

  float a1[21];
  for (int j = 0; j < kNbrdfHidden; ++j) {
    float s = nbrdf_weights[base + kNbrdfB1 + j];
    for (int i = 0; i < kNbrdfInputs; ++i) s += x[i] * nbrdf_weights[base + kNbrdfW1 + i * kNbrdfHidden + j];
    a1[j] = max(s, 0.0);
  }
  vec3 a3 = vec3(nbrdf_weights[base + kNbrdfB3], nbrdf_weights[base + kNbrdfB3 + 1],
                 nbrdf_weights[base + kNbrdfB3 + 2]);
  for (int j = 0; j < kNbrdfHidden; ++j) {
    float s = nbrdf_weights[base + kNbrdfB2 + j];
    for (int i = 0; i < kNbrdfHidden; ++i) s += a1[i] * nbrdf_weights[base + kNbrdfW2 + i * kNbrdfHidden + j];
    int k = base + kNbrdfW3 + j * 3;
    a3 += max(s, 0.0) * vec3(nbrdf_weights[k], nbrdf_weights[k + 1], nbrdf_weights[k + 2]);
  }
  return max(exp(a3) - 1.0, vec3(0.0));
}

// rho(wi, wo) of the first (or only) material in NbrdfWeights.
vec3 NbrdfEval(vec3 wi, vec3 wo) { return NbrdfEvalMaterial(0, wi, wo); }
