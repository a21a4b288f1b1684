// Counter-based random numbers; twin of src/random.rs. The numbers of draw i depend only on the
// stream's seed (`lobe chi2 --seed`), i and the group (one per view direction), so the GPU draws
// the same numbers as the CPU in any order or chunking.
#ifndef LOBE_RANDOM_GLSL
#define LOBE_RANDOM_GLSL

// pcg4d (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering", JCGT 9(3), section 3):
// GLSL's uint arithmetic wraps modulo 2^32, as the twin's wrapping_mul / wrapping_add do.
uvec4 pcg4d(uvec4 v) {
    // The LCG step of Numerical Recipes (Press et al.), as in the paper.
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    v ^= v >> 16u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    return v;
}

// The hash's input: the index as two 32-bit words (low, high), GLSL having no 64-bit integers
// without an extension, then the stream's seed and the group of four dimensions.
uvec4 random_words(uint seed, uint index_lo, uint index_hi, uint group) {
    return uvec4(index_lo, index_hi, seed, group);
}

// The top 24 bits as k / 2^24: exact in f32, so equal to the twin's f64 value bit for bit.
vec4 to_unit(uvec4 h) {
    return vec4(h >> 8u) * (1.0 / 16777216.0);
}

// Dimensions 4 group .. 4 group + 3 of draw (index_hi 2^32 + index_lo).
vec4 uniform4(uint seed, uint index_lo, uint index_hi, uint group) {
    return to_unit(pcg4d(random_words(seed, index_lo, index_hi, group)));
}

// A sampler's numbers for one draw: dimension 0 is uc (the component choice), dimensions 1 and
// 2 are u (the draw within the component).
void draw_numbers(uint seed, uint index_lo, uint index_hi, uint group, out float uc, out vec2 u) {
    vec4 r = uniform4(seed, index_lo, index_hi, group);
    uc = r.x;
    u = r.yz;
}

#endif
