// Terms shared by the BRDF models; twin of src/model/terms.rs.
#ifndef LOBE_TERMS_GLSL
#define LOBE_TERMS_GLSL
#include "common.glsl"

float pow5(float x) {
    float x2 = x * x;
    return x2 * x2 * x;
}

// log(1 - s) for 0 <= s < 1, accurate to a few ulp even when s is tiny.
// Why: a lobe cos^n with cos near 1 is pow(cos, n) = exp(n log cos). Rounding cos to f32 alone
// costs an absolute error of 2^-24 in log cos, which n = 8192 turns into a relative error of 5e-4
// in the result, and the Vulkan spec allows log2 an absolute error of 2^-21 near 1 (0.3 % at
// n = 8192). Taking s = 1 - cos from the geometry (a half-angle sine squared, computed without
// cancellation) and log(1 - s) = 2 atanh(u), u = -s / (2 - s), leaves only the relative error of s
// and of a short series in plain arithmetic: a few ulp. For s > 1/2, cos < 1/2 is far from 1 and
// log is accurate (3 ulp outside [0.5, 2]).
float log1m(float s) {
    if (s > 0.5) return log(1.0 - s);
    float u = -s / (2.0 - s);  // |u| <= 1/3: the series below reaches 2^-24 with terms to u^15
    float u2 = u * u;
    return 2.0 * u * (1.0 + u2 * (1.0 / 3.0 + u2 * (1.0 / 5.0 + u2 * (1.0 / 7.0 + u2 * (1.0 / 9.0
                    + u2 * (1.0 / 11.0 + u2 * (1.0 / 13.0 + u2 * (1.0 / 15.0))))))));
}

// (1 - s)^n for s >= 0, i.e. cos^n given s = 1 - cos, with the conventions the formulas assume:
// x^0 = 1 even at x = 0, and 0^n = 0 for n > 0 (cos <= 0 means s >= 1).
// The remaining error is exp's own, 3 + 2|x| ulp for x = n log(1 - s) (Vulkan spec): at most a
// few dozen ulp wherever the value is within e^-20 of the lobe's peak, for any exponent.
float pow1m(float s, float n) {
    if (n == 0.0) return 1.0;
    if (s >= 1.0) return 0.0;
    if (FAST_POW) return pow(1.0 - s, n);  // the fast variant: exp2(n log2(cos)), cos rounded
    return exp(n * log1m(s));
}

// 1 - h.z for a unit vector h, from its tangential components: (h_x^2 + h_y^2) / (1 + h_z),
// free of the cancellation of 1 - h.z when h is close to n.
float one_minus_cos_theta(vec3 h) {
    return (h.x * h.x + h.y * h.y) / (1.0 + h.z);
}

// half_vector from s = wi + wo given by the caller. Near the mirror direction the tangential parts
// of wi and wo cancel: their f32 rounding (eps sin(theta) each) stays in wi + wo while the sum's
// length shrinks to 2 c_o, so h's direction is off by about eps / (2 c_o), which a lobe of width
// alpha ~ 1e-3 at grazing view resolves. The albedo kernel knows s exactly (its nodes are offsets
// from the mirror direction, glsl/kernels/albedo.comp) and passes it here instead.
// One inverse square root normalises s; |s| = |s|^2 / |s| follows without a square root.
vec3 half_vector_from_sum(vec3 s, out float c_d) {
    float s2 = dot(s, s);
    float inv_len = inversesqrt(s2);
    c_d = 0.5 * (s2 * inv_len);
    return s * inv_len;
}

// Half vector h = normalize(wi + wo) and c_d = wi.h. For unit wi and wo,
// wi.h = (1 + wi.wo) / |wi + wo| = |wi + wo| / 2: exactly symmetric in wi and wo, and free of the
// cancellation that dot(wi, h) suffers when wi and wo are nearly opposite (grazing, h -> n).
vec3 half_vector(vec3 wi, vec3 wo, out float c_d) {
    return half_vector_from_sum(wi + wo, c_d);
}

// The sum s = wi + wo as the microfacet terms take it, not normalised: returns
// c_d = wi.h = |s| / 2 (as half_vector_from_sum) with one square root, and |s|^2 in s2. D and
// the V-cavity G below read h = s / |s| through s, so that no inverse square root is spent on h.
// The f64 twin is half_vector_from_sum in terms.rs.
float half_sum(vec3 s, out float s2) {
    s2 = dot(s, s);
    return 0.5 * sqrt(s2);
}

