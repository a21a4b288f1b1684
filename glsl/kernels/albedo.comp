#version 450
#extension GL_GOOGLE_include_directive : require
// Directional albedo as a reduction, E(wo) = sum_k w_k f(wi_k, wo), with the quadrature's nodes
// (wi_k, w_k) given as a list; w_k already holds cos(theta_i) (src/integrate/ derives each rule).
// No table is written: each workgroup sums one span of one wo's nodes in f32 (strided per
// invocation, then a tree in shared memory) and writes one partial sum; the host adds each wo's
// partials in f64 (src/gpu/albedo.rs).
//
// Self-contained rather than built on kernels/eval.glsl, whose push-constant block it cannot share;
// bindings 0 and 3 keep eval.glsl's meaning (parameters, output).
#include "common.glsl"
#include "model.glsl"

// Specialization constant 1 sets the workgroup size (constant 2, evaluations per invocation, is
// not used: the span per workgroup comes with the job).
layout(local_size_x_id = 1) in;

layout(std430, set = 0, binding = 0) readonly buffer ParamBlock { MODEL_PARAMS params[]; };
// xyz = wi, w = weight (with cos(theta_i)); node k of wo o is nodes[o * node_stride + k].
layout(std430, set = 0, binding = 1) readonly buffer Nodes { vec4 nodes[]; };
layout(std430, set = 0, binding = 2) readonly buffer ViewDirs { vec4 wo_list[]; };
// One rgb partial sum per workgroup: 3 floats at 3 * gl_WorkGroupID.x.
layout(std430, set = 0, binding = 3) writeonly buffer Partials { float partial_out[]; };

// nodes_per_group: the span of nodes one workgroup sums; dispatch_count: read by the host's
// dispatcher only (workgroups x its evaluations per workgroup); n_nodes: nodes per wo;
// node_stride: 0 when every wo shares one node list, else n_nodes. Twin of AlbedoPush.
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

void main() {
    uint lid = gl_LocalInvocationID.x;
    uint groups_per_wo = (job.n_nodes + job.nodes_per_group - 1u) / job.nodes_per_group;
    uint o = gl_WorkGroupID.x / groups_per_wo;
    uint begin = (gl_WorkGroupID.x - o * groups_per_wo) * job.nodes_per_group;
    uint end = min(begin + job.nodes_per_group, job.n_nodes);
    vec3 wo = wo_list[o].xyz;
    uint base = o * job.node_stride;
    vec3 acc = vec3(0.0);
    for (uint k = begin + lid; k < end; k += gl_WorkGroupSize.x) {
        vec4 node = nodes[base + k];
        acc += node.w * brdf(params[0], node.xyz, wo);
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
