//! Importance sampling: the [`Sample`] every model's sampler returns and the samplers its lobes
//! share (cosine, uniform hemisphere, power cosine, GGX and Beckmann visible normals), each with
//! its density. Samplers of one model alone (Ashikhmin & Shirley's half vectors, EON's clipped
//! transformed cosine) live in that model's file; `Reference::sample` and `Reference::pdf`
//! dispatch to every model's `sample_<model>` and `pdf_<model>` (`src/model/mod.rs`).
//!
//! Conventions (docs/design.md §13): ωi points towards the light and is the direction
//! drawn, ωo towards the viewer; the local frame has z along the normal, cos θ = w.z. A sampler
//! returns ωi with its density `pdf` over the solid angle of ωi and the weight
//! f(ωi, ωo) cos θi / pdf. A draw below the horizon (ωi.z ≤ 0) keeps its ωi, so that a caller
//! can count it, with weight 0 and pdf 0; over the upper hemisphere the model's `pdf_<model>`
//! then integrates to one minus the share of such draws (and of mirror-spike draws).

use super::components::Distribution;
use super::terms::{alpha_tan2, lambda_beckmann, lambda_ggx, pow1m, D_beckmann, D_ggx};
use glam::{DVec2, DVec3};
use std::f64::consts::{FRAC_1_PI, PI};

/// One draw of ωi for a given ωo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// The direction drawn, towards the light, a unit vector of the local frame; kept below the
    /// horizon too, where `weight` and `pdf` are 0.
    pub wi: DVec3,
    /// f(ωi, ωo) cos θi / pdf per channel, the estimator's factor; for a delta sample the spike's
    /// albedo divided by the probability of choosing the spike. 0 below the horizon.
    pub weight: DVec3,
    /// For a non-delta sample, the density of ωi over solid angle (1/sr) of the whole sampler,
    /// the probability-weighted sum over the non-delta components (not only the one drawn),
    /// equal to the model's `pdf_<model>(ωi, ωo)`; for a delta sample, the probability of having
    /// chosen the spike (no unit). 0 below the horizon.
    pub pdf: f64,
    /// Whether this is the mirror spike of a model that has one: ωi is then the mirror direction
    /// of ωo exactly, the sample has no density over solid angle and must stay out of any
    /// histogram or density comparison.
    pub delta: bool,
}

impl Sample {
    /// A draw of a non-delta component: ωi with the sampler's density `pdf` at ωi and the weight
    /// f(ωi) cos θi / pdf. Below the horizon, or where the density is 0 (an exponent's power
    /// underflowing far out in its tail), weight and pdf are 0 and ωi stays.
    pub fn from_draw(wi: DVec3, pdf: f64, f: impl FnOnce(DVec3) -> DVec3) -> Sample {
        // A NaN density is refused too; the weight then divides by a positive pdf.
        if wi.z <= 0.0 || pdf.is_nan() || pdf <= 0.0 {
            return Sample::lost(wi);
        }
        Sample {
            wi,
            weight: f(wi) * (wi.z / pdf),
            pdf,
            delta: false,
        }
    }

    /// A draw that left the upper hemisphere (or a request with ωo below it): weight 0, pdf 0.
    pub fn lost(wi: DVec3) -> Sample {
        Sample {
            wi,
            weight: DVec3::ZERO,
            pdf: 0.0,
            delta: false,
        }
    }

    /// The mirror spike chosen with probability `probability` > 0, whose albedo seen from ωo is
    /// `albedo`: ωi = the mirror direction of ωo, weight = albedo / probability.
    pub fn spike(wo: DVec3, probability: f64, albedo: DVec3) -> Sample {
        Sample {
            wi: mirror(wo),
            weight: albedo / probability,
            pdf: probability,
            delta: true,
        }
    }
}

/// The mirror direction of w about the normal, 2 (w·n) n − w with n = +z.
pub fn mirror(w: DVec3) -> DVec3 {
    DVec3::new(-w.x, -w.y, w.z)
}

/// The reflection of w about the unit vector h, 2 (w·h) h − w.
pub fn reflect(w: DVec3, h: DVec3) -> DVec3 {
    2.0 * w.dot(h) * h - w
}

/// Rec. 709 luminance Y = 0.2126 R + 0.7152 G + 0.0722 B of linear RGB, the scalar by which
/// mixtures weigh their components' albedos.
pub fn luminance(c: DVec3) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// The probability of choosing a component of albedo estimate `lobe` against the rest, `rest`:
/// lobe / (lobe + rest), with negative estimates counted as 0, and 0 when both are 0 (a black
/// material still draws, from the rest: its weights are then 0).
pub fn mixture_share(lobe: f64, rest: f64) -> f64 {
    let (a, b) = (lobe.max(0.0), rest.max(0.0));
    if a + b > 0.0 {
        a / (a + b)
    } else {
        0.0
    }
}

/// Two unit vectors that complete the unit vector `n` to a right-handed orthonormal frame
/// (Duff et al. 2017, "Building an orthonormal basis, revisited", JCGT 6(1), listing 3's
/// formulas: no division by a vanishing number, continuous except across n.z = 0).
pub fn frame(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1.0f64.copysign(n.z);
    // sign and n.z share their sign, so |sign + n.z| ≥ 1.
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Cosine-weighted hemisphere by Malley's method: a uniform point of the unit disk (polar map
/// r = √u₁, φ = 2π u₂) lifted to the hemisphere, density cos θ / π ([`pdf_cosine`]). Never
/// below the horizon: z = √(1 − u₁) > 0 for u₁ < 1.
pub fn sample_cosine(u: DVec2) -> DVec3 {
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt())
}

/// The density of [`sample_cosine`], max(0, cos θ)/π.
pub fn pdf_cosine(wi: DVec3) -> f64 {
    wi.z.max(0.0) * FRAC_1_PI
}

