//! The `peak` rule: composite Gauss–Legendre on panels aligned with the models' kinks and graded
//! towards the mirror direction, and the mirror-direction frame [`PeakFrame`].

use super::gauss::{gauss_legendre, gauss_on, graded};
use super::vcavity::{v_cavity_kinks, v_cavity_turns};
use super::Node;
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Polar coordinates (α, β) about the mirror direction r of ωo, where every built-in lobe peaks
/// (Phong's r·ωo = 1; D's maximum at h = n for the half-vector lobes):
/// ωi = cosα r + sinα (cosβ u + sinβ v), u = ∂r/∂θ (in the plane of incidence, pointing
/// down towards the horizon), v = n × r / |n × r|. Then dω = sinα dα dβ and
/// c_i = cosα cosθr − sinα cosβ sinθr, which vanishes at α_max(β) = atan2(cosθr, sinθr cosβ):
/// the horizon. The integral over the hemisphere is exactly
///   E = ∫_{−π/2}^{3π/2} dβ ∫_0^{α_max(β)} f c_i sinα dα,
/// with α = α_max(β)·t, t ∈ [0, 1]. α_max changes fastest near β = ±π/2 (width ~ cosθr), so the
/// β range splits at ±π/2 and 0, π, and each quadrant is graded towards ±π/2.
#[derive(Clone, Copy, Debug)]
pub(super) struct PeakFrame {
    pub(super) r: DVec3,
    pub(super) u: DVec3,
    pub(super) v: DVec3,
    cos_r: f64,
    sin_r: f64,
}

impl PeakFrame {
    pub(super) fn new(wo: DVec3) -> PeakFrame {
        let r = DVec3::new(-wo.x, -wo.y, wo.z);
        let sin_r = (r.x * r.x + r.y * r.y).sqrt();
        let cos_r = r.z;
        let (u, v) = if sin_r > 0.0 {
            let (c, s) = (r.x / sin_r, r.y / sin_r);
            (
                DVec3::new(cos_r * c, cos_r * s, -sin_r),
                DVec3::new(-s, c, 0.0),
            )
        } else {
            (DVec3::X, DVec3::Y)
        };
        PeakFrame {
            r,
            u,
            v,
            cos_r,
            sin_r,
        }
    }

    pub(super) fn alpha_max(&self, beta: f64) -> f64 {
        self.cos_r.atan2(self.sin_r * beta.cos())
    }

    pub(super) fn dir(&self, alpha: f64, beta: f64) -> DVec3 {
        let (sa, ca) = alpha.sin_cos();
        let (sb, cb) = beta.sin_cos();
        ca * self.r + sa * (cb * self.u + sb * self.v)
    }

    /// β breakpoints over [−π/2, 3π/2]: four quadrants graded towards ±π/2, down to a panel of
    /// about cosθr/2 (the width of α_max's turn).
    pub(super) fn beta_breaks(&self) -> Vec<f64> {
        let levels = (PI / self.cos_r.max(1e-12)).log2().ceil().clamp(1.0, 40.0) as u32;
        let g = graded(levels);
        let mut b: Vec<f64> = Vec::new();
        for t in &g {
            b.push(-FRAC_PI_2 + FRAC_PI_2 * t); // [−π/2, 0], fine at −π/2
            b.push(FRAC_PI_2 - FRAC_PI_2 * t); // [0, π/2], fine at π/2
            b.push(FRAC_PI_2 + FRAC_PI_2 * t); // [π/2, π], fine at π/2
            b.push(1.5 * PI - FRAC_PI_2 * t); // [π, 3π/2], fine at 3π/2
        }
        b.sort_by(f64::total_cmp);
        b.dedup();
        b
    }
}

/// The `peak` rule: composite Gauss–Legendre of `order` points per panel in (μi, φi) (dω = dμ dφ,
/// E = ∫∫ f μ dμ dφ), on panels aligned with where the built-in models are not smooth and graded
/// towards where they peak:
/// - μ splits at μo (the kink of max(c_i, c_o) in Oren–Nayar and Ashikhmin–Shirley; the mirror
///   direction's μ) and is graded towards it from both sides;
/// - φ splits at φo + kπ/2 (Oren–Nayar's max(0, cos Δφ) kinks at Δφ = ±π/2; the mirror direction
///   at Δφ = π) and the two quadrants beside Δφ = π are graded towards it.
///
/// A lobe of width w about the mirror direction is then covered by panels of every size down to
/// 2^-levels of the domain (see [`PEAK_LEVELS`]), so it is integrated like a smooth function.
///
/// With `v_cavity`, each μ line's Δφ panels are also split at the V-cavity's kinks (see
/// [`v_cavity_kinks`]): curves in (μ, Δφ) that no fixed panel grid follows, which would otherwise
/// leave Gauss panels integrating a kinked function at low order (~5e-5 relative at the
/// Cook–Torrance presets). With the kink on a panel edge the inner integral is smooth in every
/// panel, and the outer one in μ is smooth because the kink moves smoothly with μ.
///
/// `extra_levels` grade further towards the peak for lobes narrower than the ones
/// [`PEAK_LEVELS`] was made for ([`lobe_levels`]).
pub(super) fn peak_nodes(order: usize, v_cavity: bool, extra_levels: u32, wo: DVec3) -> Vec<Node> {
    let mut out = Vec::with_capacity(peak_node_count(order, v_cavity, extra_levels, wo));
    peak_nodes_each(order, v_cavity, extra_levels, wo, |n| out.push(n));
    out
}

