//! Counter-based random numbers: draw i of a run is a pure function of (seed, i, dimension), so
//! draws can be made in any order, in chunks on any number of threads, or on the GPU, and
//! always come out the same.
//!
//! The hash is `pcg4d` of Jarzynski & Olano 2020, "Hash Functions for GPU Rendering", JCGT 9(3),
//! §3 (a 4-dimensional variant of PCG, O'Neill 2014): an LCG step on each of four 32-bit words,
//! then two rounds of mixing the words with each other, separated by an xorshift. Its input is
//! (index low word, index high word, seed, dimension / 4) and component dimension mod 4 of its
//! output is the number. Only 32-bit wrapping multiplications, additions, shifts and xors, as
//! GLSL has them without extensions, so a shader twin gives the same integers.
//!
//! The number is the hash's top 24 bits as k/2²⁴, k ∈ [0, 2²⁴): exact in f32 as in f64, so an f32
//! twin computing `float(h >> 8u) * (1.0 / 16777216.0)` gives the bit-identical value.
//!
//! 0 is among the numbers (one draw in 2²⁴) and 1 is not: a sampler that takes a root or a
//! logarithm of u, or divides by it, must take u = 0 (1 − u lies in (0, 1]). At 2²⁸ draws the
//! sampling test (`chi2`) sees the few draws a mishandled 0 sends astray.

/// The largest number [`uniform`] returns is 1 − 2⁻²⁴; numbers are multiples of 2⁻²⁴.
pub const RESOLUTION: f64 = 1.0 / (1u64 << 24) as f64;

/// `pcg4d` (Jarzynski & Olano 2020, JCGT 9(3), listing in §3), with wrapping 32-bit arithmetic.
pub fn pcg4d(v: [u32; 4]) -> [u32; 4] {
    // The LCG step of Numerical Recipes (Press et al.), as in the paper.
    let mut v = v.map(|x| x.wrapping_mul(1664525).wrapping_add(1013904223));
    let mix = |v: &mut [u32; 4]| {
        v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[3]));
        v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
        v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
        v[3] = v[3].wrapping_add(v[1].wrapping_mul(v[2]));
    };
    mix(&mut v);
    v = v.map(|x| x ^ (x >> 16));
    mix(&mut v);
    v
}

/// The hash input for `index` and the group of four dimensions `dim / 4`: the index is split into
/// two 32-bit words, since GLSL has no 64-bit integers by default.
fn words(seed: u32, index: u64, group: u32) -> [u32; 4] {
    [index as u32, (index >> 32) as u32, seed, group]
}

fn to_unit(h: u32) -> f64 {
    (h >> 8) as f64 * RESOLUTION
}

/// Dimension `dim` of draw `index` in the stream `seed`: a number k/2²⁴ in [0, 1).
pub fn uniform(seed: u32, index: u64, dim: u32) -> f64 {
    to_unit(pcg4d(words(seed, index, dim / 4))[(dim % 4) as usize])
}

/// Dimensions 4·group to 4·group + 3 of draw `index` at once (one hash):
/// `uniform(seed, index, 4 * group + d)` for d = 0..4.
pub fn uniform4(seed: u32, index: u64, group: u32) -> [f64; 4] {
    pcg4d(words(seed, index, group)).map(to_unit)
}

