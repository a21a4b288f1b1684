// Blinn-Phong with the (N+8)/(8 pi) normalization (Akenine-Moller et al., Real-Time Rendering)
// and the lab report's smoothness mapping N = 8192^(1-s). Twin of src/model/blinn_phong.rs.
#include "brdf/terms.glsl"

// N = 8192^(1-s) = 2^(13 (1-s)) and the normalization come from the host.
struct BlinnPhongParams {
    vec3 diffuse_over_pi;  // diffuse / pi
    float exponent;        // N
    vec3 specular_norm;    // specular (N + 8)/(8 pi)
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
