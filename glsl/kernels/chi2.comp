#version 450
#extension GL_GOOGLE_include_directive : require
// The sampling test's counting on the device (docs/design.md section 14): the draws of
// kernels/sample.comp (kernels/draw.glsl: the same numbers, the same sampler) are not stored but
// counted. Each draw outside a delta lobe, finite, with pdf > 0 and above the horizon is counted
// in its (phi, cos theta) cell (cells_index, twin of Cells::index in src/chi2/cells.rs); the
// others are tallied as the CPU's Tally::draw tallies them (src/chi2/tally.rs), with the weight
// checks where CHECKED. The dispatch clears the counts before each chunk; the host reads them
// back after it and adds them in 64 bits.
#include "kernels/draw.glsl"

// The counts: HISTOGRAM_COPIES blocks of COUNT_HEADER words, each with the tallies at these
// word offsets, then (where the cells are counted here) HISTOGRAM_COPIES copies of one count
// per cell. Twins of the COUNT_* constants of src/gpu/draws.rs.
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
// The tallies and the cells' counts are kept HISTOGRAM_COPIES times, workgroup w adding to copy
// w mod HISTOGRAM_COPIES, and the host adds the copies: the threads of a CPU driver (or a GPU's
// workgroups) then rarely add to the same word at once, whose cache line would otherwise pass
// between cores at nearly every invocation (a block of tallies, 16 words, is a 64-byte cache
// line's worth). Twin of CHI2_HISTOGRAM_COPIES in src/gpu/draws.rs.
const uint HISTOGRAM_COPIES = 16u;

// Twin of chi2::UNIT_TOLERANCE_F32: a drawn wi may differ from unit length by this much.
const float UNIT_TOLERANCE_F32 = 1e-5;
// Twin of chi2::TINY_F32: below it values compare as equal (f32's subnormals keep ever fewer
// bits): 2^23 times the smallest normal f32.
const float TINY_F32 = 1.17549435e-38 * 8388608.0;

float infinity() {
    return uintBitsToFloat(0x7f800000u);
}

// The cells: n_phi equal steps of phi over [0, 2 pi), n_cos of cos theta over [0, 1], and the
// factors that take phi and cos theta to steps.
struct Cells {
    uint n_phi;
    uint n_cos;
    float phi_steps;
    float cos_steps;
};

// The cells of the chunk's third push-constant word: the steps in phi in its low 16 bits, those
// in cos theta in its high 16 (ChunkPush::n_wo on the host).
Cells cells_of(uint word) {
    uint n_phi = word & 0xffffu, n_cos = word >> 16u;
    return Cells(n_phi, n_cos, float(n_phi) / (2.0 * PI), float(n_cos));
}

