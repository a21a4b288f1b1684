//! Distances between two BRDFs sampled at the same bins: what `lobe compare` reports and what
//! `lobe fit` minimises.
//!
//! Every function takes the bins (cosθi and a quadrature weight each) and two value lists, `a`
//! and `b`, one RGB value in 1/sr per bin. Bins with missing data (a MERL file's negative values)
//! are left out by the caller; a bin's weight is its solid-angle measure on whatever grid the bins
//! come from, in any common scale (only ratios of weights matter).
//!
//! The cosine-weighted log error is the form of Löw, Kronander, Ynnerman & Unger 2012, "BRDF
//! models for accurate and efficient rendering of glossy surfaces" (ACM TOG 31(1)), who
//! fit measured MERL data with it, following the cosine-weighted fits of Ngan, Durand & Matusik
//! 2005, "Experimental analysis of BRDF models":
//!
//! E_c = sqrt( Σ w·[ln(1 + cosθi·a_c) − ln(1 + cosθi·b_c)]² / Σ w )   for each channel c,
//!
//! and E = sqrt(mean over c of E_c²). The logarithm keeps a specular peak from drowning the rest
//! of the lobe; the `1 +` keeps it finite where f = 0; the cosine weights each value by the share
//! of light it carries.

/// One bin of a comparison: the cosine of its light direction and its quadrature weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bin {
    /// cosθi of the bin's light direction (≥ 0 above the horizon).
    pub cos_i: f64,
    /// The bin's solid-angle measure (any positive common scale).
    pub weight: f64,
}

/// Which distance a fit minimises.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LossKind {
    /// The cosine-weighted log error (module docs).
    #[default]
    CosineLog,
    /// Relative L2: sqrt(Σ w (b − a)² / Σ w a²), with `a` the target.
    RelativeL2,
}

impl LossKind {
    /// The names `--loss` takes.
    pub const NAMES: [&'static str; 2] = ["log", "l2"];

    /// The kind a `--loss` name stands for.
    pub fn from_name(name: &str) -> Option<LossKind> {
        match name {
            "log" => Some(LossKind::CosineLog),
            "l2" => Some(LossKind::RelativeL2),
            _ => None,
        }
    }

    /// The `--loss` name.
    pub fn name(self) -> &'static str {
        match self {
            LossKind::CosineLog => "log",
            LossKind::RelativeL2 => "l2",
        }
    }

    /// The distance of `b` from the target `a`.
    pub fn eval(self, bins: &[Bin], a: &[[f64; 3]], b: &[[f64; 3]]) -> ChannelErrors {
        match self {
            LossKind::CosineLog => cosine_log_error(bins, a, b),
            LossKind::RelativeL2 => relative_l2(bins, a, b),
        }
    }
}

/// A distance per channel and over all three.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChannelErrors {
    /// Over all channels.
    pub total: f64,
    /// Per channel, red, green, blue.
    pub channel: [f64; 3],
}

/// The cosine-weighted log error of `b` against `a` (module docs). Zero bins give zeros.
pub fn cosine_log_error(bins: &[Bin], a: &[[f64; 3]], b: &[[f64; 3]]) -> ChannelErrors {
    check_lengths(bins, a, b);
    let mut sum = [0.0f64; 3];
    let mut weight = 0.0f64;
    for ((bin, a), b) in bins.iter().zip(a).zip(b) {
        weight += bin.weight;
        for c in 0..3 {
            let d = (bin.cos_i * a[c]).ln_1p() - (bin.cos_i * b[c]).ln_1p();
            sum[c] += bin.weight * d * d;
        }
    }
    if weight <= 0.0 {
        return ChannelErrors {
            total: 0.0,
            channel: [0.0; 3],
        };
    }
    let channel = sum.map(|s| (s / weight).sqrt());
    let total = ((sum[0] + sum[1] + sum[2]) / (3.0 * weight)).sqrt();
    ChannelErrors { total, channel }
}

/// Relative L2 of `b` against the target `a`: sqrt(Σ w (b − a)² / Σ w a²) per channel, and
/// over all channels with the sums taken together. A channel whose target is 0 everywhere
/// reports the absolute L2, sqrt(Σ w b² / Σ w), instead of a division by zero.
pub fn relative_l2(bins: &[Bin], a: &[[f64; 3]], b: &[[f64; 3]]) -> ChannelErrors {
    check_lengths(bins, a, b);
    let mut diff = [0.0f64; 3];
    let mut norm = [0.0f64; 3];
    let mut weight = 0.0f64;
    for ((bin, a), b) in bins.iter().zip(a).zip(b) {
        weight += bin.weight;
        for c in 0..3 {
            diff[c] += bin.weight * (b[c] - a[c]) * (b[c] - a[c]);
            norm[c] += bin.weight * a[c] * a[c];
        }
    }
    let ratio = |d: f64, n: f64| {
        if n > 0.0 {
            (d / n).sqrt()
        } else if weight > 0.0 {
            (d / weight).sqrt()
        } else {
            0.0
        }
    };
    let channel = [0, 1, 2].map(|c| ratio(diff[c], norm[c]));
    let total = ratio(diff.iter().sum(), norm.iter().sum());
    ChannelErrors { total, channel }
}

/// Below this value (1/sr) two values' relative difference is taken against it instead of their
/// own size, so that bins where both models are all but black (a narrow lobe's tails, 1e-30
/// against 3e-30) do not report 200 % differences nobody could see.
pub const RELATIVE_FLOOR: f64 = 1e-4;