/// The uniform hemisphere: cos θ = u₁, φ = 2π u₂, density 1/(2π) ([`pdf_uniform_hemisphere`]).
pub fn sample_uniform_hemisphere(u: DVec2) -> DVec3 {
    let s = ((1.0 - u.x) * (1.0 + u.x)).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    DVec3::new(s * phi.cos(), s * phi.sin(), u.x)
}

/// The density of [`sample_uniform_hemisphere`]: 1/(2π) above the horizon.
pub fn pdf_uniform_hemisphere(wi: DVec3) -> f64 {
    if wi.z > 0.0 {
        0.5 * FRAC_1_PI
    } else {
        0.0
    }
}

/// The draw of a model with a cosine sampler alone (Lambert-like lobes and models defined at
/// run time): ωi by [`sample_cosine`], weight f cos θi / pdf with f from `f`.
pub fn sample_by_cosine(u: DVec2, f: impl FnOnce(DVec3) -> DVec3) -> Sample {
    let wi = sample_cosine(u);
    Sample::from_draw(wi, pdf_cosine(wi), f)
}

/// A power-cosine lobe about the unit `axis` (Lafortune & Willems 1994, "Using the modified
/// Phong reflectance model for physically based rendering", §4): cos α = (1 − u₁)^{1/(n+1)},
/// the angle α from the axis, and φ = 2π u₂ about it; density (n + 1)/(2π) cosⁿα
/// ([`pdf_power_cosine`]). The draw may leave the upper hemisphere of the surface.
pub fn sample_power_cosine(axis: DVec3, n: f64, u: DVec2) -> DVec3 {
    // 1 − cos α = −expm1(ln(1 − u₁)/(n + 1)): no cancellation for the small angles of a large
    // n. 1 − u₁ rather than u₁ (the same law): the generator gives u = 0 (once in 2²⁴ draws)
    // and never 1, and u₁ = 0 would put the draw on the lobe's rim, where its density is 0.
    let one_minus_c = -((-u.x).ln_1p() / (n + 1.0)).exp_m1();
    let c = 1.0 - one_minus_c;
    let s = (one_minus_c * (2.0 - one_minus_c)).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    let (t, b) = frame(axis);
    t * (s * phi.cos()) + b * (s * phi.sin()) + axis * c
}

/// The density of [`sample_power_cosine`] at w: (n + 1)/(2π) max(0, axis·w)ⁿ, with
/// 1 − axis·w = |w − axis|²/2 (no cancellation near the axis).
pub fn pdf_power_cosine(axis: DVec3, n: f64, w: DVec3) -> f64 {
    let s = 0.5 * (w - axis).length_squared();
    if s >= 1.0 {
        return 0.0; // axis·w ≤ 0: outside the lobe (pow1m's 0⁰ = 1 would count it for n = 0)
    }
    (n + 1.0) / (2.0 * PI) * pow1m(s, n)
}

/// ωo in the stretched configuration of roughness 1 (Heitz 2014, §5.3): normalize(αx x, αy y, z)
/// (never the zero vector: z = c_o > 0).
fn stretch(wo: DVec3, ax: f64, ay: f64) -> DVec3 {
    DVec3::new(ax * wo.x, ay * wo.y, wo.z).normalize()
}

/// A normal of the stretched configuration back in the surface's: normalize(αx x, αy y, z),
/// with z clamped at 0 (it is ≥ 0 up to rounding); +z where the vector vanishes (a draw of
/// measure 0).
fn unstretch(h: DVec3, ax: f64, ay: f64) -> DVec3 {
    let v = DVec3::new(ax * h.x, ay * h.y, h.z.max(0.0));
    let len = v.length();
    if len > 0.0 {
        v / len
    } else {
        DVec3::Z
    }
}

/// A GGX visible normal h for ωo (anisotropic: αx along +x, αy along +y, as [`D_ggx`]), by
/// Dupuy & Benyoub 2023, "Sampling Visible GGX Normals with Spherical Caps" (HPG), §3: in the
/// stretched configuration the visible normals are v + c/|v + c| for c uniform on the spherical
/// cap {c : |c| = 1, c.z ≥ −v.z}, v = ωo stretched; so z = u₂' (1 + v.z) − v.z with
/// u₂' = 1 − u₂ uniform on [−v.z, 1] and φ = 2π u₁. Taken as 1 − z = u₂ (1 + v.z) and
/// sin² = (1 − z)(1 + z): near the pole (u₂ → 0) 1 − z² would cancel, which the f32 twin feels. The default GGX sampler (fewer operations
/// than [`sample_ggx_vndf_hemisphere`], the same density, both tested).
pub fn sample_ggx_vndf(wo: DVec3, ax: f64, ay: f64, u: DVec2) -> DVec3 {
    let v = stretch(wo, ax, ay);
    let phi = 2.0 * PI * u.x;
    let one_minus_z = u.y * (1.0 + v.z);
    let z = 1.0 - one_minus_z;
    let s = (one_minus_z * (2.0 - one_minus_z)).max(0.0).sqrt();
    let c = DVec3::new(s * phi.cos(), s * phi.sin(), z);
    unstretch(c + v, ax, ay)
}

/// A GGX visible normal by Heitz 2018, "Sampling the GGX Distribution of Visible Normals"
/// (JCGT 7(4)), §4: a uniform point of the unit disk perpendicular to the stretched ωo, its
/// half facing away from ωo squeezed by (1 + v.z)/2, projected onto the hemisphere about v.
/// Same density as [`sample_ggx_vndf`].
pub fn sample_ggx_vndf_hemisphere(wo: DVec3, ax: f64, ay: f64, u: DVec2) -> DVec3 {
    let v = stretch(wo, ax, ay);
    let len2 = v.x * v.x + v.y * v.y;
    let t1 = if len2 > 0.0 {
        DVec3::new(-v.y, v.x, 0.0) / len2.sqrt()
    } else {
        DVec3::X
    };
    let t2 = v.cross(t1);
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + v.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * (r * phi.sin());
    let n = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * v;
    unstretch(n, ax, ay)
}

