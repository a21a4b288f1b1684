// The general microfacet model: f = diffuse/pi + specular F(c_d) D(h) G(wi, wo) / (4 c_i c_o),
// plus, with multiscatter = kulla_conty, specular F_ms f_ms (Kulla & Conty 2017).
// Each component choice is a specialization constant, so the driver compiles only the branch a
// pipeline uses. Twin of src/model/microfacet.rs (formulas and citations there and in terms).
// What depends on the parameters alone arrives computed in the block (Microfacet::gpu_params in
// the twin); D and G come as (numerator, denominator) pairs, so that one division serves the
// specular lobe.
#include "brdf/terms.glsl"
#include "brdf/sample.glsl"
#include "brdf/kulla_conty.glsl"

layout(constant_id = 3) const uint MF_DISTRIBUTION = 1u;  // 0 beckmann, 1 ggx
layout(constant_id = 4) const uint MF_MASKING = 2u;       // 0 v_cavity, 1 smith_separable, 2 smith_correlated
layout(constant_id = 5) const uint MF_BECKMANN_G1 = 0u;   // 0 exact (erf), 1 rational (Walter 2007)
layout(constant_id = 6) const uint MF_FRESNEL = 1u;       // 0 none, 1 schlick, 2 dielectric, 3 conductor
layout(constant_id = 7) const uint MF_MULTISCATTER = 0u;  // 0 none, 1 kulla_conty

struct MicrofacetParams {
    vec3 specular;
    float alpha2_x;          // alpha_x^2
    vec3 diffuse_over_pi;    // diffuse / pi
    float alpha2_y;          // alpha_y^2
    vec3 f0;                 // Schlick's R0
    float inv_alpha2_x;      // 1 / alpha_x^2
    vec3 one_minus_f0;       // 1 - R0
    float inv_alpha2_y;      // 1 / alpha_y^2
    vec3 conductor_e2m1k2;   // (eta - 1)(eta + 1) - k^2
    float d_norm;            // 1 / (pi alpha_x alpha_y)
    vec3 conductor_q4;       // 4 eta^2 k^2
    float dielectric_e2m1;   // (ior - 1)(ior + 1)
    vec3 kc_scale;           // F_ms / (pi L_avg) of the Kulla-Conty lobe
    float kc_scale_white;    // the same with F_avg = 1 (white furnace)
    vec4 kc_weights;         // Lagrange weights in sqrt(alpha) (kulla_conty.glsl)
    uint kc_row;             // the first of their four knots
    float lobe_luminance;    // luminance of specular F_avg, for the sampler
    float kc_luminance;      // luminance of the Kulla-Conty lobe's specular F_ms
    float kc_luminance_white;  // the same with F_avg = 1
};

// Smith Lambda of direction w (c = w.z > 0) for Beckmann's exact G1 (GGX needs none:
// microfacet_vis).
float microfacet_lambda(MicrofacetParams p, vec3 w) {
    return lambda_beckmann(alpha_sin2(w, p.alpha2_x, p.alpha2_y), w.z);
}

// D at h = s / |s| as (numerator, denominator), from s = wi + wo and s2 = |s|^2. For GGX,
// ggx_q(h) = ggx_q(s) / s2: normalised by one division, since ggx_q(s)^2 and s2^2 apart scale as
// |s|^4, which leaves f32's range where wi and wo are grazing and opposite (|s| ~ 1e-7).
vec2 microfacet_d(MicrofacetParams p, vec3 s, float s2) {
    if (MF_DISTRIBUTION == 0u) {
        return vec2(D_beckmann(s, s2, p.inv_alpha2_x, p.inv_alpha2_y, p.d_norm), 1.0);
    }
    float q = ggx_q(s, p.inv_alpha2_x, p.inv_alpha2_y) / s2;
    return vec2(p.d_norm, q * q);
}

