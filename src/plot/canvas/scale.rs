//! Value-to-position scales, their ticks and tick labels.

/// A value-to-[0, 1] map, linear or logarithmic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale {
    /// The value at position 0; positive when the scale is logarithmic.
    pub lo: f64,
    /// The value at position 1 (larger values saturate).
    pub hi: f64,
    /// Logarithmic between `lo` and `hi` instead of linear.
    pub log: bool,
}

impl Scale {
    /// From the largest plotted value: [0, max] or [max·10^-decades, max]. A zero maximum (a
    /// black lobe) still gets a usable range.
    pub fn from_max(max: f64, log: bool, decades: f64) -> Scale {
        let hi = if max.is_finite() && max > 0.0 {
            max
        } else {
            1.0
        };
        if log {
            Scale {
                lo: hi * 10f64.powf(-decades),
                hi,
                log,
            }
        } else {
            Scale { lo: 0.0, hi, log }
        }
    }

    /// A scale fitted to a heat map's values: the top at the `quantile` of the positive finite
    /// values (1 = the maximum; below 1 the colour saturates above it, so that a few extreme
    /// cells, such as the 1/(c_i c_o) blow-up at grazing θd, do not flatten the rest), and for a
    /// logarithmic scale the bottom at the smallest positive value when that is within `decades`.
    pub fn fit(values: &[f64], log: bool, decades: f64, quantile: f64) -> Scale {
        let mut v: Vec<f64> = values
            .iter()
            .copied()
            .filter(|x| x.is_finite() && *x > 0.0)
            .collect();
        if v.is_empty() {
            return Scale::from_max(0.0, log, decades);
        }
        v.sort_by(f64::total_cmp);
        let k = ((v.len() - 1) as f64 * quantile.clamp(0.0, 1.0)).round() as usize;
        let mut s = Scale::from_max(v[k], log, decades);
        if log && v[0] > s.lo && v[0] < s.hi {
            s.lo = v[0];
        }
        s
    }

    /// Position in [0, 1]; values below the range map to 0 (NaN stays NaN).
    pub fn unit(&self, v: f64) -> f64 {
        let t = if self.log {
            if v <= 0.0 {
                0.0
            } else {
                (v / self.lo).log10() / (self.hi / self.lo).log10()
            }
        } else {
            (v - self.lo) / (self.hi - self.lo)
        };
        t.clamp(0.0, 1.0)
    }

    /// The value at position t in [0, 1].
    pub fn value(&self, t: f64) -> f64 {
        if self.log {
            self.lo * (self.hi / self.lo).powf(t)
        } else {
            self.lo + t * (self.hi - self.lo)
        }
    }

    /// Tick values inside the range, at least [`MIN_TICKS`] of them: powers of ten (log; then
    /// 1, 2 and 5 times them, then every integer multiple, on a short range) or round steps
    /// (linear).
    pub fn ticks(&self) -> Vec<f64> {
        if self.log {
            for mantissas in [
                &[1.0][..],
                &[1.0, 2.0, 5.0],
                &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
            ] {
                let v = self.log_ticks(mantissas);
                if v.len() >= MIN_TICKS {
                    return v;
                }
            }
            // Less than a factor of about 2.5: round steps read better than a log grid.
            Scale {
                log: false,
                ..*self
            }
            .ticks()
        } else {
            let mut intervals = 5;
            loop {
                let v = self.linear_ticks(nice_step(self.hi - self.lo, intervals));
                if v.len() >= MIN_TICKS || intervals > 40 {
                    return v;
                }
                intervals *= 2;
            }
        }
    }

