// Oren & Nayar 1994, "Generalization of Lambert's reflectance model", the qualitative model
// (eq. 30) written without angles: max(0, cos(phi_i - phi_o)) sin(alpha) tan(beta)
// = max(0, wi.wo - c_i c_o) / max(c_i, c_o). Twin of src/model/oren_nayar.rs.
#include "brdf/terms.glsl"

struct OrenNayarParams {
    vec3 albedo;
    float sigma;
};

vec3 oren_nayar(OrenNayarParams p, vec3 wi, vec3 wo) {
    float s2 = p.sigma * p.sigma;
    float a = 1.0 - 0.5 * s2 / (s2 + 0.33);
    float b = 0.45 * s2 / (s2 + 0.09);
    float s = max(0.0, dot(wi, wo) - wi.z * wo.z);
    return p.albedo * INV_PI * (a + b * s / max(wi.z, wo.z));
}
