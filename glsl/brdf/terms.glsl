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
    return exp(n * log1m(s));
}

// 1 - h.z for a unit vector h, from its tangential components: (h_x^2 + h_y^2) / (1 + h_z),
// free of the cancellation of 1 - h.z when h is close to n.
float one_minus_cos_theta(vec3 h) {
    return (h.x * h.x + h.y * h.y) / (1.0 + h.z);
}

// Half vector h = normalize(wi + wo) and c_d = wi.h. For unit wi and wo,
// wi.h = (1 + wi.wo) / |wi + wo| = |wi + wo| / 2: exactly symmetric in wi and wo, and free of the
// cancellation that dot(wi, h) suffers when wi and wo are nearly opposite (grazing, h -> n).
vec3 half_vector(vec3 wi, vec3 wo, out float c_d) {
    vec3 s = wi + wo;
    float len = length(s);
    c_d = 0.5 * len;
    return s / len;
}

// Normal-incidence reflectance of a dielectric with relative IOR eta.
float r0_from_ior(float eta) {
    float r = (eta - 1.0) / (eta + 1.0);
    return r * r;
}

// Schlick 1994, "An inexpensive BRDF model for physically-based rendering", eq. 15.
vec3 F_schlick(float c, vec3 r0) {
    return r0 + (1.0 - r0) * pow5(1.0 - c);
}

// The Fresnel factor of a specular lobe, or 1 under the white furnace (DESIGN §3).
vec3 F_specular(float c, vec3 r0) {
    return WHITE_FURNACE ? vec3(1.0) : F_schlick(c, r0);
}

// Beckmann distribution (Beckmann & Spizzichino 1963; Cook & Torrance 1982, eq. 4) with RMS slope m:
// D = exp(-tan^2(theta_h) / m^2) / (pi m^2 cos^4(theta_h)).
// tan^2 is taken as (h_x^2 + h_y^2) / h_z^2 rather than (1 - c_h^2) / c_h^2, which cancels
// catastrophically in f32 when h is close to n.
float D_beckmann(vec3 h, float m) {
    float ch2 = h.z * h.z;
    float tan2 = (h.x * h.x + h.y * h.y) / ch2;
    float m2 = m * m;
    return exp(-tan2 / m2) / (PI * m2 * ch2 * ch2);
}

#endif
