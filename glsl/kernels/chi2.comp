#version 450
#extension GL_GOOGLE_include_directive : require
// The sampling test's counting on the device (docs/design.md section 14): the draws of
// kernels/sample.comp (kernels/draw.glsl: the same numbers, the same sampler) are not stored but
// counted. Each draw outside a delta lobe, finite, with pdf > 0 and above the horizon is counted
// in its (phi, cos theta) cell (cells_index, twin of Cells::index in src/chi2/cells.rs); the
// others are tallied as the CPU's Tally::draw tallies them (src/chi2/tally.rs), with the weight
// checks where CHECKED. The host clears the
// counts before each chunk, reads them back after it and adds them in 64 bits.
#include "kernels/draw.glsl"

// The chunk's third push-constant word carries the cells, the steps in phi in its low 16 bits
// and those in cos theta in its high 16 (ChunkPush::n_wo on the host).

// The counts: the tallies at these word offsets, then one count per cell from COUNT_HEADER on.
// Twins of the COUNT_* constants of src/gpu/draws.rs.
layout(std430, set = 0, binding = 2) buffer Counts { uint counts[]; };
// HOST_COUNTS (a CPU driver, whose atomic add is a locked instruction per lane): each draw's
// cell index, or NO_CELL, is stored at its place in the chunk and the host counts them; the
// cells' counts are then not in Counts. Otherwise each draw adds 1 to its cell in Counts and
// this buffer is not touched. Twin of CellCounting in src/gpu/draws.rs.
layout(constant_id = 20) const bool HOST_COUNTS = false;
layout(std430, set = 0, binding = 3) writeonly buffer Indices { uint indices[]; };
const uint NO_CELL = 0xffffffffu;
// CHECKED: each draw's weight is also checked against f cos(theta_i) / pdf and its pdf against
// MODEL_PDF at its wi. A pipeline of its own rather than a branch: a CPU driver runs both sides
// of a branch under masks, and the checks' f and pdf would then cost every draw. Twin of the
// second of Pipeline::kernel_switches in src/gpu/pipeline/mod.rs.
layout(constant_id = 21) const bool CHECKED = false;
const uint COUNT_LOST = 0u;
const uint COUNT_DELTA = 1u;
const uint COUNT_INVALID = 2u;
const uint COUNT_NON_UNIT = 3u;
const uint COUNT_ZERO_PDF = 4u;
const uint COUNT_NON_FINITE_WEIGHT = 5u;
const uint COUNT_WEIGHT_OUTSIDE = 6u;
const uint COUNT_PDF_BELOW = 7u;
// The largest relative weight and pdf errors, as the bits of non-negative floats (whose order
// as unsigned integers is their order as numbers; +Inf above every finite value).
const uint COUNT_WEIGHT_ERROR = 8u;
const uint COUNT_PDF_ERROR = 9u;
const uint COUNT_HEADER = 16u;
// The cells' counts are kept HISTOGRAM_COPIES times, workgroup w adding to copy w mod
// HISTOGRAM_COPIES, and the host adds the copies: the threads of a CPU driver (or a GPU's
// workgroups on a peaked lobe) then rarely add to the same cell at once, whose cache line
// would otherwise pass between cores at every draw. Twin of CHI2_HISTOGRAM_COPIES in
// src/gpu/draws.rs.
const uint HISTOGRAM_COPIES = 16u;

// Twin of chi2::UNIT_TOLERANCE_F32: a drawn wi may differ from unit length by this much.
const float UNIT_TOLERANCE_F32 = 1e-5;
// Twin of chi2::TINY_F32: below it values compare as equal (f32's subnormals keep ever fewer
// bits): 2^23 times the smallest normal f32.
const float TINY_F32 = 1.17549435e-38 * 8388608.0;

float infinity() {
    return uintBitsToFloat(0x7f800000u);
}

// Twin of Cells::index: the cell (i_cos * n_phi + i_phi) of a unit direction with cos theta > 0,
// -1 otherwise; n_phi equal steps of phi over [0, 2 pi), n_cos of cos theta over [0, 1].
int cells_index(vec3 w, uint n_phi, uint n_cos) {
    if (!(w.z > 0.0)) return -1;
    float phi = atan(w.y, w.x);
    if (!(phi >= 0.0)) phi = phi < 0.0 ? phi + 2.0 * PI : 0.0;
    uint i_phi = min(uint(phi / (2.0 * PI) * float(n_phi)), n_phi - 1u);
    uint i_cos = min(uint(w.z * float(n_cos)), n_cos - 1u);
    return int(i_cos * n_phi + i_phi);
}

