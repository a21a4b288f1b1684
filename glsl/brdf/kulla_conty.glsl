// Kulla & Conty 2017, "Revisiting physically based shading at Imageworks": the multiple-scattering
// lobe of a microfacet model from tables of its single-scattering loss. Twin of
// src/model/kulla_conty.rs (tables, interpolation and formulas there); included by microfacet.glsl.

// The Kulla-Conty table of this pipeline's distribution and masking (binding 7,
// MODEL_DATA_BINDING in src/gpu/pipeline.rs; src/model/kulla_conty.rs): the loss L = 1 - E at
// s = sqrt(mu) = j/64 and r = sqrt(alpha) = k/64 at index 65 k + j, then L_avg of each row k.
const int KC_KNOTS = 65;
layout(std430, set = 0, binding = 7) readonly buffer KullaContyTable { float kc_table[]; };

// 4-point Lagrange weights at u in [0, 64] on the knots 0 ... 64; returns the first knot.
int kc_lagrange(float u, out vec4 w) {
    u = clamp(u, 0.0, float(KC_KNOTS - 1));
    int i0 = min(max(int(floor(u)) - 1, 0), KC_KNOTS - 4);
    float t = u - float(i0);
    w = vec4(-(t - 1.0) * (t - 2.0) * (t - 3.0) / 6.0, t * (t - 2.0) * (t - 3.0) / 2.0,
             -t * (t - 1.0) * (t - 3.0) / 2.0, t * (t - 1.0) * (t - 2.0) / 6.0);
    return i0;
}

// L(mu; alpha) = 1 - E, tensor-product cubic in (sqrt(mu), sqrt(alpha)), clamped at 0.
float kc_loss(float mu, int k0, vec4 wk) {
    vec4 wj;
    int j0 = kc_lagrange(sqrt(max(mu, 0.0)) * float(KC_KNOTS - 1), wj);
    float sum = 0.0;
    for (int a = 0; a < 4; a++) {
        int base = (k0 + a) * KC_KNOTS + j0;
        vec4 row = vec4(kc_table[base], kc_table[base + 1], kc_table[base + 2], kc_table[base + 3]);
        sum += wk[a] * dot(wj, row);
    }
    return max(sum, 0.0);
}

// specular F_ms f_ms with f_ms = L(mu_o) L(mu_i) / (pi L_avg), F_ms = F_avg^2 E_avg / (1 - F_avg L_avg),
// at alpha = sqrt(alpha_x alpha_y). What depends on alpha and F_avg alone comes from the host: the
// stencil in r (first knot k0, weights wk) and scale = F_ms / (pi L_avg), 0 where L_avg is 0.
vec3 kulla_conty(int k0, vec4 wk, vec3 scale, float c_i, float c_o) {
    return scale * (kc_loss(c_o, k0, wk) * kc_loss(c_i, k0, wk));
}
