// Main pass of core/render/phong_renderer.cc: the extended Phong model of
// core/render/phong_model.h per fragment (or, by u_brdf_model, another model
// of core/brdf: shaders/brdf_models.glsl; or a measured material,
// shaders/nbrdf.glsl), with shadow-map visibility per light. The structs and
// bindings mirror the Gpu* structs in phong_renderer.cc.

#define NBRDF_WEIGHTS_BINDING 3
#include "brdf_models.glsl"
#include "nbrdf.glsl"
#include "normal_detail.glsl"
#include "phong_model.glsl"
#include "solid_texture.glsl"

const int kMaxLights = 16;

struct GpuLight {
  // xyz: position (point light, world units) or unit direction towards the
  // light (directional); w: 1 for a point light, 0 for a directional one.
  vec4 position;
  vec4 intensity;  // rgb, linear
  // x: layer in the shadow-map array of the light's kind;
  // y: world length that depth 1 stands for (depth = length / y);
  // z: shadow texel size, radians (point: texel angle) or world units (directional).
  vec4 shadow;
  mat4 shadow_from_world;  // directional: world -> (s, t, depth) in [0, 1]^3
};

layout(std140, binding = 0) uniform LightBlock {
  ivec4 u_light_count;  // x: number of lights
  GpuLight u_lights[kMaxLights];
};

struct GpuMaterial {
  vec4 base_amplitude;       // solid-texture base rgb, amplitude
  vec4 offset_frequency;     // solid-texture offset xyz, frequency
  // ks rgb (the model's first parameter; a measured material's gain);
  // w > 0.5: kd from u_kd_texture
  vec4 ks_kd_from_texture;
  // rgb (the model's second parameter); w >= 0: the material is measured
  // BRDF number w of NbrdfWeights (rho(wi, wo) n.l per unit intensity; kd,
  // ks and ke unused), w < 0: an analytic one.
  vec4 ke;
  vec4 p3;  // rgb: the model's third parameter (GGX's f90_ratio)
};

layout(std430, binding = 1) readonly buffer MaterialBlock { GpuMaterial u_materials[]; };
layout(std430, binding = 2) readonly buffer TriangleMaterialBlock { uint u_triangle_material[]; };

// The viewpoint, homogeneous (scene::CameraModel::ViewOrigin), world units:
// (centre, 1) for a pinhole, (unit direction towards the camera, 0) for an
// orthographic camera, whose v is constant.
layout(location = 1) uniform vec4 u_camera_center;
layout(location = 2) uniform int u_atlas_mode;      // 0: procedural materials, 1: kd/ks/ke atlases
layout(location = 3) uniform int u_inverse_square_falloff;
// brdf::Model: 0 the thesis's Phong (ks, ke), 1 Blinn-Phong (ks, ke), 2 GGX
// (f0, roughness); "ks" and "ke" below hold the model's two parameters.
// -1 in atlas mode: per texel, from u_atlas_model (brdf::Model's value in
// its red channel, read without filtering).
layout(location = 5) uniform int u_brdf_model;
// Issue #18: 0 the mesh's normals; 1 the procedural detail
// (core/render/normal_detail.h: x amplitude, y wavelength; directions d1,
// d2); 2 the tangent-space normal atlas u_atlas_normal.
layout(location = 6) uniform int u_normal_mode;
layout(location = 7) uniform vec4 u_normal_detail;
layout(location = 8) uniform vec3 u_normal_detail_d1;
layout(location = 9) uniform vec3 u_normal_detail_d2;

