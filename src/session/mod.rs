//! [`Session`]: the library's front door. It opens the backend once (a Vulkan device, or the f64
//! CPU reference), owns the pipeline cache, carries its options as values (a log sink, the
//! validation layer, fault injection, a cancellation token) and runs every job the commands run,
//! each a method taking its options as a value and returning a typed result:
//!
//! | job | methods |
//! |---|---|
//! | f at direction pairs | [`Session::eval_pairs`], [`Session::eval_pairs_counting`], [`Session::eval_pairs_sets`] |
//! | lobe tables | [`Session::table`] (a [`Table`] in memory), [`Session::write_table`], [`Session::write_merl`] |
//! | albedo | [`Session::directional_albedo`], [`Session::hemispherical_albedo`], [`Session::albedo_report`], [`Session::albedo_rows`] |
//! | look-up tables | [`Session::albedo_lut`], [`Session::write_albedo_lut`], [`Session::engine_lut`], [`Session::write_engine_lut`] |
//! | a sampler | [`Session::sample`], [`Session::write_samples`], [`Session::pdf`] |
//! | reports | [`Session::energy`], [`Session::stability`], [`Session::tradeoff`], [`Session::compare`], [`Session::fit`] |
//! | pictures | [`Session::preview`], [`Session::plot`], [`Session::plot_difference`] |
//! | files of a scene, the demo | [`Session::run_scene`], [`Session::demo`] |
//! | environment light | [`Session::light`], [`Session::light_split_sum`], [`Session::write_light`] |
//! | throughput | [`Session::bench_table`], [`Session::bench_table_with`], [`Session::bench_albedo`], [`Session::bench_lut`] |
//!
//! ```
//! use lobe::{ParamSet, Session};
//! let session = Session::cpu();
//! let gold = ParamSet::preset("gold", "cook_torrance")?;
//! let e = session.directional_albedo(&gold, &lobe::AlbedoSettings::default(), &[(1.0, 0.0)])?;
//! assert!(e[0].albedo.x > e[0].albedo.z); // gold reflects red, not blue
//! # Ok::<(), lobe::Error>(())
//! ```

mod albedo;
mod bench;
mod files;
mod light;
mod pairs;
mod pictures;
mod reports;
mod sample;
mod table;

pub use reports::EnergyOptions;
pub use table::{Table, TableAxis};

use crate::error::Result;
use crate::eval::Evaluator;
use crate::gpu::{Device, DeviceOptions, Gpu, LogSink};
use crate::integrate;
use crate::interrupt::CancelToken;
use std::sync::Arc;
use std::time::Duration;

/// Which backend a session evaluates on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BackendKind {
    /// GLSL compute kernels on a Vulkan device, in f32: a real GPU if there is one, else a CPU
    /// driver such as lavapipe.
    #[default]
    Gpu,
    /// The CPU reference in f64; needs no Vulkan.
    Cpu,
}

/// How to open a [`Session`]. Every field has a default: the best Vulkan device, no validation,
/// no logging, a fresh cancellation token.
#[derive(Clone, Default)]
pub struct SessionOptions {
    /// GPU (default) or the f64 CPU reference.
    pub backend: BackendKind,
    /// Pick the first Vulkan device whose name contains this (case-insensitive).
    pub device: Option<String>,
    /// Turn on the Khronos validation layer; [`Session::validation_messages`] counts what it
    /// reports.
    pub validation: bool,
    /// Make every GPU dispatch end as if the device had been lost (to test that path).
    pub inject_device_lost: bool,
    /// Stage every GPU buffer through a copy to device-local memory, as a discrete GPU without
    /// host-visible device memory needs, even where the device maps its memory directly (to
    /// test that path; `LOBE_STAGING=1` on the command line).
    pub staging: bool,
    /// Receives progress notes (each pipeline built, with its build time).
    pub log: Option<LogSink>,
    /// Set it (from any thread) to stop the running job at its next chunk with
    /// [`Error::Cancelled`](crate::Error::Cancelled); nothing partial is kept.
    pub cancel: CancelToken,
}

impl std::fmt::Debug for SessionOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SessionOptions")
            .field("backend", &self.backend)
            .field("device", &self.device)
            .field("validation", &self.validation)
            .field("inject_device_lost", &self.inject_device_lost)
            .field("staging", &self.staging)
            .field("log", &self.log.as_ref().map(|_| "sink"))
            .field("cancelled", &self.cancel.is_cancelled())
            .finish()
    }
}