// G as (numerator, denominator), for V-cavity and Beckmann's two G1. With Walter's rational
// G1 = n/d, Lambda = d/n - 1, so G_separable = n_i n_o / (d_i d_o) and
// G_correlated = 1/(1 + Lambda_i + Lambda_o) = n_i n_o / (d_i n_o + d_o n_i - n_i n_o).
vec2 microfacet_g(MicrofacetParams p, vec3 s, float c_d, vec3 wi, vec3 wo) {
    if (MF_MASKING == 0u) return G_v_cavity(s.z, c_d, wi.z, wo.z);
    if (MF_BECKMANN_G1 == 1u) {
        vec2 gi = G1_beckmann_rational(alpha_sin2(wi, p.alpha2_x, p.alpha2_y), wi.z);
        vec2 go = G1_beckmann_rational(alpha_sin2(wo, p.alpha2_x, p.alpha2_y), wo.z);
        float n = gi.x * go.x;
        return vec2(n, MF_MASKING == 1u ? gi.y * go.y : gi.y * go.x + go.y * gi.x - n);
    }
    float lambda_i = microfacet_lambda(p, wi), lambda_o = microfacet_lambda(p, wo);
    if (MF_MASKING == 1u) return vec2(1.0, (1.0 + lambda_i) * (1.0 + lambda_o));
    return vec2(1.0, 1.0 + lambda_i + lambda_o);
}

// The visibility G / (4 c_i c_o) as (numerator, denominator), so that one division serves the
// specular lobe. For GGX the Smith forms need no Lambda: with q = (alpha sin theta)^2 and
// s = sqrt(c^2 + q), Lambda = (s - c)/(2c) (Heitz 2014, eq. 86), so 1 + Lambda = (c + s)/(2c) and
// - separable: G/(4 c_i c_o) = 1/((c_i + s_i)(c_o + s_o));
// - height-correlated: G/(4 c_i c_o) = 1/(2 (c_o s_i + c_i s_o)) (the form of Filament's
//   V_SmithGGXCorrelated).
// Neither divides nor cancels, and both stay finite as c_i or c_o goes to 0. The f64 twin
// (microfacet.rs) keeps the form in Lambda.
vec2 microfacet_vis(MicrofacetParams p, vec3 s, float c_d, vec3 wi, vec3 wo) {
    float c_i = wi.z, c_o = wo.z;
    if (MF_MASKING != 0u && MF_DISTRIBUTION == 1u) {
        float s_i = sqrt(c_i * c_i + alpha_sin2(wi, p.alpha2_x, p.alpha2_y));
        float s_o = sqrt(c_o * c_o + alpha_sin2(wo, p.alpha2_x, p.alpha2_y));
        if (MF_MASKING == 1u) return vec2(1.0, (c_i + s_i) * (c_o + s_o));
        return vec2(0.5, c_o * s_i + c_i * s_o);
    }
    vec2 g = microfacet_g(p, s, c_d, wi, wo);
    return vec2(g.x, 4.0 * c_i * c_o * g.y);
}

// The Fresnel factor at c_d, for fresnel = schlick, dielectric or conductor.
vec3 microfacet_fresnel(MicrofacetParams p, float c_d) {
    if (MF_FRESNEL == 1u) return F_schlick(c_d, p.f0, p.one_minus_f0);
    if (MF_FRESNEL == 2u) return vec3(F_dielectric(c_d, p.dielectric_e2m1));
    return F_conductor(c_d, p.conductor_e2m1k2, p.conductor_q4);
}

// The Fresnel factor the specular lobe takes at c_d: microfacet_fresnel's, 1 without one or
// under the white furnace.
vec3 microfacet_fresnel_factor(MicrofacetParams p, float c_d) {
    if (WHITE_FURNACE || MF_FRESNEL == 0u) return vec3(1.0);
    return microfacet_fresnel(p, c_d);
}

