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
                return bad("a lost draw needs weight 0 and ωi below the horizon (or density 0)");
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
