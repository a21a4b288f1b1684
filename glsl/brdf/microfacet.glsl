// The general microfacet model: f = diffuse/pi + specular F(c_d) D(h) G(wi, wo) / (4 c_i c_o),
// plus, with multiscatter = kulla_conty, specular F_ms f_ms (Kulla & Conty 2017).
// Each component choice is a specialization constant, so the driver compiles only the branch a
// pipeline uses. Twin of src/model/microfacet.rs (formulas and citations there and in terms).
#include "brdf/terms.glsl"

layout(constant_id = 3) const uint MF_DISTRIBUTION = 1u;  // 0 beckmann, 1 ggx
layout(constant_id = 4) const uint MF_MASKING = 2u;       // 0 v_cavity, 1 smith_separable, 2 smith_correlated
layout(constant_id = 5) const uint MF_BECKMANN_G1 = 0u;   // 0 exact (erf), 1 rational (Walter 2007)
layout(constant_id = 6) const uint MF_FRESNEL = 1u;       // 0 none, 1 schlick, 2 dielectric, 3 conductor
layout(constant_id = 7) const uint MF_MULTISCATTER = 0u;  // 0 none, 1 kulla_conty

// The Kulla-Conty table of this pipeline's distribution and masking (binding 7,
// MODEL_DATA_BINDING in src/gpu/pipeline.rs; src/model/kulla_conty.rs): the loss L = 1 - E at
// s = sqrt(mu) = j/64 and r = sqrt(alpha) = k/64 at index 65 k + j, then L_avg of each row k.
const int KC_KNOTS = 65;
layout(std430, set = 0, binding = 7) readonly buffer KullaContyTable { float kc_table[]; };

struct MicrofacetParams {
    vec3 specular;
    float alpha_x;
    vec3 diffuse;
    float alpha_y;
    vec3 f0;
    float ior;
    vec3 eta;
    vec3 k;
    vec3 f_avg;  // 2 * integral of F(mu) mu dmu, from the host
};

float microfacet_lambda(MicrofacetParams p, vec3 w) {
    float t2 = alpha_tan2(w, p.alpha_x, p.alpha_y);
    if (MF_DISTRIBUTION == 1u) return lambda_ggx(t2);
    if (MF_BECKMANN_G1 == 0u) return lambda_beckmann(t2);
    return 1.0 / G1_beckmann_rational(t2) - 1.0;
}

// 4-point Lagrange weights at u in [0, 64] on the knots 0 ... 64; returns the first knot.
int kc_lagrange(float u, out vec4 w) {
    u = clamp(u, 0.0, float(KC_KNOTS - 1));
    int i0 = min(max(int(floor(u)) - 1, 0), KC_KNOTS - 4);
    float t = u - float(i0);
    w = vec4(-(t - 1.0) * (t - 2.0) * (t - 3.0) / 6.0, t * (t - 2.0) * (t - 3.0) / 2.0,
             -t * (t - 1.0) * (t - 3.0) / 2.0, t * (t - 1.0) * (t - 2.0) / 6.0);
    return i0;
}

// L(mu; alpha) = 1 - E, tensor-product cubic in (sqrt(mu), sqrt(alpha)), clamped at 0.
float kc_loss(float mu, int k0, vec4 wk) {
    vec4 wj;
    int j0 = kc_lagrange(sqrt(max(mu, 0.0)) * float(KC_KNOTS - 1), wj);
    float sum = 0.0;
    for (int a = 0; a < 4; a++) {
        int base = (k0 + a) * KC_KNOTS + j0;
        vec4 row = vec4(kc_table[base], kc_table[base + 1], kc_table[base + 2], kc_table[base + 3]);
        sum += wk[a] * dot(wj, row);
    }
    return max(sum, 0.0);
}

// specular F_ms f_ms: f_ms = L(mu_o) L(mu_i) / (pi L_avg), F_ms = F_avg^2 E_avg / (1 - F_avg L_avg),
// at alpha = sqrt(alpha_x alpha_y); 0 where L_avg is 0.
vec3 kulla_conty(MicrofacetParams p, float c_i, float c_o) {
    vec4 wk;
    int k0 = kc_lagrange(sqrt(sqrt(p.alpha_x * p.alpha_y)) * float(KC_KNOTS - 1), wk);
    int avg = KC_KNOTS * KC_KNOTS + k0;
    float l_avg = dot(wk, vec4(kc_table[avg], kc_table[avg + 1], kc_table[avg + 2], kc_table[avg + 3]));
    if (l_avg <= 0.0) return vec3(0.0);
    float f_ms = kc_loss(c_o, k0, wk) * kc_loss(c_i, k0, wk) / (PI * l_avg);
    vec3 f_avg = WHITE_FURNACE ? vec3(1.0) : p.f_avg;
    return f_avg * f_avg * (1.0 - l_avg) / (1.0 - f_avg * l_avg) * f_ms;
}

vec3 microfacet(MicrofacetParams p, vec3 wi, vec3 wo) {
    float c_d;
    vec3 h = half_vector(wi, wo, c_d);
    float c_i = wi.z, c_o = wo.z;
    float d = MF_DISTRIBUTION == 0u ? D_beckmann(h, p.alpha_x, p.alpha_y) : D_ggx(h, p.alpha_x, p.alpha_y);
    float g;
    if (MF_MASKING == 0u) {
        g = G_v_cavity(h.z, c_d, c_i, c_o);
    } else if (MF_MASKING == 1u) {
        g = 1.0 / ((1.0 + microfacet_lambda(p, wi)) * (1.0 + microfacet_lambda(p, wo)));
    } else {
        g = 1.0 / (1.0 + microfacet_lambda(p, wi) + microfacet_lambda(p, wo));
    }
    vec3 f;
    if (WHITE_FURNACE || MF_FRESNEL == 0u) {
        f = vec3(1.0);
    } else if (MF_FRESNEL == 1u) {
        f = F_schlick(c_d, p.f0);
    } else if (MF_FRESNEL == 2u) {
        f = vec3(F_dielectric(c_d, p.ior));
    } else {
        f = F_conductor(c_d, p.eta, p.k);
    }
    // Summed in cook_torrance's order (specular * F first), so that cook_torrance equals its
    // microfacet configuration to the last bit; the f64 twin sums the same way.
    vec3 f_total = p.diffuse * INV_PI + p.specular * f * (d * g / (4.0 * c_i * c_o));
    if (MF_MULTISCATTER == 1u) f_total += p.specular * kulla_conty(p, c_i, c_o);
    return f_total;
}
