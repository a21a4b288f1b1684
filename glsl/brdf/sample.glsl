// Importance sampling shared by the models: the Sample a model's sampler returns and the samplers
// its lobes share (cosine, uniform hemisphere, power cosine, GGX and Beckmann visible normals),
// each with its density. Twin of src/model/sample.rs: the same functions under the same names,
// in f32, with the same guards; the conventions are docs/design.md section 13's (wi drawn,
// towards the light; a draw below the horizon keeps its wi with weight 0 and pdf 0).
// Two names differ: GLSL's built-in reflect(I, N) = I - 2 (N.I) N has the opposite sign, so the
// twin's reflect is reflect_about here; and the twin's Sample::from_draw, Sample::lost and
// Sample::spike are sample_from_draw, sample_lost and sample_spike, which take f at wi as a value
// (GLSL has no closures; the value is ignored where the draw is lost).
#ifndef LOBE_SAMPLE_GLSL
#define LOBE_SAMPLE_GLSL
#include "brdf/terms.glsl"

// One draw of wi for a given wo: weight = f(wi, wo) cos(theta_i) / pdf per channel; pdf the
// sampler's density over the solid angle of wi (for a delta sample, the probability of having
// chosen the spike); delta = 1 for the mirror spike of a model that has one.
struct Sample {
    vec3 wi;
    float pdf;
    vec3 weight;
    uint delta;
};

// A draw that left the upper hemisphere (or a request with wo below it): weight 0, pdf 0.
Sample sample_lost(vec3 wi) {
    return Sample(wi, 0.0, vec3(0.0), 0u);
}

// A draw of a non-delta component with density pdf at wi and f = f(wi, wo). Below the horizon,
// or where the density is 0 or NaN, weight and pdf are 0 and wi stays (!(pdf > 0) is true for NaN).
Sample sample_from_draw(vec3 wi, float pdf, vec3 f) {
    if (wi.z <= 0.0 || !(pdf > 0.0)) return sample_lost(wi);
    return Sample(wi, pdf, f * (wi.z / pdf), 0u);
}

// Finite, by the exponent's bits (a driver's fast-math may fold isnan and isinf away).
bool finite1(float x) {
    return (floatBitsToUint(x) & 0x7f800000u) != 0x7f800000u;
}

bool finite3(vec3 v) {
    return finite1(v.x) && finite1(v.y) && finite1(v.z);
}

// A draw of a sampler lobe did not write (a .brdf file's sampleL and pdfL): as sample_from_draw,
// except that a wi that is NaN or infinite, or one above the horizon whose pdf is NaN, infinite
// or negative, stays as drawn with weight 0, so that the sampling test counts the draw as
// invalid and names it rather than losing it. Below the horizon the draw is lost whatever the
// pdf says (as pdf_at, lobe asks no density there).
Sample sample_from_user_draw(vec3 wi, float pdf, vec3 f) {
    bool bad_pdf = wi.z > 0.0 && (!finite1(pdf) || pdf < 0.0);
    if (!finite3(wi) || bad_pdf) return Sample(wi, pdf, vec3(0.0), 0u);
    return sample_from_draw(wi, pdf, f);
}

// The mirror direction of w about the normal, 2 (w.n) n - w with n = +z.
vec3 mirror(vec3 w) {
    return vec3(-w.x, -w.y, w.z);
}

// The mirror spike chosen with probability > 0, whose albedo seen from wo is albedo.
Sample sample_spike(vec3 wo, float probability, vec3 albedo) {
    return Sample(mirror(wo), probability, albedo / probability, 1u);
}

// The reflection of w about the unit vector h, 2 (w.h) h - w (the twin's reflect).
vec3 reflect_about(vec3 w, vec3 h) {
    return 2.0 * dot(w, h) * h - w;
}

