#version 450
#extension GL_GOOGLE_include_directive : require
// Directional albedo as a reduction, E(wo) = sum_k w_k f(wi_k, wo), with the quadrature's nodes
// (wi_k, w_k) given as a list; w_k already holds cos(theta_i) (src/integrate/ derives each rule).
// No table is written: each workgroup sums one span of one wo's nodes in f32 (strided per
// invocation, then a tree in shared memory) and writes one partial sum; the host adds each wo's
// partials in f64 (src/gpu/albedo.rs).
//
// One dispatch serves many (parameter set, view direction) entries: a LUT's rows share each
// direction's node list, uploaded once.
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

layout(std430, set = 0, binding = 0) readonly buffer ParamBlock { MODEL_PARAMS params[]; };
// xyz = wi, w = weight (with cos(theta_i)); node k of entry e is
// nodes[entries[e].node_list * node_stride + k].
layout(std430, set = 0, binding = 1) readonly buffer Nodes { vec4 nodes[]; };
// One entry per (parameter set, view direction): twin of AlbedoEntry in src/gpu/albedo.rs.
struct Entry {
    vec3 wo;
    uint param_index;
    uint node_list;
    uint pad0;
    uint pad1;
    uint pad2;
};
layout(std430, set = 0, binding = 2) readonly buffer Entries { Entry entries[]; };
// One rgb partial sum per workgroup: 3 floats at 3 * gl_WorkGroupID.x.
layout(std430, set = 0, binding = 3) writeonly buffer Partials { float partial_out[]; };
layout(set = 0, binding = 4) uniform samplerBuffer node_texels;

// nodes_per_group: the span of nodes one workgroup sums; dispatch_count: read by the host's
// dispatcher only (workgroups x its evaluations per workgroup); n_nodes: nodes per entry;
// node_stride: 0 when every entry shares one node list, else n_nodes. Twin of AlbedoPush.
layout(push_constant) uniform AlbedoJob {
    uint nodes_per_group;
    uint dispatch_count;
    uint n_nodes;
    uint node_stride;
} job;

shared vec3 sums[gl_WorkGroupSize.x];

// docs/design.md §2: f = 0 whenever c_i <= 0 or c_o <= 0 (as in kernels/eval.glsl).
vec3 brdf(MODEL_PARAMS p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) return vec3(0.0);
    return MODEL_EVAL(p, wi, wo);
}

vec4 node_at(uint k) {
    if (TEXEL_NODES) return texelFetch(node_texels, int(k));
    return nodes[k];
}

void main() {
    uint lid = gl_LocalInvocationID.x;
    uint groups_per_wo = (job.n_nodes + job.nodes_per_group - 1u) / job.nodes_per_group;
    // Everything but the node index is the same across the workgroup: uniform loads.
    uint o = gl_WorkGroupID.x / groups_per_wo;
    uint begin = (gl_WorkGroupID.x - o * groups_per_wo) * job.nodes_per_group;
    uint end = min(begin + job.nodes_per_group, job.n_nodes);
    Entry entry = entries[o];
    MODEL_PARAMS p = params[entry.param_index];
    vec3 wo = entry.wo;
    uint base = entry.node_list * job.node_stride;
    vec3 acc = vec3(0.0);
    for (uint k = begin + lid; k < end; k += gl_WorkGroupSize.x) {
        vec4 node = node_at(base + k);
        acc += node.w * brdf(p, node.xyz, wo);
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
    if (lid == 0u) {
        partial_out[3u * gl_WorkGroupID.x + 0u] = sums[0].r;
        partial_out[3u * gl_WorkGroupID.x + 1u] = sums[0].g;
        partial_out[3u * gl_WorkGroupID.x + 2u] = sums[0].b;
    }
}