// Twin of Cells::index for the unit direction w / len (len = |w|): the cell
// (i_cos * n_phi + i_phi) where cos theta > 0, NO_CELL otherwise. phi is w's own (atan of y and
// x is that of their ratio), so only cos theta is divided by len.
uint cells_index(vec3 w, float len, Cells c) {
    float cos_theta = w.z / len;
    if (!(cos_theta > 0.0)) return NO_CELL;
    float phi = atan(w.y, w.x);
    if (!(phi >= 0.0)) phi = phi < 0.0 ? phi + 2.0 * PI : 0.0;
    uint i_phi = min(uint(phi * c.phi_steps), c.n_phi - 1u);
    uint i_cos = min(uint(cos_theta * c.cos_steps), c.n_cos - 1u);
    return i_cos * c.n_phi + i_phi;
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

// The largest of the non-negative x and the float whose bits are at word.
void tally_max(uint word, float x) {
    if (x > 0.0) atomicMax(counts[word], floatBitsToUint(x));
}

// An invocation's tallies and largest errors, added to the counts once at its end.
struct Tallies {
    uint lost, delta, invalid, non_unit, zero_pdf, non_finite_weight, weight_outside, pdf_below;
    float weight_error, pdf_error;
};

// Draws the sample of the numbers r for wo and tallies it in t: its cell, or NO_CELL where it
// is counted outside the cells.
uint count_draw(MODEL_PARAMS p, vec3 wo, vec4 r, Cells cells, inout Tallies t) {
    Sample s = draw(p, wo, r.x, r.yz);
    if (s.delta != 0u) {
        t.delta += 1u;
        return NO_CELL;
    }
    if (!finite3(s.wi) || !finite1(s.pdf) || s.pdf < 0.0) {
        t.invalid += 1u;
        return NO_CELL;
    }
    if (CHECKED && !finite3(s.weight)) t.non_finite_weight += 1u;
    float len = length(s.wi);
    if (abs(len - 1.0) > UNIT_TOLERANCE_F32) t.non_unit += 1u;
    uint cell = s.pdf > 0.0 ? cells_index(s.wi, len, cells) : NO_CELL;
    if (cell == NO_CELL) {
        t.lost += 1u;
        if (s.wi.z > 0.0) {
            t.zero_pdf += 1u;
        } else if (s.pdf != 0.0) {
            t.pdf_below += 1u;
        }
        if (CHECKED && s.weight != vec3(0.0)) t.weight_outside += 1u;
        return NO_CELL;
    }
    if (CHECKED) {
        t.pdf_error = max(t.pdf_error, relative(s.pdf, pdf_at(p, s.wi, wo)));
        vec3 want = brdf(p, s.wi, wo) * max(s.wi.z, 0.0) / s.pdf;
        for (int c = 0; c < 3; ++c) {
            t.weight_error = max(t.weight_error, relative(s.weight[c], want[c]));
        }
    }
    return cell;
}

// Draws whose hashes are made together before they are drawn: the hash is a chain of dependent
// multiplies, and four independent chains side by side keep a CPU's multiplier busy. Where an
// invocation makes fewer draws (a GPU's one), only those are hashed.
const uint HASH_BATCH = 4u;

void main() {
    // The request, the chunk and the parameters, read once: a CPU driver reads a buffer inside
    // a loop lane by lane.
    DrawRequest r = request;
    uint first = chunk.first, count = chunk.count;
    Cells cells = cells_of(chunk.n_wo);
    MODEL_PARAMS p = params[0];
    uint base = gl_GlobalInvocationID.x * EVALS_PER_INVOCATION;
    uint copy = gl_WorkGroupID.x % HISTOGRAM_COPIES;
    uint tallies = copy * COUNT_HEADER;
    uint histogram = HISTOGRAM_COPIES * COUNT_HEADER + copy * cells.n_phi * cells.n_cos;
    Tallies t = Tallies(0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u, 0.0, 0.0);
    for (uint k0 = 0u; k0 < EVALS_PER_INVOCATION; k0 += HASH_BATCH) {
        vec4 numbers[HASH_BATCH];
        // The two inner loops' trip counts are constants once specialised (the draws past the
        // chunk are skipped by an if, not a break), so that they are unrolled and numbers[j]
        // stays in registers.
        for (uint j = 0u; j < HASH_BATCH; ++j) {
            if (j >= EVALS_PER_INVOCATION) break;
            uint lo, hi;
            draw_index(r, first + base + k0 + j, lo, hi);
            numbers[j] = uniform4(r.seed, lo, hi, r.group);
        }
        for (uint j = 0u; j < HASH_BATCH; ++j) {
            if (j >= EVALS_PER_INVOCATION) break;
            uint local_index = base + k0 + j;
            if (k0 + j < EVALS_PER_INVOCATION && local_index < count) {
                uint cell = count_draw(p, r.wo, numbers[j], cells, t);
                if (HOST_COUNTS) {
                    indices[local_index] = cell;
                } else if (cell != NO_CELL) {
                    atomicAdd(counts[histogram + cell], 1u);
                }
            }
        }
    }
    tally(tallies + COUNT_LOST, t.lost);
    tally(tallies + COUNT_DELTA, t.delta);
    tally(tallies + COUNT_INVALID, t.invalid);
    tally(tallies + COUNT_NON_UNIT, t.non_unit);
    tally(tallies + COUNT_ZERO_PDF, t.zero_pdf);
    tally(tallies + COUNT_NON_FINITE_WEIGHT, t.non_finite_weight);
    tally(tallies + COUNT_WEIGHT_OUTSIDE, t.weight_outside);
    tally(tallies + COUNT_PDF_BELOW, t.pdf_below);
    tally_max(tallies + COUNT_WEIGHT_ERROR, t.weight_error);
    tally_max(tallies + COUNT_PDF_ERROR, t.pdf_error);
}
