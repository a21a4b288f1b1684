// Blinn-Phong with the (N+8)/(8 pi) normalization (Akenine-Moller et al., Real-Time Rendering)
// and the lab report's smoothness mapping N = 8192^(1-s). Twin of src/model/blinn_phong.rs.
#include "brdf/terms.glsl"
#include "brdf/sample.glsl"

// N = 8192^(1-s) = 2^(13 (1-s)) and the normalization come from the host.
struct BlinnPhongParams {
    vec3 diffuse_over_pi;  // diffuse / pi
    float exponent;        // N
    vec3 specular_norm;    // specular (N + 8)/(8 pi)
    float lobe_probability;  // blinn_phong_lobe_probability of the twin
};

// s = wi + wo, exact from the albedo kernel's mirror offsets (half_vector_from_sum in terms.glsl).
vec3 blinn_phong_from_sum(BlinnPhongParams p, vec3 wi, vec3 wo, vec3 s) {
    vec3 h = normalize(s);
    return p.diffuse_over_pi + p.specular_norm * pow1m(one_minus_cos_theta(h), p.exponent);
}

vec3 blinn_phong(BlinnPhongParams p, vec3 wi, vec3 wo) {
    return blinn_phong_from_sum(p, wi, wo, wi + wo);
}
#define MODEL_EVAL_SUM blinn_phong_from_sum

// The probability of the half-vector lobe against the cosine (luminances of the reflectances).
float blinn_phong_lobe_probability(BlinnPhongParams p) {
    return p.lobe_probability;
}

// (1 - P) cos(theta_i)/pi + P (N + 1)/(2 pi) c_h^N / (4 wo.h), the last factor the reflection's
// Jacobian (Walter et al. 2007, eq. 14).
float pdf_blinn_phong(BlinnPhongParams p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) return 0.0;
    float c_d;
    vec3 h = half_vector(wi, wo, c_d);
    float lobe = blinn_phong_lobe_probability(p);
    return (1.0 - lobe) * pdf_cosine(wi)
        + lobe * pdf_power_cosine(vec3(0.0, 0.0, 1.0), p.exponent, h) / (4.0 * c_d);
}

// The mixture of h by a power cosine about the normal, wi = wo reflected about h, and the cosine.
Sample sample_blinn_phong(BlinnPhongParams p, vec3 wo, float uc, vec2 u) {
    vec3 wi;
    if (uc < blinn_phong_lobe_probability(p)) {
        vec3 h = sample_power_cosine(vec3(0.0, 0.0, 1.0), p.exponent, u);
        wi = reflect_about(wo, h);
    } else {
        wi = sample_cosine(u);
    }
    return sample_from_draw(wi, pdf_blinn_phong(p, wi, wo), blinn_phong(p, wi, wo));
}
