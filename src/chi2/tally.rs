//! The counts of a range of draws and the checks of each draw against the sampler's own pdf and
//! eval_cos, as the CPU makes them in f64 or a device's counting kernel reduces them in f32.

use super::UNIT_TOLERANCE_F32;
use super::{Cells, Drawn, Sampler, DRAW_TOLERANCE, DRAW_TOLERANCE_F32, UNIT_TOLERANCE};
use crate::backend::DrawCounts;
use glam::DVec3;
use serde::Serialize;

/// The draw-by-draw checks of one direction.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct DrawChecks {
    /// The relative weight and pdf error allowed: [`DRAW_TOLERANCE`] for draws checked in f64,
    /// [`DRAW_TOLERANCE_F32`] for draws checked on a device in f32.
    pub tolerance: f64,
    /// The difference from unit length allowed: [`UNIT_TOLERANCE`] or [`UNIT_TOLERANCE_F32`].
    pub unit_tolerance: f64,
    /// Draws whose ωi or pdf is NaN or infinite, or whose pdf is negative.
    pub invalid: u64,
    /// Draws whose ωi is off unit length by more than `unit_tolerance` (counted in their
    /// normalised direction's cell).
    pub non_unit: u64,
    /// Draws above the horizon with pdf 0 (counted as leaving the hemisphere).
    pub zero_pdf: u64,
    /// Draws with a NaN or infinite weight.
    pub non_finite_weight: u64,
    /// Draws below the horizon or with pdf 0 whose weight is not 0.
    pub nonzero_weight_outside: u64,
    /// Draws below the horizon reported with a pdf other than 0 (the contract asks for 0).
    pub nonzero_pdf_below: u64,
    /// The largest relative difference |w − eval_cos/pdf| / max(|w|, |eval_cos/pdf|) over
    /// channels and draws counted in cells, and the draw (its index i) where it occurred.
    pub max_weight_error: f64,
    /// The draw with the largest weight error (None for draws counted on a device, which
    /// reduces the errors without their indices).
    pub worst_weight_draw: Option<u64>,
    /// The largest relative difference between a draw's pdf and pdf(ωi, ωo).
    pub max_pdf_error: f64,
    /// The draw with the largest pdf error.
    pub worst_pdf_draw: Option<u64>,
    /// How many of the direction's first draws had their weight and pdf checked (the errors
    /// above, `non_finite_weight` and `nonzero_weight_outside`); the other counts are of every
    /// draw.
    pub checked_draws: u64,
}

impl DrawChecks {
    /// Whether every draw is finite, of unit length, with weight and pdf within `tolerance`
    /// of eval_cos / pdf and pdf(ωi), and weight 0 when it leaves.
    pub fn consistent(&self) -> bool {
        self.invalid == 0
            && self.non_unit == 0
            && self.non_finite_weight == 0
            && self.nonzero_weight_outside == 0
            && self.nonzero_pdf_below == 0
            && self.max_weight_error <= self.tolerance
            && self.max_pdf_error <= self.tolerance
    }
}

/// Below this, values are compared as equal: a product whose factors are normal f64 numbers can
/// land among the subnormals (below 2.2e-308), which keep ever fewer significant bits, and the
/// same weight reached along two paths then differs in its leading digits (a Phong lobe of
/// exponent 1000 in a channel whose diffuse part is 0 reaches 1e-310 far from its peak).
/// 2⁵² times the smallest normal number leaves every bit of a normal result's precision.
pub const TINY: f64 = f64::MIN_POSITIVE * (1u64 << 52) as f64;

/// |a − b| / max(|a|, |b|), 0 when both are below [`TINY`].
fn relative(a: f64, b: f64) -> f64 {
    let m = a.abs().max(b.abs());
    if m < TINY {
        0.0
    } else if !m.is_finite() {
        if a == b {
            0.0
        } else {
            f64::INFINITY
        }
    } else {
        (a - b).abs() / m
    }
}

/// The counts of a range of draws.
#[derive(Clone)]
pub(super) struct Tally {
    pub(super) hist: Vec<u64>,
    pub(super) leaked: u64,
    pub(super) delta: u64,
    pub(super) checks: DrawChecks,
}

impl Tally {
    /// No draws yet, to be checked in f64.
    pub(super) fn new(cells: usize) -> Tally {
        Tally {
            hist: vec![0; cells],
            leaked: 0,
            delta: 0,
            checks: DrawChecks {
                tolerance: DRAW_TOLERANCE,
                unit_tolerance: UNIT_TOLERANCE,
                ..DrawChecks::default()
            },
        }
    }