/// A Beckmann visible normal h for ωo (anisotropic as [`D_beckmann`]), by Heitz & d'Eon 2014,
/// "Importance Sampling Microfacet-Based BSDFs using the Distribution of Visible Normals"
/// (EGSR), §4 and appendix: stretch ωo to roughness 1 (angle θ from the normal, azimuth φ),
/// draw the slopes (x̃, ỹ) of the visible normals of that standard surface seen from θ in the
/// plane φ = 0, rotate them by φ, scale them by (αx, αy), and h = normalize(−x̃, −ỹ, 1).
/// The slopes: the standard Beckmann slope density e^{−x̃²−ỹ²}/π weighted by the projected
/// area max(0, 1 − x̃ tan θ) separates, so ỹ is normal with variance 1/2 and x̃ has the
/// cumulative distribution C(x) = [erfc(−x)/2 + tan θ e^{−x²}/(2√π)] / (1 + Λ(θ)) on x < cot θ
/// (Jakob 2014, "An Improved Visible Normal Sampling Routine for the Beckmann Distribution",
/// solves C(x) = u the same way: Newton's method kept inside a bisection bracket).
pub fn sample_beckmann_vndf(wo: DVec3, ax: f64, ay: f64, u: DVec2) -> DVec3 {
    let v = stretch(wo, ax, ay);
    let sin_t = (v.x * v.x + v.y * v.y).sqrt();
    // v.z > 0 for ωo above the horizon (the caller's test); the cap keeps tan θ finite for a
    // subnormal v.z, where the distribution is the grazing limit's to f64 precision anyway
    // (and pdf_vndf, whose Λ overflows there, gives such draws density 0).
    let tan_t = (sin_t / v.z).min(1e150);
    let (cos_phi, sin_phi) = if sin_t > 0.0 {
        (v.x / sin_t, v.y / sin_t)
    } else {
        (1.0, 0.0)
    };
    let (x, y) = (
        beckmann_visible_slope(tan_t, u.x),
        standard_normal_slope(u.y),
    );
    let (sx, sy) = (cos_phi * x - sin_phi * y, sin_phi * x + cos_phi * y);
    DVec3::new(-ax * sx, -ay * sy, 1.0).normalize()
}

/// Slopes beyond ±[`SLOPE_RANGE`] of the standard Beckmann surface carry a probability below
/// erfc(10)/2 ≈ 1e-45 (the Gaussian tail e^{−x²}): the inverse distributions stop there.
const SLOPE_RANGE: f64 = 10.0;

/// ỹ with the cumulative distribution erfc(−y)/2 = u (a normal of variance 1/2).
fn standard_normal_slope(u: f64) -> f64 {
    let cdf = |y: f64| 0.5 * libm::erfc(-y);
    let density = |y: f64| (-y * y).exp() / PI.sqrt();
    invert_cdf(cdf, density, u, -SLOPE_RANGE, SLOPE_RANGE)
}

/// x̃ with C(x) = u for the visible slopes seen from tan θ (see [`sample_beckmann_vndf`]).
fn beckmann_visible_slope(tan_t: f64, u: f64) -> f64 {
    let k = tan_t / (2.0 * PI.sqrt());
    // Unnormalised F(x) = erfc(−x)/2 + tanθ e^{−x²}/(2√π): no cancellation in the left tail.
    let f = |x: f64| 0.5 * libm::erfc(-x) + k * (-x * x).exp();
    // The support ends at x = cot θ (the facets seen edge-on); for θ → 0 cot θ → ∞ and the
    // range is cut at SLOPE_RANGE instead.
    let hi = if tan_t > 0.0 {
        (1.0 / tan_t).min(SLOPE_RANGE)
    } else {
        SLOPE_RANGE
    };
    let total = f(hi);
    let cdf = |x: f64| f(x) / total;
    let density = |x: f64| (1.0 - x * tan_t).max(0.0) * (-x * x).exp() / (PI.sqrt() * total);
    invert_cdf(cdf, density, u, -SLOPE_RANGE, hi)
}

/// The x in [lo, hi] with cdf(x) = u for an increasing cdf, by Newton's method from the middle,
/// each step kept inside the bracket that the signs of cdf − u maintain (bisection where a step
/// would leave it or where the density vanishes).
fn invert_cdf(
    cdf: impl Fn(f64) -> f64,
    density: impl Fn(f64) -> f64,
    u: f64,
    lo: f64,
    hi: f64,
) -> f64 {
    let (mut lo, mut hi) = (lo, hi);
    let mut x = 0.0f64.clamp(lo, hi);
    for _ in 0..200 {
        let g = cdf(x) - u;
        if g > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let d = density(x);
        // Where d = 0 the quotient is ±∞ or NaN; neither passes the bracket test, so the step
        // is a bisection.
        let newton = x - g / d;
        let next = if d > 0.0 && newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        // 4 ulp of the slope's magnitude (at least of 1): the roundings of cdf leave no more.
        if (next - x).abs() <= 4.0 * f64::EPSILON * x.abs().max(1.0) || hi - lo <= 0.0 {
            return next;
        }
        x = next;
    }
    x
}

/// Smith's Λ(ωo) of a distribution for anisotropic roughness, the exact forms of
/// [`lambda_ggx`] and [`lambda_beckmann`] (the visible-normal samplers draw from the exact
/// distribution of visible normals, so their density uses the exact Λ whatever G1 the model's
/// masking uses); None where (α tan θ)² overflows (ωo on the horizon to f64 precision).
fn smith_lambda(distribution: Distribution, wo: DVec3, ax: f64, ay: f64) -> Option<f64> {
    let t2 = alpha_tan2(wo, ax, ay);
    if !t2.is_finite() {
        return None;
    }
    Some(match distribution {
        Distribution::Ggx => lambda_ggx(t2),
        Distribution::Beckmann => lambda_beckmann(t2),
    })
}