// Rec. 709 luminance of linear RGB, by which mixtures weigh their components' albedos.
float luminance(vec3 c) {
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

// lobe / (lobe + rest) with negative estimates counted as 0; 0 when both are 0.
float mixture_share(float lobe, float rest) {
    float a = max(lobe, 0.0), b = max(rest, 0.0);
    return a + b > 0.0 ? a / (a + b) : 0.0;
}

// e^x - 1 for x <= 0 without the cancellation of exp(x) - 1 near 0 (GLSL has no expm1). For
// |x| < 0.35 the Taylor series to x^8: the first term left out, x^9/9!, is below 1e-9 of x; beyond,
// exp(x) - 1 loses at most a factor 1/(1 - e^-0.35) = 3.4 in relative error to exp's own.
float expm1_nonpositive(float x) {
    if (x > -0.35) {
        return x * (1.0 + x * (1.0 / 2.0 + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0
            + x * (1.0 / 720.0 + x * (1.0 / 5040.0 + x * (1.0 / 40320.0))))))));
    }
    return exp(x) - 1.0;
}

// Two unit vectors completing n to a right-handed orthonormal frame (Duff et al. 2017, "Building
// an orthonormal basis, revisited", JCGT 6(1), listing 3). GLSL has no copysign: n.z = -0 takes
// the sign +1 here and -1 in the twin, a case no sampler meets (its axes have n.z > 0).
void frame(vec3 n, out vec3 t, out vec3 b) {
    float sign_z = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sign_z + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + sign_z * n.x * n.x * a, sign_z * c, -sign_z * n.x);
    b = vec3(c, sign_z + n.y * n.y * a, -n.y);
}

// Cosine-weighted hemisphere by Malley's method: density cos(theta) / pi.
vec3 sample_cosine(vec2 u) {
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u.x, 0.0)));
}

float pdf_cosine(vec3 wi) {
    return max(wi.z, 0.0) * INV_PI;
}

// The uniform hemisphere: cos(theta) = u1, phi = 2 pi u2, density 1/(2 pi).
vec3 sample_uniform_hemisphere(vec2 u) {
    float s = sqrt(max((1.0 - u.x) * (1.0 + u.x), 0.0));
    float phi = 2.0 * PI * u.y;
    return vec3(s * cos(phi), s * sin(phi), u.x);
}

float pdf_uniform_hemisphere(vec3 wi) {
    return wi.z > 0.0 ? 0.5 * INV_PI : 0.0;
}

// A power-cosine lobe about the unit axis (Lafortune & Willems 1994, section 4):
// 1 - cos(alpha) = -expm1(ln(1 - u1) / (n + 1)), phi = 2 pi u2. 1 - u1 rather than u1 (the same
// law): the draws' numbers include 0 and never 1; log1m (terms.glsl) keeps a few ulp for small u1.
vec3 sample_power_cosine(vec3 axis, float n, vec2 u) {
    float one_minus_c = -expm1_nonpositive(log1m(u.x) / (n + 1.0));
    float c = 1.0 - one_minus_c;
    float s = sqrt(max(one_minus_c * (2.0 - one_minus_c), 0.0));
    float phi = 2.0 * PI * u.y;
    vec3 t, b;
    frame(axis, t, b);
    return t * (s * cos(phi)) + b * (s * sin(phi)) + axis * c;
}

// (n + 1)/(2 pi) max(0, axis.w)^n, with 1 - axis.w = |w - axis|^2 / 2.
float pdf_power_cosine(vec3 axis, float n, vec3 w) {
    vec3 d = w - axis;
    float s = 0.5 * dot(d, d);
    if (s >= 1.0) return 0.0;  // axis.w <= 0: outside the lobe
    return (n + 1.0) / (2.0 * PI) * pow1m(s, n);
}

// wo in the stretched configuration of roughness 1 (Heitz 2014, section 5.3).
vec3 stretch(vec3 wo, float ax, float ay) {
    return normalize(vec3(ax * wo.x, ay * wo.y, wo.z));
}

// A stretched normal back in the surface's, z clamped at 0; +z where the vector vanishes.
vec3 unstretch(vec3 h, float ax, float ay) {
    vec3 v = vec3(ax * h.x, ay * h.y, max(h.z, 0.0));
    float len = length(v);
    // One division for the three components' (a CPU driver divides at a fraction of its rate
    // of multiplying), within an f32 rounding of the twin's v / len.
    return len > 0.0 ? v * (1.0 / len) : vec3(0.0, 0.0, 1.0);
}

