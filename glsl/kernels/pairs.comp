#version 450
#extension GL_GOOGLE_include_directive : require
// f at explicit direction pairs, each with the index of its parameter set, so that one dispatch
// evaluates many parameter sets (the parity tests use this).
#include "kernels/eval.glsl"

struct Pair {
    vec3 wi;
    uint param_index;
    vec3 wo;
    uint pad;
};

layout(std430, set = 0, binding = 1) readonly buffer Pairs { Pair pairs[]; };

void main() {
    uint base = gl_GlobalInvocationID.x * EVALS_PER_INVOCATION;
    for (uint k = 0u; k < EVALS_PER_INVOCATION; ++k) {
        uint local_index = base + k;
        if (local_index >= chunk.count) return;
        Pair p = pairs[local_index];  // the host uploads one chunk of pairs at a time
        store(local_index, brdf(params[p.param_index], p.wi, p.wo));
    }
}
