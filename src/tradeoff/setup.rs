//! What the integration and table-resolution sections share: their set-up (view directions,
//! node counts, table resolutions, repeats), the reference E(μ) both are judged against, the
//! error measure, and the backend's tag in variant names.

use crate::backend::Precision;
use crate::eval::Evaluator;
use crate::input::BadInput;
use crate::integrate::{
    reference_albedo, reference_albedo_within, view_direction, Budget, Estimate, DEFAULT_MUS,
    REFERENCE_MAX_EVALS, REFERENCE_RTOL,
};
use crate::interrupt::CancelToken;
use crate::model::{ParamSet, Reference};
use anyhow::Result;
use glam::DVec3;
use serde::Serialize;

/// What the integration and table-resolution sections measure.
#[derive(Clone, Debug, Serialize)]
pub struct AlbedoSetup {
    /// View directions μ = cosθo (φo = 0), each in (0, 1].
    pub mus: Vec<f64>,
    /// The ladder of node counts asked of each rule (a rule may round them: see
    /// [`Method::rule`](crate::integrate::Method::rule); rules that come out equal are measured
    /// once).
    pub samples: Vec<usize>,
    /// Table resolutions N: N × N × 2N cells in (θi, θo, Δφ).
    pub table_res: Vec<usize>,
    /// Timed runs per variant (the median is reported), after one untimed run that builds the
    /// pipeline and gives the value whose error is reported.
    pub repeats: usize,
}

impl AlbedoSetup {
    /// What `lobe tradeoff` measures by default: grazing, oblique and normal view; 2^8 … 2^16
    /// nodes in steps of 4; tables of 8 … 128 cells per θ axis.
    pub fn standard() -> AlbedoSetup {
        AlbedoSetup {
            mus: DEFAULT_MUS.to_vec(),
            samples: vec![1 << 8, 1 << 10, 1 << 12, 1 << 14, 1 << 16],
            table_res: vec![8, 16, 32, 64, 128],
            repeats: 5,
        }
    }

    /// `--quick`: the same shape at a fraction of the time (tests, a first look).
    pub fn quick() -> AlbedoSetup {
        AlbedoSetup {
            mus: DEFAULT_MUS.to_vec(),
            samples: vec![1 << 8, 1 << 10, 1 << 12],
            table_res: vec![8, 16, 32],
            repeats: 2,
        }
    }

    /// Checks every μ (in (0, 1]), node count (in [16, 4194304]), table resolution (in [2, 512])
    /// and that `repeats` is at least 1.
    pub fn check(&self) -> Result<()> {
        if self.mus.is_empty() {
            return Err(BadInput::new("mus", "give at least one view direction mu").into());
        }
        for &mu in &self.mus {
            if !(mu > 0.0 && mu <= 1.0) {
                return Err(BadInput::new(
                    "mus",
                    format!("view direction mu = {mu}: expected mu = cos(theta_o) in (0, 1]"),
                )
                .into());
            }
        }
        for &n in &self.samples {
            if !(16..=1 << 22).contains(&n) {
                return Err(BadInput::new(
                    "samples",
                    format!("{n} nodes per albedo: node counts lie in [16, 4194304]"),
                )
                .into());
            }
        }
        for &n in &self.table_res {
            if !(2..=512).contains(&n) {
                return Err(BadInput::new(
                    "table_res",
                    format!(
                        "table resolution {n}: resolutions lie in [2, 512] cells per theta axis"
                    ),
                )
                .into());
            }
        }
        if self.repeats == 0 {
            return Err(BadInput::new("repeats", "0 timed runs: time at least one run").into());
        }
        Ok(())
    }
}

/// The reference E(μ) (delta lobe excluded) at each view direction of `setup`, φo = 0.
pub fn reference_albedos(params: &ParamSet, mus: &[f64]) -> Vec<Estimate> {
    let r = Reference::new(params, false);
    mus.iter()
        .map(|&mu| reference_albedo(&r, view_direction(mu, 0.0), REFERENCE_RTOL))
        .collect()
}

/// [`reference_albedos`] that stops once `cancel` is set (checked before every batch of the
/// reference's panels): `Error::Cancelled` then, never an unfinished value. One budget of
/// [`REFERENCE_MAX_EVALS`] per direction, as [`reference_albedo`] has.
pub fn reference_albedos_within(
    params: &ParamSet,
    mus: &[f64],
    cancel: Option<&CancelToken>,
) -> Result<Vec<Estimate>> {
    let r = Reference::new(params, false);
    mus.iter()
        .map(|&mu| {
            let budget = Budget::new(REFERENCE_MAX_EVALS, cancel);
            let (e, _) =
                reference_albedo_within(&r, view_direction(mu, 0.0), REFERENCE_RTOL, &budget);
            if let Some(c) = cancel {
                c.check()?;
            }
            Ok(e)
        })
        .collect()
}

/// (max, RMS) absolute error of `got` against `truth` over directions and channels.
pub fn albedo_errors(got: &[DVec3], truth: &[DVec3]) -> (f64, f64) {
    let (mut max, mut sum2, mut n) = (0.0f64, 0.0f64, 0usize);
    for (g, t) in got.iter().zip(truth) {
        for e in (*g - *t).abs().to_array() {
            max = max.max(e);
            sum2 += e * e;
            n += 1;
        }
    }
    (max, (sum2 / n.max(1) as f64).sqrt())
}

/// "f32 GPU" or "f64 CPU": the precision and place of a backend, for variant names.
pub(super) fn backend_tag(backend: &Evaluator) -> &'static str {
    if backend.precision() == Precision::F32 {
        "f32 GPU"
    } else {
        "f64 CPU"
    }
}
