// Shirley's smooth layered model: a mirror spike F_s(c_o) delta over a Lambertian base. The spike
// cannot live on a grid, so this function returns the non-delta part only (docs/design.md §3); the
// spike's albedo is added exactly by the integrators. Twin of src/model/smooth_layered.rs.
#include "brdf/terms.glsl"
#include "brdf/sample.glsl"

struct SmoothLayeredParams {
    vec3 diffuse_over_pi;  // diffuse / pi, from the host
    float r0;              // Schlick's R0 from ior, for the spike's albedo
};

vec3 smooth_layered(SmoothLayeredParams p, vec3 wi, vec3 wo) {
    return p.diffuse_over_pi;
}

// The mirror spike's albedo seen from c_o: F_s(c_o).
vec3 smooth_layered_delta(SmoothLayeredParams p, float c_o) {
    return F_schlick(c_o, vec3(p.r0), vec3(1.0 - p.r0));
}

// The spike's albedo against the base's, diffuse (luminances).
float smooth_layered_spike_probability(SmoothLayeredParams p, vec3 wo) {
    return mixture_share(luminance(smooth_layered_delta(p, wo.z)), luminance(p.diffuse_over_pi) * PI);
}

float pdf_smooth_layered(SmoothLayeredParams p, vec3 wi, vec3 wo) {
    return (1.0 - smooth_layered_spike_probability(p, wo)) * pdf_cosine(wi);
}

// The spike with its probability by uc, else wi by the cosine for the non-delta part.
Sample sample_smooth_layered(SmoothLayeredParams p, vec3 wo, float uc, vec2 u) {
    float spike = smooth_layered_spike_probability(p, wo);
    if (uc < spike) return sample_spike(wo, spike, smooth_layered_delta(p, wo.z));
    vec3 wi = sample_cosine(u);
    return sample_from_draw(wi, pdf_smooth_layered(p, wi, wo), smooth_layered(p, wi, wo));
}