layout(binding = 0) uniform sampler2D u_kd_texture;
layout(binding = 1) uniform sampler2D u_atlas_kd;
layout(binding = 2) uniform sampler2D u_atlas_ks;
layout(binding = 3) uniform sampler2D u_atlas_ke;
layout(binding = 4) uniform samplerCubeArray u_point_shadows;      // distance to the light / shadow.y
layout(binding = 5) uniform sampler2DArray u_directional_shadows;  // orthographic depth
layout(binding = 6) uniform sampler2D u_atlas_model;
layout(binding = 7) uniform sampler2D u_atlas_p3;  // the third parameter (GGX's f90_ratio)
// Atlas mode: GGX's grazing support per texel, its cluster's (red channel;
// brdf::Ggx::SpecularWithin, result.json's clusters[].ggxGrazingSupport):
// V's denominator held at or above it; 0 draws the plain lobe.
layout(binding = 8) uniform sampler2D u_atlas_ggx_support;
layout(binding = 9) uniform sampler2D u_atlas_normal;  // tangent-space unit normals

in vec3 v_position;
in vec3 v_normal;
in vec3 v_rest_position;
in vec2 v_uv;
in vec4 v_tangent;

layout(location = 0) out vec4 out_radiance;  // rgb radiance, a = 1 (coverage)

// kd W g + S per unit intensity of a half-vector model (core/fit/lobe_fit.h's
// equation; the caller multiplies by I, the fall-off and V).
vec3 HalfVectorModelTerm(int model, vec3 kd, vec3 p0, vec3 p1, vec3 p2, float support, vec3 l, vec3 n, vec3 v) {
  BrdfGeometry g;
  g.n_dot_l = dot(n, l);
  g.n_dot_v = dot(n, v);
  vec3 sum = l + v;
  float length_sum = length(sum);
  vec3 h = length_sum > 0.0 ? sum / length_sum : n;
  g.n_dot_h = length_sum > 0.0 ? max(0.0, dot(n, h)) : 0.0;
  g.v_dot_h = length_sum > 0.0 ? max(0.0, dot(v, h)) : 0.0;
  g.r_dot_v = max(0.0, dot(2.0 * g.n_dot_l * n - l, v));
  vec3 term;
  for (int c = 0; c < 3; ++c) {
    float specular = model == 1 ? BlinnPhongSpecular(p0[c], p1[c], g) : GgxSpecular(p0[c], p1[c], p2[c], support, g);
    float weight = model == 2 ? GgxDiffuseWeight(p2[c], g) : 1.0;
    term[c] = kd[c] * weight * g.n_dot_l + specular;
  }
  return term;
}

// A measured material's rho(l, v) n.l per unit intensity, in a tangent frame
// of n's choosing (the networks are isotropic: core/brdf/nbrdf.h).
vec3 MeasuredTerm(int material, vec3 l, vec3 n, vec3 v) {
  vec3 helper = abs(n.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0);
  vec3 t = normalize(cross(helper, n));
  vec3 b = cross(n, t);
  vec3 wi = vec3(dot(l, t), dot(l, b), dot(l, n));
  vec3 wo = vec3(dot(v, t), dot(v, b), dot(v, n));
  return NbrdfEvalMaterial(material, wi, wo) * max(wi.z, 0.0);
}

// Slope-scaled bias, world units: a nearest shadow texel of world size
// `texel_world` covers surface depths up to about half a texel diagonal times
// tan(angle between light and surface normal) away from its centre sample.
float ShadowBias(float texel_world, vec3 l, vec3 geometric_normal) {
  float c = abs(dot(l, geometric_normal));  // the derivative normal's sign is arbitrary
  float tan_theta = sqrt(max(0.0, 1.0 - c * c)) / max(c, 1e-4);
  return texel_world * (1.0 + 1.5 * min(tan_theta, 10.0));
}

bool PointLightVisible(GpuLight light, float distance_to_light, vec3 l, vec3 geometric_normal) {
  float stored = textureLod(u_point_shadows, vec4(-l, light.shadow.x), 0.0).r * light.shadow.y;
  float bias = ShadowBias(distance_to_light * light.shadow.z, l, geometric_normal);
  return distance_to_light - bias <= stored;
}

