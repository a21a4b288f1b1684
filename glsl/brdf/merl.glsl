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

// The importance sampler (twin of MerlSampler in src/model/merl.rs, docs/design.md section 13):
// per slice of cos(theta_o), a piecewise-constant density over the half vector's
// (theta_h, phi_h - phi_o) cells, tabulated on the host after the bins; wi is the reflection of wo
// about the half vector drawn, mixed with the cosine. The tables, in floats from
// MERL_SAMPLER_OFFSET: 1 - cos(theta) at the 91 row edges, each slice's share of table draws, each
// slice's row CDF (91), each slice's and row's column CDF (65).
const int MERL_SLICES = 32;
const int MERL_ROWS = 90;
const int MERL_COLUMNS = 64;
const uint MERL_SAMPLER_OFFSET = 3u * MERL_BINS;
const uint MERL_OMC = MERL_SAMPLER_OFFSET;
const uint MERL_SHARE = MERL_OMC + uint(MERL_ROWS + 1);
const uint MERL_MARGINAL = MERL_SHARE + uint(MERL_SLICES);
const uint MERL_CONDITIONAL = MERL_MARGINAL + uint(MERL_SLICES * (MERL_ROWS + 1));
const float MERL_COLUMN_STEP = 2.0 * PI / float(MERL_COLUMNS);

// The largest k < n with cdf[k] <= u among the n + 1 values from merl_table[at] (0 up to 1), and
// where u lies within [cdf[k], cdf[k + 1]) as a fraction in [0, 1].
int merl_search(uint at, int n, float u, out float t) {
    int lo = 0, hi = n;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (merl_table[at + uint(mid)] <= u) lo = mid; else hi = mid;
    }
    float a = merl_table[at + uint(lo)], b = merl_table[at + uint(lo + 1)];
    t = b > a ? clamp((u - a) / (b - a), 0.0, 1.0) : 0.0;
    return lo;
}

int merl_slice(vec3 wo) {
    return min(int(float(MERL_SLICES) * (1.0 - wo.z)), MERL_SLICES - 1);
}

// cos and sin of wo's azimuth, (1, 0) along the normal.
vec2 merl_azimuth(vec3 wo) {
    float r = length(wo.xy);
    return r > 0.0 ? wo.xy / r : vec2(1.0, 0.0);
}

uint merl_marginal(int j) {
    return MERL_MARGINAL + uint(j * (MERL_ROWS + 1));
}

uint merl_conditional(int j, int k) {
    return MERL_CONDITIONAL + uint((j * MERL_ROWS + k) * (MERL_COLUMNS + 1));
}

float pdf_merl(MerlParams p, vec3 wi, vec3 wo) {
    int j = merl_slice(wo);
    float share = merl_table[MERL_SHARE + uint(j)];
    float cosine = (1.0 - share) * pdf_cosine(wi);
    if (share == 0.0) return cosine;
    vec3 h = normalize(wi + wo);
    vec2 a = merl_azimuth(wo);
    float x = a.x * h.x + a.y * h.y, y = a.x * h.y - a.y * h.x;
    // 1 - cos(theta_h) = sin^2 / (1 + cos), without the cancellation of 1 - h.z.
    float m = (x * x + y * y) / (1.0 + h.z);
    float unused;
    int k = merl_search(MERL_OMC, MERL_ROWS, min(m, 1.0), unused);
    float phi = merl_angle(abs(y), x);
    if (y < 0.0) phi = 2.0 * PI - phi;
    int c = clamp(int(phi / MERL_COLUMN_STEP), 0, MERL_COLUMNS - 1);
    uint rows = merl_marginal(j), cols = merl_conditional(j, k);
    float prob = (merl_table[rows + uint(k + 1)] - merl_table[rows + uint(k)])
        * (merl_table[cols + uint(c + 1)] - merl_table[cols + uint(c)]);
    float solid_angle = (merl_table[MERL_OMC + uint(k + 1)] - merl_table[MERL_OMC + uint(k)]) * MERL_COLUMN_STEP;
    return share * prob / (solid_angle * 4.0 * dot(wo, h)) + cosine;
}

Sample sample_merl(MerlParams p, vec3 wo, float uc, vec2 u) {
    int j = merl_slice(wo);
    vec3 wi;
    if (uc < merl_table[MERL_SHARE + uint(j)]) {
        float tr, tc;
        int k = merl_search(merl_marginal(j), MERL_ROWS, u.x, tr);
        int c = merl_search(merl_conditional(j, k), MERL_COLUMNS, u.y, tc);
        float a = merl_table[MERL_OMC + uint(k)], b = merl_table[MERL_OMC + uint(k + 1)];
        float m = a + tr * (b - a);
        float cos_h = 1.0 - m, sin_h = sqrt(max(m * (2.0 - m), 0.0));
        float phi = (float(c) + tc) * MERL_COLUMN_STEP;
        float x = sin_h * cos(phi), y = sin_h * sin(phi);
        vec2 az = merl_azimuth(wo);
        wi = reflect_about(wo, vec3(az.x * x - az.y * y, az.y * x + az.x * y, cos_h));
    } else {
        wi = sample_cosine(u);
    }
    return sample_from_draw(wi, pdf_merl(p, wi, wo), merl(p, wi, wo));
}
