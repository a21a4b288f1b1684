#version 450
#extension GL_GOOGLE_include_directive : require
// Directional albedo as a reduction, E(wo) = sum_k w_k f(wi_k, wo), with the quadrature's nodes
// (wi_k, w_k) given as a list; w_k already holds cos(theta_i) (src/integrate/ derives each rule).
// No table is written: each workgroup sums one span of one node list for one (parameter set,
// view direction) in f32 and writes its partial sums; the host adds each sum's partials in f64
// (src/gpu/albedo.rs).
//
// One dispatch serves many sums: a LUT's rows and a rule's coarse check share the node buffer,
// uploaded once, and every span of every sum is one workgroup of the same dispatch.
//
// Self-contained rather than built on kernels/eval.glsl, whose push-constant block it cannot share;
// bindings 0 and 3 keep eval.glsl's meaning (parameters, output).
#include "common.glsl"
#include "model.glsl"

// Specialization constant 1 sets the workgroup size (constant 2, evaluations per invocation, is
// not used: the span per workgroup comes with the job).
layout(local_size_x_id = 1) in;
// Read the nodes through the texel buffer of binding 4 (the same list) instead of the storage
// buffer of binding 1: a CPU driver (lavapipe) gathers texels cheaply but turns a storage load
// whose index varies across invocations into a loop over the SIMD lanes. The host turns it on
// where the list fits maxTexelBufferElements.
layout(constant_id = 20) const bool TEXEL_NODES = false;
// Each invocation writes its own partial sum instead of the workgroup folding them in shared
// memory: a CPU driver (lavapipe) runs a barrier as a switch between the workgroup's SIMD
// slices, so the tree's barriers cost more than the host's f64 sum of 64 partials. The host
// turns it on for a CPU driver (src/gpu/pipeline.rs, albedo_lane_partials).
layout(constant_id = 21) const bool LANE_PARTIALS = false;

// Nodes per invocation of a whole span with LANE_PARTIALS: four running sums of 16 terms. Twin of
// LANE_NODES_PER_INVOCATION (src/gpu/albedo_kernel.rs), which sizes the spans.
const uint LANE_SPAN_NODES = 64u;

layout(std430, set = 0, binding = 0) readonly buffer ParamBlock { MODEL_PARAMS params[]; };
// xyz = wi, w = weight (with cos(theta_i)), every sum's list back to back; in a span with
// `mirror` set, xy = the tangential part of wi - r, r = (-wo.x, -wo.y, wo.z) the mirror direction
// of wo, and z = wi.z (see brdf).
layout(std430, set = 0, binding = 1) readonly buffer Nodes { vec4 nodes[]; };
// One span per workgroup: nodes[begin, end) at one (parameter set, view direction). Twin of
// AlbedoSpan in src/gpu/albedo.rs.
struct Span {
    vec3 wo;
    uint param_index;
    uint begin;
    uint end;
    uint mirror;  // 1: the span's nodes are offsets from the mirror direction of wo
    uint pad0;
};
layout(std430, set = 0, binding = 2) readonly buffer Spans { Span spans[]; };
// One rgb partial sum per workgroup at gl_WorkGroupID.x, or with LANE_PARTIALS one per
// invocation at gl_GlobalInvocationID.x; w counts the invalid values f it summed (NaN, +-Inf or
// negative, docs/design.md §2.1), exact in f32 up to 2^24, which no span reaches.
layout(std430, set = 0, binding = 3) writeonly buffer Partials { vec4 partial_out[]; };
layout(set = 0, binding = 4) uniform samplerBuffer node_texels;

// first_span: the span of workgroup 0 (a job larger than one dispatch goes out in several); dispatch_count: read by the host's dispatcher only (workgroups x its evaluations
// per workgroup). Twin of AlbedoPush.
layout(push_constant) uniform AlbedoJob {
    uint first_span;
    uint dispatch_count;
    uint pad0;
    uint pad1;
} job;

shared vec4 sums[gl_WorkGroupSize.x];

