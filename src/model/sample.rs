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

#[cfg(test)]
/// Quasi-random points and the checks every model's sampler passes (used by the models' tests).
pub(crate) mod checks;

#[cfg(test)]
mod tests;