// A GGX visible normal by Dupuy & Benyoub 2023, "Sampling Visible GGX Normals with Spherical
// Caps" (HPG), section 3; 1 - z = u2 (1 + v.z) and sin^2 = (1 - z)(1 + z), free of the
// cancellation of 1 - z^2 near the pole.
vec3 sample_ggx_vndf(vec3 wo, float ax, float ay, vec2 u) {
    vec3 v = stretch(wo, ax, ay);
    float phi = 2.0 * PI * u.x;
    float one_minus_z = u.y * (1.0 + v.z);
    float z = 1.0 - one_minus_z;
    float s = sqrt(max(one_minus_z * (2.0 - one_minus_z), 0.0));
    vec3 c = vec3(s * cos(phi), s * sin(phi), z);
    return unstretch(c + v, ax, ay);
}

// A GGX visible normal by Heitz 2018, "Sampling the GGX Distribution of Visible Normals" (JCGT
// 7(4)), section 4; the same density as sample_ggx_vndf.
vec3 sample_ggx_vndf_hemisphere(vec3 wo, float ax, float ay, vec2 u) {
    vec3 v = stretch(wo, ax, ay);
    float len2 = v.x * v.x + v.y * v.y;
    vec3 t1 = len2 > 0.0 ? vec3(-v.y, v.x, 0.0) * inversesqrt(len2) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(v, t1);
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    float p1 = r * cos(phi);
    float s = 0.5 * (1.0 + v.z);
    float p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * (r * sin(phi));
    vec3 n = p1 * t1 + p2 * t2 + sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0)) * v;
    return unstretch(n, ax, ay);
}

// Slopes beyond +-SLOPE_RANGE of the standard Beckmann surface carry a probability below 1e-45.
const float SLOPE_RANGE = 10.0;
const float SQRT_PI = 1.7724538509055160;

// erfc of either sign from erfc_approx (terms.glsl, x >= 0): erfc(-x) = 2 - erfc(x).
float erfc_signed(float x) {
    return x >= 0.0 ? erfc_approx(x) : 2.0 - erfc_approx(-x);
}

// The x in [lo, hi] with cdf(x) = u for the visible slopes seen from tan_t, cdf(x) =
// F(x) / total, F(x) = erfc(-x)/2 + k e^{-x^2}, total = F(x_max), density
// max(0, 1 - x tan_t) e^{-x^2} / (sqrt(pi) total); tan_t = k = 0 and x_max = SLOPE_RANGE give the
// normal slope of variance 1/2. Newton's method from the middle kept inside the bracket that the
// signs of cdf - u maintain, as the twin's invert_cdf (which takes the two functions as
// closures); the stop is 4 ulp of f32, and 64 steps bound the loop (bisection alone halves the
// bracket of width 20 to an f32 ulp in 30).
// One difference, for f32: for x > 0, where cdf nears 1 and its f32 rounding (2^-25 absolute)
// would move x by 2^-25 / density (0.01 at u = 1 - 1e-6), cdf - u is taken as
// (1 - u) - (total - F(x)) / total, 1 - u exact for the draws' numbers (src/random.rs) and
// total - F(x) = (erfc(x) - erfc(x_max))/2 + k (e^{-x_max^2} - e^{-x^2}) (erfc(-x) = 2 - erfc(x))
// formed without rounding near 1. The twin's f64 has the digits to spare.
float invert_slope_cdf(float u, float lo, float hi, float tan_t, float k, float total) {
    float x_max = hi;
    float erfc_max = erfc_signed(x_max), exp_max = exp(-x_max * x_max);
    float x = clamp(0.0, lo, hi);
    for (int i = 0; i < 64; ++i) {
        float e = exp(-x * x);
        float g = x > 0.0
            ? (1.0 - u) - (0.5 * (erfc_approx(x) - erfc_max) + k * (exp_max - e)) / total
            : (0.5 * erfc_signed(-x) + k * e) / total - u;
        if (g > 0.0) hi = x; else lo = x;
        float d = max(1.0 - x * tan_t, 0.0) * e / (SQRT_PI * total);
        float newton = x - g / d;
        float next = d > 0.0 && newton > lo && newton < hi ? newton : 0.5 * (lo + hi);
        if (abs(next - x) <= 4.0 * 1.1920929e-7 * max(abs(x), 1.0) || hi - lo <= 0.0) return next;
        x = next;
    }
    return x;
}

