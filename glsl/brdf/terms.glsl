// Terms shared by the BRDF models; twin of src/model/terms.rs.
#ifndef LOBE_TERMS_GLSL
#define LOBE_TERMS_GLSL
#include "common.glsl"

float pow5(float x) {
    float x2 = x * x;
    return x2 * x2 * x;
}

// x^n for x >= 0 with the conventions the formulas assume: x^0 = 1 (also at x = 0, where GLSL's
// pow is undefined) and 0^n = 0 for n > 0 (GLSL's pow is undefined for x <= 0).
float pow_guarded(float x, float n) {
    if (n == 0.0) return 1.0;
    if (x <= 0.0) return 0.0;
    return pow(x, n);
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
