#version 450
#extension GL_GOOGLE_include_directive : require
// `lobe preview`: shades one object per cell of a contact sheet with the pipeline's model, one
// pixel per evaluation. Twin of src/preview/shade.rs (the f64 CPU render), which documents the scene:
// camera at the origin looking down -z with +y up and +x right (OpenGL eye space), the lab's
// lights as positions in that space, and the shading frame n = +z, t = +x, b = +y
// (docs/design.md §2) with t = normalize(cross(+y, n)), the sphere's lines of latitude.
//
// Pixels are numbered cell by cell, then row by row from the top: index = (cell * H + y) * W + x.
#include "kernels/eval.glsl"

struct Light {
    vec4 position;   // xyz; w = 1 a point light at xyz, w = 0 a directional light toward xyz
    vec4 intensity;  // rgb: W/sr for a point light, W/m^2 (irradiance at normal incidence) for a direction
};

struct Object {
    vec3 centre;
    float radius;      // the sphere's radius, the icosahedron's circumradius
    uint shape;        // SHAPE_SPHERE or SHAPE_ICOSAHEDRON
    uint param_index;  // which parameter block of binding 0 shades it
    uint pad0;
    uint pad1;
};

const uint SHAPE_SPHERE = 0u;
const uint SHAPE_ICOSAHEDRON = 1u;

layout(std430, set = 0, binding = 1) readonly buffer Scene {
    uvec4 dims;    // cell width, cell height, cells, lights
    vec4 camera;   // tan(vertical field of view / 2), aspect = width / height
    vec4 ambient;  // rgb radiance of a uniform sky (0: the lab's "no ambient light")
    Light lights[];
};
layout(std430, set = 0, binding = 2) readonly buffer Objects { Object objects[]; };

// The golden ratio: the icosahedron's vertices are the cyclic permutations of (0, +-1, +-PHI).
const float PHI = 1.61803398874989484820;

// Outward unit normal of face k (0..19) of that icosahedron: the face centres are the vertices of
// the dual dodecahedron, (+-1, +-1, +-1) and the cyclic permutations of (+-1/PHI, 0, +-PHI), all of
// length sqrt(3).
vec3 icosahedron_normal(uint k) {
    vec3 v;
    if (k < 8u) {
        v = vec3((k & 1u) != 0u ? -1.0 : 1.0, (k & 2u) != 0u ? -1.0 : 1.0, (k & 4u) != 0u ? -1.0 : 1.0);
    } else {
        uint j = k - 8u;
        float a = (j & 1u) != 0u ? -1.0 / PHI : 1.0 / PHI;
        float b = (j & 2u) != 0u ? -PHI : PHI;
        uint perm = j >> 2u;
        v = perm == 0u ? vec3(a, 0.0, b) : (perm == 1u ? vec3(b, a, 0.0) : vec3(0.0, b, a));
    }
    return v * 0.57735026918962576451;  // 1/sqrt(3)
}

// Inradius / circumradius of a regular icosahedron: PHI^2 / (sqrt(3) sqrt(1 + PHI^2)).
const float ICOSAHEDRON_INRADIUS = 0.79465447229176612295;

