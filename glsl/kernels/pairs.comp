#version 450
#extension GL_GOOGLE_include_directive : require
// f at explicit direction pairs, each with the index of its parameter set, so that one dispatch
// evaluates many parameter sets (the parity tests use this); or, where the chunk asks for it,
// the model's sampling density at each pair (kernels/sampler.glsl's pdf_at, Reference::pdf's
// twin), stored in the first of the pair's three floats with the other two 0: the sampling
// test integrates a .brdf file's pdfL this way.
#include "kernels/sampler.glsl"

struct Pair {
    vec3 wi;
    uint param_index;
    vec3 wo;
    uint pad;
};

layout(std430, set = 0, binding = 1) readonly buffer Pairs { Pair pairs[]; };

// The chunk's third push-constant word chooses what is stored: f, or the density. Twin of
// PairsOutput (src/gpu/mod.rs).
const uint PAIRS_F = 0u;
const uint PAIRS_DENSITY = 1u;

void main() {
    uint base = gl_GlobalInvocationID.x * EVALS_PER_INVOCATION;
    bool density = chunk.n_wo == PAIRS_DENSITY;
    for (uint k = 0u; k < EVALS_PER_INVOCATION; ++k) {
        uint local_index = base + k;
        if (local_index >= chunk.count) return;
        Pair p = pairs[local_index];  // the host uploads one chunk of pairs at a time
        MODEL_PARAMS params_k = params[p.param_index];
        store(local_index, density ? vec3(pdf_at(params_k, p.wi, p.wo), 0.0, 0.0)
                                   : brdf(params_k, p.wi, p.wo));
    }
}
