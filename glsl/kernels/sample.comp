#version 450
#extension GL_GOOGLE_include_directive : require
// Draws of the model's sampler for one wo (docs/design.md section 13): draw i of the request
// takes its numbers from draw_numbers(seed, i, group), as the CPU's Reference::sample does with
// random::draw_numbers, so both sides draw the same directions. Each draw stores the sample
// (wi, pdf, weight, delta) and, at the drawn wi, the model's density MODEL_PDF and f cos(theta_i),
// for the host to check the three against each other and against the f64 reference.
#include "kernels/draw.glsl"

// Floats per draw in the output: wi (3), pdf, weight (3), delta (0 or 1), pdf_at, eval_cos (3).
const uint DRAW_FLOATS = 12u;

void store_draw(uint local_index, Sample s, float pdf_value, vec3 eval_cos) {
    uint o = DRAW_FLOATS * local_index;
    f_out[o + 0u] = s.wi.x;
    f_out[o + 1u] = s.wi.y;
    f_out[o + 2u] = s.wi.z;
    f_out[o + 3u] = s.pdf;
    f_out[o + 4u] = s.weight.x;
    f_out[o + 5u] = s.weight.y;
    f_out[o + 6u] = s.weight.z;
    f_out[o + 7u] = float(s.delta);
    f_out[o + 8u] = pdf_value;
    f_out[o + 9u] = eval_cos.x;
    f_out[o + 10u] = eval_cos.y;
    f_out[o + 11u] = eval_cos.z;
}

void main() {
    DrawRequest r = request;
    MODEL_PARAMS p = params[0];
    uint base = gl_GlobalInvocationID.x * EVALS_PER_INVOCATION;
    for (uint k = 0u; k < EVALS_PER_INVOCATION; ++k) {
        uint local_index = base + k;
        if (local_index >= chunk.count) return;
        uint lo, hi;
        draw_index(r, chunk.first + local_index, lo, hi);
        float uc;
        vec2 u;
        draw_numbers(r.seed, lo, hi, r.group, uc, u);
        Sample s = draw(p, r.wo, uc, u);
        store_draw(local_index, s, pdf_at(p, s.wi, r.wo), brdf(p, s.wi, r.wo) * max(s.wi.z, 0.0));
    }
}