bool DirectionalLightVisible(GpuLight light, vec3 l, vec3 geometric_normal) {
  vec3 s = (light.shadow_from_world * vec4(v_position, 1.0)).xyz;
  if (any(lessThan(s, vec3(0.0))) || any(greaterThan(s, vec3(1.0)))) return true;
  float stored = textureLod(u_directional_shadows, vec3(s.xy, light.shadow.x), 0.0).r;
  float bias = ShadowBias(light.shadow.z, l, geometric_normal) / light.shadow.y;
  return s.z - bias <= stored;
}

void main() {
  vec3 n = normalize(v_normal);
  if (u_normal_mode == 1) {
    n = TangentToWorld(NormalDetailAt(u_normal_detail, u_normal_detail_d1, u_normal_detail_d2, v_rest_position),
                       v_tangent, n);
  } else if (u_normal_mode == 2) {
    vec3 m = texture(u_atlas_normal, v_uv).xyz;
    if (m.z > 0.0) n = TangentToWorld(normalize(m), v_tangent, n);
  }
  // The flat triangle's normal, for the shadow bias only.
  vec3 face = cross(dFdx(v_position), dFdy(v_position));
  float face_length = length(face);
  vec3 geometric_normal = face_length > 0.0 ? face / face_length : n;

  vec3 kd;
  vec3 ks;
  vec3 ke;
  vec3 p3;
  float ggx_support = 0.0;  // the truth's lobes (procedural) are drawn plain
  int model = u_brdf_model;
  int measured = -1;
  if (u_atlas_mode != 0) {
    kd = texture(u_atlas_kd, v_uv).rgb;
    ks = texture(u_atlas_ks, v_uv).rgb;
    ke = texture(u_atlas_ke, v_uv).rgb;
    p3 = texture(u_atlas_p3, v_uv).rgb;
    ggx_support = texture(u_atlas_ggx_support, v_uv).r;
    if (model < 0) {
      ivec2 size = textureSize(u_atlas_model, 0);
      ivec2 texel = clamp(ivec2(floor(v_uv * vec2(size))), ivec2(0), size - 1);
      model = int(texelFetch(u_atlas_model, texel, 0).r + 0.5);
    }
  } else {
    GpuMaterial m = u_materials[u_triangle_material[gl_PrimitiveID]];
    vec3 kd_texture = texture(u_kd_texture, v_uv).rgb;
    kd = m.ks_kd_from_texture.w > 0.5
             ? kd_texture
             : EvaluateSolidTexture(m.base_amplitude.rgb, m.base_amplitude.w, m.offset_frequency.w,
                                    m.offset_frequency.xyz, v_rest_position);
    ks = m.ks_kd_from_texture.rgb;
    ke = m.ke.rgb;
    p3 = m.p3.rgb;
    measured = int(floor(m.ke.w + 0.5));
  }

  vec3 v = normalize(u_camera_center.xyz - u_camera_center.w * v_position);
  vec3 f = vec3(0.0);
  for (int k = 0; k < u_light_count.x; ++k) {
    GpuLight light = u_lights[k];
    vec3 l;
    float attenuation = 1.0;
    float distance_to_light = 0.0;
    bool point = light.position.w > 0.5;
    if (point) {
      vec3 to_light = light.position.xyz - v_position;
      float distance_squared = dot(to_light, to_light);
      distance_to_light = sqrt(distance_squared);
      l = to_light / distance_to_light;
      if (u_inverse_square_falloff != 0) attenuation = 1.0 / distance_squared;
    } else {
      l = light.position.xyz;
    }
    vec2 cosines = PhongCosines(l, n, v);
    if (!(cosines.x > 0.0)) continue;
    bool visible = point ? PointLightVisible(light, distance_to_light, l, geometric_normal)
                         : DirectionalLightVisible(light, l, geometric_normal);
    if (!visible) continue;
    vec3 term = measured >= 0 ? ks * MeasuredTerm(measured, l, n, v)
                : model == 0  ? PhongTerm(kd, ks, ke, cosines)
                              : HalfVectorModelTerm(model, kd, ks, ke, p3, ggx_support, l, n, v);
    f += light.intensity.rgb * attenuation * term;
  }
  out_radiance = vec4(f, 1.0);
}
