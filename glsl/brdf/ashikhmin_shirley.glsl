// Ashikhmin & Shirley 2000, "An anisotropic Phong BRDF model" (JGT 5(2)), eqs. 4 and 5.
// Twin of src/model/ashikhmin_shirley.rs.
#include "brdf/terms.glsl"
#include "brdf/sample.glsl"

struct AshikhminShirleyParams {
    vec3 diffuse_scale;       // 28/(23 pi) diffuse (1 - specular), from the host
    float nu;
    vec3 specular;
    float nv;
    vec3 one_minus_specular;  // 1 - specular
    float spec_norm;          // sqrt((nu + 1)(nv + 1))/(8 pi)
    float mean_exponent;      // (nu + nv)/2
    float base_luminance;     // luminance of diffuse (1 - specular), for the sampler
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

// A half vector from Ashikhmin & Shirley 2000, section 3 (eq. 9): the quadrant q = floor(4 u1)
// by the density's symmetry, phi in it by atan(sqrt((nu + 1)/(nv + 1)) tan(pi xi / 2)) taken as
// an atan of the two scaled sides, cos(theta_h) = u2^(1/(e + 1)) with 1 - cos(theta_h) =
// -expm1(ln(u2) / (e + 1)); u2 = 0 gives theta_h = pi/2 (GLSL's log(0) is undefined, hence the
// branch).
vec3 sample_ashikhmin_shirley_h(float nu, float nv, vec2 u) {
    float x = 4.0 * u.x;
    int q = min(int(x), 3);
    float t = 0.5 * PI * (x - float(q));
    float phi1 = atan(sqrt(nu + 1.0) * sin(t), sqrt(nv + 1.0) * cos(t));
    float phi = q == 0 ? phi1 : q == 1 ? PI - phi1 : q == 2 ? PI + phi1 : 2.0 * PI - phi1;
    float c = cos(phi), s = sin(phi);
    float e = nu * c * c + nv * s * s;
    // 1 - u2 rather than u2, as the twin: the draws' numbers include 0 and never 1.
    float one_minus_c = -expm1_nonpositive(log1m(u.y) / (e + 1.0));
    float sin_h = sqrt(max(one_minus_c * (2.0 - one_minus_c), 0.0));
    return vec3(sin_h * c, sin_h * s, 1.0 - one_minus_c);
}

// The density of sample_ashikhmin_shirley_h over the solid angle of h (eq. 8).
float pdf_ashikhmin_shirley_h(AshikhminShirleyParams p, vec3 h) {
    float e = ashikhmin_shirley_exponent(h, p.nu, p.nv, p.mean_exponent);
    return sqrt((p.nu + 1.0) * (p.nv + 1.0)) / (2.0 * PI) * pow1m(one_minus_cos_theta(h), e);
}

// The coat's Fresnel factor at c_o (1 under the white furnace) against the base's diffuse (1 - R0).
float ashikhmin_shirley_lobe_probability(AshikhminShirleyParams p, vec3 wo) {
    float coat = luminance(F_specular(wo.z, p.specular, p.one_minus_specular));
    return mixture_share(coat, p.base_luminance);
}

// (1 - P) cos(theta_i)/pi + P p_h(h) / (4 wo.h) (eq. 10).
float pdf_ashikhmin_shirley(AshikhminShirleyParams p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) return 0.0;
    float c_d;
    vec3 h = half_vector_from_sum(wi + wo, c_d);
    float lobe = ashikhmin_shirley_lobe_probability(p, wo);
    return (1.0 - lobe) * pdf_cosine(wi) + lobe * pdf_ashikhmin_shirley_h(p, h) / (4.0 * c_d);
}

// The mixture of the coat's half-vector lobe (wi = wo reflected about h) and the cosine.
Sample sample_ashikhmin_shirley(AshikhminShirleyParams p, vec3 wo, float uc, vec2 u) {
    vec3 wi = uc < ashikhmin_shirley_lobe_probability(p, wo)
        ? reflect_about(wo, sample_ashikhmin_shirley_h(p.nu, p.nv, u))
        : sample_cosine(u);
    return sample_from_draw(wi, pdf_ashikhmin_shirley(p, wi, wo), ashikhmin_shirley(p, wi, wo));
}
