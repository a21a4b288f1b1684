// Blinn-Phong with the (N+8)/(8 pi) normalization (Akenine-Moller et al., Real-Time Rendering)
// and the lab report's smoothness mapping N = 8192^(1-s). Twin of src/model/blinn_phong.rs.
#include "brdf/terms.glsl"

struct BlinnPhongParams {
    vec3 diffuse;
    float smoothness;
    vec3 specular;
};

// N = 8192^(1-s) = 2^(13 (1-s)), exact at s = 0 and s = 1.
float blinn_phong_exponent(float smoothness) {
    return exp2(13.0 * (1.0 - smoothness));
}

// s = wi + wo, exact from the albedo kernel's mirror offsets (half_vector_from_sum in terms.glsl).
vec3 blinn_phong_from_sum(BlinnPhongParams p, vec3 wi, vec3 wo, vec3 s) {
    vec3 h = normalize(s);
    float n = blinn_phong_exponent(p.smoothness);
    float lobe = (n + 8.0) / (8.0 * PI) * pow1m(one_minus_cos_theta(h), n);
    return p.diffuse * INV_PI + p.specular * lobe;
}

vec3 blinn_phong(BlinnPhongParams p, vec3 wi, vec3 wo) {
    return blinn_phong_from_sum(p, wi, wo, wi + wo);
}
#define MODEL_EVAL_SUM blinn_phong_from_sum
