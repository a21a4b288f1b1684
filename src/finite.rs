//! Invalid BRDF values: NaN, ±Inf and negative numbers (docs/design.md §2.1). One counter,
//! [`InvalidCount`], is filled wherever evaluated values are seen, on either backend; `eval` and
//! `table` keep the values and report the count, every other job refuses with [`InvalidValues`].

use crate::grid::angles_deg;
use glam::DVec3;
use serde_json::json;
use std::fmt;

/// Values per block of the validity scan: 256 KiB of f32, each block in one branch-free pass, the
/// scan stopping at the first block with an invalid value.
const SCAN_BLOCK: usize = 1 << 16;

/// Whether `v` is a valid BRDF value: finite and not negative (−0 is valid).
pub fn is_valid(v: f64) -> bool {
    v.is_finite() && v >= 0.0
}

/// The larger of `a` and `b`, or NaN where either is: `f64::max` drops a NaN, so a largest
/// error estimate taken with it would pass a limit it does not meet.
pub fn max_or_nan(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// Whether every f32 of `values` is valid: the common case, in one branch-free pass (vectorised)
/// per block. On one thread: a table's chunks are scanned as they arrive, while the driver runs
/// the next chunk on every core (on lavapipe), and a parallel scan there measured 5-10 % slower
/// tables than this one (its threads wake and yield against the driver's).
pub fn all_valid_f32(values: &[f32]) -> bool {
    values.chunks(SCAN_BLOCK).all(|block| {
        block
            .iter()
            .fold(true, |ok, &v| ok & (v >= 0.0) & (v <= f32::MAX))
    })
}

/// Whether every channel of an RGB value is valid.
pub fn is_valid_rgb(v: DVec3) -> bool {
    is_valid(v.x) && is_valid(v.y) && is_valid(v.z)
}

/// The refusal of `model`'s values at `pairs` for `job`, counted one by one with `f`: the slow
/// path of a job whose fast path (a sum) only noticed that some value was invalid.
pub fn refuse_pairs(
    model: &str,
    job: &str,
    pairs: impl Iterator<Item = (DVec3, DVec3)>,
    f: impl Fn(DVec3, DVec3) -> DVec3,
) -> InvalidValues {
    let mut count = InvalidCount::default();
    for (k, (wi, wo)) in pairs.enumerate() {
        count.add(k as u64, f(wi, wo).to_array(), || (Some((wi, wo)), None));
    }
    InvalidValues {
        model: model.to_string(),
        job: job.to_string(),
        count,
    }
}

/// The first invalid value a counter saw: where, and what it was.
#[derive(Clone, Debug, PartialEq)]
pub struct FirstInvalid {
    /// Its index among the values evaluated (a table's cell, a pair's row, a pixel).
    pub index: u64,
    /// (ωi, ωo) where the value was evaluated, where the job knows them.
    pub directions: Option<(DVec3, DVec3)>,
    /// Where it was, in the job's words, when not a direction pair (a preview's pixel).
    pub place: Option<String>,
    /// The RGB value.
    pub value: [f64; 3],
}

/// How many evaluated RGB values were invalid, of each kind, and the first of them.
///
/// A value counts once in `invalid` and once under each kind its channels show (a value with a
/// NaN and a negative channel counts under both).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InvalidCount {
    /// RGB values seen.
    pub evaluated: u64,
    /// RGB values with at least one invalid channel.
    pub invalid: u64,
    /// Values with a NaN channel.
    pub nan: u64,
    /// Values with a +Inf channel.
    pub pos_inf: u64,
    /// Values with a −Inf channel.
    pub neg_inf: u64,
    /// Values with a finite negative channel.
    pub negative: u64,
    /// The first invalid value, by index.
    pub first: Option<FirstInvalid>,
}

impl InvalidCount {
    /// Whether every value seen was valid.
    pub fn is_clean(&self) -> bool {
        self.invalid == 0
    }

    /// Counts one RGB value at `index`; `locate` says where it was, asked only for the first
    /// invalid one.
    pub fn add(
        &mut self,
        index: u64,
        value: [f64; 3],
        locate: impl FnOnce() -> (Option<(DVec3, DVec3)>, Option<String>),
    ) {
        self.evaluated += 1;
        if value.iter().all(|&v| is_valid(v)) {
            return;
        }
        self.invalid += 1;
        let any = |f: fn(f64) -> bool| value.iter().any(|&v| f(v));
        self.nan += any(f64::is_nan) as u64;
        self.pos_inf += any(|v| v == f64::INFINITY) as u64;
        self.neg_inf += any(|v| v == f64::NEG_INFINITY) as u64;
        self.negative += any(|v| v.is_finite() && v < 0.0) as u64;
        if self.first.as_ref().is_none_or(|f| index < f.index) {
            let (directions, place) = locate();
            self.first = Some(FirstInvalid {
                index,
                directions,
                place,
                value,
            });
        }
    }

    /// Counts f32 RGB values (`values` holds 3 per value), the first at index `first`;
    /// `pair_at` gives the directions of an index.
    pub fn add_f32(&mut self, first: u64, values: &[f32], pair_at: impl Fn(u64) -> (DVec3, DVec3)) {
        let all_valid = all_valid_f32(values);
        if all_valid {
            self.evaluated += (values.len() / 3) as u64;
            return;
        }
        for (k, v) in values.chunks_exact(3).enumerate() {
            let i = first + k as u64;
            self.add(i, [v[0], v[1], v[2]].map(f64::from), || {
                (Some(pair_at(i)), None)
            });
        }
    }

