// A measured BRDF in the MERL database's layout (Matusik, Pfister, Brand & McMillan 2003, "A
// data-driven reflectance model"): 90 x 90 x 180 bins of (theta_h, theta_d, phi_d) per channel,
// indexed as MERL's reference reader (BRDFRead.cpp) indexes them. Twin of src/merl/lookup.rs.
//
// The table (binding 7, MODEL_DATA_BINDING in src/gpu/pipeline.rs) holds f in 1/sr as f32, planar:
// every red bin, then every green, then every blue; bin = phi_d + 180 (theta_d + 90 theta_h). The
// host has applied MERL's channel scales and written missing bins (negative in the file) as 0.
#include "common.glsl"
#include "brdf/sample.glsl"

struct MerlParams {
    uint lookup;  // MERL_NEAREST or MERL_TRILINEAR (the `lookup` choice)
};

const uint MERL_NEAREST = 0u;
const uint MERL_TRILINEAR = 1u;
const int MERL_THETA_H = 90;
const int MERL_THETA_D = 90;
const int MERL_PHI_D = 180;
const uint MERL_BINS = 1458000u;  // 90 * 90 * 180

layout(std430, set = 0, binding = 7) readonly buffer MerlTable { float merl_table[]; };

// atan2(y, x) for y >= 0, in [0, pi], in plain arithmetic: the Vulkan spec lets atan (and acos) be
// off by 4096 ulp, which would move bin edges. With r = |(x, y)|, tan(a/2) = y/(r + |x|) gives the
// angle to the nearer x half-axis; one more half-angle step leaves w = tan(a/4) <= tan(pi/8) =
// 0.4142, where atan's series to w^15 is within 2^-24 relative (as eon_angle in brdf/eon.glsl). For
// x < 0 the angle is pi minus that. atan2(0, 0) = 0, as in C. The f64 twin uses atan2.
float merl_angle(float y, float x) {
    float ax = abs(x);
    float r = sqrt(ax * ax + y * y);
    if (r == 0.0) return 0.0;
    float t = y / (r + ax);
    float w = t / (1.0 + sqrt(1.0 + t * t));
    float w2 = w * w;
    float a = 4.0 * w * (1.0 + w2 * (-1.0 / 3.0 + w2 * (1.0 / 5.0 + w2 * (-1.0 / 7.0 + w2 * (1.0 / 9.0
                + w2 * (-1.0 / 11.0 + w2 * (1.0 / 13.0 + w2 * (-1.0 / 15.0))))))));
    return x < 0.0 ? PI - a : a;
}

// (theta_h, theta_d, phi_d) of a pair, as MERL's reader builds them (src/grid.rs
// pair_to_half_diff): h = normalize(wi + wo); d = wi rotated by -phi_h about n, then by -theta_h
// about the bitangent (0, 1, 0). The rotations take cos and sin of phi_h and theta_h from h itself
// (h.x/|h.xy|, h.y/|h.xy|, h.z, |h.xy|; phi_h = 0 where |h.xy| = 0): in f32, acos(h.z) could not
// tell theta_h apart below ~3e-4 rad, which spans MERL's first two theta_h bins. phi_d in (-pi, pi].
vec3 merl_half_diff(vec3 wi, vec3 wo) {
    vec3 h = normalize(wi + wo);
    float sin_h = length(h.xy);
    float cos_phi = sin_h > 0.0 ? h.x / sin_h : 1.0;
    float sin_phi = sin_h > 0.0 ? h.y / sin_h : 0.0;
    vec3 t = vec3(cos_phi * wi.x + sin_phi * wi.y, cos_phi * wi.y - sin_phi * wi.x, wi.z);
    vec3 d = vec3(h.z * t.x - sin_h * t.z, t.y, sin_h * t.x + h.z * t.z);
    float phi_d = merl_angle(abs(d.y), d.x);
    return vec3(merl_angle(sin_h, h.z), merl_angle(length(d.xy), d.z), d.y < 0.0 ? -phi_d : phi_d);
}

// The continuous bin coordinates of (theta_h, theta_d, phi_d): MERL's reader takes the floor of
// each (theta_h -> 90 sqrt(theta_h / (pi/2)), theta_d -> 90 theta_d / (pi/2), phi_d + pi where
// negative, then 180 phi_d / pi), so bin k spans [k, k + 1) and its centre is k + 1/2.
vec3 merl_coordinates(vec3 a) {
    float phi_d = a.z < 0.0 ? a.z + PI : a.z;
    return vec3(a.x <= 0.0 ? 0.0 : float(MERL_THETA_H) * sqrt(a.x / (PI / 2.0)),
                float(MERL_THETA_D) * a.y / (PI / 2.0), float(MERL_PHI_D) * phi_d / PI);
}

vec3 merl_bin(int h, int d, int p) {
    uint k = uint(p + MERL_PHI_D * (d + MERL_THETA_D * h));
    return vec3(merl_table[k], merl_table[k + MERL_BINS], merl_table[k + 2u * MERL_BINS]);
}

// MERL's reader: the bin the coordinates fall in, each clamped to its axis.
vec3 merl_nearest(vec3 u) {
    int h = clamp(int(u.x), 0, MERL_THETA_H - 1);
    int d = clamp(int(u.y), 0, MERL_THETA_D - 1);
    int p = clamp(int(u.z), 0, MERL_PHI_D - 1);
    return merl_bin(h, d, p);
}

// Trilinear between the eight bin centres around the coordinates: beyond the first or last centre
// of theta_h and theta_d the edge bin holds (clamped); phi_d wraps (f(phi_d) = f(phi_d + pi), so
// bin 179 neighbours bin 0).
vec3 merl_trilinear(vec3 u) {
    vec3 c = u - 0.5;
    vec3 base = floor(c);
    vec3 t = c - base;
    int h0 = int(base.x);
    int d0 = int(base.y);
    int p0 = int(base.z);
    vec3 f = vec3(0.0);
    for (int k = 0; k < 8; ++k) {
        int dh = k & 1;
        int dd = (k >> 1) & 1;
        int dp = (k >> 2) & 1;
        float w = (dh == 1 ? t.x : 1.0 - t.x) * (dd == 1 ? t.y : 1.0 - t.y) * (dp == 1 ? t.z : 1.0 - t.z);
        int h = clamp(h0 + dh, 0, MERL_THETA_H - 1);
        int d = clamp(d0 + dd, 0, MERL_THETA_D - 1);
        int p = (p0 + dp + MERL_PHI_D) % MERL_PHI_D;
        f += w * merl_bin(h, d, p);
    }
    return f;
}

vec3 merl(MerlParams p, vec3 wi, vec3 wo) {
    vec3 u = merl_coordinates(merl_half_diff(wi, wo));
    return p.lookup == MERL_TRILINEAR ? merl_trilinear(u) : merl_nearest(u);
}

// A measured BRDF is drawn by the cosine, as every model defined at run time is
// (Reference::sample in src/model/mod.rs).
Sample sample_merl(MerlParams p, vec3 wo, float uc, vec2 u) {
    vec3 wi = sample_cosine(u);
    return sample_from_draw(wi, pdf_cosine(wi), merl(p, wi, wo));
}

float pdf_merl(MerlParams p, vec3 wi, vec3 wo) {
    return pdf_cosine(wi);
}
