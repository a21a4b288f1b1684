// Shirley's smooth layered model: a mirror spike F_s(c_o) delta over a Lambertian base. The spike
// cannot live on a grid, so this function returns the non-delta part only (docs/design.md §3); the
// spike's albedo is added exactly by the integrators. Twin of src/model/smooth_layered.rs.
#include "brdf/terms.glsl"

struct SmoothLayeredParams {
    vec3 diffuse_over_pi;  // diffuse / pi, from the host
};

vec3 smooth_layered(SmoothLayeredParams p, vec3 wi, vec3 wo) {
    return p.diffuse_over_pi;
}