// Nearest hit of the ray t*d (t > 0, from the origin) with object o: t and the outward normal, or
// t < 0 for a miss.
float intersect(Object o, vec3 d, out vec3 n) {
    n = vec3(0.0, 0.0, 1.0);
    if (o.shape == SHAPE_SPHERE) {
        // Haines, Guenther & Akenine-Moeller, "Precision improvements for ray/sphere intersection"
        // (Ray Tracing Gems, 2019, ch. 7): the discriminant as r^2 - |c - b d|^2 has no
        // cancellation at the silhouette, and the near root as c/q avoids b - sqrt(disc).
        float b = dot(d, o.centre);
        vec3 f = o.centre - b * d;
        float disc = o.radius * o.radius - dot(f, f);
        if (disc < 0.0 || b <= 0.0) return -1.0;
        float q = b + sqrt(disc);
        float t = (dot(o.centre, o.centre) - o.radius * o.radius) / q;
        n = (t * d - o.centre) / o.radius;
        return t;
    }
    // Convex polyhedron as the intersection of its face half-spaces (Haines, "Fast ray-convex
    // polyhedron intersection", Graphics Gems II, 1991): the ray is inside between the last
    // entering plane and the first leaving one. Face k: dot(n_k, x - centre) <= inradius.
    float inradius = o.radius * ICOSAHEDRON_INRADIUS;
    float t_near = 0.0, t_far = 3.0e38;
    for (uint k = 0u; k < 20u; ++k) {
        vec3 nk = icosahedron_normal(k);
        float offset = inradius + dot(nk, o.centre);  // plane: dot(nk, x) = offset
        float denom = dot(nk, d);
        if (denom == 0.0) {
            if (offset < 0.0) return -1.0;  // parallel and the origin outside this face
            continue;
        }
        float t = offset / denom;
        if (denom < 0.0) {
            if (t > t_near) { t_near = t; n = nk; }
        } else {
            t_far = min(t_far, t);
        }
    }
    return (t_near > 0.0 && t_near <= t_far) ? t_near : -1.0;
}

// The radiance toward the camera from the point p = t d with outward normal n.
vec3 shade(MODEL_PARAMS params_, vec3 p, vec3 n, vec3 d) {
    // Tangent along the lines of latitude about +y (the anisotropic models' +x); n is never
    // +-y on a visible sphere point (those points face away from the camera), but an icosahedron
    // or a sphere placed elsewhere might: fall back to +x there.
    vec3 t = cross(vec3(0.0, 1.0, 0.0), n);
    float tl = length(t);
    t = tl > 1e-6 ? t / tl : vec3(1.0, 0.0, 0.0);
    vec3 bt = cross(n, t);
    vec3 wo_w = -d;
    vec3 wo = vec3(dot(wo_w, t), dot(wo_w, bt), dot(wo_w, n));
    vec3 radiance = vec3(0.0);
    for (uint l = 0u; l < dims.w; ++l) {
        Light light = lights[l];
        vec3 to_light = light.position.w != 0.0 ? light.position.xyz - p : light.position.xyz;
        float dist2 = dot(to_light, to_light);
        vec3 wi_w = to_light * inversesqrt(dist2);
        vec3 wi = vec3(dot(wi_w, t), dot(wi_w, bt), dot(wi_w, n));
        // Point: intensity / distance^2; directional: the intensity is the irradiance already.
        vec3 e = light.position.w != 0.0 ? light.intensity.rgb / dist2 : light.intensity.rgb;
        radiance += brdf(params_, wi, wo) * max(wi.z, 0.0) * e;
    }
    // Uniform sky of radiance A: its irradiance pi A is taken as arriving along the normal, so
    // L = A pi f(n, wo). Exact for Lambert; a crude stand-in for glossy lobes (see src/preview/shade.rs).
    radiance += ambient.rgb * PI * brdf(params_, vec3(0.0, 0.0, 1.0), wo);
    return radiance;
}

void main() {
    uint w = dims.x, h = dims.y;
    uint base = gl_GlobalInvocationID.x * EVALS_PER_INVOCATION;
    for (uint k = 0u; k < EVALS_PER_INVOCATION; ++k) {
        uint local_index = base + k;
        if (local_index >= chunk.count) return;
        uint pixel = chunk.first + local_index;
        uint cell = pixel / (w * h);
        uint rest = pixel - cell * (w * h);
        uint y = rest / w;
        uint x = rest - y * w;
        // Pixel centres; +y up, so image row 0 is the top.
        float u = (2.0 * (float(x) + 0.5) / float(w) - 1.0) * camera.x * camera.y;
        float v = (1.0 - 2.0 * (float(y) + 0.5) / float(h)) * camera.x;
        vec3 d = normalize(vec3(u, v, -1.0));
        Object o = objects[cell];
        vec3 n;
        float t = intersect(o, d, n);
        vec3 radiance = t > 0.0 ? shade(params[o.param_index], t * d, n, d) : vec3(0.0);
        store(local_index, radiance);
    }
}
