// What the draws kernel (kernels/sample.comp) and the sampling test's counting kernel
// (kernels/chi2.comp) share: the model's sampler (kernels/sampler.glsl), the request (wo, the
// stream, the first draw) and a draw's 64-bit index.
// Draw i of a request takes its numbers from draw_numbers(seed, i, group), as the CPU does with
// random::draw_numbers, so both sides draw the same directions (docs/design.md section 13).
#ifndef LOBE_DRAW_GLSL
#define LOBE_DRAW_GLSL
#include "kernels/sampler.glsl"
#include "random.glsl"

// wo, and the stream: seed, the group of dimensions (the direction's index in a test) and the
// request's first draw index as two 32-bit words (low, high).
struct DrawRequest {
    vec3 wo;
    uint seed;
    uint group;
    uint first_lo;
    uint first_hi;
    uint pad;
};

layout(std430, set = 0, binding = 1) readonly buffer Request { DrawRequest request; };

// Draw first + offset of the request r: the 64-bit index as (low, high) with the carry of the
// low word's sum.
void draw_index(DrawRequest r, uint offset, out uint lo, out uint hi) {
    uint carry;
    lo = uaddCarry(r.first_lo, offset, carry);
    hi = r.first_hi + carry;
}

#endif