/// The μ breakpoints of [`peak_nodes`] at ωo, the V-cavity's turns included with `v_cavity`.
fn peak_mu_breaks_at(v_cavity: bool, extra_levels: u32, wo: DVec3) -> Vec<f64> {
    let mut mb = peak_mu_breaks(wo.z, extra_levels);
    if v_cavity {
        mb.extend(v_cavity_turns(wo.z));
        mb.sort_by(f64::total_cmp);
        mb.dedup();
    }
    mb
}

/// The Δφ breakpoints of the μ line at `mu` with the V-cavity's kinks added to `pb`.
fn with_v_cavity_kinks(pb: &[f64], mu: f64, mu_o: f64) -> Vec<f64> {
    let mut b = pb.to_vec();
    b.extend(v_cavity_kinks(mu, mu_o));
    b.sort_by(f64::total_cmp);
    b.dedup();
    b
}

/// How many nodes [`peak_nodes`] makes at ωo, from its breakpoints alone (no node is made).
pub(super) fn peak_node_count(order: usize, v_cavity: bool, extra_levels: u32, wo: DVec3) -> usize {
    let mb = peak_mu_breaks_at(v_cavity, extra_levels, wo);
    let pb = peak_phi_breaks(wo.z, extra_levels);
    let panels = |b: &[f64]| b.len().saturating_sub(1);
    if !v_cavity {
        return order * panels(&mb) * order * panels(&pb);
    }
    let gl = gauss_legendre(order);
    mb.windows(2)
        .flat_map(|w| gauss_on(&gl, w[0], w[1]))
        .map(|(mu, _)| order * panels(&with_v_cavity_kinks(&pb, mu, wo.z)))
        .sum()
}

/// [`peak_nodes`], each node handed to `emit` in order instead of collected.
pub(super) fn peak_nodes_each(
    order: usize,
    v_cavity: bool,
    extra_levels: u32,
    wo: DVec3,
    mut emit: impl FnMut(Node),
) {
    let phi_o = wo.y.atan2(wo.x);
    let gl = gauss_legendre(order);
    let mb = peak_mu_breaks_at(v_cavity, extra_levels, wo);
    let pb = peak_phi_breaks(wo.z, extra_levels);
    let line = |breaks: &[f64]| -> Vec<(f64, f64, f64)> {
        let mut phis = Vec::with_capacity(order * breaks.len());
        for w in breaks.windows(2) {
            for (dphi, wp) in gauss_on(&gl, w[0], w[1]) {
                let (sp, cp) = (phi_o + dphi).sin_cos();
                phis.push((sp, cp, wp));
            }
        }
        phis
    };
    let shared = line(&pb);
    for w in mb.windows(2) {
        for (mu, wm) in gauss_on(&gl, w[0], w[1]) {
            let s = (1.0 - mu * mu).max(0.0).sqrt();
            let own;
            let phis = if v_cavity {
                own = line(&with_v_cavity_kinks(&pb, mu, wo.z));
                &own
            } else {
                &shared
            };
            for &(sp, cp, wp) in phis {
                emit(Node {
                    wi: DVec3::new(s * cp, s * sp, mu),
                    weight: wm * wp * mu,
                });
            }
        }
    }
}

/// The `peak` rule's μ breakpoints. Below μo: graded towards μo. Above: towards μo and towards
/// the pole, where sinθi = √(1 − μ²) (Oren–Nayar's sinθi sinθo cosΔφ term) has an infinite
/// derivative.
pub(super) fn peak_mu_breaks(mu_o: f64, extra_levels: u32) -> Vec<f64> {
    let mu_o = mu_o.clamp(0.0, 1.0);
    let g = graded(PEAK_LEVELS);
    // Towards μo, [`pole_levels`] more levels for a view near the normal.
    let gp = graded(PEAK_LEVELS + extra_levels + pole_levels(mu_o));
    let mid = 0.5 * (mu_o + 1.0);
    let mut mb: Vec<f64> = gp.iter().map(|t| mu_o - mu_o * t).collect();
    mb.extend(gp.iter().map(|t| mu_o + (mid - mu_o) * t));
    mb.extend(g.iter().map(|t| 1.0 - (1.0 - mid) * t));
    mb.sort_by(f64::total_cmp);
    mb.dedup();
    mb
}

