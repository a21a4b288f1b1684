#version 450
#extension GL_GOOGLE_include_directive : require
// A lobe table as the outer product of a list of light directions and a list of view
// directions: cell = i * n_wo + o. The host lays the grid's angles out into the two lists, so the
// same kernel serves the full and the isotropic grid.
//
// Shaped for CPU drivers (lavapipe) without costing a GPU anything: a load or store whose index
// varies across invocations becomes a loop over the SIMD lanes there, so
// - the parameter block is read once per invocation, before the loop;
// - one invocation makes EVALS_PER_INVOCATION consecutive cells (a multiple of 4) with one
//   division, stepping o and wrapping to the next i, and fetches wi only when i changes;
// - with TEXEL_DIRECTIONS the direction lists are read through uniform texel buffers
//   (bindings 4 and 5, the same lists), which such a driver gathers cheaply;
// - four cells go out as three vec4 stores.
// Cells past the chunk's end (in the last invocations) are evaluated with i clamped to the last
// row and written to the output buffer's padding, which the host sizes for whole invocations;
// so the kernel has no bounds branch.
// An invocation that made a value that is not a valid BRDF value (NaN, ±Inf, negative; also
// -0.0, which the host then finds valid) sets `invalid_seen` (binding 6, cleared before each
// chunk): the host reads a chunk's values for them only then (docs/design.md §2.1).
//
// UPPER_TRIANGLE (docs/design.md §4.5): the isotropic grid of a reciprocal model with equal θ
// axes, wo = (θo, Δφ) row-major, n_wo = n_wi · NDPHI. Only the cells with o ≥ i are made, packed
// row after row (row i holds view cells i · NDPHI .. n_wo − 1), and `first` counts packed cells;
// the host copies each cell (i, o, Δφ) with o > i to (o, i, Δφ).
#include "common.glsl"
#include "model.glsl"

layout(local_size_x_id = 1) in;
// Evaluations per invocation: a multiple of 4 (on a CPU driver the host picks the largest of 64,
// 32, 16 and 8 that divides a row, else 8; 4 on a GPU: pipeline::table_evals_per_invocation).
layout(constant_id = 2) const uint EVALS_PER_INVOCATION = 8u;
// Read the direction lists through the texel buffers of bindings 4 and 5 instead of the storage
// buffers of bindings 1 and 2 (the host turns it on where the lists fit maxTexelBufferElements).
layout(constant_id = 20) const bool TEXEL_DIRECTIONS = false;
// Make the packed upper triangle instead of every cell (see the top of the file).
layout(constant_id = 22) const bool UPPER_TRIANGLE = false;
// Every invocation's cells lie in one row: the host sets it where EVALS_PER_INVOCATION divides a
// row's view cells (NDPHI with UPPER_TRIANGLE, n_wo otherwise), so that every row starts on an
// invocation's first cell (the padding's o too: its i is clamped to the last row, its o starts
// on a multiple of EVALS_PER_INVOCATION). Then there is no wrap to test and wi is one value for
// the whole invocation, so that a model's terms of wi alone are computed once: on lavapipe the
// roughconductor table kernel ran x1.13 faster. A constant, not a test on the push constants:
// a uniform branch between the two loops measured slower than either.
layout(constant_id = 23) const bool ROW_ALIGNED = false;
// With ROW_ALIGNED and a multiple of 8 evaluations per invocation: 8 view directions at a time
// are read first and their 8 evaluations follow as one stretch of straight code (brdf() has no
// branch), which the compiler interleaves. On lavapipe from Mesa 22.3.6 the roughconductor table
// kernel ran x1.46 faster; Mesa 25.0.7's code for it spills and ran x0.85, and lighter models ran
// slower, so the host sets it only for the models and drivers where it measured a gain
// (src/gpu/mod.rs, table_interleaves; ModelInfo::interleave_table).
layout(constant_id = 24) const bool INTERLEAVED = false;

layout(std430, set = 0, binding = 0) readonly buffer ParamBlock { MODEL_PARAMS params[]; };
layout(std430, set = 0, binding = 1) readonly buffer LightDirs { vec4 wi_list[]; };
layout(std430, set = 0, binding = 2) readonly buffer ViewDirs { vec4 wo_list[]; };
// RGB triples, cell after cell from the chunk's first cell, as vec4s (4 cells = 3 vec4s).
layout(std430, set = 0, binding = 3) writeonly buffer Output { vec4 f_out[]; };
layout(set = 0, binding = 4) uniform samplerBuffer wi_texels;
layout(set = 0, binding = 5) uniform samplerBuffer wo_texels;
layout(std430, set = 0, binding = 6) writeonly buffer InvalidSeen { uint invalid_seen; };

// first: the chunk's first cell (a multiple of EVALS_PER_INVOCATION); count: cells in the
// chunk; n_wo, n_wi: the lists' lengths. Twin of TablePush (src/gpu/pipeline.rs).
layout(push_constant) uniform Chunk { uint first; uint count; uint n_wo; uint n_wi; } chunk;

// docs/design.md §2: f = 0 whenever c_i <= 0 or c_o <= 0 (as in kernels/eval.glsl), chosen
// after the model's value rather than branched around it, so that INTERLEAVED's evaluations are
// one stretch of code.
vec3 brdf(MODEL_PARAMS p, vec3 wi, vec3 wo) {
    vec3 f = MODEL_EVAL(p, wi, wo);
    return wi.z > 0.0 && wo.z > 0.0 ? f : vec3(0.0);
}

vec3 light_dir(uint i) {
    if (TEXEL_DIRECTIONS) return texelFetch(wi_texels, int(i)).xyz;
    return wi_list[i].xyz;
}

