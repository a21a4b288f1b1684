// The energy-preserving Oren-Nayar model, EON (Portsmouth, Kutz & Hill, JCGT 14(1), 2025;
// arXiv 2410.18026): Fujii's lobe f_ss = rho/pi (A + B s/t) plus the multiple-scattering lobe
// f_ms = rho_ms/pi (1 - E(mu_o))(1 - E(mu_i)) / (1 - E_avg), written as
// rho_ms/pi B loss(mu_o) loss(mu_i) / (c1 - c2) with loss = c1 - G/pi (1 - E = B loss,
// 1 - E_avg = B (c1 - c2)): no cancellation for small r, no division by 1 - E_avg -> 0, and
// r = 0 is Lambert exactly. The multiscatter choice is specialization constant 3, so a pipeline
// holds only the branch it uses. Twin of src/model/eon.rs (derivations and citations there).
#include "brdf/terms.glsl"
#include "brdf/sample.glsl"

layout(constant_id = 3) const uint EON_MULTISCATTER = 0u;  // 0 exact, 1 approx, 2 none

// c1 = 1/2 - 2/(3 pi) and c2 = 2/3 - 28/(15 pi) as decimal literals, each rounded once to f32
// (c2 folded in f32 would lose a few ulp to the cancellation 0.667 - 0.594).
const float EON_C1 = 0.2877934092108062190;
const float EON_C2 = 0.0724882124569240798;

// What depends on the parameters alone comes from the host (Eon::gpu_params in the twin):
// A = 1/(1 + c1 r), B = r A, and rho_ms/pi B/(c1 - c2) with rho_ms = rho^2 E_avg/(1 - rho (1 - E_avg)),
// E_avg = A (1 + c2 r).
struct EonParams {
    vec3 albedo_over_pi;  // rho / pi
    float a;
    vec3 ms_scale;        // rho_ms/pi B/(c1 - c2)
    float b;
    float a_one_minus_r;  // A (1 - r)
    float roughness;      // r, for the sampler's fits
};

// theta = atan2(s, mu) for s, mu >= 0 on the unit circle, in plain arithmetic: the Vulkan spec
// lets atan be off by 4096 ulp, which G(theta) would carry into f. Two half-angle steps,
// tan(theta/2) = s/(1 + mu) in [0, 1] and tan(theta/4) = t/(1 + sqrt(1 + t^2)) in [0, tan(pi/8)],
// leave |w| <= 0.4142, where atan's series to w^15 is within 2^-24 relative (the first term left
// out, w^17/17, is at most 0.1716^8/17 = 4.4e-8 of w). The f64 twin uses atan2.
float eon_angle(float s, float mu) {
    float t = s / (1.0 + mu);
    float w = t / (1.0 + sqrt(1.0 + t * t));
    float w2 = w * w;
    return 4.0 * w * (1.0 + w2 * (-1.0 / 3.0 + w2 * (1.0 / 5.0 + w2 * (-1.0 / 7.0 + w2 * (1.0 / 9.0
                    + w2 * (-1.0 / 11.0 + w2 * (1.0 / 13.0 + w2 * (-1.0 / 15.0))))))));
}

// G(theta)/pi without the removable 1/cos(theta): (1 - sin^3)/cos = cos (1 + sin + sin^2)/(1 + sin),
// finite and free of cancellation on both sides of mu = 0 (the f32 form of the paper loses
// about eps/mu there).
float eon_g_over_pi(float mu) {
    float s = sqrt(max(0.0, (1.0 - mu) * (1.0 + mu)));
    float theta = eon_angle(s, mu);
    float g = s * (theta - s * mu) + (2.0 / 3.0) * s * (mu * (1.0 + s + s * s) / (1.0 + s) - 1.0);
    return g * INV_PI;
}

// The paper's quartic fit of G/pi in m = 1 - mu.
float eon_g_over_pi_fit(float mu) {
    float m = 1.0 - mu;
    return m * (0.0571085289 + m * (0.491881867 + m * (-0.332181442 + m * 0.0714429953)));
}