/// The numbers a sampler takes for draw `index` of the direction `group` in the stream `seed`:
/// dimension 0 of [`uniform4`] is `uc`, the choice of a mixture's component, and dimensions 1
/// and 2 are `u`, the draw within it (dimension 3 is unused). The sampling test
/// ([`crate::chi2`]) and both backends' draws (`Backend::draws`) take their numbers from here;
/// `draw_numbers` in `glsl/random.glsl` is the twin.
pub fn draw_numbers(seed: u32, index: u64, group: u32) -> (f64, glam::DVec2) {
    let u = uniform4(seed, index, group);
    (u[0], glam::DVec2::new(u[1], u[2]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    /// The chi-square statistic of `counts` against equal expectations.
    fn chi2_equal(counts: &[u64]) -> f64 {
        let total: u64 = counts.iter().sum();
        let e = total as f64 / counts.len() as f64;
        counts.iter().map(|&o| (o as f64 - e).powi(2) / e).sum()
    }

    /// Bound on a chi-square statistic with `dof` degrees of freedom: the mean plus 7 spreads
    /// sqrt(2 dof). By Wilson & Hilferty's normal approximation a fair generator exceeds it with
    /// probability about 1e-7 at 63 dof and 1e-9 at 255, so a failure means a flaw.
    fn chi2_bound(dof: usize) -> f64 {
        dof as f64 + 7.0 * (2.0 * dof as f64).sqrt()
    }

    #[test]
    fn random_is_deterministic_and_seeded() {
        for i in [0u64, 1, 77, 1 << 33, u64::MAX] {
            for d in 0..8 {
                assert_eq!(uniform(3, i, d), uniform(3, i, d));
            }
        }
        // Different seeds give different streams: of 10⁴ draws, agreement at 24 bits happens
        // by chance with probability 2⁻²⁴ each.
        let same = (0..10_000u64)
            .filter(|&i| uniform(1, i, 0) == uniform(2, i, 0))
            .count();
        assert!(same <= 2, "{same} of 10⁴ draws equal between seeds 1 and 2");
    }

    #[test]
    fn random_uniform4_is_four_dimensions_at_once() {
        for i in (0..1000u64).chain([1 << 32, (1 << 40) + 5]) {
            for g in [0, 1, 5] {
                let four = uniform4(9, i, g);
                for d in 0..4 {
                    let dim = 4 * g + d;
                    assert_eq!(
                        four[d as usize],
                        uniform(9, i, dim),
                        "draw {i}, dimension {dim}"
                    );
                }
            }
        }
    }

    #[test]
    fn random_draw_numbers_are_dimensions_0_to_2() {
        for i in [0u64, 1, 4095, (1 << 32) - 1, 1 << 32] {
            for g in [0, 2, 7] {
                let u = uniform4(13, i, g);
                let (uc, uv) = draw_numbers(13, i, g);
                assert_eq!((uc, uv.x, uv.y), (u[0], u[1], u[2]), "draw {i}, group {g}");
            }
        }
    }

    #[test]
    fn random_values_are_24_bit_fractions_exact_in_f32() {
        for i in 0..100_000u64 {
            for d in 0..4 {
                let u = uniform(5, i * 7919, d);
                assert!((0.0..1.0).contains(&u), "{u}");
                let k = u / RESOLUTION;
                assert_eq!(k, k.trunc(), "draw {i}: {u} is not k/2^24");
                // The f32 twin's arithmetic: float(h >> 8) * 2^-24, exact.
                let f = (k as u32) as f32 * (1.0f32 / 16_777_216.0);
                assert_eq!(f as f64, u);
            }
        }
    }

    #[test]
    fn random_draws_do_not_depend_on_chunking() {
        let n = 1u64 << 16;
        let whole: Vec<f64> = (0..n).map(|i| uniform(11, i, 1)).collect();
        for chunk in [1u64, 7, 1000, 1 << 12] {
            let chunks: Vec<Vec<f64>> = (0..n.div_ceil(chunk))
                .into_par_iter()
                .map(|c| {
                    (c * chunk..((c + 1) * chunk).min(n))
                        .map(|i| uniform(11, i, 1))
                        .collect()
                })
                .collect();
            assert_eq!(chunks.concat(), whole, "chunks of {chunk}");
        }
        // The high word of the index matters: draw i and draw i + 2³² differ.
        let same = (0..10_000u64)
            .filter(|&i| uniform(0, i, 0) == uniform(0, i + (1 << 32), 0))
            .count();
        assert!(same <= 2, "{same} of 10⁴ draws repeat 2^32 later");
    }

    #[test]
    fn random_is_equidistributed_in_each_dimension() {
        // 10⁶ draws over 64 bins, each dimension, several seeds, and far indices.
        const DRAWS: u64 = 1_000_000;
        for (seed, start) in [(0u32, 0u64), (1, 0), (0xdead_beef, 0), (7, 1 << 40)] {
            for d in 0..6 {
                let mut counts = [0u64; 64];
                for i in start..start + DRAWS {
                    counts[(uniform(seed, i, d) * 64.0) as usize] += 1;
                }
                let s = chi2_equal(&counts);
                assert!(
                    s < chi2_bound(63),
                    "seed {seed}, start {start}, dimension {d}: chi-square {s} over 63 dof, bound {}",
                    chi2_bound(63)
                );
            }
        }
    }

    #[test]
    fn random_pairs_are_equidistributed() {
        // Pairs of dimensions of one draw, and the same dimension of consecutive draws (a
        // counter-based generator's weak spot), over 16 × 16 bins at 10⁶ draws.
        const DRAWS: u64 = 1_000_000;
        let bin = |u: f64| (u * 16.0) as usize;
        type Pair = fn(u64) -> (f64, f64);
        let cases: [(&str, Pair); 4] = [
            ("dims 0, 1", |i| (uniform(3, i, 0), uniform(3, i, 1))),
            ("dims 1, 2", |i| (uniform(3, i, 1), uniform(3, i, 2))),
            ("dims 3, 4", |i| (uniform(3, i, 3), uniform(3, i, 4))),
            ("draws i, i+1", |i| (uniform(3, i, 0), uniform(3, i + 1, 0))),
        ];
        for (name, pair) in cases {
            let mut counts = vec![0u64; 256];
            for i in 0..DRAWS {
                let (a, b) = pair(i);
                counts[bin(a) * 16 + bin(b)] += 1;
            }
            let s = chi2_equal(&counts);
            assert!(
                s < chi2_bound(255),
                "{name}: chi-square {s} over 255 dof, bound {}",
                chi2_bound(255)
            );
        }
    }

    #[test]
    fn random_mean_and_variance_are_those_of_the_uniform_law() {
        // Mean 1/2 − 2⁻²⁵ and variance 1/12 (less 2⁻⁴⁸/12) of k/2²⁴; at 10⁶ draws the sample mean
        // has σ = 0.29e-3 and the sample variance σ ≈ 0.075e-3; 6σ bounds.
        let n = 1_000_000u64;
        let (mut s, mut s2) = (0.0, 0.0);
        for i in 0..n {
            let u = uniform(21, i, 2);
            s += u;
            s2 += u * u;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        assert!((mean - 0.5).abs() < 6.0 * 0.29e-3, "mean {mean}");
        assert!((var - 1.0 / 12.0).abs() < 6.0 * 0.075e-3, "variance {var}");
    }
}
