// Lambert: f = albedo / pi. Twin of src/model/lambert.rs.
#include "brdf/terms.glsl"

struct LambertParams {
    vec3 albedo;
};

vec3 lambert(LambertParams p, vec3 wi, vec3 wo) {
    return p.albedo * INV_PI;
}
