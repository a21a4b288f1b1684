// Cook & Torrance 1982, "A reflectance model for computer graphics": Beckmann D, V-cavity G and
// Schlick's Fresnel in place of the exact one. Twin of src/model/cook_torrance.rs. What depends on
// the parameters alone arrives computed in the block (CookTorrance::gpu_params in the twin), as
// for the microfacet model, whose configuration beckmann/v_cavity/schlick this equals to the last
// bit.
#include "brdf/terms.glsl"

struct CookTorranceParams {
    vec3 diffuse_over_pi;  // diffuse / pi
    float inv_alpha2;      // 1 / m^2
    vec3 specular;
    float d_norm;          // 1 / (pi m^2)
    float r0;              // Schlick's R0 from ior
    float one_minus_r0;    // 1 - R0
};

// s = wi + wo, exact from the albedo kernel's mirror offsets (half_vector_from_sum in terms.glsl).
vec3 cook_torrance_from_sum(CookTorranceParams p, vec3 wi, vec3 wo, vec3 s) {
    float s2;
    float c_d = half_sum(s, s2);
    float c_i = wi.z, c_o = wo.z;
    vec3 f = F_specular(c_d, vec3(p.r0), vec3(p.one_minus_r0));
    vec2 d = vec2(D_beckmann(s, s2, p.inv_alpha2, p.inv_alpha2, p.d_norm), 1.0);
    float spec = specular_ratio(d, G_v_cavity(s.z, c_d, c_i, c_o), c_i, c_o);
    return p.diffuse_over_pi + p.specular * f * spec;
}

vec3 cook_torrance(CookTorranceParams p, vec3 wi, vec3 wo) {
    return cook_torrance_from_sum(p, wi, wo, wi + wo);
}
#define MODEL_EVAL_SUM cook_torrance_from_sum
