//! The search space of a fit: the free keys' numbers as one unbounded vector z ∈ Rⁿ, mapped
//! into each key's range from the model's parameter table, and the starting points.
//!
//! Bounds map: x = lo + (hi − lo)·σ(z) with σ(z) = 1/(1 + e^(−z)), the logistic function, so
//! every z is a valid value and the optimiser needs no constraints. A range wider than
//! [`LOG_MAP_SPAN`] (the Phong-like exponents, [0, 10⁶]) is mapped in ln(1 + x) instead, so that
//! 10 and 10⁴ are as far apart as their ratio says. An rgb key is three coordinates, one per
//! channel; a scalar key is one.
//!
//! Starts: point s (s = 1, 2, …) of the Halton sequence in the unit box (base 2, 3, 5, … per
//! coordinate), mapped through σ⁻¹: spread over the box, the same every run.

use crate::input::BadInput;
use crate::model::params::{ParamKind, Value};
use crate::model::ParamSet;
use anyhow::Result;

/// Ranges wider than this (max − min) are mapped in ln(1 + x): 1000 covers every bounded
/// parameter of the built-in models (at most [1, 5] or [0.01, 10]) but not the exponents.
pub const LOG_MAP_SPAN: f64 = 1000.0;

/// σ is kept within [ε, 1 − ε] so that a value never lands on a closed bound it may not take
/// (a roughness's 0): 1e-12 of the range is far below any fit's resolution.
const EDGE: f64 = 1e-12;

/// One free key and where its coordinates sit in z.
#[derive(Clone, Debug)]
pub struct FreeKey {
    /// The parameter key.
    pub key: &'static str,
    /// Whether it is an rgb key (three coordinates) or a scalar (one).
    pub rgb: bool,
    /// The lower bound of its range.
    pub min: f64,
    /// The upper bound of its range.
    pub max: f64,
    /// Whether the map is in ln(1 + x) ([`LOG_MAP_SPAN`]).
    pub log: bool,
}

impl FreeKey {
    /// Coordinates of this key in z.
    pub fn len(&self) -> usize {
        if self.rgb {
            3
        } else {
            1
        }
    }

    /// Whether the key has no coordinates (never: a key has one or three).
    pub fn is_empty(&self) -> bool {
        false
    }

    fn bounds(&self) -> (f64, f64) {
        if self.log {
            (self.min.ln_1p(), self.max.ln_1p())
        } else {
            (self.min, self.max)
        }
    }

    /// The value of coordinate z.
    pub fn value(&self, z: f64) -> f64 {
        let (lo, hi) = self.bounds();
        let s = (1.0 / (1.0 + (-z).exp())).clamp(EDGE, 1.0 - EDGE);
        let t = lo + (hi - lo) * s;
        let x = if self.log { t.exp_m1() } else { t };
        x.clamp(self.min, self.max)
    }

    /// The coordinate of a value at fraction `s` ∈ (0, 1) of the mapped range.
    pub fn coordinate_of_fraction(s: f64) -> f64 {
        let s = s.clamp(EDGE, 1.0 - EDGE);
        (s / (1.0 - s)).ln()
    }
}

/// The free keys of a fit, in the order given.
#[derive(Clone, Debug)]
pub struct Space {
    /// The keys.
    pub keys: Vec<FreeKey>,
    /// The parameter set the free values are written into (every other key as given).
    pub base: ParamSet,
}

impl Space {
    /// Checks `free` against `base`'s model: each key must exist, be a number (scalar or rgb,
    /// not a choice or a switch), change f under the model's choices, appear once, and not be
    /// among `fixed` (keys the caller set to a value: a key cannot be both fixed and fitted).
    pub fn new(base: ParamSet, free: &[String], fixed: &[String]) -> Result<Space> {
        let model = base.model();
        let refuse = |m: String| anyhow::Error::from(BadInput::new("free", m));
        if free.is_empty() {
            return Err(refuse(format!(
                "no free keys: name the parameters of {} to fit, e.g. {}",
                model.name(),
                numeric_keys(&base).join(",")
            )));
        }
        let mut keys: Vec<FreeKey> = Vec::new();
        for name in free {
            let name = name.trim();
            let Some(spec) = model.params().iter().find(|s| s.key == name) else {
                return Err(refuse(format!(
                    "free key '{name}': {} has no such parameter; its numeric parameters are: {}",
                    model.name(),
                    numeric_keys(&base).join(", ")
                )));
            };
            let rgb = match spec.kind {
                ParamKind::Rgb => true,
                ParamKind::Scalar => false,
                ParamKind::Choice(options) => {
                    return Err(refuse(format!(
                        "free key '{name}': it is a choice ({}), not a number; give it a fixed value ({name}=VALUE) and fit the numbers",
                        options.join(" | ")
                    )))
                }
                ParamKind::Flag => {
                    return Err(refuse(format!(
                        "free key '{name}': it is a switch (0 or 1), not a number; give it a fixed value ({name}=0 or 1)"
                    )))
                }
            };
            if keys.iter().any(|k| k.key == spec.key) {
                return Err(refuse(format!("free key '{name}' is listed twice")));
            }
            if fixed.iter().any(|f| f == name) {
                return Err(refuse(format!(
                    "free key '{name}' is also given a value (an assignment or the model spec): a key is either fixed or fitted, not both"
                )));
            }
            if !base.is_active(name) {
                return Err(refuse(format!(
                    "free key '{name}' does not change {} under its current choices ({}); fitting it would be meaningless",
                    model.name(),
                    base.to_text()
                )));
            }
            keys.push(FreeKey {
                key: spec.key,
                rgb,
                min: spec.min,
                max: spec.max,
                log: spec.max - spec.min > LOG_MAP_SPAN,
            });
        }
        Ok(Space { keys, base })
    }

