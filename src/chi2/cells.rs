//! The sampling test's cells over the upper hemisphere and their expected counts.
//!
//! Cells are a product grid in (φ, cosθ): `n_phi` equal steps of φ over [0, 2π) times `n_cos`
//! equal steps of cosθ over [0, 1]. Since dω = dcosθ dφ, every cell has the same solid angle
//! 2π / (n_phi n_cos). Cell (i_phi, i_cos) has index i_cos · n_phi + i_phi.
//!
//! A cell's expected count is N ∫_cell pdf dω = N ∫∫ pdf(ω(φ, μ)) dμ dφ, integrated in f64 by a
//! globally adaptive product Gauss–Kronrod 7/15 rule in (μ, φ) on each cell alone: the test
//! needs each count accurate to well under its own noise, sqrt(count), so every cell is refined
//! to its own tolerance (docs/design.md §14). The rule refines all cells together in rounds, and
//! each round asks the density for every new node at once ([`Density`]), so that a density
//! evaluated on a device (a `.brdf` file's `pdfL`) costs one dispatch a round.

use crate::error::{Error, Result};
use crate::quadrature::{gk15_combine, gk15_nodes, Estimate};
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::f64::consts::PI;

/// Each cell's integral is refined until its error estimate is below this share of its value…
pub const RELATIVE_TOLERANCE: f64 = 1e-6;
/// …or below this many draws (divided by N, as a probability): a thousandth of one draw is
/// negligible against the noise of any count, even a cell's that is pooled with others.
pub const ABSOLUTE_TOLERANCE_DRAWS: f64 = 1e-3;
/// Refinement of one cell stops at this many rectangles (225 evaluations each) even if the
/// tolerance is not met; the reported accuracy then says so.
pub const MAX_RECTANGLES: usize = 1000;

/// A cell found holding far more draws than its integral expects is integrated again from this
/// many steps in each of μ and φ (REFINE_SPLITS² rectangles, [`Cells::refine`]): a lobe
/// narrower than the spacing of one rectangle's 15 nodes (a grazing Beckmann lobe of α = 0.01
/// is 0.09° wide in φ, a fortieth of a cell) can fall between them, its error estimate then
/// nothing. 32 steps put nodes 1.5 × 10⁻⁴ rad apart in φ across a cell of 100.
pub const REFINE_SPLITS: usize = 32;

/// The resolution Mitsuba 3's chi-square test uses over the sphere is 101 × 50 cells (φ × θ); over
/// the upper hemisphere alone this is at most 100 × 50.
pub const MAX_COS: usize = 50;
/// Cells are made no smaller than this many expected draws under a uniform density, so that
/// cells of a broad lobe stay well above the pooling threshold.
pub const MIN_DRAWS_PER_CELL: f64 = 64.0;

/// Cells of equal solid angle over (φ ∈ [0, 2π), cosθ ∈ [0, 1]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Cells {
    /// Steps in φ.
    pub n_phi: usize,
    /// Steps in cosθ.
    pub n_cos: usize,
}

impl Cells {
    /// `n_phi` × `n_cos` cells (each at least 1).
    pub fn new(n_phi: usize, n_cos: usize) -> Cells {
        Cells {
            n_phi: n_phi.max(1),
            n_cos: n_cos.max(1),
        }
    }

    /// The resolution for `samples` draws: twice as many steps in φ as in cosθ, as many as keep
    /// [`MIN_DRAWS_PER_CELL`] draws per cell of a uniform density, at most 2·[`MAX_COS`] × [`MAX_COS`].
    pub fn for_samples(samples: u64) -> Cells {
        let n = (samples as f64 / (2.0 * MIN_DRAWS_PER_CELL)).sqrt().floor() as usize;
        let n_cos = n.clamp(1, MAX_COS);
        Cells::new(2 * n_cos, n_cos)
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.n_phi * self.n_cos
    }

