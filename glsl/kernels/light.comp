#version 450
#extension GL_GOOGLE_include_directive : require
// `lobe light`'s exact sum (docs/design.md §15): one pixel of the lit sphere per evaluation, the
// radiance toward the camera as the sum over every texel of the environment map of
// f(wi, wo) cos(theta_i) L dOmega, texels below the pixel's horizon skipped (whole rows, and
// the columns of a row outside the arc that may lie above it). Twin of
// `WeightedTexels::light_pixel` (src/backend/light.rs): the host makes each pixel's frame and
// each texel's direction and L dOmega in f64 and hands them over rounded to f32, so the kernel
// only rotates, evaluates and sums.
//
// A model whose f is a Fresnel factor at c_d = wi.h times the rest (MODEL_FRESNEL_FOLDS: the
// microfacet model without a diffuse part or the Kulla-Conty lobe) has the factor folded into
// each texel's weight by a first pass of this kernel over the texels (chunk.n_wo =
// FRESNEL_PASS): the camera is orthographic along +z, so every pixel's wo is +z in the world and
// c_d = |d + z| / 2 depends on the texel's direction d alone. The sum then evaluates f with a
// factor of 1 (MODEL_EVAL_FRESNEL), the same formula in the same operations but for the order of
// one product and c_d's rounding (from world rather than local coordinates, an ulp or so): one
// Fresnel evaluation per texel rather than per pixel and texel.
//
// f32 accumulation: each map row is summed on its own, then the rows' sums are added, so a
// term meets at most (width + height) additions instead of width * height (a rounding error
// bound of about (W + H) 2^-24 relative to the sum of |terms| rather than W H 2^-24).
#include "kernels/eval.glsl"

struct Pixel {
    vec4 t;  // tangent (world), w = wo.x
    vec4 b;  // bitangent (world), w = wo.y
    vec4 n;  // normal (world), w = wo.z
};

struct Texel {
    vec4 direction;  // the texel centre's world direction, w unused
    vec4 weight;     // rgb: radiance times the texel's solid angle, w unused
};

layout(std430, set = 0, binding = 1) readonly buffer Pixels {
    uvec4 map;  // texels per row, rows, unused, unused
    Pixel pixels[];
};
layout(std430, set = 0, binding = 2) buffer Texels { Texel texels[]; };

// chunk.n_wo of the first pass (twin of FRESNEL_PASS in src/gpu/light.rs); 0 for the sum.
const uint FRESNEL_PASS = 1u;

// A map row whose texels all lie below the pixel's horizon is skipped whole: over a row of
// polar angle theta the largest n . d is cos(theta) n.y + sin(theta) |n.xz| (the first texel's
// direction gives cos and sin), and a row whose bound is below -HORIZON_MARGIN has every texel's
// computed cos(theta_i) below 0 (f32 rounding of these dot products is about 1e-7), so the
// texels skipped are exactly those the loop would skip one by one: the sum is unchanged.
// Twin of HORIZON_MARGIN in src/backend/light.rs.
const float HORIZON_MARGIN = 1e-5;

// The columns of a row that may lie above the pixel's horizon, as the spans [0, a) and [lo, hi)
// in increasing order (a = 0 where there is one span): over a row of polar angle theta the texel
// at azimuth phi has n . d = cos(theta) n.y + sin(theta) |n.xz| cos(phi - psi), psi = atan(n.x,
// -n.z), below -HORIZON_MARGIN outside the arc |phi - psi| <= acos(c), widened by COLUMN_MARGIN
// columns on each side (one column's angle is far more than acos's and atan's f32 error). Twin
// of visible_columns in src/backend/light.rs.
const float COLUMN_MARGIN = 1.0;
const float TWO_PI = 6.283185307179586;