// f at a node, f = 0 whenever c_i <= 0 or c_o <= 0 (docs/design.md §2, as in kernels/eval.glsl).
// With `mirror` the node is an offset from the mirror direction r of the host's f64 wo (computed
// in f64, src/gpu/albedo.rs mirror_node): wi = r + (dx, dy, .), and wi + wo = (dx, dy, wi.z + wo.z)
// exactly in its tangential part, where the f32 sum of wi and wo keeps their roundings
// (eps sin(theta) each) after the tangential parts cancel. A model that takes the sum
// (MODEL_EVAL_SUM) then resolves lobes of width ~1e-3 about the mirror direction at grazing view.
// wi.z is stored as it is, not as an offset, so that it keeps its relative precision near the
// horizon.
vec3 brdf(MODEL_PARAMS p, vec4 node, vec3 wo, bool mirror) {
    vec3 wi = mirror ? vec3(node.x - wo.x, node.y - wo.y, node.z) : node.xyz;
    if (wi.z <= 0.0 || wo.z <= 0.0) return vec3(0.0);
#ifdef MODEL_EVAL_SUM
    vec3 s = mirror ? vec3(node.x, node.y, node.z + wo.z) : wi + wo;
    return MODEL_EVAL_SUM(p, wi, wo, s);
#else
    return MODEL_EVAL(p, wi, wo);
#endif
}

// w * f in xyz, and in w 1 where f is invalid (a NaN, an infinity or a negative channel), so that
// a sum of these counts them beside the weighted sum. A channel is valid exactly where
// 0 <= f <= FLT_MAX: a NaN fails both comparisons, an infinity or a negative value one (-0
// passes). Written without || (which compiles to branches, one per node): on lavapipe the
// branchy test cost a quarter of a GGX LUT's time.
vec4 term(vec4 node, vec3 f) {
    bvec3 low = greaterThanEqual(f, vec3(0.0));
    bvec3 high = lessThanEqual(f, vec3(3.40282347e38));
    bool valid = all(bvec3(uvec3(low) & uvec3(high)));
    return vec4(node.w * f, valid ? 0.0 : 1.0);
}

vec4 node_at(uint k) {
    if (TEXEL_NODES) return texelFetch(node_texels, int(k));
    return nodes[k];
}

void main() {
    uint lid = gl_LocalInvocationID.x;
    // Everything but the node index is the same across the workgroup: uniform loads.
    Span span = spans[job.first_span + gl_WorkGroupID.x];
    MODEL_PARAMS p = params[span.param_index];
    vec3 wo = span.wo;
    bool mirror = span.mirror != 0u;
    const uint W = gl_WorkGroupSize.x;
    if (LANE_PARTIALS) {
        // Four running sums over interleaved nodes (at most 16 terms each in a span of
        // 64 x 64 nodes), added pairwise: fewer partials per evaluation, the same rounding depth.
        vec4 a0 = vec4(0.0), a1 = vec4(0.0), a2 = vec4(0.0), a3 = vec4(0.0);
        if (span.end - span.begin == LANE_SPAN_NODES * W) {
            // A whole span (every span but a list's last): no bounds to test, which on lavapipe
            // made a GGX LUT 12 % faster.
            for (uint k = span.begin + lid; k < span.end; k += 4u * W) {
                vec4 n0 = node_at(k), n1 = node_at(k + W), n2 = node_at(k + 2u * W),
                     n3 = node_at(k + 3u * W);
                a0 += term(n0, brdf(p, n0, wo, mirror));
                a1 += term(n1, brdf(p, n1, wo, mirror));
                a2 += term(n2, brdf(p, n2, wo, mirror));
                a3 += term(n3, brdf(p, n3, wo, mirror));
            }
            partial_out[gl_GlobalInvocationID.x] = (a0 + a1) + (a2 + a3);
            return;
        }
        for (uint k = span.begin + lid; k < span.end; k += 4u * W) {
            vec4 n0 = node_at(k);
            a0 += term(n0, brdf(p, n0, wo, mirror));
            if (k + W < span.end) {
                vec4 n1 = node_at(k + W);
                a1 += term(n1, brdf(p, n1, wo, mirror));
            }
            if (k + 2u * W < span.end) {
                vec4 n2 = node_at(k + 2u * W);
                a2 += term(n2, brdf(p, n2, wo, mirror));
            }
            if (k + 3u * W < span.end) {
                vec4 n3 = node_at(k + 3u * W);
                a3 += term(n3, brdf(p, n3, wo, mirror));
            }
        }
        partial_out[gl_GlobalInvocationID.x] = (a0 + a1) + (a2 + a3);
        return;
    }
    vec4 acc = vec4(0.0);
    for (uint k = span.begin + lid; k < span.end; k += W) {
        vec4 node = node_at(k);
        acc += term(node, brdf(p, node, wo, mirror));
    }
    sums[lid] = acc;
    barrier();
    // Pairwise tree for any workgroup size: fold the upper half onto the lower.
    for (uint width = gl_WorkGroupSize.x; width > 1u;) {
        uint half_width = (width + 1u) / 2u;
        if (lid < width - half_width) sums[lid] += sums[lid + half_width];
        barrier();
        width = half_width;
    }
    if (lid == 0u) partial_out[gl_WorkGroupID.x] = sums[0];
}
