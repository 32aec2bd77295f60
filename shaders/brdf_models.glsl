// The BRDF models of core/brdf (phong.h, blinn_phong.h, ggx.h), the GLSL
// twins of their CPU evaluation: the same formulas from the same cosines
// (core/brdf/geometry.h), one colour channel, per unit light intensity.
// core/brdf/brdf_glsl_test.cc checks every function against the CPU.

struct BrdfGeometry {
  float n_dot_l, n_dot_v, n_dot_h, v_dot_h, r_dot_v;
};

const float kBrdfPi = 3.14159265358979323846;

// The thesis's Phong: ks h^ke, h = min(1, R(l).v); 0 where n.l <= 0 or h <= 0.
float PhongSpecular(float ks, float ke, BrdfGeometry g) {
  float h = min(g.r_dot_v, 1.0);
  if (!(g.n_dot_l > 0.0) || !(h > 0.0)) return 0.0;
  return ks * exp(ke * log(h));
}

// Energy-normalised Blinn-Phong: n.l ks N(ke) (n.h)^ke,
// N(ke) = (ke + 2)(ke + 4) / (8 pi (2^(-ke/2) + ke)); 0 where n.l or n.v <= 0.
float BlinnPhongSpecular(float ks, float ke, BrdfGeometry g) {
  float c = min(g.n_dot_h, 1.0);
  if (!(g.n_dot_l > 0.0) || !(g.n_dot_v > 0.0) || !(c > 0.0)) return 0.0;
  float normalisation = (ke + 2.0) * (ke + 4.0) / (8.0 * kBrdfPi * (exp2(-0.5 * ke) + ke));
  return g.n_dot_l * ks * normalisation * exp(ke * log(c));
}

// Schlick's (1 - v.h)^5.
float BrdfSchlickWeight(BrdfGeometry g) {
  float m = 1.0 - clamp(g.v_dot_h, 0.0, 1.0);
  float m2 = m * m;
  return m2 * m2 * m;
}

// F / F0 = 1 + (ratio - 1) w, ratio = F90 / F0 (ggx.h; 25: a dielectric of
// index 1.5, Ggx::kDielectricRatio).
float GgxFresnelShape(float ratio, BrdfGeometry g) {
  return 1.0 + (ratio - 1.0) * BrdfSchlickWeight(g);
}

// glTF's GGX lobe: n.l F D V with a = roughness^2; 0 where n.l or n.v <= 0;
// V's denominator held at or above `support` (Ggx::SpecularWithin; 0: the
// plain lobe).
float GgxSpecular(float f0, float roughness, float ratio, float support, BrdfGeometry g) {
  if (!(g.n_dot_l > 0.0) || !(g.n_dot_v > 0.0)) return 0.0;
  float nl = min(g.n_dot_l, 1.0), nv = min(g.n_dot_v, 1.0), c = clamp(g.n_dot_h, 0.0, 1.0);
  float a = roughness * roughness, a2 = a * a;
  float q = c * c * (a2 - 1.0) + 1.0;
  float d = a2 / (kBrdfPi * q * q);
  float v = 0.5 / max(nl * sqrt(nv * nv * (1.0 - a2) + a2) + nv * sqrt(nl * nl * (1.0 - a2) + a2), support);
  float f = f0 * GgxFresnelShape(ratio, g);
  return g.n_dot_l * f * d * v;
}

// The weight of the diffuse term kd n.l under GGX: 1 - F / F90 =
// (1 - 1 / ratio) (1 - w).
float GgxDiffuseWeight(float ratio, BrdfGeometry g) {
  return (1.0 - 1.0 / ratio) * (1.0 - BrdfSchlickWeight(g));
}
