// Shirley, Hu, Smits & Lafortune 1997, "A practitioners' assessment of light reflection models",
// the coupled matte-specular model: F_s(c_o) delta plus
// 21/(20 pi) (1 - R0) matte [1 - (1 - c_i)^5] [1 - (1 - c_o)^5]. The non-delta part only, as for
// smooth_layered. Twin of src/model/coupled.rs.
#include "brdf/terms.glsl"
#include "brdf/sample.glsl"

struct CoupledParams {
    vec3 matte_scale;  // matte 21/(20 pi) (1 - R0), from the host
    float r0;          // Schlick's R0 from ior, for the spike's albedo
};

vec3 coupled(CoupledParams p, vec3 wi, vec3 wo) {
    return p.matte_scale * (pow5_complement(wi.z) * pow5_complement(wo.z));
}

// The mirror spike's albedo seen from c_o: F_s(c_o).
vec3 coupled_delta(CoupledParams p, float c_o) {
    return F_schlick(c_o, vec3(p.r0), vec3(1.0 - p.r0));
}

// The spike's albedo against the matte term's directional albedo matte (1 - R0) (1 - (1 - c_o)^5)
// = matte_scale 20 pi/21 (1 - (1 - c_o)^5).
float coupled_spike_probability(CoupledParams p, vec3 wo) {
    return mixture_share(luminance(coupled_delta(p, wo.z)),
                         luminance(p.matte_scale) * (20.0 * PI / 21.0) * pow5_complement(wo.z));
}

float pdf_coupled(CoupledParams p, vec3 wi, vec3 wo) {
    return (1.0 - coupled_spike_probability(p, wo)) * pdf_cosine(wi);
}

// The spike with its probability by uc, else wi by the cosine for the non-delta part.
Sample sample_coupled(CoupledParams p, vec3 wo, float uc, vec2 u) {
    float spike = coupled_spike_probability(p, wo);
    if (uc < spike) return sample_spike(wo, spike, coupled_delta(p, wo.z));
    vec3 wi = sample_cosine(u);
    return sample_from_draw(wi, pdf_coupled(p, wi, wo), coupled(p, wi, wo));
}