    /// Coordinates in z.
    pub fn dims(&self) -> usize {
        self.keys.iter().map(FreeKey::len).sum()
    }

    /// The parameter set at z: `base` with every free key's value from its coordinates.
    pub fn params(&self, z: &[f64]) -> Result<ParamSet> {
        let mut p = self.base.clone();
        let mut at = 0;
        for k in &self.keys {
            let value = if k.rgb {
                Value::Three([0, 1, 2].map(|c| k.value(z[at + c])))
            } else {
                Value::One(k.value(z[at]))
            };
            at += k.len();
            p.set(k.key, value)?;
        }
        Ok(p)
    }

    /// The `count` starting points (module docs).
    pub fn starts(&self, count: usize) -> Vec<Vec<f64>> {
        let primes = first_primes(self.dims());
        (1..=count)
            .map(|s| {
                primes
                    .iter()
                    .map(|&b| FreeKey::coordinate_of_fraction(radical_inverse(s, b)))
                    .collect()
            })
            .collect()
    }
}

/// The keys of `p`'s model that a fit can free (scalars and rgb values that change f).
pub fn numeric_keys(p: &ParamSet) -> Vec<&'static str> {
    p.model()
        .params()
        .iter()
        .filter(|s| matches!(s.kind, ParamKind::Rgb | ParamKind::Scalar) && p.is_active(s.key))
        .map(|s| s.key)
        .collect()
}

/// The radical inverse of `k` in base `b`: k's digits mirrored after the point.
pub fn radical_inverse(mut k: usize, b: usize) -> f64 {
    let (mut out, mut scale) = (0.0, 1.0 / b as f64);
    while k > 0 {
        out += (k % b) as f64 * scale;
        k /= b;
        scale /= b as f64;
    }
    out
}

fn first_primes(n: usize) -> Vec<usize> {
    let mut out: Vec<usize> = Vec::with_capacity(n);
    let mut c = 2;
    while out.len() < n {
        if out.iter().all(|p| c % p != 0) {
            out.push(c);
        }
        c += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Round trips through exp and ln: a few ulps.
    const MAP_TOLERANCE: f64 = 1e-12;

    #[test]
    fn the_map_covers_the_range_and_its_middle() {
        let lin = FreeKey {
            key: "alpha",
            rgb: false,
            min: 0.0,
            max: 1.0,
            log: false,
        };
        assert_eq!(lin.value(0.0), 0.5);
        assert!(lin.value(-800.0) > 0.0 && lin.value(800.0) <= 1.0);
        let log = FreeKey {
            log: true,
            max: 1e6,
            ..lin
        };
        // σ = 1/2 is the geometric middle of 1 + x over [1, 1e6 + 1].
        assert!((log.value(0.0) - ((1e6f64 + 1.0).sqrt() - 1.0)).abs() < MAP_TOLERANCE * 1e3);
        let s = FreeKey::coordinate_of_fraction(0.25);
        assert!((lin.value(s) - 0.25).abs() < MAP_TOLERANCE);
    }

    #[test]
    fn halton_starts_are_spread_and_fixed() {
        assert_eq!(radical_inverse(1, 2), 0.5);
        assert!((radical_inverse(5, 3) - (2.0 / 3.0 + 1.0 / 9.0)).abs() < MAP_TOLERANCE);
        assert_eq!(first_primes(5), vec![2, 3, 5, 7, 11]);
    }
}
