// Normalized Phong (Lafortune & Willems 1994, "Using the modified Phong reflectance model for
// physically based rendering"): f = diffuse/pi + specular (n+2)/(2 pi) max(0, r.wo)^n,
// r = 2 c_i n - wi. Twin of src/model/phong.rs.
#include "brdf/terms.glsl"

struct PhongParams {
    vec3 diffuse;
    float shininess;
    vec3 specular;
};

vec3 phong(PhongParams p, vec3 wi, vec3 wo) {
    vec3 r = vec3(-wi.x, -wi.y, wi.z);  // mirror of wi about n = +z: 2 c_i n - wi
    // 1 - r.wo = |r - wo|^2 / 2 for unit vectors: no cancellation near the mirror direction.
    vec3 d = r - wo;
    float s = 0.5 * dot(d, d);
    float lobe = (p.shininess + 2.0) / (2.0 * PI) * pow1m(s, p.shininess);
    return p.diffuse * INV_PI + p.specular * lobe;
}