// (1 - E(mu))/B = c1 - G/pi, clamped at 0 (the fit overshoots c1 for mu < 1.4e-3). For the closed
// form, pi c1 - G = (pi/2 - theta) + (theta - 2/3) mu^2/(1 + sin) + sin^2 mu
// - (2/3) sin mu (1 + sin + sin^2)/(1 + sin), with pi/2 - theta taken directly: no cancellation as
// mu -> 0, where subtracting G/pi ~ c1 would leave a relative error of eps/mu.
float eon_loss(float mu) {
    if (EON_MULTISCATTER == 1u) return max(0.0, EON_C1 - eon_g_over_pi_fit(mu));
    float s = sqrt(max(0.0, (1.0 - mu) * (1.0 + mu)));
    float theta = eon_angle(s, mu);
    float complement = eon_angle(mu, s);
    float d = complement + (theta - 2.0 / 3.0) * (mu * mu / (1.0 + s)) + s * s * mu
            - (2.0 / 3.0) * s * mu * (1.0 + s + s * s) / (1.0 + s);
    return max(0.0, d * INV_PI);
}

// E(mu) = A + B G/pi, the single-scattering lobe's directional albedo for rho = 1.
float eon_albedo_ss(float mu, float r) {
    float a = 1.0 / (1.0 + EON_C1 * r);
    float g = EON_MULTISCATTER == 1u ? eon_g_over_pi_fit(mu) : eon_g_over_pi(mu);
    return a + r * a * g;
}

// E_avg = A (1 + c2 r).
float eon_albedo_avg(float r) {
    return (1.0 + EON_C2 * r) / (1.0 + EON_C1 * r);
}

vec3 eon(EonParams p, vec3 wi, vec3 wo) {
    float mu_i = wi.z, mu_o = wo.z;
    vec2 ui = wi.xy, uo = wo.xy;
    float s = dot(ui, uo);  // wi.wo - mu_i mu_o
    // Where s <= 0: A + B s = A (1 - r) + B (1 + s) with 1 + s = (|ui + uo|^2 + mu_i^2 + mu_o^2)/2
    // for unit vectors, a sum of squares: no cancellation as 1 + s -> 0, never negative.
    vec2 u = ui + uo;
    float lobe = s > 0.0 ? p.a + p.b * s / max(mu_i, mu_o)
                         : p.a_one_minus_r + p.b * (0.5 * (dot(u, u) + (mu_i * mu_i + mu_o * mu_o)));
    vec3 f_ss = p.albedo_over_pi * lobe;
    if (EON_MULTISCATTER == 2u) return f_ss;
    return f_ss + p.ms_scale * (eon_loss(mu_o) * eon_loss(mu_i));
}

// The probability of the uniform lobe in the mixture that samples EON (Portsmouth, Kutz & Hill
// 2025, section 5, the fit P_u(mu_o, r) of their listing), clamped to [0, 1]; 0 at r = 0.
float eon_uniform_probability(EonParams p, vec3 wo) {
    float mu = clamp(wo.z, 0.0, 1.0);
    float r = clamp(p.roughness, 0.0, 1.0);
    float fit = 0.162925 + mu * (-0.372058 + mu * (0.538233 - 0.290822 * mu));
    return clamp(pow(r, 0.1) * fit, 0.0, 1.0);
}

// The transform M = [[a, 0, b], [0, c, 0], [d, 0, 1]] of EON's clipped linearly transformed
// cosine (ibid., section 5, the coefficients' rational fits in mu_o and r); both denominators are
// negative on [0, 1].
vec4 eon_ltc_coefficients(float mu, float r) {
    float a = 1.0 + r * (0.303392 + (-0.518982 + 0.111709 * mu) * mu + (-0.276266 + 0.335918 * mu) * r);
    float b = r * (-1.16407 + 1.15859 * mu + (0.150815 - 0.150105 * mu) * r) / (mu * mu * mu - 1.43545);
    float c = 1.0 + r * (0.20013 + (-0.506373 + 0.261777 * mu) * mu);
    float d = r * (0.540852 + (-1.01625 + 0.475392 * mu) * mu) / (-1.0743 + (0.0725628 + mu) * mu);
    return vec4(a, b, c, d);
}