    /// Whether there are no cells (never for cells made by [`Cells::new`]).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The cell of a unit direction with cosθ > 0 (None otherwise).
    pub fn index(&self, w: DVec3) -> Option<usize> {
        if w.z.is_nan() || w.z <= 0.0 {
            return None;
        }
        let mut phi = w.y.atan2(w.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let i_phi = ((phi / (2.0 * PI) * self.n_phi as f64) as usize).min(self.n_phi - 1);
        let i_cos = ((w.z * self.n_cos as f64) as usize).min(self.n_cos - 1);
        Some(i_cos * self.n_phi + i_phi)
    }

    /// Cell `cell`'s range of φ (radians) and of cosθ.
    pub fn bounds(&self, cell: usize) -> ([f64; 2], [f64; 2]) {
        let (i_phi, i_cos) = (cell % self.n_phi, cell / self.n_phi);
        let dphi = 2.0 * PI / self.n_phi as f64;
        let dmu = 1.0 / self.n_cos as f64;
        (
            [i_phi as f64 * dphi, (i_phi + 1) as f64 * dphi],
            [i_cos as f64 * dmu, ((i_cos + 1) as f64 * dmu).min(1.0)],
        )
    }

    /// Each cell's integral of `pdf` (a density over solid angle), for a test of `samples` draws
    /// (which sets the absolute tolerance), the nodes evaluated in parallel.
    pub fn integrate<F: Fn(DVec3) -> f64 + Sync>(&self, pdf: &F, samples: u64) -> Integrals {
        let mut density = pointwise(pdf);
        self.integrate_density(&mut density, samples)
            .expect("a pointwise density cannot fail")
    }

    /// [`Cells::integrate`] of a density evaluated many directions at a time.
    pub fn integrate_density(&self, pdf: &mut Density<'_>, samples: u64) -> Result<Integrals> {
        let floor = ABSOLUTE_TOLERANCE_DRAWS / samples.max(1) as f64;
        let all: Vec<usize> = (0..self.len()).collect();
        let per_cell = self.integrate_cells(pdf, floor, &all, 1)?;
        let mut ints = Integrals {
            probability: per_cell.iter().map(|c| c.value).collect(),
            error: per_cell.iter().map(|c| c.error).collect(),
            evaluations: per_cell.iter().map(|c| c.evals).sum(),
            unconverged_cells: per_cell.iter().filter(|c| !c.converged).count(),
            converged: per_cell.iter().map(|c| c.converged).collect(),
            total: 0.0,
            total_error: 0.0,
            accuracy: 0.0,
            non_finite_cells: 0,
            negative_cells: 0,
            refined_cells: 0,
        };
        ints.summarise(samples);
        Ok(ints)
    }

    /// Integrates the cells `suspects` again from [`REFINE_SPLITS`]² rectangles each and puts
    /// their values into `ints` (which came from [`Cells::integrate`] for the same `pdf` and
    /// `samples`), its sums and accuracy made again. A correct integral stays what it was to
    /// within its tolerance; a lobe the first rule's nodes missed is found.
    pub fn refine<F: Fn(DVec3) -> f64 + Sync>(
        &self,
        pdf: &F,
        samples: u64,
        ints: &mut Integrals,
        suspects: &[usize],
    ) {
        let mut density = pointwise(pdf);
        self.refine_density(&mut density, samples, ints, suspects)
            .expect("a pointwise density cannot fail")
    }

    /// [`Cells::refine`] of a density evaluated many directions at a time.
    pub fn refine_density(
        &self,
        pdf: &mut Density<'_>,
        samples: u64,
        ints: &mut Integrals,
        suspects: &[usize],
    ) -> Result<()> {
        let floor = ABSOLUTE_TOLERANCE_DRAWS / samples.max(1) as f64;
        let again = self.integrate_cells(pdf, floor, suspects, REFINE_SPLITS)?;
        for (&c, cell) in suspects.iter().zip(again) {
            ints.probability[c] = cell.value;
            ints.error[c] = cell.error;
            ints.evaluations += cell.evals;
            if ints.converged[c] && !cell.converged {
                ints.unconverged_cells += 1;
            } else if !ints.converged[c] && cell.converged {
                ints.unconverged_cells -= 1;
            }
            ints.converged[c] = cell.converged;
        }
        ints.summarise(samples);
        ints.refined_cells += suspects.len();
        Ok(())
    }

    /// The cells `which`, each from `splits` × `splits` equal rectangles, refined adaptively and
    /// all together: in each round every cell short of its tolerance, max(RELATIVE_TOLERANCE ·
    /// |value|, floor), bisects its rectangles of largest error (each across the variable that
    /// contributes more of it) until those it leaves hold at most half the tolerance, and the
    /// new rectangles' nodes of every cell go to `pdf` at once. A cell stops at
    /// max(MAX_RECTANGLES, 2 splits²) rectangles even short of its tolerance.
    fn integrate_cells(
        &self,
        pdf: &mut Density<'_>,
        floor: f64,
        which: &[usize],
        splits: usize,
    ) -> Result<Vec<CellIntegral>> {
        let splits = splits.max(1);
        let max_rectangles = MAX_RECTANGLES.max(2 * splits * splits);
        let tolerance = |v: f64| (RELATIVE_TOLERANCE * v.abs()).max(floor);
        let at = |r: [f64; 2], k: usize| r[0] + (r[1] - r[0]) * k as f64 / splits as f64;
        let mut work: Vec<CellWork> = which.iter().map(|_| CellWork::default()).collect();
        // (slot in `work`, μ range, φ range) of the rectangles whose nodes are wanted.
        let mut pending: Vec<(usize, [f64; 2], [f64; 2])> = Vec::new();
        for (slot, &c) in which.iter().enumerate() {
            let (phi, mu) = self.bounds(c);
            for i in 0..splits {
                for j in 0..splits {
                    pending.push((
                        slot,
                        [at(mu, i), at(mu, i + 1)],
                        [at(phi, j), at(phi, j + 1)],
                    ));
                }
            }
        }
        while !pending.is_empty() {
            let rects = evaluate(pdf, &pending)?;
            for (&(slot, _, _), r) in pending.iter().zip(rects) {
                work[slot].heap.push(r);
                work[slot].evals += RECT_NODES as u64;
            }
            pending.clear();
            for (slot, w) in work.iter_mut().enumerate() {
                if w.settled {
                    continue;
                }
                let (value, error) = w.sums();
                let tol = tolerance(value);
                // A NaN error stops the refinement at once (no bisection mends it); the final
                // test below reports the cell as not converged.
                if error.is_nan() || error <= tol {
                    w.settled = true;
                    continue;
                }
                let mut rest = error;
                let mut live = w.heap.len() + w.done.len();
                let before = pending.len();
                while rest > 0.5 * tol && live < max_rectangles {
                    let Some(worst) = w.heap.pop() else { break };
                    rest -= worst.error();
                    let split_mu = worst.error_mu >= worst.error_phi;
                    let [lo, hi] = if split_mu { worst.mu } else { worst.phi };
                    let mid = 0.5 * (lo + hi);
                    // Rectangles too narrow to bisect in f64 keep their error: counted, not
                    // hidden.
                    if !(mid > lo && mid < hi) {
                        w.done.push(worst);
                        continue;
                    }
                    live += 1;
                    if split_mu {
                        pending.push((slot, [lo, mid], worst.phi));
                        pending.push((slot, [mid, hi], worst.phi));
                    } else {
                        pending.push((slot, worst.mu, [lo, mid]));
                        pending.push((slot, worst.mu, [mid, hi]));
                    }
                }
                if pending.len() == before {
                    w.settled = true;
                }
            }
        }
        Ok(work
            .iter()
            .map(|w| {
                let (value, error) = w.sums();
                CellIntegral {
                    value,
                    error,
                    evals: w.evals,
                    converged: error <= tolerance(value),
                }
            })
            .collect())
    }
}

/// A density over solid angle evaluated at many directions at once, in order: the f64
/// reference's pdf on the CPU's threads ([`Cells::integrate`]), or a backend's kernels
/// ([`crate::backend::Backend::pdf`]).
pub type Density<'a> = dyn FnMut(&[DVec3]) -> Result<Vec<f64>> + 'a;

/// A pointwise density as a [`Density`], evaluated in parallel.
fn pointwise<F: Fn(DVec3) -> f64 + Sync>(pdf: &F) -> impl FnMut(&[DVec3]) -> Result<Vec<f64>> + '_ {
    move |w: &[DVec3]| Ok(w.par_iter().map(|&d| pdf(d)).collect())
}