    /// Counts f64 RGB values at `pairs`, the first at index `first`.
    pub fn add_pairs(&mut self, first: u64, values: &[[f64; 3]], pairs: &[(DVec3, DVec3)]) {
        for (k, (v, p)) in values.iter().zip(pairs).enumerate() {
            self.add(first + k as u64, *v, || (Some(*p), None));
        }
    }

    /// Adds another count of later values (a chunk counted on its own).
    pub fn merge(&mut self, other: InvalidCount) {
        self.evaluated += other.evaluated;
        self.invalid += other.invalid;
        self.nan += other.nan;
        self.pos_inf += other.pos_inf;
        self.neg_inf += other.neg_inf;
        self.negative += other.negative;
        if let Some(o) = other.first {
            if self.first.as_ref().is_none_or(|f| o.index < f.index) {
                self.first = Some(o);
            }
        }
    }

    /// `Ok` when clean, else the refusal of `model`'s values in `job`.
    pub fn refuse(self, model: &str, job: &str) -> Result<(), InvalidValues> {
        if self.is_clean() {
            return Ok(());
        }
        Err(InvalidValues {
            model: model.to_string(),
            job: job.to_string(),
            count: self,
        })
    }

    /// The record a table's JSON sidecar keeps: the counts and the first invalid cell.
    pub fn to_json(&self) -> serde_json::Value {
        let first = self.first.as_ref().map(|f| {
            let angles = f.directions.map(|(wi, wo)| {
                let (ti, pi) = angles_deg(wi);
                let (to, po) = angles_deg(wo);
                json!({"theta_i_deg": ti, "phi_i_deg": pi, "theta_o_deg": to, "phi_o_deg": po})
            });
            json!({
                "index": f.index,
                "angles": angles,
                "value": f.value.map(json_number),
            })
        });
        json!({
            "evaluated": self.evaluated,
            "invalid": self.invalid,
            "nan": self.nan,
            "pos_inf": self.pos_inf,
            "neg_inf": self.neg_inf,
            "negative": self.negative,
            "first": first,
        })
    }
}

/// A JSON number, or the strings "NaN", "Infinity", "-Infinity" that JSON has no number for.
fn json_number(v: f64) -> serde_json::Value {
    if v.is_nan() {
        "NaN".into()
    } else if v.is_infinite() {
        (if v > 0.0 { "Infinity" } else { "-Infinity" }).into()
    } else {
        v.into()
    }
}

/// "3 NaN, 1 negative": the kinds a count holds.
pub fn kinds_text(c: &InvalidCount) -> String {
    let kinds: Vec<String> = [
        (c.nan, "NaN"),
        (c.pos_inf, "+Inf"),
        (c.neg_inf, "-Inf"),
        (c.negative, "negative"),
    ]
    .into_iter()
    .filter(|(n, _)| *n > 0)
    .map(|(n, k)| format!("{n} {k}"))
    .collect();
    kinds.join(", ")
}

impl fmt::Display for InvalidCount {
    /// "3 of 100 values are invalid (3 NaN); the first is value 17 at theta_i ...: [NaN, 0.1, 0.1]"
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            out,
            "{} of {} values are invalid",
            self.invalid, self.evaluated
        )?;
        let kinds = kinds_text(self);
        if !kinds.is_empty() {
            write!(out, " ({kinds})")?;
        }
        if let Some(f) = &self.first {
            write!(out, "; the first is value {}", f.index)?;
            if let Some((wi, wo)) = f.directions {
                let (ti, pi) = angles_deg(wi);
                let (to, po) = angles_deg(wo);
                write!(
                    out,
                    " at theta_i {ti:.3} deg, phi_i {pi:.3} deg, theta_o {to:.3} deg, phi_o {po:.3} deg"
                )?;
            }
            if let Some(p) = &f.place {
                write!(out, " ({p})")?;
            }
            write!(out, ": [{}, {}, {}]", f.value[0], f.value[1], f.value[2])?;
        }
        Ok(())
    }
}

/// A job refused a model's values: some were NaN, ±Inf or negative.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{job}: the model {model} gives invalid BRDF values (a BRDF is finite and not negative): {count}")]
pub struct InvalidValues {
    /// The model's name (a `.brdf` file's path for models loaded from one).
    pub model: String,
    /// The job that refused ("albedo", "lut", "preview", ...).
    pub job: String,
    /// What was seen up to the refusal.
    pub count: InvalidCount,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_kind_is_counted_and_the_first_is_kept() {
        let mut c = InvalidCount::default();
        let p = (DVec3::Z, DVec3::Z);
        c.add_pairs(
            5,
            &[
                [0.1, 0.2, 0.3],
                [f64::NAN, -1.0, 0.0],
                [f64::INFINITY, 0.0, 0.0],
                [-0.0, 0.0, f64::NEG_INFINITY],
            ],
            &[p; 4],
        );
        assert_eq!(
            (
                c.evaluated,
                c.invalid,
                c.nan,
                c.pos_inf,
                c.neg_inf,
                c.negative
            ),
            (4, 3, 1, 1, 1, 1)
        );
        assert_eq!(c.first.as_ref().map(|f| f.index), Some(6));
        let mut later = InvalidCount::default();
        later.add_pairs(0, &[[-2.0, 0.0, 0.0]], &[p]);
        c.merge(later);
        assert_eq!((c.invalid, c.negative), (4, 2));
        assert_eq!(c.first.as_ref().map(|f| f.index), Some(0));
    }

    #[test]
    fn minus_zero_is_valid_and_nan_is_not() {
        assert!(is_valid(-0.0) && is_valid(0.0) && is_valid(f64::MAX));
        assert!(!is_valid(f64::NAN) && !is_valid(f64::INFINITY) && !is_valid(-1e-30));
    }
}