    /// The mantissas times powers of ten inside the range, thinned to at most about seven.
    fn log_ticks(&self, mantissas: &[f64]) -> Vec<f64> {
        let a = self.lo.log10().floor() as i32;
        let b = self.hi.log10().ceil() as i32;
        let inside = |v: f64| v >= self.lo * (1.0 - 1e-9) && v <= self.hi * (1.0 + 1e-9);
        if mantissas.len() == 1 {
            let v: Vec<f64> = (a..=b)
                .map(|e| 10f64.powi(e))
                .filter(|v| inside(*v))
                .collect();
            let step = (v.len() / 7).max(1);
            return v.into_iter().step_by(step).collect();
        }
        (a..=b)
            .flat_map(|e| mantissas.iter().map(move |m| m * 10f64.powi(e)))
            .filter(|v| inside(*v))
            .collect()
    }

    /// Multiples of `step` inside the range.
    fn linear_ticks(&self, step: f64) -> Vec<f64> {
        let mut v = Vec::new();
        let mut k = (self.lo / step).ceil();
        while k * step <= self.hi * (1.0 + 1e-9) + 1e-300 {
            v.push(k * step);
            k += 1.0;
        }
        v
    }
}

/// The fewest ticks a scale shows: with fewer a reader cannot tell a log axis from a linear
/// one, nor read a value between two labels.
pub const MIN_TICKS: usize = 4;

/// A round step (1, 2 or 5 times a power of ten) giving about `n` intervals over `span`.
pub fn nice_step(span: f64, n: usize) -> f64 {
    let raw = span / n as f64;
    let p = 10f64.powf(raw.log10().floor());
    let m = raw / p;
    let k = if m < 1.5 {
        1.0
    } else if m < 3.5 {
        2.0
    } else if m < 7.5 {
        5.0
    } else {
        10.0
    };
    k * p
}

/// A short number for a tick label: `0.25`, `12`, `3e-4`.
pub fn fmt_value(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".to_string()
    } else if (0.01..1e4).contains(&a) {
        let s = format!("{v:.3}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        let s = format!("{v:.1e}");
        s.replace(".0e", "e")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_scale_maps_its_ends_and_ticks_are_inside() {
        let s = Scale::from_max(10.0, true, 3.0);
        assert!((s.unit(10.0) - 1.0).abs() < 1e-12);
        assert!((s.unit(0.01) - 0.0).abs() < 1e-12);
        assert_eq!(s.unit(0.0), 0.0);
        assert!((s.value(s.unit(0.5)) - 0.5).abs() < 1e-12);
        for t in s.ticks() {
            assert!(t >= s.lo * 0.999 && t <= s.hi * 1.001);
        }
        let l = Scale::from_max(0.25, false, 3.0);
        assert_eq!(l.ticks().first(), Some(&0.0));
    }

    #[test]
    fn every_scale_has_at_least_four_ticks() {
        // A fitted map of a dim model: 0.3 to 2 holds only the power 1 (one tick before).
        let cases = [
            Scale {
                lo: 0.3,
                hi: 2.0,
                log: true,
            },
            Scale {
                lo: 0.9,
                hi: 1.1,
                log: true,
            },
            Scale {
                lo: 0.05,
                hi: 0.5,
                log: true,
            },
            Scale {
                lo: 1e-4,
                hi: 1.0,
                log: true,
            },
            Scale {
                lo: 0.0,
                hi: 1.3,
                log: false,
            },
            Scale {
                lo: 0.17,
                hi: 0.29,
                log: false,
            },
        ];
        for s in cases {
            let t = s.ticks();
            assert!(t.len() >= MIN_TICKS, "{s:?}: ticks {t:?}");
            assert!(
                t.iter().all(|v| *v >= s.lo * 0.999 && *v <= s.hi * 1.001),
                "{s:?}: {t:?}"
            );
        }
    }

    #[test]
    fn a_fitted_scale_saturates_above_its_quantile_and_starts_at_the_smallest_value() {
        let mut v: Vec<f64> = (1..=100).map(f64::from).collect();
        v.push(1e9);
        v.push(f64::NAN);
        v.push(0.0);
        let s = Scale::fit(&v, true, 4.0, 0.99);
        assert_eq!((s.lo, s.hi), (1.0, 100.0));
        let m = Scale::fit(&v, false, 4.0, 1.0);
        assert_eq!((m.lo, m.hi), (0.0, 1e9));
    }
}