/// A visible normal of `distribution` for ωo ([`sample_ggx_vndf`] or [`sample_beckmann_vndf`]).
pub fn sample_vndf(distribution: Distribution, wo: DVec3, ax: f64, ay: f64, u: DVec2) -> DVec3 {
    match distribution {
        Distribution::Ggx => sample_ggx_vndf(wo, ax, ay, u),
        Distribution::Beckmann => sample_beckmann_vndf(wo, ax, ay, u),
    }
}

/// The density over ωi of reflecting ωo about a visible normal (Heitz 2018, eq. 17 and the
/// reflection Jacobian 1/(4 ωo·h) of Walter et al. 2007, eq. 14):
/// pdf(ωi) = G1(ωo) max(0, ωo·h) D(h) / (cos θo · 4 (ωo·h)) = D(h) / (4 cos θo (1 + Λ(ωo))),
/// h = normalize(ωi + ωo); 0 unless both directions are above the horizon.
pub fn pdf_vndf(distribution: Distribution, wi: DVec3, wo: DVec3, ax: f64, ay: f64) -> f64 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    // Both above the horizon: |ωi + ωo| ≥ c_i + c_o > 0, so h is defined, h.z > 0 and
    // ωo·h = |ωi + ωo|/2 > 0; the factor ωo·h of the visible-normal density and that of the
    // Jacobian cancel exactly and are not formed.
    let h = (wi + wo).normalize();
    let Some(lambda) = smith_lambda(distribution, wo, ax, ay) else {
        return 0.0;
    };
    let d = match distribution {
        Distribution::Ggx => D_ggx(h, ax, ay),
        Distribution::Beckmann => D_beckmann(h, ax, ay),
    };
    // cos θo (1 + Λ) > 0: Λ ≥ 0 and c_o > 0; it stays finite where Λ is (checked above).
    d / (4.0 * wo.z * (1.0 + lambda))
}

/// Quasi-random points and the checks every model's sampler passes (used by the models' tests).
#[cfg(test)]
pub(crate) mod checks {
    use super::*;
    use crate::quadrature::gauss_legendre;

    /// The radical inverse of i in `base` (van der Corput), a coordinate of the Halton sequence.
    pub fn radical_inverse(base: u64, mut i: u64) -> f64 {
        let (mut inv, mut f) = (0.0, 1.0 / base as f64);
        while i > 0 {
            inv += f * (i % base) as f64;
            i /= base;
            f /= base as f64;
        }
        inv
    }

    /// The i-th point of the Halton sequence in bases 5 (the component choice uc) and 2, 3 (u).
    pub fn halton(i: u64) -> (f64, DVec2) {
        (
            radical_inverse(5, i),
            DVec2::new(radical_inverse(2, i), radical_inverse(3, i)),
        )
    }

    /// ωo at polar angle θo and azimuth φo (degrees).
    pub fn direction(theta_deg: f64, phi_deg: f64) -> DVec3 {
        let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
        DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    }

