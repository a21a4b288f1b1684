// The model's sampler and density behind the rules of Reference::sample and Reference::pdf:
// what the draw kernels (kernels/draw.glsl) and the pairs kernel's densities share.
#ifndef LOBE_SAMPLER_GLSL
#define LOBE_SAMPLER_GLSL
#include "kernels/eval.glsl"
#include "brdf/sample.glsl"

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

#endif