// The largest bit pattern of the values so far: as unsigned integers, every valid f32 (0 to the
// largest finite, +0.0) lies below 0x7F800000 (+Inf), and every NaN and negative value above.
uvec3 widest(uvec3 seen, vec3 f) {
    return max(seen, floatBitsToUint(f));
}

vec3 view_dir(uint o) {
    if (TEXEL_DIRECTIONS) return texelFetch(wo_texels, int(o)).xyz;
    return wo_list[o].xyz;
}

// Row i and view cell o of packed cell `cell` of the upper triangle. Counted from the table's
// end, row n − 1 − r holds r + 1 (θi, θo) pairs, so the q-th pair from the end lies in the row
// r with r(r + 1)/2 ≤ q < (r + 1)(r + 2)/2; the float square root finds r to within one, the two
// loops make it exact. Twin of UpperTriangle::locate (src/backend/mirror.rs). n(n + 1) fits a
// uint: the host refuses tables of 2^32 cells or more.
void upper_start(uint cell, uint n_dphi, out uint i, out uint o) {
    uint n = chunk.n_wi;
    uint pairs = n * (n + 1u) / 2u;
    uint pair = cell / n_dphi;
    uint d = cell - pair * n_dphi;
    // Cells past the table's end (padding of the last invocation) start at its last pair.
    uint q = pairs - 1u - min(pair, pairs - 1u);
    uint r = uint((sqrt(8.0 * float(q) + 1.0) - 1.0) * 0.5);
    while (r > 0u && r * (r + 1u) / 2u > q) --r;
    while ((r + 1u) * (r + 2u) / 2u <= q) ++r;
    i = n - 1u - r;
    o = (n - 1u - (q - r * (r + 1u) / 2u)) * n_dphi + d;
}

// Marks the chunk where an invocation's largest bit pattern is +Inf's or above (see widest).
void flag_invalid(uvec3 seen) {
    if (max(seen.x, max(seen.y, seen.z)) >= 0x7F800000u) invalid_seen = 1u;
}

void main() {
    MODEL_PARAMS p = params[0];
    uint local0 = gl_GlobalInvocationID.x * EVALS_PER_INVOCATION;
    uint cell = chunk.first + local0;
    uint n_dphi = UPPER_TRIANGLE ? chunk.n_wo / chunk.n_wi : 0u;
    uint i;
    uint o;
    if (UPPER_TRIANGLE) {
        upper_start(cell, n_dphi, i, o);
    } else {
        i = cell / chunk.n_wo;
        o = cell - i * chunk.n_wo;
    }
    uint last_i = chunk.n_wi - 1u;
    vec3 wi = light_dir(min(i, last_i));
    uint out_index = 3u * (local0 / 4u);
    uvec3 seen = uvec3(0u);
    if (INTERLEAVED && EVALS_PER_INVOCATION % 8u == 0u) {
        // 8 cells at a time: every view direction first, then every evaluation, then the stores:
        // one stretch of code without calls or branches, which the compiler interleaves, so that
        // one evaluation's chain of square roots and divisions overlaps the others'.
        for (uint g = 0u; g < EVALS_PER_INVOCATION / 8u; ++g) {
            vec3 wo0 = view_dir(o), wo1 = view_dir(o + 1u), wo2 = view_dir(o + 2u),
                 wo3 = view_dir(o + 3u), wo4 = view_dir(o + 4u), wo5 = view_dir(o + 5u),
                 wo6 = view_dir(o + 6u), wo7 = view_dir(o + 7u);
            vec3 f0 = brdf(p, wi, wo0), f1 = brdf(p, wi, wo1), f2 = brdf(p, wi, wo2),
                 f3 = brdf(p, wi, wo3), f4 = brdf(p, wi, wo4), f5 = brdf(p, wi, wo5),
                 f6 = brdf(p, wi, wo6), f7 = brdf(p, wi, wo7);
            f_out[out_index + 0u] = vec4(f0, f1.r);
            f_out[out_index + 1u] = vec4(f1.gb, f2.rg);
            f_out[out_index + 2u] = vec4(f2.b, f3);
            f_out[out_index + 3u] = vec4(f4, f5.r);
            f_out[out_index + 4u] = vec4(f5.gb, f6.rg);
            f_out[out_index + 5u] = vec4(f6.b, f7);
            seen = widest(widest(widest(widest(seen, f0), f1), f2), f3);
            seen = widest(widest(widest(widest(seen, f4), f5), f6), f7);
            o += 8u;
            out_index += 6u;
        }
        flag_invalid(seen);
        return;
    }
    for (uint q = 0u; q < EVALS_PER_INVOCATION / 4u; ++q) {
        vec3 f[4];
        for (uint r = 0u; r < 4u; ++r) {
            f[r] = brdf(p, wi, view_dir(o));
            if (++o == chunk.n_wo && !ROW_ALIGNED) {
                ++i;
                o = UPPER_TRIANGLE ? min(i, last_i) * n_dphi : 0u;
                wi = light_dir(min(i, last_i));
            }
        }
        f_out[out_index + 0u] = vec4(f[0], f[1].r);
        f_out[out_index + 1u] = vec4(f[1].gb, f[2].rg);
        f_out[out_index + 2u] = vec4(f[2].b, f[3]);
        out_index += 3u;
        // After the four, not after each: inside the loop over them the maxima made the
        // roughconductor kernel x0.86 as fast on Mesa 25.0.7.
        seen = max(seen, max(max(floatBitsToUint(f[0]), floatBitsToUint(f[1])),
                             max(floatBitsToUint(f[2]), floatBitsToUint(f[3]))));
    }
    flag_invalid(seen);
}