// f at s = wi + wo with the Fresnel factor given (microfacet_fresnel_factor at c_d = |s| / 2):
// the same operations as microfacet_from_sum (a factor of 1 multiplies exactly).
vec3 microfacet_from_sum_fresnel(MicrofacetParams p, vec3 wi, vec3 wo, vec3 s, vec3 fresnel) {
    float s2;
    float c_d = half_sum(s, s2);
    float c_i = wi.z, c_o = wo.z;
    // specular F.
    vec3 weight = p.specular * fresnel;
    // D G / (4 c_i c_o) with one division; for Beckmann (D's denominator 1) it rounds as
    // specular_ratio does in cook_torrance.
    vec2 d = microfacet_d(p, s, s2);
    vec2 v = microfacet_vis(p, s, c_d, wi, wo);
    float spec = d.x * v.x / (d.y * v.y);
    // Summed in cook_torrance's order (specular * F first), so that cook_torrance equals its
    // microfacet configuration to the last bit; the f64 twin sums the same way.
    vec3 f_total = p.diffuse_over_pi + weight * spec;
    if (MF_MULTISCATTER == 1u) {
        vec3 scale = WHITE_FURNACE ? vec3(p.kc_scale_white) : p.kc_scale;
        f_total += p.specular * kulla_conty(int(p.kc_row), p.kc_weights, scale, c_i, c_o);
    }
    return f_total;
}

// s = wi + wo, exact from the albedo kernel's mirror offsets (half_vector_from_sum in terms.glsl).
vec3 microfacet_from_sum(MicrofacetParams p, vec3 wi, vec3 wo, vec3 s) {
    float s2;
    float c_d = half_sum(s, s2);
    return microfacet_from_sum_fresnel(p, wi, wo, s, microfacet_fresnel_factor(p, c_d));
}

vec3 microfacet(MicrofacetParams p, vec3 wi, vec3 wo) {
    return microfacet_from_sum(p, wi, wo, wi + wo);
}
#define MODEL_EVAL_SUM microfacet_from_sum
// Whether f is its Fresnel factor times the rest (no diffuse part, no Kulla-Conty lobe): the lit
// sphere's kernel (kernels/light.comp) then folds the factor into each texel's weight.
bool microfacet_fresnel_folds(MicrofacetParams p) {
    return MF_MULTISCATTER == 0u && p.diffuse_over_pi == vec3(0.0);
}
#define MODEL_FRESNEL microfacet_fresnel_factor
#define MODEL_FRESNEL_FOLDS microfacet_fresnel_folds
#define MODEL_EVAL_FRESNEL microfacet_from_sum_fresnel

// The specular lobe's probability against the cosine's (diffuse and, with Kulla-Conty, that
// lobe's directional albedo at wo, specular F_ms L(mu_o)); the luminances come from the host.
float microfacet_lobe_probability(MicrofacetParams p, vec3 wo) {
    float cosine = luminance(p.diffuse_over_pi) * PI;
    if (MF_MULTISCATTER == 1u) {
        float kc = WHITE_FURNACE ? p.kc_luminance_white : p.kc_luminance;
        cosine += kc * kc_loss(wo.z, int(p.kc_row), p.kc_weights);
    }
    float lobe = WHITE_FURNACE ? luminance(p.specular) : p.lobe_luminance;
    return mixture_share(lobe, cosine);
}

// (1 - P) cos(theta_i)/pi + P D(h) / (4 c_o (1 + Lambda(wo))), the distribution's exact Lambda
// whatever masking f uses.
float pdf_microfacet(MicrofacetParams p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) return 0.0;
    float lobe = microfacet_lobe_probability(p, wo);
    float vndf = pdf_vndf(MF_DISTRIBUTION, wi, wo, sqrt(p.alpha2_x), sqrt(p.alpha2_y));
    return (1.0 - lobe) * pdf_cosine(wi) + lobe * vndf;
}

// The mixture of wo reflected about a visible normal of the distribution (GGX by spherical caps,
// Beckmann by Heitz & d'Eon's slopes) and the cosine.
Sample sample_microfacet(MicrofacetParams p, vec3 wo, float uc, vec2 u) {
    vec3 wi = uc < microfacet_lobe_probability(p, wo)
        ? reflect_about(wo, sample_vndf(MF_DISTRIBUTION, wo, sqrt(p.alpha2_x), sqrt(p.alpha2_y), u))
        : sample_cosine(u);
    return sample_from_draw(wi, pdf_microfacet(p, wi, wo), microfacet(p, wi, wo));
}
