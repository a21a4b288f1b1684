// Oren & Nayar 1994, "Generalization of Lambert's reflectance model", the qualitative model
// (eq. 30) written without angles: max(0, cos(phi_i - phi_o)) sin(alpha) tan(beta)
// = max(0, wi.wo - c_i c_o) / max(c_i, c_o). Twin of src/model/oren_nayar.rs.
#include "brdf/terms.glsl"
#include "brdf/sample.glsl"

// A = 1 - sigma^2 / (2 (sigma^2 + 0.33)) and B = 0.45 sigma^2 / (sigma^2 + 0.09) come from the host.
struct OrenNayarParams {
    vec3 albedo_over_pi;  // albedo / pi
    float a;
    float b;
};

vec3 oren_nayar(OrenNayarParams p, vec3 wi, vec3 wo) {
    float s = max(0.0, dot(wi, wo) - wi.z * wo.z);
    return p.albedo_over_pi * (p.a + p.b * s / max(wi.z, wo.z));
}

// Draws wi by the cosine.
Sample sample_oren_nayar(OrenNayarParams p, vec3 wo, float uc, vec2 u) {
    vec3 wi = sample_cosine(u);
    return sample_from_draw(wi, pdf_cosine(wi), oren_nayar(p, wi, wo));
}

float pdf_oren_nayar(OrenNayarParams p, vec3 wi, vec3 wo) {
    return pdf_cosine(wi);
}