    /// A backend's counts of draws made and checked in f32 on its device.
    pub(super) fn from_device(d: DrawCounts) -> Tally {
        Tally {
            hist: d.cells,
            leaked: d.lost,
            delta: d.delta,
            checks: DrawChecks {
                tolerance: DRAW_TOLERANCE_F32,
                unit_tolerance: UNIT_TOLERANCE_F32,
                invalid: d.invalid,
                non_unit: d.non_unit,
                zero_pdf: d.zero_pdf,
                non_finite_weight: d.non_finite_weight,
                nonzero_weight_outside: d.nonzero_weight_outside,
                nonzero_pdf_below: d.nonzero_pdf_below,
                max_weight_error: d.max_weight_error,
                worst_weight_draw: None,
                max_pdf_error: d.max_pdf_error,
                worst_pdf_draw: None,
                checked_draws: 0,
            },
        }
    }

    /// Keeps the larger error; on a tie the earlier draw, so the result does not depend on the
    /// order chunks are merged in.
    fn worse(a: (f64, Option<u64>), b: (f64, Option<u64>)) -> (f64, Option<u64>) {
        match a.0.total_cmp(&b.0) {
            std::cmp::Ordering::Greater => a,
            std::cmp::Ordering::Less => b,
            std::cmp::Ordering::Equal => (a.0, a.1.min(b.1).or(a.1).or(b.1)),
        }
    }

    pub(super) fn merge(mut self, other: Tally) -> Tally {
        self.checks.tolerance = self.checks.tolerance.max(other.checks.tolerance);
        self.checks.unit_tolerance = self.checks.unit_tolerance.max(other.checks.unit_tolerance);
        for (a, b) in self.hist.iter_mut().zip(&other.hist) {
            *a += b;
        }
        self.leaked += other.leaked;
        self.delta += other.delta;
        let (c, o) = (&mut self.checks, &other.checks);
        c.invalid += o.invalid;
        c.non_unit += o.non_unit;
        c.zero_pdf += o.zero_pdf;
        c.non_finite_weight += o.non_finite_weight;
        c.nonzero_weight_outside += o.nonzero_weight_outside;
        c.nonzero_pdf_below += o.nonzero_pdf_below;
        (c.max_weight_error, c.worst_weight_draw) = Tally::worse(
            (c.max_weight_error, c.worst_weight_draw),
            (o.max_weight_error, o.worst_weight_draw),
        );
        (c.max_pdf_error, c.worst_pdf_draw) = Tally::worse(
            (c.max_pdf_error, c.worst_pdf_draw),
            (o.max_pdf_error, o.worst_pdf_draw),
        );
        self
    }

    /// Counts draw `i`, `d`, and checks it; its weight and pdf too where `checked`.
    pub(super) fn draw<S: Sampler>(
        &mut self,
        s: &S,
        cells: &Cells,
        wo: DVec3,
        (i, checked): (u64, bool),
        d: Drawn,
    ) {
        let c = &mut self.checks;
        if d.delta {
            self.delta += 1;
            return;
        }
        if !d.wi.is_finite() || d.pdf.is_nan() || d.pdf.is_infinite() || d.pdf < 0.0 {
            c.invalid += 1;
            return;
        }
        if checked && !d.weight.is_finite() {
            c.non_finite_weight += 1;
        }
        // pdf and eval_cos see ωi as drawn; only the cell is found from its normalised form.
        let wi = d.wi;
        let len = wi.length();
        if (len - 1.0).abs() > UNIT_TOLERANCE {
            c.non_unit += 1;
        }
        let cell = if d.pdf > 0.0 {
            cells.index(wi / len)
        } else {
            None
        };
        let Some(cell) = cell else {
            self.leaked += 1;
            if wi.z > 0.0 {
                c.zero_pdf += 1;
            } else if d.pdf != 0.0 {
                c.nonzero_pdf_below += 1;
            }
            if checked && d.weight != DVec3::ZERO {
                c.nonzero_weight_outside += 1;
            }
            return;
        };
        self.hist[cell] += 1;
        if !checked {
            return;
        }
        let pdf = s.pdf(wi, wo);
        let e = relative(d.pdf, pdf);
        let e = if e.is_nan() { f64::INFINITY } else { e };
        if e > c.max_pdf_error {
            (c.max_pdf_error, c.worst_pdf_draw) = (e, Some(i));
        }
        let want = s.eval_cos(wi, wo) / d.pdf;
        let e = (0..3)
            .map(|k| relative(d.weight[k], want[k]))
            .fold(
                0.0,
                |m: f64, x| if x.is_nan() { f64::INFINITY } else { m.max(x) },
            );
        if e > c.max_weight_error {
            (c.max_weight_error, c.worst_weight_draw) = (e, Some(i));
        }
    }
}
