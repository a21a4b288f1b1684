//! The error estimate of a fixed rule from three of its levels (docs/design.md §5.5).
//!
//! A rule is run at its own resolution n₀ and at two coarser ones n₁ > n₂ ([`Rule::coarse`]
//! twice), giving E₀, E₁, E₂ and the differences d₁ = |E₀ − E₁|, d₂ = |E₁ − E₂|. If the errors
//! fall geometrically in the resolution, e(n) = C λⁿ (Gauss–Legendre on an integrand analytic on
//! every panel; a rule whose levels halve h converges geometrically in the level for any
//! algebraic order), then r = d₁/d₂ = λ^(n₁ − n₂), λ^(n₀ − n₁) = r^p with p = (n₀ − n₁)/(n₁ − n₂),
//! and the fine rule's error is
//!
//!   e₀ = e₁ r^p = d₁ r^p / (1 − r^p).
//!
//! The estimate is [`ESTIMATE_SAFETY`] times that, and at most [`ESTIMATE_SAFETY`] ×
//! [`NOT_CONVERGING`] × d₁ when r^p ≥ ½ or when E₀ − E₁ and E₁ − E₂ differ in sign (which no
//! geometric convergence does): the errors are not falling fast enough, or not steadily enough,
//! for the model to say more (a discontinuity inside a panel, or a lobe no level resolves), plus
//! [`SHARED_ERROR_FLOOR`] × |E₀| for what no level difference shows.
//!
//! Why the old two-level estimate |E₀ − E₁| failed both ways: for a smooth integrand it is E₁'s
//! error, many times E₀'s (30× on the default DFG table); for a piecewise-constant one (a table
//! read by its nearest bin) E₀'s and E₁'s errors are of one size and either sign, and their
//! difference can be smaller than either.

use super::rules::Rule;
use glam::DVec3;

/// The factor between the estimate and the geometric model's e₀. Measured on GGX and Beckmann
/// under the white furnace (α from 1.5e-5 to 1, μo from 1/64 to 1), the default peak rule's
/// actual error is within a factor 2 of the model's where the model holds (tests/estimates.rs);
/// a factor 4 leaves a margin of 2 and stays within the 30 × of the actual error those tests
/// allow on smooth integrands.
pub const ESTIMATE_SAFETY: f64 = 4.0;

/// The largest e₀/d₁ the model is trusted to give: at r^p = ½ (and beyond, where the levels'
/// errors hardly fall or change sign at random) e₀ is taken to be d₁ itself, times
/// [`ESTIMATE_SAFETY`]. The constant table with bins zeroed below the horizon and the cap tables
/// of tests/estimates.rs (jumps on curves that cross the panels) lie in this regime.
pub const NOT_CONVERGING: f64 = 1.0;

/// What no difference between levels can show, relative to |E|: an error the three levels
/// share (all `peak` levels use the same panels; a feature narrower than every level's nodes
/// is missed by all alike), and the f64 rounding of sums of ~10⁵ terms. The largest such error
/// seen on GGX and Beckmann under the white furnace (α from 1.5e-5 to 1, μo from 1/64 to 1) was
/// 1.6e-8 (Beckmann, α = 1.5e-5, μo = 1, tests/estimates.rs); 1e-7 leaves a margin of 6 and
/// stays 10 × below the default rule's target of 1e-6.
pub const SHARED_ERROR_FLOOR: f64 = 1e-7;

/// The estimate of the fine rule's error from its three levels' values (per channel), with
/// `p` = (n₀ − n₁)/(n₁ − n₂) of the rule ([`Rule::level_exponent`]).
pub fn three_level_error(fine: DVec3, coarse: DVec3, coarser: DVec3, p: f64) -> DVec3 {
    let (s1, s2) = (fine - coarse, coarse - coarser);
    let model = DVec3::from_array(std::array::from_fn(|c| {
        let (d1, d2) = (s1[c].abs(), s2[c].abs());
        let rp = if d2 > 0.0 { (d1 / d2).powf(p) } else { 1.0 };
        // Geometric convergence moves every level the same way; differences of opposite signs
        // mean errors of either sign at random (a jump inside a panel).
        let geometric = s1[c] * s2[c] > 0.0;
        let growth = if geometric && rp < 0.5 {
            rp / (1.0 - rp)
        } else {
            NOT_CONVERGING
        };
        ESTIMATE_SAFETY * d1 * growth.min(NOT_CONVERGING)
    }));
    model + SHARED_ERROR_FLOOR * fine.abs()
}

impl Rule {
    /// p = (n₀ − n₁)/(n₁ − n₂) over the rule and its two coarser levels, n the resolution in
    /// which its error falls geometrically: Gauss points per axis (`gauss`, `peak`), the level
    /// for rules whose levels halve h (`midpoint`, `qmc`: p = 1).
    pub fn level_exponent(&self) -> f64 {
        let n = |r: &Rule| -> f64 {
            match *r {
                Rule::Gauss { n_mu } => n_mu as f64,
                Rule::Peak { order, .. } => order as f64,
                _ => 0.0,
            }
        };
        let (c1, c2) = (self.coarse(), self.coarse().coarse());
        let (n0, n1, n2) = (n(self), n(&c1), n(&c2));
        if n1 > n2 && n0 > n1 {
            (n0 - n1) / (n1 - n2)
        } else {
            1.0
        }
    }
}