// The frame's X, the unit azimuth of wo (+x for wo along the normal); Y = Z x X.
void eon_ltc_frame(vec3 wo, out vec3 x, out vec3 y) {
    float len = sqrt(wo.x * wo.x + wo.y * wo.y);
    x = len > 0.0 ? vec3(wo.x / len, wo.y / len, 0.0) : vec3(1.0, 0.0, 0.0);
    y = vec3(-x.y, x.x, 0.0);
}

// The share (1 + 1/sqrt(1 + d^2))/2 of the cosine-weighted disk that the clip keeps.
float eon_clip_share(float d) {
    return 0.5 * (1.0 + inversesqrt(1.0 + d * d));
}

// A direction of EON's clipped linearly transformed cosine: a uniform point of the kept part of
// the unit disk (squeezed as in Heitz 2018, section 4.2), lifted to the hemisphere, then
// wi = M w / |M w| in the frame of wo.
vec3 sample_eon_cltc(EonParams p, vec3 wo, vec2 u) {
    vec4 m = eon_ltc_coefficients(clamp(wo.z, 0.0, 1.0), p.roughness);
    float s = eon_clip_share(m.w);
    float radius = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    float x0 = radius * cos(phi), y = radius * sin(phi);
    float side = m.w > 0.0 ? 1.0 : -1.0;
    float x = side * ((1.0 - s) * sqrt(max(1.0 - y * y, 0.0)) + s * x0);
    float z = sqrt(max(1.0 - x * x - y * y, 0.0));
    vec3 w = normalize(vec3(m.x * x + m.y * z, m.z * y, m.w * x + z));
    vec3 fx, fy;
    eon_ltc_frame(wo, fx, fy);
    return normalize(w.x * fx + w.y * fy + vec3(0.0, 0.0, w.z));
}

// The density of sample_eon_cltc: det(M)^2 max(0, w_z) / (pi s |w|^4), w = adj(M) wi in the
// frame of wo (Heitz, Dupuy, Hill & Neubelt 2016, "Real-Time Polygonal-Light Shading with
// Linearly Transformed Cosines").
float pdf_eon_cltc(EonParams p, vec3 wi, vec3 wo) {
    vec4 m = eon_ltc_coefficients(clamp(wo.z, 0.0, 1.0), p.roughness);
    vec3 fx, fy;
    eon_ltc_frame(wo, fx, fy);
    float x = dot(wi, fx), y = dot(wi, fy), z = wi.z;
    vec3 w = vec3(m.z * (x - m.y * z), (m.x - m.y * m.w) * y, m.z * (m.x * z - m.w * x));
    float det = m.z * (m.x - m.y * m.w);
    float len2 = dot(w, w);
    return det * det * max(w.z, 0.0) / (PI * eon_clip_share(m.w) * len2 * len2);
}

// P_u/(2 pi) + (1 - P_u) pdf_eon_cltc; 0 below the horizon.
float pdf_eon(EonParams p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0) return 0.0;
    float pu = eon_uniform_probability(p, wo);
    return pu * pdf_uniform_hemisphere(wi) + (1.0 - pu) * pdf_eon_cltc(p, wi, wo);
}

// The paper's mixture: the uniform hemisphere with probability P_u (by uc), else the clipped
// transformed cosine.
Sample sample_eon(EonParams p, vec3 wo, float uc, vec2 u) {
    vec3 wi = uc < eon_uniform_probability(p, wo) ? sample_uniform_hemisphere(u)
                                                  : sample_eon_cltc(p, wo, u);
    return sample_from_draw(wi, pdf_eon(p, wi, wo), eon(p, wi, wo));
}
