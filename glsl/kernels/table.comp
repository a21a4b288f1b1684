#version 450
#extension GL_GOOGLE_include_directive : require
// A lobe table as the outer product of a list of light directions and a list of view
// directions: cell = i * n_wo + o. The host lays the grid's angles out into the two lists, so the
// same kernel serves the full and the isotropic grid.
#include "kernels/eval.glsl"

layout(std430, set = 0, binding = 1) readonly buffer LightDirs { vec4 wi_list[]; };
layout(std430, set = 0, binding = 2) readonly buffer ViewDirs { vec4 wo_list[]; };

void main() {
    uint base = gl_GlobalInvocationID.x * EVALS_PER_INVOCATION;
    for (uint k = 0u; k < EVALS_PER_INVOCATION; ++k) {
        uint local_index = base + k;
        if (local_index >= chunk.count) return;
        uint cell = chunk.first + local_index;
        uint i = cell / chunk.n_wo;
        uint o = cell - i * chunk.n_wo;
        store(local_index, brdf(params[0], wi_list[i].xyz, wo_list[o].xyz));
    }
}
