//! The error estimate of a fixed rule from three of its levels, or four on tabulated data
//! (docs/design.md §5.5).
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
//! [`SHARED_ERROR_FLOOR`] × |E₀| for what no level difference shows. A tabulated model (measured
//! data read by its bins) is not smooth anywhere the model could hold: there a third coarser
//! level is run, and the estimate is [`ESTIMATE_SAFETY`] × the largest of the three differences
//! (the fourth level costs (¾)⁶ ≈ 18 % of the fine `peak` rule's nodes).
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

/// What no difference between levels can show, relative to |E|: an error the levels
/// share (all `peak` levels use the same panels; a feature narrower than every level's nodes
/// is missed by all alike), and the f64 rounding of sums of ~10⁵ terms. The largest such error
/// seen on GGX and Beckmann under the white furnace (α from 1.5e-5 to 1, μo from 1/64 to 1) was
/// 1.6e-8 (Beckmann, α = 1.5e-5, μo = 1, tests/estimates.rs); 1e-7 leaves a margin of 6 and
/// stays 10 × below the default rule's target of 1e-6.
pub const SHARED_ERROR_FLOOR: f64 = 1e-7;

/// The estimate of the fine rule's error from its levels' values (per channel), finest first
/// ([`Rule::levels`]), with `p` = (n₀ − n₁)/(n₁ − n₂) of the rule ([`Rule::level_exponent`]).
///
/// Three levels for a smooth integrand: the geometric model where s₁ = E₀ − E₁ and
/// s₂ = E₁ − E₂ share their sign and rᵖ < ½, 4 d₁ elsewhere. Four for a tabulated one
/// ([`crate::model::Model::is_tabulated`]: measured data read by its bins, with a jump or a
/// kink on every bin boundary), where no level converges geometrically: the levels' errors are
/// of one size and either sign, and two neighbouring levels can agree by chance far below their
/// common error (a MERL table split at θd = 45°, at μo = 0.3: E₀ − E₁ and E₁ − E₂ of about 1e-7,
/// which the geometric model took for convergence, at a true error of 9.5e-4). The estimate is
/// then 4 × the largest of the three differences, which four levels would all have to share by
/// chance to hide.
pub fn level_error(levels: &[DVec3], p: f64) -> DVec3 {
    let fine = levels[0];
    let s: Vec<DVec3> = levels.windows(2).map(|w| w[0] - w[1]).collect();
    let tabulated = s.len() > 2;
    let model = DVec3::from_array(std::array::from_fn(|c| {
        let d: Vec<f64> = s.iter().map(|v| v[c].abs()).collect();
        if tabulated {
            return ESTIMATE_SAFETY * NOT_CONVERGING * d.iter().copied().fold(0.0, f64::max);
        }
        let (d1, d2) = (d[0], d[1]);
        let rp = if d2 > 0.0 { (d1 / d2).powf(p) } else { 1.0 };
        // Geometric convergence moves every level the same way; differences of opposite signs
        // mean errors of either sign at random (a jump inside a panel).
        let geometric = s[0][c] * s[1][c] > 0.0;
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
    /// The rule and the coarser levels whose values [`level_error`] reads, finest first: two
    /// coarser ones, or three for a tabulated model ([`crate::model::Model::is_tabulated`]).
    pub fn levels(&self, tabulated: bool) -> Vec<Rule> {
        let mut levels = vec![*self];
        for _ in 0..if tabulated { 3 } else { 2 } {
            let next = levels[levels.len() - 1].coarse();
            levels.push(next);
        }
        levels
    }

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
