// Lambert: f = albedo / pi. Twin of src/model/lambert.rs.
#include "brdf/terms.glsl"

struct LambertParams {
    vec3 albedo_over_pi;  // albedo / pi, from the host
};

vec3 lambert(LambertParams p, vec3 wi, vec3 wo) {
    return p.albedo_over_pi;
}
