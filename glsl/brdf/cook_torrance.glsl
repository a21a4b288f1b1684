// Cook & Torrance 1982, "A reflectance model for computer graphics": Beckmann D, V-cavity G and
// Schlick's Fresnel in place of the exact one. Twin of src/model/cook_torrance.rs. What depends on
// the parameters alone arrives computed in the block (CookTorrance::gpu_params in the twin), as
// for the microfacet model, whose configuration beckmann/v_cavity/schlick this equals to the last
// bit.
#include "brdf/terms.glsl"
#include "brdf/sample.glsl"

struct CookTorranceParams {
    vec3 diffuse_over_pi;  // diffuse / pi
    float inv_alpha2;      // 1 / m^2
    vec3 specular;
    float d_norm;          // 1 / (pi m^2)
    float r0;              // Schlick's R0 from ior
    float one_minus_r0;    // 1 - R0
    float lobe_probability;        // cook_torrance_lobe_probability of the twin
    float lobe_probability_white;  // the same under the white furnace
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

// The Beckmann lobe's probability against the cosine (the twin computes it; the host sends it).
float cook_torrance_lobe_probability(CookTorranceParams p) {
    return WHITE_FURNACE ? p.lobe_probability_white : p.lobe_probability;
}

// (1 - P) cos(theta_i)/pi + P pdf_vndf (Beckmann, m); m = 1 / sqrt(inv_alpha2).
float pdf_cook_torrance(CookTorranceParams p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) return 0.0;
    float lobe = cook_torrance_lobe_probability(p);
    float m = inversesqrt(p.inv_alpha2);
    return (1.0 - lobe) * pdf_cosine(wi) + lobe * pdf_vndf(0u, wi, wo, m, m);
}

// The mixture of wo reflected about a Beckmann visible normal (Heitz & d'Eon 2014) and the cosine.
Sample sample_cook_torrance(CookTorranceParams p, vec3 wo, float uc, vec2 u) {
    float m = inversesqrt(p.inv_alpha2);
    vec3 wi = uc < cook_torrance_lobe_probability(p)
        ? reflect_about(wo, sample_vndf(0u, wo, m, m, u))
        : sample_cosine(u);
    return sample_from_draw(wi, pdf_cook_torrance(p, wi, wo), cook_torrance(p, wi, wo));
}