/// Relative differences bin by bin: |b − a| / max(|a|, |b|, [`RELATIVE_FLOOR`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RelativeDifference {
    /// Weighted RMS over bins and channels.
    pub rms: f64,
    /// Largest over bins and channels.
    pub max: f64,
    /// The bin (index into the lists) and channel of the largest.
    pub argmax: Option<(usize, usize)>,
}

/// The relative differences of `b` against `a` (see [`RelativeDifference`]).
pub fn relative_difference(bins: &[Bin], a: &[[f64; 3]], b: &[[f64; 3]]) -> RelativeDifference {
    check_lengths(bins, a, b);
    let mut sum = 0.0f64;
    let mut weight = 0.0f64;
    let mut max = 0.0f64;
    let mut argmax = None;
    for (i, ((bin, a), b)) in bins.iter().zip(a).zip(b).enumerate() {
        weight += 3.0 * bin.weight;
        for c in 0..3 {
            let r = relative(a[c], b[c]);
            sum += bin.weight * r * r;
            if r > max || argmax.is_none() {
                max = r;
                argmax = Some((i, c));
            }
        }
    }
    let rms = if weight > 0.0 {
        (sum / weight).sqrt()
    } else {
        0.0
    };
    RelativeDifference { rms, max, argmax }
}

/// |b − a| / max(|a|, |b|, [`RELATIVE_FLOOR`]).
pub fn relative(a: f64, b: f64) -> f64 {
    (b - a).abs() / a.abs().max(b.abs()).max(RELATIVE_FLOOR)
}

fn check_lengths(bins: &[Bin], a: &[[f64; 3]], b: &[[f64; 3]]) {
    assert!(
        bins.len() == a.len() && a.len() == b.len(),
        "loss: {} bins, {} and {} values",
        bins.len(),
        a.len(),
        b.len()
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sums of a few terms: a few ulps of the result.
    const SUM_TOLERANCE: f64 = 1e-14;

    fn bins() -> Vec<Bin> {
        [(1.0, 1.0), (0.5, 2.0), (0.0, 1.0)]
            .map(|(cos_i, weight)| Bin { cos_i, weight })
            .to_vec()
    }

    #[test]
    fn identical_values_have_no_distance() {
        let a = vec![[0.3, 1.0, 7.0], [0.0, 2.0, 0.1], [5.0, 5.0, 5.0]];
        for kind in [LossKind::CosineLog, LossKind::RelativeL2] {
            let e = kind.eval(&bins(), &a, &a);
            assert_eq!(e.total, 0.0, "{kind:?}");
            assert_eq!(e.channel, [0.0; 3], "{kind:?}");
        }
        let r = relative_difference(&bins(), &a, &a);
        assert_eq!((r.rms, r.max), (0.0, 0.0));
    }

    #[test]
    fn log_error_matches_its_formula_by_hand() {
        // Red only differs: a = (1, 0.5, 0) against b = (e − 1, 0.5, 0) at cosθi = 1 in the
        // first bin gives ln(2) − 1 there; bin 2 (cos 0.5): ln(1.25) − ln(1.25) = 0; bin 3
        // (cos 0): 0. So E_red² = (1 − ln 2)² · 1 / 4.
        let a = vec![[1.0, 0.5, 0.0], [0.5, 0.5, 0.0], [9.0, 1.0, 0.0]];
        let mut b = a.clone();
        b[0][0] = std::f64::consts::E - 1.0;
        b[2][0] = 100.0; // cosθi = 0: carries no light, counts nothing
        let e = cosine_log_error(&bins(), &a, &b);
        let red = (1.0 - 2f64.ln()) / 2.0;
        assert!((e.channel[0] - red).abs() < SUM_TOLERANCE, "{e:?}");
        assert_eq!(e.channel[1], 0.0);
        assert!((e.total - red / 3f64.sqrt()).abs() < SUM_TOLERANCE, "{e:?}");
    }

    #[test]
    fn relative_l2_of_a_scaled_copy_is_the_scale_error() {
        // b = 1.1 a in every channel: sqrt(Σ w (0.1 a)² / Σ w a²) = 0.1 exactly in real numbers.
        let a = vec![[0.2, 1.0, 3.0], [4.0, 0.1, 1.0], [1.0, 2.0, 0.5]];
        let b: Vec<_> = a.iter().map(|v| v.map(|x| 1.1 * x)).collect();
        let e = relative_l2(&bins(), &a, &b);
        for x in e.channel.into_iter().chain([e.total]) {
            assert!((x - 0.1).abs() < SUM_TOLERANCE, "{e:?}");
        }
    }

    #[test]
    fn relative_difference_is_floored_and_finds_its_largest() {
        let tiny = relative(1e-30, 3e-30);
        assert!(
            (tiny - 2e-30 / RELATIVE_FLOOR).abs() < SUM_TOLERANCE * 2e-26,
            "{tiny}"
        );
        assert_eq!(relative(2.0, 1.0), 0.5);
        let a = vec![[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]];
        let mut b = a.clone();
        b[1][2] = 0.25;
        let r = relative_difference(&bins(), &a, &b);
        assert_eq!(r.max, 0.75);
        assert_eq!(r.argmax, Some((1, 2)));
        // One channel of the weight-2 bin out of 4 weight × 3 channels: 0.75² · 2 / 12.
        assert!((r.rms - (0.75f64.powi(2) * 2.0 / 12.0).sqrt()).abs() < SUM_TOLERANCE);
    }
}
