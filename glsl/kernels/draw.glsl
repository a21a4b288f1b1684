// What the draws kernel (kernels/sample.comp) and the sampling test's counting kernel
// (kernels/chi2.comp) share: the model's sampler behind the rules of Reference::sample and
// Reference::pdf, the request (wo, the stream, the first draw) and a draw's 64-bit index.
// Draw i of a request takes its numbers from draw_numbers(seed, i, group), as the CPU does with
// random::draw_numbers, so both sides draw the same directions (docs/design.md section 13).
#ifndef LOBE_DRAW_GLSL
#define LOBE_DRAW_GLSL
#include "kernels/eval.glsl"
#include "brdf/sample.glsl"
#include "random.glsl"

#ifndef MODEL_SAMPLE
// A model without a sampler of its own (a .brdf file's shader) is drawn by the cosine, as
// Reference::sample draws every model defined at run time (sample_by_cosine in the twin).
Sample sample_by_cosine(MODEL_PARAMS p, vec3 wo, float uc, vec2 u) {
    vec3 wi = sample_cosine(u);
    return sample_from_draw(wi, pdf_cosine(wi), brdf(p, wi, wo));
}

float pdf_by_cosine(MODEL_PARAMS p, vec3 wi, vec3 wo) {
    return pdf_cosine(wi);
}
#define MODEL_SAMPLE sample_by_cosine
#define MODEL_PDF pdf_by_cosine
#endif

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

// Reference::sample's rule: for wo below the horizon every draw is lost, wi the mirror of wo.
Sample draw(MODEL_PARAMS p, vec3 wo, float uc, vec2 u) {
    if (wo.z <= 0.0) return sample_lost(mirror(wo));
    return MODEL_SAMPLE(p, wo, uc, u);
}

// Reference::pdf's rule: 0 unless both directions are above the horizon.
float pdf_at(MODEL_PARAMS p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) return 0.0;
    return MODEL_PDF(p, wi, wo);
}

// Draw first + offset: the 64-bit index as (low, high) with the carry of the low word's sum.
void draw_index(uint offset, out uint lo, out uint hi) {
    uint carry;
    lo = uaddCarry(request.first_lo, offset, carry);
    hi = request.first_hi + carry;
}

#endif