/// An open backend and everything built on it so far. `Send` and `Sync`: hold it in a worker
/// thread, an `Arc`, or a Python object.
pub struct Session {
    gpu: Option<Arc<Gpu>>,
    cancel: CancelToken,
}

/// The albedo options of [`Session::directional_albedo`] and friends (method, nodes per
/// direction, white furnace).
pub type AlbedoSettings = integrate::Settings;

impl Session {
    /// Opens the backend `opts` asks for.
    ///
    /// ```
    /// use lobe::{BackendKind, Session, SessionOptions};
    /// let session = Session::open(SessionOptions {
    ///     backend: BackendKind::Cpu,
    ///     ..SessionOptions::default()
    /// })?;
    /// assert_eq!(session.backend(), BackendKind::Cpu);
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn open(opts: SessionOptions) -> Result<Session> {
        let gpu = match opts.backend {
            BackendKind::Cpu => None,
            BackendKind::Gpu => {
                let dev = Device::open(&DeviceOptions {
                    name_contains: opts.device.clone(),
                    validation: opts.validation,
                    inject_device_lost: opts.inject_device_lost,
                    force_staging: opts.staging,
                    ..DeviceOptions::default()
                })?;
                Some(Arc::new(Gpu::new(dev).with_log(opts.log.clone())))
            }
        };
        Ok(Session {
            gpu,
            cancel: opts.cancel,
        })
    }

    /// A session on the f64 CPU reference (never fails: it needs no device).
    ///
    /// ```
    /// assert_eq!(lobe::Session::cpu().backend(), lobe::BackendKind::Cpu);
    /// ```
    pub fn cpu() -> Session {
        Session {
            gpu: None,
            cancel: CancelToken::new(),
        }
    }

    /// This session's backend (the same device, and every kernel built on it) with `cancel` as its
    /// cancellation token: one call's own stop, typically a [`CancelToken::child`] of this
    /// session's token so that both stop it.
    ///
    /// ```
    /// let session = lobe::Session::cpu();
    /// let call = session.with_cancel(session.cancel_token().child());
    /// call.cancel_token().cancel(); // stops this call's jobs only
    /// assert!(!session.cancel_token().is_cancelled());
    /// session.cancel_token().cancel(); // stops every call's too
    /// assert!(session.with_cancel(session.cancel_token().child()).cancel_token().is_cancelled());
    /// ```
    pub fn with_cancel(&self, cancel: CancelToken) -> Session {
        Session {
            gpu: self.gpu.clone(),
            cancel,
        }
    }