/// Nodes of one rectangle's 15 × 15 product rule.
const RECT_NODES: usize = 225;

/// Rectangles whose nodes go to the density in one call: 2¹¹ × 225 directions (11 MB), few
/// calls a round for a device and parts large enough for the CPU's threads.
const EVALUATE_RECTS: usize = 1 << 11;

/// The rectangles `pending` integrated from the density at their nodes.
fn evaluate(pdf: &mut Density<'_>, pending: &[(usize, [f64; 2], [f64; 2])]) -> Result<Vec<Rect>> {
    let mut out = Vec::with_capacity(pending.len());
    for part in pending.chunks(EVALUATE_RECTS) {
        let nodes: Vec<DVec3> = part
            .par_iter()
            .flat_map_iter(|&(_, mu, phi)| {
                let phis = gk15_nodes(phi[0], phi[1]);
                gk15_nodes(mu[0], mu[1])
                    .into_iter()
                    .flat_map(move |m| phis.map(|p| direction(p, m)))
            })
            .collect();
        let values = pdf(&nodes)?;
        if values.len() != nodes.len() {
            return Err(Error::Invalid(format!(
                "the density gave {} values for {} directions",
                values.len(),
                nodes.len()
            )));
        }
        out.par_extend(
            part.par_iter()
                .zip(values.par_chunks(RECT_NODES))
                .map(|(&(_, mu, phi), v)| rect(v, mu, phi)),
        );
    }
    Ok(out)
}

