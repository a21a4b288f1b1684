//! The sampling test of a model's own sampler: the f64 reference's `sample` and `pdf`
//! (docs/design.md §13) judged by [`run`](super::run).

use super::{Counting, Drawn, Options, Report, Sampler};
use crate::backend::{Backend, Precision, Query};
use crate::error::Result;
use crate::interrupt::CancelToken;
use crate::model::{ParamSet, Reference};
use glam::{DVec2, DVec3};

impl Sampler for Reference {
    fn sample(&self, wo: DVec3, uc: f64, u: DVec2) -> Drawn {
        let s = Reference::sample(self, wo, uc, u);
        Drawn {
            wi: s.wi,
            weight: s.weight,
            pdf: s.pdf,
            delta: s.delta,
        }
    }

    fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        Reference::pdf(self, wi, wo)
    }

    fn eval_cos(&self, wi: DVec3, wo: DVec3) -> DVec3 {
        self.eval(wi, wo) * wi.z.max(0.0)
    }
}

/// The sampling test of `params`' sampler (with every Fresnel factor at 1 under
/// `white_furnace`): drawn and counted on `backend` where it draws on a device
/// ([`Counting::on`]), else drawn and checked in f64 on the CPU; the expected counts are the
/// integrals of the f64 reference's pdf either way. A model without an f64 reference (a `.brdf`
/// shader) is drawn and counted on the device and its expected counts integrate the density its
/// kernels evaluate ([`super::run_on_device`]); on the CPU it is refused with a sentence.
pub fn test_model(
    params: &ParamSet,
    white_furnace: bool,
    options: &Options,
    backend: &dyn Backend,
    cancel: Option<&CancelToken>,
    progress: impl FnMut(u64, u64),
) -> Result<Report> {
    let query = Query::one(params).with_white_furnace(white_furnace);
    if !params.model().has_reference() && backend.precision() == Precision::F32 {
        return super::run_on_device(backend, query, options, cancel, progress);
    }
    params
        .model()
        .require_reference("the sampling test on the CPU")?;
    let reference = Reference::new(params, white_furnace);
    super::run_counted(
        &reference,
        Counting::on(backend, query),
        options,
        cancel,
        progress,
    )
}
