//! One row of the demo's parity table: the GPU kernels (f32) against the f64 reference.

use super::ParityRow;
use crate::eval::Evaluator;
use crate::grid::direction;
use crate::material;
use crate::model::{Model, ParamSet, Reference};
use crate::stability::{parity_tolerance, REL_FLOOR};
use anyhow::Result;
use glam::DVec3;

/// GPU against the f64 reference for one model at every material, on a cell-centred grid. As in
/// tests/parity.rs, both sides see the same inputs (f32-rounded parameters and directions), and
/// each value is held to |g − c| ≤ ATOL + rtol·|c| + conditioning.
pub(super) fn parity_of(
    eval: &Evaluator,
    model: Model,
    materials: &[&str],
    [n_ti, n_to, n_po]: [usize; 3],
) -> Result<ParityRow> {
    use std::f64::consts::{FRAC_PI_2, TAU};
    let f32v = |v: DVec3| DVec3::new(v.x as f32 as f64, v.y as f32 as f64, v.z as f32 as f64);
    let mut pairs = Vec::with_capacity(n_ti * n_to * n_po);
    for a in 0..n_ti {
        let ti = (a as f64 + 0.5) * FRAC_PI_2 / n_ti as f64;
        for b in 0..n_to {
            let to = (b as f64 + 0.5) * FRAC_PI_2 / n_to as f64;
            for c in 0..n_po {
                let po = (c as f64 + 0.5) * TAU / n_po as f64;
                pairs.push((f32v(direction(ti, 0.0)), f32v(direction(to, po))));
            }
        }
    }
    let mut row = ParityRow {
        model: model.name().to_string(),
        values: 0,
        max_rel: 0.0,
        max_ratio: 0.0,
        over: 0,
        worst: String::new(),
    };
    for mat in materials {
        let p32: ParamSet = material::preset(mat, model)?.rounded_to_f32();
        let r = Reference::new(&p32, false);
        let g = eval.eval_pairs(&p32, &pairs)?;
        for (&(wi, wo), gv) in pairs.iter().zip(&g) {
            let c = r.eval(wi, wo);
            let tol = parity_tolerance(&p32, &r, wi, wo, c);
            for ch in 0..3 {
                let err = (gv[ch] - c[ch]).abs();
                let rel = err / c[ch].abs().max(REL_FLOOR);
                let ratio = err / tol[ch];
                row.values += 1;
                if ratio.is_nan() || ratio > 1.0 {
                    row.over += 1;
                }
                row.max_ratio =
                    row.max_ratio
                        .max(if ratio.is_nan() { f64::INFINITY } else { ratio });
                if rel > row.max_rel || rel.is_nan() {
                    row.max_rel = if rel.is_nan() { f64::INFINITY } else { rel };
                    row.worst = format!(
                        "{mat}, θi {:.1}°, θo {:.1}°, φo {:.1}°, channel {}",
                        wi.z.acos().to_degrees(),
                        wo.z.acos().to_degrees(),
                        wo.y.atan2(wo.x).to_degrees().rem_euclid(360.0),
                        ["r", "g", "b"][ch]
                    );
                }
            }
        }
    }
    Ok(row)
}