/// One cell's rectangles during [`Cells::integrate_cells`].
#[derive(Default)]
struct CellWork {
    /// Rectangles that may be bisected, the worst on top.
    heap: BinaryHeap<Rect>,
    /// Rectangles too narrow to bisect in f64.
    done: Vec<Rect>,
    evals: u64,
    settled: bool,
}

impl CellWork {
    /// The cell's integral and error estimate: its rectangles' sums.
    fn sums(&self) -> (f64, f64) {
        let all = || self.heap.iter().chain(self.done.iter());
        (all().map(|r| r.value).sum(), all().map(|r| r.error()).sum())
    }
}

impl Integrals {
    /// The sums, the accuracy and the counts of bad cells made again from the cells' values.
    fn summarise(&mut self, samples: u64) {
        let n = samples as f64;
        self.total = self.probability.iter().sum();
        self.total_error = self.error.iter().sum();
        self.accuracy = self
            .probability
            .iter()
            .zip(&self.error)
            .map(|(v, e)| n * e / (n * v).max(1.0).sqrt())
            .fold(0.0, f64::max);
        self.non_finite_cells = self
            .probability
            .iter()
            .zip(&self.error)
            .filter(|(v, e)| !v.is_finite() || !e.is_finite())
            .count();
        self.negative_cells = self.probability.iter().filter(|v| **v < 0.0).count();
    }
}

/// The cells' integrals of a pdf, with their error estimates.
#[derive(Clone, Debug, Serialize)]
pub struct Integrals {
    /// ∫_cell pdf dω per cell (a probability).
    pub probability: Vec<f64>,
    /// Each cell's error estimate, absolute, as a probability.
    pub error: Vec<f64>,
    /// Σ over cells: ∫ pdf over the upper hemisphere.
    pub total: f64,
    /// Σ of the cells' error estimates.
    pub total_error: f64,
    /// The largest N · error / sqrt(max(N · probability, 1)) over cells: a cell's count error
    /// against its noise. The test is valid while this is ≪ 1.
    pub accuracy: f64,
    /// pdf evaluations spent.
    pub evaluations: u64,
    /// Cells that stopped at [`MAX_RECTANGLES`] before meeting their tolerance.
    pub unconverged_cells: usize,
    /// Cells whose integral is NaN or infinite (the pdf returned such values).
    pub non_finite_cells: usize,
    /// Cells whose integral is negative (the pdf returned negative values).
    pub negative_cells: usize,
    /// Cells integrated again from finer rectangles ([`Cells::refine`]).
    pub refined_cells: usize,
    /// Per cell, whether it met its tolerance.
    #[serde(skip)]
    pub converged: Vec<bool>,
}