void visible_columns(vec3 d0, vec3 n, float n_xz, uint width, out uint a, out uint lo, out uint hi) {
    a = 0u;
    lo = 0u;
    hi = width;
    float across = length(d0.xz) * n_xz;
    if (!(across > 0.0)) return;
    float c = (-HORIZON_MARGIN - d0.y * n.y) / across;
    if (c <= -1.0) return;
    float w = float(width);
    float half_width = acos(min(c, 1.0)) * w / TWO_PI + COLUMN_MARGIN;
    if (2.0 * half_width + 1.0 >= w) return;
    float centre = atan(n.x, -n.z) * w / TWO_PI - 0.5;
    int l = int(ceil(centre - half_width));
    int h = int(floor(centre + half_width));
    int wi = int(width);
    if (l < 0) {
        l += wi;
        h += wi;
    }
    if (h >= wi) {
        a = uint(h - wi + 1);
        lo = uint(l);
        hi = width;
    } else {
        lo = uint(l);
        hi = uint(h + 1);
    }
}

// Whether the first pass folds the model's Fresnel factor into the texels' weights.
bool fresnel_folds(MODEL_PARAMS p) {
#ifdef MODEL_FRESNEL_FOLDS
    return MODEL_FRESNEL_FOLDS(p);
#else
    return false;
#endif
}

// f at a texel: with folded, f's Fresnel factor is in the texel's weight.
vec3 texel_f(MODEL_PARAMS p, vec3 wi, vec3 wo, bool folded) {
#ifdef MODEL_EVAL_FRESNEL
    if (folded) return wo.z > 0.0 ? MODEL_EVAL_FRESNEL(p, wi, wo, wi + wo, vec3(1.0)) : vec3(0.0);
#endif
    return brdf(p, wi, wo);
}

// Adds the terms of texels first + begin .. first + end to sum, in order.
void add_terms(MODEL_PARAMS p, Pixel px, vec3 wo, uint first, uint begin, uint end, bool folded,
               inout vec3 sum) {
    for (uint k = first + begin; k < first + end; ++k) {
        vec3 d = texels[k].direction.xyz;
        vec3 wi = vec3(dot(d, px.t.xyz), dot(d, px.b.xyz), dot(d, px.n.xyz));
        if (wi.z > 0.0) sum += texel_f(p, wi, wo, folded) * wi.z * texels[k].weight.rgb;
    }
}

vec3 light_pixel(MODEL_PARAMS p, Pixel px, bool folded) {
    vec3 wo = vec3(px.t.w, px.b.w, px.n.w);
    vec3 total = vec3(0.0);
    float n_xz = length(px.n.xz);
    for (uint row = 0u, k = 0u; row < map.y; ++row, k += map.x) {
        vec3 d0 = texels[k].direction.xyz;
        if (d0.y * px.n.y + length(d0.xz) * n_xz < -HORIZON_MARGIN) continue;
        uint a, lo, hi;
        visible_columns(d0, px.n.xyz, n_xz, map.x, a, lo, hi);
        // The two spans in order into one sum, so the row adds its terms as the full loop would.
        vec3 sum = vec3(0.0);
        add_terms(p, px, wo, k, 0u, a, folded, sum);
        add_terms(p, px, wo, k, lo, hi, folded, sum);
        total += sum;
    }
    return total;
}

// One pixel per invocation (the runner sets EVALS_PER_INVOCATION to 1 for this kernel: the loop
// over every texel is work enough to carry an invocation's overhead). The first pass
// (chunk.n_wo = FRESNEL_PASS) instead folds the Fresnel factor into texel first + index's weight
// where the model's f allows. Each way of the sum has a loop of its own, so that a CPU driver's
// SIMD lanes, which step through both sides of a branch under a mask, skip the other's loop at
// once (the condition is the same for every lane).
void main() {
    uint local_index = gl_GlobalInvocationID.x;
    if (local_index >= chunk.count) return;
    if (chunk.n_wo == FRESNEL_PASS) {
#ifdef MODEL_FRESNEL
        if (fresnel_folds(params[0])) {
            uint k = chunk.first + local_index;
            float s2;
            float c_d = half_sum(texels[k].direction.xyz + vec3(0.0, 0.0, 1.0), s2);
            texels[k].weight.rgb *= MODEL_FRESNEL(params[0], c_d);
        }
#endif
        return;
    }
    MODEL_PARAMS p = params[0];
    Pixel px = pixels[chunk.first + local_index];
    vec3 l;
    if (fresnel_folds(p)) {
        l = light_pixel(p, px, true);
    } else {
        l = light_pixel(p, px, false);
    }
    store(local_index, l);
}