    /// The evaluator the job modules' functions take: this session's backend and cancellation
    /// token (every job is also a method of the session).
    ///
    /// ```
    /// let session = lobe::Session::cpu();
    /// assert_eq!(session.evaluator().name(), session.backend_name());
    /// ```
    pub fn evaluator(&self) -> Evaluator<'_> {
        match &self.gpu {
            Some(g) => Evaluator::gpu(g),
            None => Evaluator::cpu(),
        }
        .with_cancel(&self.cancel)
    }

    /// Which backend this session evaluates on.
    ///
    /// ```
    /// assert_eq!(lobe::Session::cpu().backend(), lobe::BackendKind::Cpu);
    /// ```
    pub fn backend(&self) -> BackendKind {
        match self.gpu {
            Some(_) => BackendKind::Gpu,
            None => BackendKind::Cpu,
        }
    }

    /// "gpu (device name)" or "cpu (f64 reference)".
    ///
    /// ```
    /// assert!(lobe::Session::cpu().backend_name().starts_with("cpu"));
    /// ```
    pub fn backend_name(&self) -> String {
        self.evaluator().name()
    }

    /// The token that stops this session's jobs; clones share it.
    ///
    /// ```
    /// let session = lobe::Session::cpu();
    /// let stop = session.cancel_token().clone();
    /// stop.cancel();
    /// let lambert = lobe::ParamSet::for_model("lambert")?;
    /// let e = session.directional_albedo(&lambert, &lobe::AlbedoSettings::default(), &[(1.0, 0.0)]);
    /// assert!(matches!(e, Err(lobe::Error::Cancelled(_))));
    /// # Ok::<(), lobe::Error>(())
    /// ```
    pub fn cancel_token(&self) -> &CancelToken {
        &self.cancel
    }

    /// Warnings and errors the validation layer has reported on this session's device so far.
    ///
    /// ```
    /// assert_eq!(lobe::Session::cpu().validation_messages(), 0);
    /// ```
    pub fn validation_messages(&self) -> usize {
        self.gpu
            .as_ref()
            .map_or(0, |g| g.device().validation_messages())
    }

    /// Every GPU pipeline this session has built so far, with its build time; None on the CPU
    /// reference, which builds none.
    ///
    /// ```
    /// assert!(lobe::Session::cpu().built_kernels().is_none());
    /// ```
    pub fn built_kernels(&self) -> Option<Vec<(String, Duration)>> {
        self.gpu
            .as_ref()
            .map(|_| self.evaluator().backend().built_kernels())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;
    use crate::grid::Grid;
    use glam::DVec3;

    fn assert_send_sync<T: Send + Sync>() {}

    #[test]
    fn a_session_can_move_to_another_thread_and_be_shared() {
        assert_send_sync::<Session>();
        assert_send_sync::<SessionOptions>();
        assert_send_sync::<Error>();
    }

    #[test]
    fn the_cpu_session_evaluates_lambert_as_albedo_over_pi() {
        let s = Session::cpu();
        let p = crate::resolve_params("lambert", None, &["albedo=0.5".into()]).unwrap();
        let f = s.eval_pairs(&p, &[(DVec3::Z, DVec3::Z)]).unwrap();
        assert!((f[0][0] - 0.5 / std::f64::consts::PI).abs() < 1e-15);
    }

    #[test]
    fn a_refused_request_is_an_input_error_tagged_with_its_option() {
        let s = Session::cpu();
        let p = crate::resolve_params(
            "ashikhmin_shirley",
            None,
            &["nu=10".into(), "nv=1000".into()],
        )
        .unwrap();
        let grid = Grid::Isotropic {
            n_theta_i: 2,
            n_theta_o: 2,
            n_dphi: 2,
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.exr");
        let e = s
            .write_table(&p, grid, &path, false, &mut |_, _| {})
            .unwrap_err();
        match &e {
            Error::Input { input, .. } => assert_eq!(input.option, "grid", "{e}"),
            other => panic!("expected an input error, got {other:?}"),
        }
        assert!(e.to_string().contains("anisotropic"), "{e}");
        assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
    }

    #[test]
    fn a_cancelled_session_stops_with_the_cancelled_error() {
        let s = Session::cpu();
        s.cancel_token().cancel();
        let p = crate::resolve_params("lambert", None, &[]).unwrap();
        let grid = Grid::Isotropic {
            n_theta_i: 4,
            n_theta_o: 4,
            n_dphi: 4,
        };
        let e = s.table(&p, &grid, 1 << 20).unwrap_err();
        assert!(matches!(e, Error::Cancelled(_)), "{e}");
        // Every albedo method stops too, the adaptive reference included.
        for method in crate::integrate::Method::ALL {
            let settings = AlbedoSettings {
                method,
                samples: method.default_samples(),
                seed: crate::integrate::DEFAULT_SEED,
                white_furnace: false,
            };
            let e = s
                .directional_albedo(&p, &settings, &[(0.5, 0.0)])
                .unwrap_err();
            assert!(matches!(e, Error::Cancelled(_)), "{}: {e}", method.name());
        }
    }

    #[test]
    fn a_call_with_its_own_token_stops_alone() {
        let s = Session::cpu();
        let call = s.with_cancel(s.cancel_token().child());
        call.cancel_token().cancel();
        let p = crate::resolve_params("lambert", None, &[]).unwrap();
        let grid = Grid::Isotropic {
            n_theta_i: 4,
            n_theta_o: 4,
            n_dphi: 4,
        };
        let e = call.table(&p, &grid, 1 << 20).unwrap_err();
        assert!(matches!(e, Error::Cancelled(_)), "{e}");
        // The session's own jobs and another call's run.
        assert!(s.table(&p, &grid, 1 << 20).is_ok());
        let other = s.with_cancel(s.cancel_token().child());
        assert!(other.table(&p, &grid, 1 << 20).is_ok());
        // The session's token stops every call.
        s.cancel_token().cancel();
        let e = other.table(&p, &grid, 1 << 20).unwrap_err();
        assert!(matches!(e, Error::Cancelled(_)), "{e}");
    }
}