    /// A sampler under test: draw, density, f (for the weight) and the spike's albedo.
    pub struct Sampler<'a> {
        /// What the failure messages name: model and parameters.
        pub name: String,
        /// (ωo, uc, u) → sample.
        pub sample: &'a dyn Fn(DVec3, f64, DVec2) -> Sample,
        /// (ωi, ωo) → density of the non-delta part.
        pub pdf: &'a dyn Fn(DVec3, DVec3) -> f64,
        /// (ωi, ωo) → f, for the weight.
        pub f: &'a dyn Fn(DVec3, DVec3) -> DVec3,
        /// c_o → albedo of the mirror spike (zero for models without one).
        pub delta_albedo: &'a dyn Fn(f64) -> DVec3,
        /// The lobe's angular width about the mirror direction in radians, which sets the
        /// histogram's cells (π/4 for a diffuse lobe).
        pub width: f64,
    }

    /// Draws per check: the 10⁶ of the density check's brief, as a power of 2.
    pub const DRAWS: u64 = 1 << 20;

    /// |∫ pdf − (1 − lost − spike)| allowed: the quadrature is good to ~1e-7 (graded panels,
    /// spectral in ψ), the share of lost draws from 2²⁰ Halton points is good to a few 1e-5
    /// (quasi-Monte Carlo error of an indicator over a smooth region of the unit square,
    /// ~N^{-3/4}); 5e-4 leaves a factor of ten, and a missing Jacobian moves ∫ pdf by tens of
    /// percent.
    pub const INTEGRAL_TOL: f64 = 5e-4;

    /// ∫ pdf above 1 allowed: the quadrature's error. Smooth lobes integrate to ~1e-7, but a
    /// density with a kink inside the hemisphere that no panel follows (EON's clipped
    /// transformed cosine falls to 0 linearly along a great circle) converges only as the
    /// panels' size squared: measured 1.2e-5 there, so 5e-5.
    pub const OVER_ONE_TOL: f64 = 5e-5;

    /// Sample's pdf against pdf(ωi, ωo), and weight against f cos θi / pdf, relative: both are
    /// the same f64 expressions in the same order, so only rounding of the dispatch differs.
    pub const MATCH_REL: f64 = 1e-9;

    /// Histogram cells with fewer expected draws than this are pooled into one cell.
    pub const MIN_EXPECTED: f64 = 50.0;

    /// Deviation allowed per cell in Poisson standard deviations √e: the Halton counts deviate
    /// much less than independent draws would (their discrepancy is O(log² N / N); the correct
    /// samplers stay below 1 σ in every cell), so 5 is a bound no correct sampler reaches. A
    /// density off by 5 % in a cell of 10⁴ expected draws, or by 1.6 % in one of 10⁵, exceeds
    /// it; subtler distortions are the chi-square test's to find.
    pub const SIGMAS: f64 = 5.0;

    /// The frame about the mirror direction a of ωo: (a, e1, e2), e2 horizontal, e1 = e2 × a, so
    /// that ω(α, ψ) = cos α a + sin α (cos ψ e1 + sin ψ e2) has
    /// ω.z = cos α cos θo − sin α sin θo cos ψ.
    fn mirror_frame(wo: DVec3) -> (DVec3, DVec3, DVec3) {
        let a = mirror(wo);
        let rho = (a.x * a.x + a.y * a.y).sqrt();
        let e2 = if rho > 0.0 {
            DVec3::new(-a.y / rho, a.x / rho, 0.0)
        } else {
            DVec3::Y
        };
        (a, e2.cross(a), e2)
    }

    /// α at which ω(α, ψ) reaches the horizon: ω.z = R cos(α + γ), γ = atan2(sin θo cos ψ,
    /// cos θo), so α_max = π/2 − γ ∈ (0, π).
    fn alpha_max(wo: DVec3, psi: f64) -> f64 {
        let s = (wo.x * wo.x + wo.y * wo.y).sqrt();
        0.5 * PI - (s * psi.cos()).atan2(wo.z)
    }

    /// ∫ pdf(ω(α, ψ)) sin α dα over [a0, a1], with panels graded geometrically towards 0 (a1/2ᵏ)
    /// and a breakpoint at π/2 (where a power-cosine lobe about the axis ends).
    fn integrate_alpha(g: &dyn Fn(f64) -> f64, a0: f64, a1: f64, rule: &[(f64, f64)]) -> f64 {
        if a1 <= a0 {
            return 0.0;
        }
        let mut edges = vec![a0, a1];
        let mut x = a1;
        for _ in 0..48 {
            x *= 0.5;
            if x > a0 {
                edges.push(x);
            }
        }
        if a0 < 0.5 * PI && 0.5 * PI < a1 {
            edges.push(0.5 * PI);
        }
        edges.sort_by(f64::total_cmp);
        let mut sum = 0.0;
        for w in edges.windows(2) {
            let (m, h) = (0.5 * (w[0] + w[1]), 0.5 * (w[1] - w[0]));
            for &(t, wt) in rule {
                let a = m + h * t;
                sum += h * wt * g(a) * a.sin();
            }
        }
        sum
    }

    fn at(frame: (DVec3, DVec3, DVec3), alpha: f64, psi: f64) -> DVec3 {
        let (a, e1, e2) = frame;
        let w = alpha.cos() * a + alpha.sin() * (psi.cos() * e1 + psi.sin() * e2);
        w.normalize()
    }

    /// ∫ pdf dω over the upper hemisphere: ψ by the trapezoid rule (periodic and smooth:
    /// spectrally accurate), α from 0 to the horizon by graded Gauss–Legendre panels.
    pub fn integral(pdf: &dyn Fn(DVec3) -> f64, wo: DVec3) -> f64 {
        let rule = gauss_legendre(12);
        let frame = mirror_frame(wo);
        let m = 512;
        let mut sum = 0.0;
        for k in 0..m {
            let psi = 2.0 * PI * (k as f64 + 0.5) / m as f64;
            let g = |alpha: f64| {
                let w = at(frame, alpha, psi);
                if w.z > 0.0 {
                    pdf(w)
                } else {
                    0.0
                }
            };
            sum += integrate_alpha(&g, 0.0, alpha_max(wo, psi), &rule);
        }
        sum * 2.0 * PI / m as f64
    }

    /// The histogram's cells in α: 0, w/4, w/2, w, 2w, … up to π.
    fn alpha_edges(width: f64) -> Vec<f64> {
        let mut edges = vec![0.0];
        let mut x = 0.25 * width;
        while x < PI {
            edges.push(x);
            x *= 2.0;
        }
        edges.push(PI);
        edges
    }

    /// Sectors in ψ.
    const SECTORS: usize = 8;

    /// ∫ pdf over each cell (α bin × ψ sector), above the horizon: Gauss–Legendre in ψ within
    /// each sector, graded panels in α.
    fn cell_integrals(pdf: &dyn Fn(DVec3) -> f64, wo: DVec3, edges: &[f64]) -> Vec<f64> {
        let rule_a = gauss_legendre(10);
        let rule_p = gauss_legendre(24);
        let frame = mirror_frame(wo);
        let mut out = vec![0.0; (edges.len() - 1) * SECTORS];
        let dpsi = 2.0 * PI / SECTORS as f64;
        for s in 0..SECTORS {
            let (m, h) = (dpsi * (s as f64 + 0.5), 0.5 * dpsi);
            for &(t, wt) in &rule_p {
                let psi = m + h * t;
                let top = alpha_max(wo, psi);
                let g = |alpha: f64| {
                    let w = at(frame, alpha, psi);
                    if w.z > 0.0 {
                        pdf(w)
                    } else {
                        0.0
                    }
                };
                for b in 0..edges.len() - 1 {
                    let v = integrate_alpha(&g, edges[b], edges[b + 1].min(top), &rule_a);
                    out[b * SECTORS + s] += h * wt * v;
                }
            }
        }
        out
    }

    /// The cell of ωi: its α bin and ψ sector about the mirror direction.
    fn cell_of(frame: (DVec3, DVec3, DVec3), edges: &[f64], wi: DVec3) -> usize {
        let (a, e1, e2) = frame;
        // α = 2 asin(|ωi − a|/2): accurate for small angles, unlike acos.
        let alpha = 2.0 * (0.5 * (wi - a).length()).min(1.0).asin();
        let psi = wi.dot(e2).atan2(wi.dot(e1)).rem_euclid(2.0 * PI);
        let b = edges
            .partition_point(|&e| e <= alpha)
            .clamp(1, edges.len() - 1)
            - 1;
        let s = ((psi / (2.0 * PI) * SECTORS as f64) as usize).min(SECTORS - 1);
        b * SECTORS + s
    }

    /// What the draws and the quadrature measured at one ωo.
    #[derive(Debug)]
    pub struct Measured {
        /// ∫ pdf over the upper hemisphere.
        pub integral: f64,
        /// Share of draws below the horizon (or of density 0).
        pub lost: f64,
        /// Share of mirror-spike draws.
        pub spike: f64,
        /// The largest |o − e|/√e over the histogram's cells (pooled below MIN_EXPECTED).
        pub worst_sigma: f64,
        /// The cell where it was, as (α bin, ψ sector, observed, expected).
        pub worst_cell: (usize, usize, f64, f64),
    }

    /// Runs the draws and the quadratures of checks 1 and 3 at ωo, without asserting.
    pub fn measure(s: &Sampler, wo: DVec3) -> Measured {
        let pdf = |w: DVec3| (s.pdf)(w, wo);
        let edges = alpha_edges(s.width);
        let frame = mirror_frame(wo);
        let mut counts = vec![0.0; (edges.len() - 1) * SECTORS];
        let (mut lost, mut spike) = (0u64, 0u64);
        for i in 0..DRAWS {
            let (uc, u) = halton(i);
            let d = (s.sample)(wo, uc, u);
            if d.delta {
                spike += 1;
            } else if d.pdf == 0.0 {
                lost += 1;
            } else {
                counts[cell_of(frame, &edges, d.wi)] += 1.0;
            }
        }
        let n = DRAWS as f64;
        let expected: Vec<f64> = cell_integrals(&pdf, wo, &edges)
            .iter()
            .map(|p| p * n)
            .collect();
        let (mut pool_o, mut pool_e) = (0.0, 0.0);
        let mut worst = (0.0, (0, 0, 0.0, 0.0));
        for (c, (&o, &e)) in counts.iter().zip(&expected).enumerate() {
            if e < MIN_EXPECTED {
                pool_o += o;
                pool_e += e;
                continue;
            }
            let z = (o - e).abs() / e.sqrt();
            if z > worst.0 {
                worst = (z, (c / SECTORS, c % SECTORS, o, e));
            }
        }
        let z = (pool_o - pool_e).abs() / pool_e.max(MIN_EXPECTED).sqrt();
        if z > worst.0 {
            worst = (z, (usize::MAX, usize::MAX, pool_o, pool_e));
        }
        Measured {
            integral: integral(&pdf, wo),
            lost: lost as f64 / n,
            spike: spike as f64 / n,
            worst_sigma: worst.0,
            worst_cell: worst.1,
        }
    }

    /// Check 1 on a measurement: ∫ pdf = 1 − lost − spike within [`INTEGRAL_TOL`], and ≤ 1.
    pub fn integral_ok(m: &Measured) -> Result<(), String> {
        let want = 1.0 - m.lost - m.spike;
        if (m.integral - want).abs() > INTEGRAL_TOL || m.integral > 1.0 + OVER_ONE_TOL {
            return Err(format!(
                "∫ pdf = {:.7} but 1 − lost − spike = {:.7} (lost {:.6}, spike {:.6}): \
                 difference {:.2e}, allowed {INTEGRAL_TOL:.0e}",
                m.integral,
                want,
                m.lost,
                m.spike,
                m.integral - want
            ));
        }
        Ok(())
    }

    /// Check 3 on a measurement: every cell within [`SIGMAS`] Poisson deviations.
    pub fn histogram_ok(m: &Measured) -> Result<(), String> {
        if m.worst_sigma > SIGMAS {
            let (b, s, o, e) = m.worst_cell;
            return Err(format!(
                "histogram cell (α bin {b}, ψ sector {s}) has {o} draws against {e:.1} \
                 expected: {:.1} σ, allowed {SIGMAS}",
                m.worst_sigma
            ));
        }
        Ok(())
    }

    /// Check 2 at ωo: the sample's pdf equals pdf(ωi, ωo), the weight f cos θi / pdf (or the
    /// spike's albedo / its probability), lost draws have weight 0 and pdf 0, nothing is NaN.
    pub fn consistency_ok(s: &Sampler, wo: DVec3) -> Result<(), String> {
        for i in 0..4096 {
            let (uc, u) = halton(i);
            let d = (s.sample)(wo, uc, u);
            let finite = d.wi.is_finite() && d.weight.is_finite() && d.pdf.is_finite();
            let bad = |what: &str| Err(format!("draw {i} (uc {uc}, u {u}): {what}: {d:?}"));
            if !finite {
                return bad("not finite");
            }
            if d.delta {
                let w = (s.delta_albedo)(wo.z) / d.pdf;
                if d.wi != mirror(wo)
                    || d.pdf.is_nan()
                    || d.pdf <= 0.0
                    || (d.weight - w).abs().max_element() > MATCH_REL * w.max_element()
                {
                    return bad(&format!(
                        "spike should be ωi = {:?}, weight {w:?}",
                        mirror(wo)
                    ));
                }
                continue;
            }
            if d.pdf == 0.0 {
                if d.weight != DVec3::ZERO || (d.wi.z > 0.0 && (s.pdf)(d.wi, wo) != 0.0) {
                    return bad(
                        "a lost draw needs weight 0 and ωi below the horizon (or density 0)",
                    );
                }
                continue;
            }
            let p = (s.pdf)(d.wi, wo);
            if (d.pdf - p).abs() > MATCH_REL * p {
                return bad(&format!("pdf(ωi, ωo) = {p}"));
            }
            let w = (s.f)(d.wi, wo) * d.wi.z / p;
            if (d.weight - w).abs().max_element() > MATCH_REL * w.abs().max_element() {
                return bad(&format!("f cos / pdf = {w:?}"));
            }
        }
        Ok(())
    }

    /// A parameter set of `model` with `key=value` assignments.
    pub fn params(model: crate::model::Model, assignments: &[&str]) -> crate::model::ParamSet {
        let mut p = crate::model::ParamSet::defaults(model);
        for a in assignments {
            p.set_text(a).unwrap_or_else(|e| panic!("{a}: {e}"));
        }
        p
    }

    /// Checks 1–3 of [`crate::model::Reference`]'s `sample` and `pdf` for `p` (the dispatch and
    /// the model's own `sample_<model>` and `pdf_<model>`), the lobe `width` wide.
    pub fn check_reference(p: &crate::model::ParamSet, white_furnace: bool, width: f64) {
        let r = crate::model::Reference::new(p, white_furnace);
        let sample = |wo: DVec3, uc: f64, u: DVec2| r.sample(wo, uc, u);
        let pdf = |wi: DVec3, wo: DVec3| r.pdf(wi, wo);
        let f = |wi: DVec3, wo: DVec3| r.eval(wi, wo);
        let delta_albedo = |c_o: f64| r.delta_albedo(c_o);
        check(&Sampler {
            name: format!(
                "{} {}{}",
                p.model().label(),
                p.to_text(),
                if white_furnace {
                    " (white furnace)"
                } else {
                    ""
                }
            ),
            sample: &sample,
            pdf: &pdf,
            f: &f,
            delta_albedo: &delta_albedo,
            width,
        });
    }

    /// The outgoing directions every sampler is checked at: θo = 0°, 40°, 85° (grazing), at an
    /// azimuth that is no symmetry axis of an anisotropic lobe.
    pub const ANGLES: [f64; 3] = [0.0, 40.0, 85.0];

    /// Checks 1–3 at every angle of [`ANGLES`]; panics with the model, ωo and the numbers.
    pub fn check(s: &Sampler) {
        for theta in ANGLES {
            let wo = direction(theta, 30.0);
            let m = measure(s, wo);
            let result = consistency_ok(s, wo)
                .and_then(|_| integral_ok(&m))
                .and_then(|_| histogram_ok(&m));
            if let Err(e) = result {
                panic!("{} at θo = {theta}°: {e}\n{m:?}", s.name);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::checks::*;
    use super::*;

    #[test]
    fn frame_is_orthonormal() {
        for n in [
            DVec3::Z,
            -DVec3::Z,
            direction(40.0, 30.0),
            direction(120.0, 200.0),
            DVec3::X,
        ] {
            let (t, b) = frame(n);
            for (x, y) in [(t, b), (t, n), (b, n)] {
                assert!(x.dot(y).abs() < 1e-15, "{n}: {x} · {y}");
            }
            assert!((t.cross(b) - n).length() < 1e-15, "{n}: right-handed");
        }
    }

    #[test]
    fn beckmann_visible_slope_inverts_its_distribution() {
        // C(x(u)) = u, to the rounding of C: the solver's own stopping rule.
        const TOL: f64 = 1e-13;
        for tan_t in [0.0, 0.1, 1.0, 20.0] {
            for u in [1e-9, 0.01, 0.3, 0.5, 0.9, 0.999_999] {
                let x = beckmann_visible_slope(tan_t, u);
                let k = tan_t / (2.0 * PI.sqrt());
                let f = |x: f64| 0.5 * libm::erfc(-x) + k * (-x * x).exp();
                let hi = if tan_t > 0.0 {
                    (1.0 / tan_t).min(SLOPE_RANGE)
                } else {
                    SLOPE_RANGE
                };
                let c = f(x) / f(hi);
                assert!((c - u).abs() < TOL, "tan θ {tan_t}, u {u}: x {x}, C(x) {c}");
            }
        }
    }

    /// The visible-normal samplers alone (no model around them): GGX in both forms and
    /// Beckmann, isotropic and anisotropic, against [`pdf_vndf`].
    #[test]
    fn visible_normal_samplers_match_their_density() {
        let f = |_: DVec3, _: DVec3| DVec3::ONE;
        let none = |_: f64| DVec3::ZERO;
        for (dist, form) in [
            (Distribution::Ggx, "cap"),
            (Distribution::Ggx, "hemisphere"),
            (Distribution::Beckmann, "slopes"),
        ] {
            for (ax, ay) in [(0.05, 0.05), (0.8, 0.8), (0.1, 0.5)] {
                let sample = |wo: DVec3, _uc: f64, u: DVec2| {
                    let h = match form {
                        "hemisphere" => sample_ggx_vndf_hemisphere(wo, ax, ay, u),
                        _ => sample_vndf(dist, wo, ax, ay, u),
                    };
                    let wi = reflect(wo, h);
                    Sample::from_draw(wi, pdf_vndf(dist, wi, wo, ax, ay), |_| DVec3::ONE)
                };
                let pdf = |wi: DVec3, wo: DVec3| pdf_vndf(dist, wi, wo, ax, ay);
                check(&Sampler {
                    name: format!("{dist:?} VNDF ({form}) αx {ax} αy {ay}"),
                    sample: &sample,
                    pdf: &pdf,
                    f: &f,
                    delta_albedo: &none,
                    width: 2.0 * ax.min(ay),
                });
            }
        }
    }

    /// Every built-in model and component choice, with and without the white furnace, through
    /// [`crate::model::Reference`]: check 2 at every angle, and nothing for ωo below the
    /// horizon (weight 0, pdf 0) or density for ωi below it.
    #[test]
    fn every_model_samples_consistently_through_the_reference() {
        use crate::model::{Model, ParamSet, Reference};
        for model in Model::ALL.iter().flat_map(|m| m.variants()) {
            for white_furnace in [false, true] {
                let r = Reference::new(&ParamSet::defaults(model), white_furnace);
                let sample = |wo: DVec3, uc: f64, u: DVec2| r.sample(wo, uc, u);
                let pdf = |wi: DVec3, wo: DVec3| r.pdf(wi, wo);
                let f = |wi: DVec3, wo: DVec3| r.eval(wi, wo);
                let delta_albedo = |c_o: f64| r.delta_albedo(c_o);
                let s = Sampler {
                    name: model.label(),
                    sample: &sample,
                    pdf: &pdf,
                    f: &f,
                    delta_albedo: &delta_albedo,
                    width: 0.5,
                };
                for theta in ANGLES {
                    let wo = direction(theta, 30.0);
                    if let Err(e) = consistency_ok(&s, wo) {
                        panic!(
                            "{} (white furnace {white_furnace}) at θo = {theta}°: {e}",
                            s.name
                        );
                    }
                    let below = DVec3::new(wo.x, wo.y, -wo.z);
                    assert_eq!(r.pdf(below, wo), 0.0, "{}: ωi below the horizon", s.name);
                    let d = r.sample(below, 0.3, DVec2::new(0.4, 0.6));
                    assert!(
                        d.pdf == 0.0 && d.weight == DVec3::ZERO && d.wi.z <= 0.0,
                        "{}: ωo below the horizon gave {d:?}",
                        s.name
                    );
                }
            }
        }
    }

    /// A model defined at run time is drawn by the cosine: with a Phong-like reference (a lobe
    /// the cosine does not follow), the checks hold and the weight is f cos θi / pdf of the
    /// caller's f.
    #[test]
    fn a_run_time_model_samples_by_the_cosine() {
        use crate::model::params::ParamSpec;
        use crate::model::runtime::RuntimeModel;
        use crate::model::Model;
        let table = vec![ParamSpec::scalar("n", 0.0, 100.0, 10.0, "exponent")];
        let m = RuntimeModel::new("sample_runtime_twin", "a run-time lobe", table, true)
            .expect("a valid run-time model")
            .with_reference(std::sync::Arc::new(|v: &[f64], wi: DVec3, wo: DVec3| {
                DVec3::splat(pdf_power_cosine(mirror(wo), v[0], wi))
            }));
        let model = Model::Runtime(Box::leak(Box::new(m)));
        check_reference(&params(model, &["n=10"]), false, 0.8);
    }

    /// The test of the tests: a density without the reflection Jacobian 1/(4 ωo·h) (the
    /// density of h taken for that of ωi), and a density of the wrong distribution for the
    /// draws, must each fail check 1 or check 3.
    #[test]
    fn broken_densities_are_caught() {
        let (ax, ay) = (0.3, 0.3);
        let sample = |wo: DVec3, _uc: f64, u: DVec2| {
            let wi = reflect(wo, sample_ggx_vndf(wo, ax, ay, u));
            Sample::from_draw(wi, pdf_vndf(Distribution::Ggx, wi, wo, ax, ay), |_| {
                DVec3::ONE
            })
        };
        let no_jacobian = |wi: DVec3, wo: DVec3| {
            let h = (wi + wo).normalize();
            pdf_vndf(Distribution::Ggx, wi, wo, ax, ay) * 4.0 * wo.dot(h)
        };
        let wrong_distribution =
            |wi: DVec3, wo: DVec3| pdf_vndf(Distribution::Beckmann, wi, wo, ax, ay);
        let f = |_: DVec3, _: DVec3| DVec3::ONE;
        let none = |_: f64| DVec3::ZERO;
        for (what, pdf) in [
            ("no Jacobian", &no_jacobian as &dyn Fn(DVec3, DVec3) -> f64),
            ("Beckmann density for GGX draws", &wrong_distribution),
        ] {
            let s = Sampler {
                name: what.to_string(),
                sample: &sample,
                pdf,
                f: &f,
                delta_albedo: &none,
                width: 2.0 * ax,
            };
            for theta in ANGLES {
                let m = measure(&s, direction(theta, 30.0));
                assert!(
                    integral_ok(&m).is_err() || histogram_ok(&m).is_err(),
                    "{what} at θo = {theta}° passed: {m:?}"
                );
            }
        }
    }

    /// The test of the tests in a mixture: Blinn–Phong's density with the half-vector lobe's
    /// density taken for that of ωi (no 1/(4 ωo·h)) must fail check 1 or check 3 at every angle,
    /// although the cosine half of the mixture is right.
    #[test]
    fn a_mixture_without_its_jacobian_is_caught() {
        use crate::model::blinn_phong::{
            blinn_phong, blinn_phong_exponent, blinn_phong_lobe_probability, sample_blinn_phong,
        };
        use crate::model::{Model, ParamSet};
        let p = crate::model::blinn_phong::BlinnPhong::new(&ParamSet::defaults(Model::BlinnPhong));
        let sample = |wo: DVec3, uc: f64, u: DVec2| sample_blinn_phong(&p, wo, uc, u);
        let broken = |wi: DVec3, wo: DVec3| {
            if wi.z <= 0.0 {
                return 0.0;
            }
            let lobe = blinn_phong_lobe_probability(&p);
            let h = (wi + wo).normalize();
            let n = blinn_phong_exponent(p.smoothness);
            (1.0 - lobe) * pdf_cosine(wi) + lobe * pdf_power_cosine(DVec3::Z, n, h)
        };
        let f = |wi: DVec3, wo: DVec3| blinn_phong(&p, wi, wo);
        let none = |_: f64| DVec3::ZERO;
        let s = Sampler {
            name: "Blinn–Phong without its Jacobian".to_string(),
            sample: &sample,
            pdf: &broken,
            f: &f,
            delta_albedo: &none,
            width: 0.2,
        };
        for theta in ANGLES {
            let m = measure(&s, direction(theta, 30.0));
            assert!(
                integral_ok(&m).is_err() || histogram_ok(&m).is_err(),
                "{} at θo = {theta}° passed: {m:?}",
                s.name
            );
        }
    }
}
