// Shirley, Hu, Smits & Lafortune 1997, "A practitioners' assessment of light reflection models",
// the coupled matte-specular model: F_s(c_o) delta plus
// 21/(20 pi) (1 - R0) matte [1 - (1 - c_i)^5] [1 - (1 - c_o)^5]. The non-delta part only, as for
// smooth_layered. Twin of src/model/coupled.rs.
#include "brdf/terms.glsl"

struct CoupledParams {
    vec3 matte;
    float ior;
};

vec3 coupled(CoupledParams p, vec3 wi, vec3 wo) {
    float r0 = r0_from_ior(p.ior);
    float k = 21.0 / (20.0 * PI) * (1.0 - r0);
    return p.matte * (k * pow5_complement(wi.z) * pow5_complement(wo.z));
}