// D G / (4 c_i c_o) for D = d.x / d.y and G = g.x / g.y: one division for the specular lobe.
float specular_ratio(vec2 d, vec2 g, float c_i, float c_o) {
    return d.x * g.x / (4.0 * c_i * c_o * d.y * g.y);
}

// Normal-incidence reflectance of a dielectric with relative IOR eta.
float r0_from_ior(float eta) {
    float r = (eta - 1.0) / (eta + 1.0);
    return r * r;
}

// Schlick 1994, "An inexpensive BRDF model for physically-based rendering", eq. 15.
// c is clamped to 1: c_d = |wi + wo|/2 of unit-length f32 inputs (|w| = 1 +- a few ulp) can round
// above 1, and (1 - c)^5 < 0 would then push F below R0 (below 0 for R0 = 0, an index-matched
// interface).
// one_minus_r0 = 1 - r0 comes from the host with r0.
vec3 F_schlick(float c, vec3 r0, vec3 one_minus_r0) {
    return r0 + one_minus_r0 * pow5(1.0 - min(c, 1.0));
}

// 1 - (1 - x)^5 for x in [0, 1], the diffuse factor of Shirley's coupled and Ashikhmin-Shirley's
// models. Written as x (1 + y + y^2 + y^3 + y^4) with y = 1 - x (1 - y^5 = (1 - y)(1 + ... + y^4)):
// every term is positive, so there is no cancellation; the direct form loses all digits in f32 when
// x is below the unit roundoff (grazing directions, cos theta ~ 1e-7), where the factor is ~5x.
float pow5_complement(float x) {
    float y = 1.0 - x;
    return x * (1.0 + y * (1.0 + y * (1.0 + y * (1.0 + y))));
}

// The Fresnel factor of a specular lobe, or 1 under the white furnace (docs/design.md §3).
vec3 F_specular(float c, vec3 r0, vec3 one_minus_r0) {
    return WHITE_FURNACE ? vec3(1.0) : F_schlick(c, r0, one_minus_r0);
}

// Beckmann distribution (Beckmann & Spizzichino 1963; Cook & Torrance 1982, eq. 4), anisotropic
// as in Heitz 2014 ("Understanding the masking-shadowing function", eq. 84), RMS slopes ax, ay:
// D = exp(-(h_x^2/ax^2 + h_y^2/ay^2) / h_z^2) / (pi ax ay h_z^4), at h = s / |s|, taken from
// s = wi + wo (s.z > 0) and s2 = |s|^2 (half_sum) without forming h: the exponent is
// (s_x^2/ax^2 + s_y^2/ay^2) / s_z^2 and 1/h_z^2 = s2 / s_z^2, so one reciprocal of s_z^2 serves
// both. The exponent is tan^2(theta_h) weighted by azimuth, taken from the tangential components
// rather than (1 - c_h^2) / c_h^2, which cancels catastrophically in f32 when h is close to n.
// The f64 twin (D_beckmann in terms.rs) takes h.
// The roughness enters through constants the host computes once per parameter set:
// inv_alpha2_x = 1/ax^2, inv_alpha2_y = 1/ay^2 and d_norm = 1/(pi ax ay). Where exp(-e)
// underflows D is 0 (1/h_z^2 may be +inf there, at a grazing h). Where exp(-e) > 0:
// e >= (1/h_z^2 - 1) / max(ax, ay)^2 and e < 104 bound 1/h_z^2 by 1 + 104 max(ax, ay)^2 <= 105,
// so the product stays finite.
float D_beckmann(vec3 s, float s2, float inv_alpha2_x, float inv_alpha2_y, float d_norm) {
    float inv_sz2 = 1.0 / (s.z * s.z);
    float e = (s.x * s.x * inv_alpha2_x + s.y * s.y * inv_alpha2_y) * inv_sz2;
    float peak = exp(-e);
    float inv_ch2 = s2 * inv_sz2;
    return peak == 0.0 ? 0.0 : peak * d_norm * (inv_ch2 * inv_ch2);
}