// y with erfc(-y)/2 = u (a normal of variance 1/2).
float standard_normal_slope(float u) {
    return invert_slope_cdf(u, -SLOPE_RANGE, SLOPE_RANGE, 0.0, 0.0, 1.0);
}

// x with C(x) = u for the visible slopes seen from tan(theta) (sample_beckmann_vndf).
float beckmann_visible_slope(float tan_t, float u) {
    float k = tan_t / (2.0 * SQRT_PI);
    float hi = tan_t > 0.0 ? min(1.0 / tan_t, SLOPE_RANGE) : SLOPE_RANGE;
    float total = 0.5 * erfc_signed(-hi) + k * exp(-hi * hi);
    return invert_slope_cdf(u, -SLOPE_RANGE, hi, tan_t, k, total);
}

// A Beckmann visible normal by Heitz & d'Eon 2014, "Importance Sampling Microfacet-Based BSDFs
// using the Distribution of Visible Normals" (EGSR), section 4 and appendix; the slopes by
// inverting their distribution as Jakob 2014 does (the twin's notes give the derivation). The
// cap keeps tan(theta) finite in f32 (its range ends at 3.4e38).
vec3 sample_beckmann_vndf(vec3 wo, float ax, float ay, vec2 u) {
    vec3 v = stretch(wo, ax, ay);
    float sin_t = sqrt(v.x * v.x + v.y * v.y);
    float tan_t = min(sin_t / v.z, 1e30);
    float cos_phi = sin_t > 0.0 ? v.x / sin_t : 1.0;
    float sin_phi = sin_t > 0.0 ? v.y / sin_t : 0.0;
    float x = beckmann_visible_slope(tan_t, u.x);
    float y = standard_normal_slope(u.y);
    float sx = cos_phi * x - sin_phi * y, sy = sin_phi * x + cos_phi * y;
    return normalize(vec3(-ax * sx, -ay * sy, 1.0));
}

// A visible normal of the distribution (0 beckmann, 1 ggx, as MF_DISTRIBUTION).
vec3 sample_vndf(uint distribution, vec3 wo, float ax, float ay, vec2 u) {
    return distribution == 0u ? sample_beckmann_vndf(wo, ax, ay, u) : sample_ggx_vndf(wo, ax, ay, u);
}

// The density over wi of reflecting wo about a visible normal (Heitz 2018, eq. 17, with the
// reflection Jacobian 1/(4 wo.h) of Walter et al. 2007, eq. 14): D(h) / (4 c_o (1 + Lambda(wo)))
// with the distribution's exact Smith Lambda; 0 unless both directions are above the horizon, or
// where (alpha tan theta_o)^2 overflows (the twin's smith_lambda returns None there).
float pdf_vndf(uint distribution, vec3 wi, vec3 wo, float ax, float ay) {
    if (wi.z <= 0.0 || wo.z <= 0.0) return 0.0;
    // The twin's normalize with one division: some drivers take normalize(v) as v / length(v),
    // a division per component, and a CPU driver divides at a fraction of its rate of
    // multiplying.
    vec3 sum = wi + wo;
    vec3 h = sum * inversesqrt(dot(sum, sum));
    float q = alpha_sin2(wo, ax * ax, ay * ay);
    float t2 = q / (wo.z * wo.z);
    if (isinf(t2)) return 0.0;
    float inv_x = 1.0 / (ax * ax), inv_y = 1.0 / (ay * ay), d_norm = 1.0 / (PI * ax * ay);
    float lambda, d;
    if (distribution == 0u) {
        lambda = lambda_beckmann(q, wo.z);
        d = D_beckmann(h, 1.0, inv_x, inv_y, d_norm);
    } else {
        // lambda_ggx of the twin's terms.rs, without cancellation for small t2.
        lambda = t2 / (2.0 * (sqrt(1.0 + t2) + 1.0));
        float g = ggx_q(h, inv_x, inv_y);
        d = d_norm / (g * g);
    }
    // The factor is wo's alone: computed once for a loop over draws, then each multiplies.
    return d * (1.0 / (4.0 * wo.z * (1.0 + lambda)));
}

#endif
