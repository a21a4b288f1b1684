// Normalized Phong (Lafortune & Willems 1994, "Using the modified Phong reflectance model for
// physically based rendering"): f = diffuse/pi + specular (n+2)/(2 pi) max(0, r.wo)^n,
// r = 2 c_i n - wi. Twin of src/model/phong.rs.
#include "brdf/terms.glsl"
#include "brdf/sample.glsl"

struct PhongParams {
    vec3 diffuse_over_pi;  // diffuse / pi, from the host
    float shininess;
    vec3 specular_norm;    // specular (n + 2)/(2 pi), from the host
    float lobe_probability;  // phong_lobe_probability of the twin, from the host
};

// s = wi + wo, exact from the albedo kernel's mirror offsets (half_vector_from_sum in terms.glsl).
vec3 phong_from_sum(PhongParams p, vec3 wi, vec3 wo, vec3 s) {
    // r - wo with r = (-wi.x, -wi.y, wi.z), the mirror of wi about n = +z (2 c_i n - wi): its
    // tangential part is -(wi + wo)'s. 1 - r.wo = |r - wo|^2 / 2 for unit vectors: no
    // cancellation near the mirror direction.
    vec3 d = vec3(-s.x, -s.y, wi.z - wo.z);
    float one_minus_r_wo = 0.5 * dot(d, d);
    return p.diffuse_over_pi + p.specular_norm * pow1m(one_minus_r_wo, p.shininess);
}

vec3 phong(PhongParams p, vec3 wi, vec3 wo) {
    return phong_from_sum(p, wi, wo, wi + wo);
}
#define MODEL_EVAL_SUM phong_from_sum

// The probability of the power-cosine lobe against the cosine (luminances of the two reflectances).
float phong_lobe_probability(PhongParams p) {
    return p.lobe_probability;
}

float pdf_phong(PhongParams p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0) return 0.0;
    float lobe = phong_lobe_probability(p);
    return (1.0 - lobe) * pdf_cosine(wi) + lobe * pdf_power_cosine(mirror(wo), p.shininess, wi);
}

// The mixture of a power cosine about the mirror direction of wo (Lafortune & Willems 1994,
// section 4) and the cosine, chosen by uc.
Sample sample_phong(PhongParams p, vec3 wo, float uc, vec2 u) {
    vec3 wi = uc < phong_lobe_probability(p) ? sample_power_cosine(mirror(wo), p.shininess, u)
                                             : sample_cosine(u);
    return sample_from_draw(wi, pdf_phong(p, wi, wo), phong(p, wi, wo));
}