// GGX / Trowbridge-Reitz (Walter et al. 2007, eq. 33; anisotropic: Heitz 2014, eq. 85):
// D = 1 / (pi ax ay (h_x^2/ax^2 + h_y^2/ay^2 + h_z^2)^2) = d_norm / ggx_q(h)^2, with the host's
// inv_alpha2_x, inv_alpha2_y and d_norm as for D_beckmann. The caller divides, so that D's
// denominator joins the common one of the specular lobe. Homogeneous of degree 2: for an
// unnormalised s = |s| h, ggx_q(s) = |s|^2 ggx_q(h) (microfacet_d takes it so).
float ggx_q(vec3 h, float inv_alpha2_x, float inv_alpha2_y) {
    return h.x * h.x * inv_alpha2_x + h.y * h.y * inv_alpha2_y + h.z * h.z;
}

// (alpha sin theta)^2 = ax^2 w_x^2 + ay^2 w_y^2 of a direction for anisotropic roughness, with
// the host's alpha2_x = ax^2 and alpha2_y = ay^2: (alpha tan theta)^2 (Heitz 2014, eq. 80 with the
// projected roughness of eq. 81; alpha_tan2 in terms.rs) times w_z^2. The Smith terms below take it
// with c = w_z > 0 and fold the 1/w_z^2 into their own formulas.
float alpha_sin2(vec3 w, float alpha2_x, float alpha2_y) {
    return alpha2_x * w.x * w.x + alpha2_y * w.y * w.y;
}

// erfc(x) for x >= 0 (Press et al., Numerical Recipes, 2nd ed., section 6.2, erfcc): a Chebyshev
// fit with fractional error below 1.2e-7 everywhere, i.e. about one f32 ulp. GLSL has no erf.
float erfc_approx(float x) {
    float t = 1.0 / (1.0 + 0.5 * x);
    return t * exp(-x * x - 1.26551223 + t * (1.00002368 + t * (0.37409196 + t * (0.09678418
        + t * (-0.18628806 + t * (0.27886807 + t * (-1.13520398 + t * (1.48851587
        + t * (-0.82215223 + t * 0.17087277)))))))));
}

// Smith Lambda for Beckmann, exact (Walter et al. 2007, eq. 25 integrated; Heitz 2014, eq. 83):
// a = 1 / sqrt(t2) = c / sqrt(q); Lambda = (erf(a) - 1)/2 + exp(-a^2) / (2 a sqrt(pi)).
// Written with erfc so that erf(a) - 1 does not cancel for large a. Lambda = 0 at w = n.
float lambda_beckmann(float q, float c) {
    if (q <= 0.0) return 0.0;
    float a = c * inversesqrt(q);
    return 0.5 * (exp(-a * a) / (a * 1.7724538509055160) - erfc_approx(a));
}

// Walter et al. 2007, eq. 27: the rational approximation of Beckmann's Smith G1 in a = c / sqrt(q),
// (3.535 a + 2.181 a^2) / (1 + 2.276 a + 2.577 a^2), as (numerator, denominator), so that the caller
// folds the denominator into its own; (1, 1) where G1 = 1 (a >= 1.6, i.e. c^2 >= 2.56 q).
// Both multiplied by q, with r = sqrt(q): c (3.535 r + 2.181 c) / (q + 2.276 c r + 2.577 c^2), so
// that a costs no division (the f64 twin, G1_beckmann_rational in terms.rs, keeps the form in a).
vec2 G1_beckmann_rational(float q, float c) {
    float r = sqrt(q);
    vec2 g = vec2(c * (3.535 * r + 2.181 * c), q + c * (2.276 * r + 2.577 * c));
    return q <= 0.0 || c * c >= 2.56 * q ? vec2(1.0) : g;
}

// Cook-Torrance's V-cavity masking-shadowing: min(1, 2 c_h c_o / c_d, 2 c_h c_i / c_d), from
// s = wi + wo: with c_h = s_z / |s| = s_z / (2 c_d), as (numerator, denominator) =
// (min(c_d^2, s_z min(c_i, c_o)), c_d^2), so that the caller folds c_d^2 into its own
// denominator and no division is spent on c_h. The f64 twin (G_v_cavity in terms.rs) takes c_h.
vec2 G_v_cavity(float s_z, float c_d, float c_i, float c_o) {
    float c_d2 = c_d * c_d;
    return vec2(min(c_d2, s_z * min(c_i, c_o)), c_d2);
}