// Twin of chi2's relative: |a - b| / max(|a|, |b|), 0 when both are below TINY_F32, infinite
// where one is not finite and they differ.
float relative(float a, float b) {
    if (!finite1(a) || !finite1(b)) return a == b ? 0.0 : infinity();
    float m = max(abs(a), abs(b));
    if (m < TINY_F32) return 0.0;
    return abs(a - b) / m;
}

void tally(uint word, uint n) {
    if (n > 0u) atomicAdd(counts[word], n);
}

// Draws whose hashes are made together before they are drawn: the hash is a chain of dependent
// multiplies, and four independent chains side by side keep a CPU's multiplier busy. Where an
// invocation makes fewer draws (a GPU's one), only those are hashed.
const uint HASH_BATCH = 4u;

void main() {
    const bool checked = CHECKED;
    uint base = gl_GlobalInvocationID.x * EVALS_PER_INVOCATION;
    uint n_phi = chunk.n_wo & 0xffffu;
    uint n_cos = chunk.n_wo >> 16u;
    MODEL_PARAMS p = params[0];
    vec3 wo = request.wo;
    uint histogram = COUNT_HEADER + (gl_WorkGroupID.x % HISTOGRAM_COPIES) * n_phi * n_cos;
    // This invocation's tallies and largest errors, added to the counts once at its end.
    uint lost = 0u, delta = 0u, invalid = 0u, non_unit = 0u, zero_pdf = 0u;
    uint non_finite_weight = 0u, weight_outside = 0u, pdf_below = 0u;
    float weight_error = 0.0, pdf_error = 0.0;
    for (uint k0 = 0u; k0 < EVALS_PER_INVOCATION; k0 += HASH_BATCH) {
        vec4 numbers[HASH_BATCH];
        for (uint j = 0u; j < HASH_BATCH; ++j) {
            // A constant once the loop is unrolled and specialised: a GPU's one draw per
            // invocation makes one hash.
            if (j >= EVALS_PER_INVOCATION) break;
            uint lo, hi;
            draw_index(chunk.first + base + k0 + j, lo, hi);
            numbers[j] = uniform4(request.seed, lo, hi, request.group);
        }
        for (uint j = 0u; j < HASH_BATCH; ++j) {
            uint local_index = base + k0 + j;
            if (k0 + j >= EVALS_PER_INVOCATION || local_index >= chunk.count) break;
            Sample s = draw(p, wo, numbers[j].x, numbers[j].yz);
            if (HOST_COUNTS) indices[local_index] = NO_CELL;
            if (s.delta != 0u) {
                delta += 1u;
                continue;
            }
            if (!finite3(s.wi) || !finite1(s.pdf) || s.pdf < 0.0) {
                invalid += 1u;
                continue;
            }
            if (checked && !finite3(s.weight)) non_finite_weight += 1u;
            float len = length(s.wi);
            if (abs(len - 1.0) > UNIT_TOLERANCE_F32) non_unit += 1u;
            int cell = s.pdf > 0.0 ? cells_index(s.wi / len, n_phi, n_cos) : -1;
            if (cell < 0) {
                lost += 1u;
                if (s.wi.z > 0.0) {
                    zero_pdf += 1u;
                } else if (s.pdf != 0.0) {
                    pdf_below += 1u;
                }
                if (checked && s.weight != vec3(0.0)) weight_outside += 1u;
                continue;
            }
            if (HOST_COUNTS) {
                indices[local_index] = uint(cell);
            } else {
                atomicAdd(counts[histogram + uint(cell)], 1u);
            }
            if (checked) {
                pdf_error = max(pdf_error, relative(s.pdf, pdf_at(p, s.wi, wo)));
                vec3 want = brdf(p, s.wi, wo) * max(s.wi.z, 0.0) / s.pdf;
                for (int c = 0; c < 3; ++c) {
                    weight_error = max(weight_error, relative(s.weight[c], want[c]));
                }
            }
        }
    }
    tally(COUNT_LOST, lost);
    tally(COUNT_DELTA, delta);
    tally(COUNT_INVALID, invalid);
    tally(COUNT_NON_UNIT, non_unit);
    tally(COUNT_ZERO_PDF, zero_pdf);
    tally(COUNT_NON_FINITE_WEIGHT, non_finite_weight);
    tally(COUNT_WEIGHT_OUTSIDE, weight_outside);
    tally(COUNT_PDF_BELOW, pdf_below);
    if (weight_error > 0.0) atomicMax(counts[COUNT_WEIGHT_ERROR], floatBitsToUint(weight_error));
    if (pdf_error > 0.0) atomicMax(counts[COUNT_PDF_ERROR], floatBitsToUint(pdf_error));
}
