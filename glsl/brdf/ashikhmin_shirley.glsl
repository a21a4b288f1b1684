// Ashikhmin & Shirley 2000, "An anisotropic Phong BRDF model" (JGT 5(2)), eqs. 4 and 5.
// Twin of src/model/ashikhmin_shirley.rs.
#include "brdf/terms.glsl"

struct AshikhminShirleyParams {
    vec3 diffuse_scale;       // 28/(23 pi) diffuse (1 - specular), from the host
    float nu;
    vec3 specular;
    float nv;
    vec3 one_minus_specular;  // 1 - specular
    float spec_norm;          // sqrt((nu + 1)(nv + 1))/(8 pi)
    float mean_exponent;      // (nu + nv)/2
};

// (nu h_x^2 + nv h_y^2) / (1 - c_h^2), with 1 - c_h^2 taken as h_x^2 + h_y^2 so that it does not
// cancel near h = n. At h = n exactly the ratio is 0/0, but c_h = 1 there and 1^e = 1 for any
// finite e, so any finite value will do: the mean of the two exponents keeps it continuous along
// the diagonal (mean_exponent, from the host).
float ashikhmin_shirley_exponent(vec3 h, float nu, float nv, float mean_exponent) {
    float hx2 = h.x * h.x, hy2 = h.y * h.y;
    float s = hx2 + hy2;
    return s > 0.0 ? (nu * hx2 + nv * hy2) / s : mean_exponent;
}

// s = wi + wo, exact from the albedo kernel's mirror offsets (half_vector_from_sum in terms.glsl).
vec3 ashikhmin_shirley_from_sum(AshikhminShirleyParams p, vec3 wi, vec3 wo, vec3 s) {
    float c_d;
    vec3 h = half_vector_from_sum(s, c_d);
    float c_i = wi.z, c_o = wo.z;
    float e = ashikhmin_shirley_exponent(h, p.nu, p.nv, p.mean_exponent);
    float spec = p.spec_norm * pow1m(one_minus_cos_theta(h), e) / (c_d * max(c_i, c_o));
    vec3 rho_s = spec * F_specular(c_d, p.specular, p.one_minus_specular);
    vec3 rho_d = p.diffuse_scale * (pow5_complement(0.5 * c_i) * pow5_complement(0.5 * c_o));
    return rho_s + rho_d;
}

vec3 ashikhmin_shirley(AshikhminShirleyParams p, vec3 wi, vec3 wo) {
    return ashikhmin_shirley_from_sum(p, wi, wo, wi + wo);
}
#define MODEL_EVAL_SUM ashikhmin_shirley_from_sum