// Exact unpolarized Fresnel reflectance of a dielectric with relative IOR eta (Walter et al.
// 2007, eq. 22): g^2 = eta^2 - 1 + c^2; F = 1/2 ((g-c)/(g+c))^2 (1 + ((c(g+c)-1)/(c(g-c)+1))^2).
// g^2 < 0 is total internal reflection (only possible for eta < 1).
float F_dielectric(float c, float e2m1) {
    // e2m1 = eta^2 - 1, from the host as (eta - 1)(eta + 1), and g - c as (eta^2 - 1) / (g + c)
    // (g^2 - c^2 = eta^2 - 1): as eta -> 1 both differences would otherwise cancel and F, which
    // is O((eta - 1)^2), would lose every digit in f32.
    float g2 = e2m1 + c * c;
    if (g2 < 0.0) return 1.0;
    float g = sqrt(g2);
    float gpc = g + c;
    // g + c = 0 only for eta = 1 at grazing: no interface, no reflection.
    if (gpc == 0.0) return 0.0;
    float a = e2m1 / (gpc * gpc);
    float s2 = 1.0 - c * c;
    float b = (c * g - s2) / (c * g + s2);
    return 0.5 * a * a * (1.0 + b * b);
}

// Exact unpolarized Fresnel reflectance of a conductor with complex IOR eta + i k, per channel
// (Born & Wolf, Principles of Optics, section 14.2; the a, b form as in Lagarde 2013, "Memo on
// Fresnel equations"). With k = 0 it reduces to F_dielectric.
vec3 F_conductor(float c, vec3 e2m1k2, vec3 q4) {
    // With n + i k = eta + i k and s^2 = sin^2 theta, (a + i b)^2 = (eta + i k)^2 - s^2, so
    // a^2 - b^2 = t0 = eta^2 - 1 - k^2 + c^2 and a b = eta k; then
    // Rs = ((a - c)^2 + b^2) / ((a + c)^2 + b^2),
    // Rp = Rs ((a c - s^2)^2 + b^2 c^2) / ((a c + s^2)^2 + b^2 c^2).
    // Written as sums of squares (never negative) and without the differences that cancel near
    // an index-matched interface (eta -> 1, k -> 0, where F -> 0):
    // - t0 from e2m1k2 + c^2, e2m1k2 = (eta - 1)(eta + 1) - k^2 from the host, not eta^2 - (1 - c^2);
    // - u = a^2 + b^2 = sqrt(t0^2 + 4 a^2 b^2) = sqrt(t0^2 + q4), q4 = 4 eta^2 k^2 from the host;
    // - the larger of a^2, b^2 as w/2 with w = u + |t0| (a sum of positive terms), the smaller as
    //   r = 2 eta^2 k^2 / w (their product is eta^2 k^2), not from (u - |t0|)/2;
    // - a - c as m / (a + c) with m = a^2 - c^2 = e2m1k2 + r when t0 >= 0.
    // The sum of Rp's numerator X and denominator Y is 2 (u c^2 + s^4) = 2 p, and
    // Y = p + 2 a c s^2, so (Rs + Rp)/2 = Rs p / Y with
    // Rs = (m^2 + b^2 (a + c)^2) / ((a + c)^2 ((a + c)^2 + b^2)): one division for F, and every
    // factor a sum of non-negative terms. Against the form that builds X and Y apart, this one
    // measured x1.06 (Mesa 25) and x1.09 (Mesa 22) on the roughconductor table kernel.
    // At eta = 1, k = 0 this gives m = 0, b = 0 and F = 0 exactly.
    float c2 = c * c, s2 = 1.0 - c2;
    vec3 t0 = e2m1k2 + c2;
    vec3 u = sqrt(t0 * t0 + q4);
    vec3 w = u + abs(t0);
    // w = 0 only when q4 = 0 too: the floor makes r = 0 there.
    vec3 r = q4 / max(w + w, vec3(1e-30));
    bvec3 t0_pos = greaterThanEqual(t0, vec3(0.0));
    vec3 hw = 0.5 * w;
    vec3 a2 = mix(r, hw, t0_pos);
    vec3 b2 = mix(hw, r, t0_pos);
    vec3 m = mix(r - c2, e2m1k2 + r, t0_pos);
    vec3 a = sqrt(a2);
    vec3 apc = a + c;
    vec3 apc2 = apc * apc;
    vec3 p = u * c2 + s2 * s2;
    vec3 y = p + a * (2.0 * c * s2);
    return (m * m + b2 * apc2) * p / max(apc2 * (apc2 + b2) * y, vec3(1e-37));
}

#endif
