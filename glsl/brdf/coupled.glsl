// Shirley, Hu, Smits & Lafortune 1997, "A practitioners' assessment of light reflection models",
// the coupled matte-specular model: F_s(c_o) delta plus
// 21/(20 pi) (1 - R0) matte [1 - (1 - c_i)^5] [1 - (1 - c_o)^5]. The non-delta part only, as for
// smooth_layered. Twin of src/model/coupled.rs.
#include "brdf/terms.glsl"

struct CoupledParams {
    vec3 matte_scale;  // matte 21/(20 pi) (1 - R0), from the host
};

vec3 coupled(CoupledParams p, vec3 wi, vec3 wo) {
    return p.matte_scale * (pow5_complement(wi.z) * pow5_complement(wo.z));
}
