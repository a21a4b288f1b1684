// Lambert: f = albedo / pi. Twin of src/model/lambert.rs.
#include "brdf/terms.glsl"
#include "brdf/sample.glsl"

struct LambertParams {
    vec3 albedo_over_pi;  // albedo / pi, from the host
};

vec3 lambert(LambertParams p, vec3 wi, vec3 wo) {
    return p.albedo_over_pi;
}

// Draws wi by the cosine (Malley's method): the density is f's own shape, so the weight is albedo.
Sample sample_lambert(LambertParams p, vec3 wo, float uc, vec2 u) {
    vec3 wi = sample_cosine(u);
    return sample_from_draw(wi, pdf_cosine(wi), lambert(p, wi, wo));
}

float pdf_lambert(LambertParams p, vec3 wi, vec3 wo) {
    return pdf_cosine(wi);
}
