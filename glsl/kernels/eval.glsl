// What every kernel shares: the selected model behind the one-sided rule, the parameter block,
// the output buffer and the chunk description. A kernel's main() only computes indices, calls
// brdf() and stores.
#include "common.glsl"
#include "model.glsl"

// Specialization constant 1 sets the workgroup size; 2 sets how many evaluations one invocation
// makes (on lavapipe several per invocation amortise the per-invocation overhead).
layout(local_size_x_id = 1) in;
layout(constant_id = 2) const uint EVALS_PER_INVOCATION = 4u;

layout(std430, set = 0, binding = 0) readonly buffer ParamBlock { MODEL_PARAMS params[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Output { float f_out[]; };

// first: index of the chunk's first element in the whole job; count: elements in this chunk;
// n_wo: length of the wo list (the table kernel; the counting kernel: the cells' steps in phi;
// the pairs kernel: whether to store f or the density).
layout(push_constant) uniform Chunk { uint first; uint count; uint n_wo; uint pad; } chunk;

// docs/design.md §2: f = 0 whenever c_i <= 0 or c_o <= 0.
vec3 brdf(MODEL_PARAMS p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) return vec3(0.0);
    return MODEL_EVAL(p, wi, wo);
}

void store(uint local_index, vec3 f) {
    f_out[3u * local_index + 0u] = f.r;
    f_out[3u * local_index + 1u] = f.g;
    f_out[3u * local_index + 2u] = f.b;
}