/// The `peak` rule's breakpoints in Δφ = φi − φo ∈ [0, 2π]: the quadrants, the two beside the
/// mirror azimuth Δφ = π graded towards it, with [`grazing_levels`] more levels for a grazing
/// view.
pub(super) fn peak_phi_breaks(mu_o: f64, extra_levels: u32) -> Vec<f64> {
    let g = graded(PEAK_LEVELS + extra_levels + grazing_levels(mu_o));
    let mut pb: Vec<f64> = vec![0.0, FRAC_PI_2];
    pb.extend(g.iter().map(|t| PI - FRAC_PI_2 * t));
    pb.extend(g.iter().map(|t| PI + FRAC_PI_2 * t));
    pb.extend([1.5 * PI, TAU]);
    pb.sort_by(f64::total_cmp);
    pb.dedup();
    pb
}

/// Extra levels of Δφ grading for a view at μo: near the horizon a lobe is narrower in Δφ than in
/// angle. With ωi and ωo both near grazing and Δφ near π, |ωi + ωo| ≈ 2μo, so turning ωi by δ in
/// azimuth tilts h by about δ/(2μo): a lobe of width w in h spans only ~2μo·w in Δφ (GGX with
/// α = 0.01 at μo = 1/64: 3e-4 rad, a tenth of the finest panel at 9 levels, which left 6e-4 of
/// E at 65536 nodes). log2(1/μo) more levels keep the finest panel in step; capped at 8.
fn grazing_levels(mu_o: f64) -> u32 {
    (1.0 / mu_o.max(1e-12)).log2().ceil().clamp(0.0, 8.0) as u32
}

/// Extra levels of μ grading for a view at μo near the normal: a lobe of angular width w about
/// the mirror direction spans δμ ≈ sinθo·w + w²/2 in μ, down to w²/2 at μo = 1 (GGX α = 0.01:
/// 2e-4, a fifth of the finest panel at 9 levels, which left 5e-5 of E at 65536 nodes).
/// log2(1/sinθo) more levels, capped at 9 (finest panel 2^-18 in μ, ~3e-3 rad at the pole).
fn pole_levels(mu_o: f64) -> u32 {
    let sin_o = (1.0 - mu_o * mu_o).max(0.0).sqrt();
    (1.0 / sin_o.max(1e-12)).log2().ceil().clamp(0.0, 9.0) as u32
}

/// Levels of grading of the `peak` rule's panels towards the mirror direction: the finest panel
/// is 2^-9 of its side's extent, finer than the narrowest built-in lobe (Phong n = 8192 has width
/// 1/√n ≈ 1.1e-2 rad; Cook–Torrance m = 0.01 about 2e-2 rad in ωi).
const PEAK_LEVELS: u32 = 9;

/// The narrowest lobe [`PEAK_LEVELS`] resolves: Phong n = 8192, width 1/√8192 rad.
const NARROWEST_LOBE: f64 = 0.011;

/// Extra grading levels for a lobe of power-cosine exponent `n` (width 1/√n rad): one per
/// halving of the width below [`NARROWEST_LOBE`], so that the finest panel keeps the same size
/// relative to the lobe (GGX α = 2.4e-4, the first row of a 32-row table in α = r², had 4e-3 of
/// error at 9 levels); capped at 16 (a width of 2e-7 rad).
pub(super) fn lobe_levels(n: f64) -> u32 {
    let width = 1.0 / n.max(1.0).sqrt();
    (NARROWEST_LOBE / width).log2().ceil().clamp(0.0, 16.0) as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::view_direction;

    #[test]
    fn peak_frame_reaches_the_horizon_exactly() {
        for mu in [1.0, 0.5, 0.1, 1e-3] {
            let f = PeakFrame::new(view_direction(mu, 1.1));
            for k in 0..16 {
                let beta = -FRAC_PI_2 + TAU * k as f64 / 16.0;
                let z = f.dir(f.alpha_max(beta), beta).z;
                assert!(z.abs() < 1e-14, "mu {mu} beta {beta}: z = {z}");
            }
            assert!((f.dir(0.0, 0.3) - f.r).length() < 1e-15);
        }
    }
}
