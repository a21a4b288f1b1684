// Cook & Torrance 1982, "A reflectance model for computer graphics": Beckmann D, V-cavity G and
// Schlick's Fresnel in place of the exact one. Twin of src/model/cook_torrance.rs.
#include "brdf/terms.glsl"

struct CookTorranceParams {
    vec3 diffuse;
    float ior;
    vec3 specular;
    float roughness;
};

// s = wi + wo, exact from the albedo kernel's mirror offsets (half_vector_from_sum in terms.glsl).
vec3 cook_torrance_from_sum(CookTorranceParams p, vec3 wi, vec3 wo, vec3 s) {
    float c_d;
    vec3 h = half_vector_from_sum(s, c_d);
    float c_i = wi.z, c_o = wo.z;
    float d = D_beckmann(h, p.roughness, p.roughness);
    float g = G_v_cavity(h.z, c_d, c_i, c_o);
    vec3 f = F_specular(c_d, vec3(r0_from_ior(p.ior)));
    return p.diffuse * INV_PI + p.specular * f * (d * g / (4.0 * c_i * c_o));
}

vec3 cook_torrance(CookTorranceParams p, vec3 wi, vec3 wo) {
    return cook_torrance_from_sum(p, wi, wo, wi + wo);
}
#define MODEL_EVAL_SUM cook_torrance_from_sum