struct CellIntegral {
    value: f64,
    error: f64,
    evals: u64,
    converged: bool,
}

/// One rectangle [μ0, μ1] × [φ0, φ1] with its product-rule integral and error estimates.
#[derive(Clone, Copy)]
struct Rect {
    mu: [f64; 2],
    phi: [f64; 2],
    value: f64,
    /// The part of the error estimate due to the rule in μ, and the part due to the rule in φ.
    error_mu: f64,
    error_phi: f64,
}

impl Rect {
    fn error(&self) -> f64 {
        self.error_mu + self.error_phi
    }
}

impl PartialEq for Rect {
    fn eq(&self, other: &Rect) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Rect {}
impl PartialOrd for Rect {
    fn partial_cmp(&self, other: &Rect) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Rect {
    fn cmp(&self, other: &Rect) -> Ordering {
        self.error().total_cmp(&other.error())
    }
}

/// The direction at (φ, μ = cosθ).
fn direction(phi: f64, mu: f64) -> DVec3 {
    let s = (1.0 - mu * mu).max(0.0).sqrt();
    DVec3::new(s * phi.cos(), s * phi.sin(), mu)
}

/// The 15 × 15 Kronrod product rule on a rectangle from the density at its nodes (`values`, in
/// the order [`evaluate`] makes them: μ nodes outer, φ nodes inner). Along φ at each μ node, K15
/// and its error |K15 − G7|; then K15 along μ of those: |K15 − G7| along μ is the μ part of the
/// error, and the φ errors carried through the μ weights the φ part (quadrature::gk15_combine).
fn rect(values: &[f64], mu: [f64; 2], phi: [f64; 2]) -> Rect {
    let rows: Vec<Estimate> = values
        .chunks_exact(15)
        .map(|row| {
            let vals: Vec<Estimate> = row
                .iter()
                .map(|&v| Estimate {
                    value: DVec3::new(v, 0.0, 0.0),
                    error: DVec3::ZERO,
                    evals: 1,
                })
                .collect();
            gk15_combine(phi[0], phi[1], &vals)
        })
        .collect();
    let both = gk15_combine(mu[0], mu[1], &rows);
    let bare: Vec<Estimate> = rows
        .iter()
        .map(|r| Estimate {
            error: DVec3::ZERO,
            ..*r
        })
        .collect();
    let error_mu = gk15_combine(mu[0], mu[1], &bare).error.x;
    Rect {
        mu,
        phi,
        value: both.value.x,
        error_mu,
        error_phi: (both.error.x - error_mu).max(0.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_cells_have_equal_solid_angle_and_find_their_directions() {
        let cells = Cells::new(12, 5);
        for c in 0..cells.len() {
            let (phi, mu) = cells.bounds(c);
            let omega = (phi[1] - phi[0]) * (mu[1] - mu[0]);
            assert!(
                (omega - 2.0 * PI / 60.0).abs() < 1e-14,
                "cell {c}: {omega} sr"
            );
            // The centre and points near the corners map back to the cell.
            for (fp, fm) in [(0.5, 0.5), (1e-9, 1e-9), (1.0 - 1e-9, 1.0 - 1e-9)] {
                let w = direction(
                    phi[0] + fp * (phi[1] - phi[0]),
                    mu[0] + fm * (mu[1] - mu[0]),
                );
                assert_eq!(cells.index(w), Some(c), "cell {c}, {w}");
            }
        }
        assert_eq!(cells.index(DVec3::new(1.0, 0.0, 0.0)), None);
        assert_eq!(cells.index(DVec3::new(0.6, 0.0, -0.8)), None);
        assert_eq!(cells.index(DVec3::Z), Some(4 * 12));
        // φ just below 2π falls in the last φ step, not past it.
        assert_eq!(cells.index(DVec3::new(0.6, -1e-18, 0.7)), Some(3 * 12 + 11));
    }

    #[test]
    fn chi2_cells_resolution_follows_the_sample_count() {
        assert_eq!(Cells::for_samples(1 << 30), Cells::new(100, 50));
        let c = Cells::for_samples(1 << 16);
        assert_eq!((c.n_phi, c.n_cos), (44, 22));
        assert!((1u64 << 16) as f64 / c.len() as f64 >= MIN_DRAWS_PER_CELL);
        assert_eq!(Cells::for_samples(10), Cells::new(2, 1));
    }

    #[test]
    fn chi2_cells_integrate_the_cosine_exactly() {
        // ∫_cell cosθ/π dω = Δφ (μ1² − μ0²) / (2π): a polynomial the rule integrates exactly.
        let cells = Cells::new(100, 50);
        let n = 1u64 << 30;
        let ints = cells.integrate(&|w: DVec3| w.z.max(0.0) / PI, n);
        for c in 0..cells.len() {
            let (phi, mu) = cells.bounds(c);
            let want = (phi[1] - phi[0]) * (mu[1] * mu[1] - mu[0] * mu[0]) / (2.0 * PI);
            let got = ints.probability[c];
            assert!(
                (got - want).abs() <= 1e-15 * want.max(1e-3),
                "cell {c}: {got} vs {want}"
            );
        }
        assert!((ints.total - 1.0).abs() < 1e-13, "total {}", ints.total);
        assert!(ints.accuracy < 1e-6, "accuracy {}", ints.accuracy);
        assert_eq!(ints.evaluations, 225 * 5000);
        assert_eq!(ints.unconverged_cells, 0);
    }

    #[test]
    fn chi2_cells_integrate_a_very_peaked_lobe() {
        // A power-cosine lobe (n + 1)/(2π) cos^n α about a direction 30° from the normal, n = 10⁴:
        // its width is ~1/sqrt(n) = 0.01 rad, a fraction of one cell of 100 × 50; all of its mass
        // is in the upper hemisphere (cos α < cos 60° below the horizon: 0.5^10⁴ ≈ 0).
        let n_exp = 1e4;
        let axis = direction(2.0, 30f64.to_radians().cos());
        let pdf = |w: DVec3| (n_exp + 1.0) / (2.0 * PI) * w.dot(axis).max(0.0).powf(n_exp);
        let cells = Cells::new(100, 50);
        let n = 1u64 << 30;
        let ints = cells.integrate(&pdf, n);
        assert!(
            (ints.total - 1.0).abs() < 1e-9,
            "total {} (error estimate {:e}), accuracy {:e}, {} evaluations",
            ints.total,
            ints.total_error,
            ints.accuracy,
            ints.evaluations
        );
        assert!(ints.accuracy < 1e-2, "accuracy {:e}", ints.accuracy);
        assert_eq!(ints.unconverged_cells, 0);
        // The cell holding the axis holds a large share, and almost no cell holds anything.
        let peak = ints.probability.iter().cloned().fold(0.0, f64::max);
        let holding = ints.probability.iter().filter(|&&p| p > 1e-6).count();
        assert!(
            peak > 0.2 && holding < 12,
            "peak {peak}, {holding} cells above 1e-6"
        );
    }

    #[test]
    fn chi2_cells_integrate_a_sharp_ggx_reflection_lobe() {
        // Reflection with the half vector drawn from GGX's D(h) cosθh at ωo = n: pdf(ωi) =
        // D(h) / 4 with h = normalize(ωi + n) (Walter et al. 2007, eq. 14 with ωo·h = cosθh). ωi
        // stays above the horizon while θh < 45°, and GGX's P(θh ≤ θ) = tan²θ / (α² + tan²θ), so
        // ∫ pdf over the hemisphere is 1 / (1 + α²) exactly. At α = 0.01 the lobe is ~0.02 rad
        // wide in ωi: the top row of cells holds nearly all of it, with a tail reaching the horizon.
        for alpha in [0.1, 0.01] {
            let a2: f64 = alpha * alpha;
            let pdf = |w: DVec3| {
                let h = (w + DVec3::Z).normalize();
                let c2 = h.z * h.z;
                let d = a2 / (PI * ((a2 - 1.0) * c2 + 1.0).powi(2));
                if w.z > 0.0 {
                    0.25 * d
                } else {
                    0.0
                }
            };
            let ints = Cells::new(100, 50).integrate(&pdf, 1 << 30);
            let want = 1.0 / (1.0 + a2);
            assert!(
                (ints.total - want).abs() < 1e-9,
                "α = {alpha}: {} vs {want}, error estimate {:e}, accuracy {:e}",
                ints.total,
                ints.total_error,
                ints.accuracy
            );
            assert!(
                ints.accuracy < 1e-2 && ints.unconverged_cells == 0,
                "α = {alpha}: {:e}",
                ints.accuracy
            );
        }
    }

    #[test]
    fn chi2_cells_refine_finds_a_lobe_between_the_nodes() {
        // A density uniform in μ and Gaussian in φ with σ = 2e-4 rad about a point 35 % into a
        // cell's φ step (15σ from the nearest of one rectangle's nodes, at 29.7 % and 39.6 %):
        // ∫ over the hemisphere is 1 (∫ dμ over [0, 1] times the Gaussian's 1). The plain rule
        // sees none of it; refining the cells of that φ column finds it all.
        let cells = Cells::new(100, 50);
        let dphi = 2.0 * PI / 100.0;
        let (centre, sigma) = ((10.35) * dphi, 2e-4);
        let pdf = |w: DVec3| {
            let phi = w.y.atan2(w.x).rem_euclid(2.0 * PI);
            let x = (phi - centre) / sigma;
            (-0.5 * x * x).exp() / ((2.0 * PI).sqrt() * sigma)
        };
        let n = 1u64 << 30;
        let mut ints = cells.integrate(&pdf, n);
        assert!(ints.total < 1e-12, "the plain rule found {}", ints.total);
        let column: Vec<usize> = (0..50).map(|i_cos| i_cos * 100 + 10).collect();
        cells.refine(&pdf, n, &mut ints, &column);
        assert!(
            (ints.total - 1.0).abs() < 1e-6,
            "refined: {} (error estimate {:e})",
            ints.total,
            ints.total_error
        );
        assert_eq!((ints.refined_cells, ints.unconverged_cells), (50, 0));
        assert!(ints.accuracy < 1e-2, "accuracy {:e}", ints.accuracy);
    }

    #[test]
    fn chi2_cells_meet_their_tolerance_cell_by_cell() {
        // A power-cosine lobe about the normal, (n + 1)/(2π) μⁿ: each cell's integral is
        // Δφ/(2π) (μ₁ⁿ⁺¹ − μ₀ⁿ⁺¹) in closed form. Every cell must be within its tolerance,
        // max(RELATIVE_TOLERANCE · value, ABSOLUTE_TOLERANCE_DRAWS / N), and within its own error
        // estimate, at n = 10 (smooth) and n = 10⁴ (all the mass in the top row, 0.02 in μ).
        // The error estimate leaves out f64 rounding of the 225-term sums and of the closed form.
        const ROUNDING: f64 = 1e-13;
        let cells = Cells::new(100, 50);
        let n_draws = 1u64 << 30;
        for n in [10.0, 1e4] {
            let pdf = |w: DVec3| (n + 1.0) / (2.0 * PI) * w.z.max(0.0).powf(n);
            let ints = cells.integrate(&pdf, n_draws);
            for c in 0..cells.len() {
                let (phi, mu) = cells.bounds(c);
                // μ₁ⁿ⁺¹ − μ₀ⁿ⁺¹ without cancellation: μ₁ⁿ⁺¹ (1 − (μ₀/μ₁)ⁿ⁺¹).
                let want = (phi[1] - phi[0]) / (2.0 * PI)
                    * mu[1].powf(n + 1.0)
                    * -((n + 1.0) * (mu[0] / mu[1]).ln()).exp_m1();
                let (got, estimate) = (ints.probability[c], ints.error[c]);
                let err = (got - want).abs();
                let tolerance =
                    (RELATIVE_TOLERANCE * want).max(ABSOLUTE_TOLERANCE_DRAWS / n_draws as f64);
                assert!(
                    err <= tolerance && err <= estimate + ROUNDING * want,
                    "n = {n}, cell {c} (μ {mu:?}): {got:e} vs {want:e}, error {err:e}, estimate {estimate:e}, tolerance {tolerance:e}"
                );
            }
        }
    }
}
