// The general microfacet model: f = diffuse/pi + specular F(c_d) D(h) G(wi, wo) / (4 c_i c_o),
// plus, with multiscatter = kulla_conty, specular F_ms f_ms (Kulla & Conty 2017).
// Each component choice is a specialization constant, so the driver compiles only the branch a
// pipeline uses. Twin of src/model/microfacet.rs (formulas and citations there and in terms).
#include "brdf/terms.glsl"
#include "brdf/kulla_conty.glsl"

layout(constant_id = 3) const uint MF_DISTRIBUTION = 1u;  // 0 beckmann, 1 ggx
layout(constant_id = 4) const uint MF_MASKING = 2u;       // 0 v_cavity, 1 smith_separable, 2 smith_correlated
layout(constant_id = 5) const uint MF_BECKMANN_G1 = 0u;   // 0 exact (erf), 1 rational (Walter 2007)
layout(constant_id = 6) const uint MF_FRESNEL = 1u;       // 0 none, 1 schlick, 2 dielectric, 3 conductor
layout(constant_id = 7) const uint MF_MULTISCATTER = 0u;  // 0 none, 1 kulla_conty

struct MicrofacetParams {
    vec3 specular;
    float alpha_x;
    vec3 diffuse;
    float alpha_y;
    vec3 f0;
    float ior;
    vec3 eta;
    vec3 k;
    vec3 f_avg;  // 2 * integral of F(mu) mu dmu, from the host
};

float microfacet_lambda(MicrofacetParams p, vec3 w) {
    float t2 = alpha_tan2(w, p.alpha_x, p.alpha_y);
    if (MF_DISTRIBUTION == 1u) return lambda_ggx(t2);
    if (MF_BECKMANN_G1 == 0u) return lambda_beckmann(t2);
    return 1.0 / G1_beckmann_rational(t2) - 1.0;
}

// s = wi + wo, exact from the albedo kernel's mirror offsets (half_vector_from_sum in terms.glsl).
vec3 microfacet_from_sum(MicrofacetParams p, vec3 wi, vec3 wo, vec3 s) {
    float c_d;
    vec3 h = half_vector_from_sum(s, c_d);
    float c_i = wi.z, c_o = wo.z;
    float d = MF_DISTRIBUTION == 0u ? D_beckmann(h, p.alpha_x, p.alpha_y) : D_ggx(h, p.alpha_x, p.alpha_y);
    float g;
    if (MF_MASKING == 0u) {
        g = G_v_cavity(h.z, c_d, c_i, c_o);
    } else if (MF_MASKING == 1u) {
        g = 1.0 / ((1.0 + microfacet_lambda(p, wi)) * (1.0 + microfacet_lambda(p, wo)));
    } else {
        g = 1.0 / (1.0 + microfacet_lambda(p, wi) + microfacet_lambda(p, wo));
    }
    vec3 f;
    if (WHITE_FURNACE || MF_FRESNEL == 0u) {
        f = vec3(1.0);
    } else if (MF_FRESNEL == 1u) {
        f = F_schlick(c_d, p.f0);
    } else if (MF_FRESNEL == 2u) {
        f = vec3(F_dielectric(c_d, p.ior));
    } else {
        f = F_conductor(c_d, p.eta, p.k);
    }
    // Summed in cook_torrance's order (specular * F first), so that cook_torrance equals its
    // microfacet configuration to the last bit; the f64 twin sums the same way.
    vec3 f_total = p.diffuse * INV_PI + p.specular * f * (d * g / (4.0 * c_i * c_o));
    if (MF_MULTISCATTER == 1u) {
        vec3 f_avg = WHITE_FURNACE ? vec3(1.0) : p.f_avg;
        f_total += p.specular * kulla_conty(p.alpha_x, p.alpha_y, f_avg, c_i, c_o);
    }
    return f_total;
}

vec3 microfacet(MicrofacetParams p, vec3 wi, vec3 wo) {
    return microfacet_from_sum(p, wi, wo, wi + wo);
}
#define MODEL_EVAL_SUM microfacet_from_sum
