//! [`Session`]: the library's front door. It opens the backend once (a Vulkan device, or the f64
//! CPU reference), owns the pipeline cache, carries its options as values (a log sink, the
//! validation layer, fault injection, a cancellation token) and runs every job the commands run.
//!
//! ```no_run
//! use lobe::{Session, SessionOptions};
//! let session = Session::open(SessionOptions::default())?;
//! let params = lobe::resolve_params("cook_torrance", Some("gold"), &[])?;
//! let e = session.directional_albedo(&params, &lobe::AlbedoSettings::default(), &[(1.0, 0.0)])?;
//! println!("E(mu = 1) = {:?}", e[0].albedo);
//! # Ok::<(), lobe::Error>(())
//! ```

use crate::error::{Error, IntoLobe, Result};
use crate::eval::Evaluator;
use crate::finite::InvalidCount;
use crate::gpu::{Device, DeviceOptions, Gpu, LogSink};
use crate::grid::Grid;
use crate::integrate::{self, AlbedoReport, HemiAlbedo, PointAlbedo};
use crate::interrupt::CancelToken;
use crate::lut::{LutSpec, LutSummary};
use crate::model::ParamSet;
use crate::table::TableMeta;
use glam::DVec3;
use std::path::Path;

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
    /// [`Error::Cancelled`]; nothing partial is kept.
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
    gpu: Option<Gpu>,
    cancel: CancelToken,
}

/// The albedo options of [`Session::directional_albedo`] and friends (method, nodes per
/// direction, white furnace).
pub type AlbedoSettings = integrate::Settings;

impl Session {
    /// Opens the backend `opts` asks for.
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
                Some(Gpu::new(dev).with_log(opts.log.clone()))
            }
        };
        Ok(Session {
            gpu,
            cancel: opts.cancel,
        })
    }

    /// A session on the f64 CPU reference (never fails: it needs no device).
    pub fn cpu() -> Session {
        Session {
            gpu: None,
            cancel: CancelToken::new(),
        }
    }

    /// The evaluator every job takes: this session's backend and cancellation token.
    pub fn evaluator(&self) -> Evaluator<'_> {
        match &self.gpu {
            Some(g) => Evaluator::gpu(g),
            None => Evaluator::cpu(),
        }
        .with_cancel(&self.cancel)
    }

    /// The GPU runner, where the session has one.
    pub fn gpu(&self) -> Option<&Gpu> {
        self.gpu.as_ref()
    }

    /// Which backend this session evaluates on.
    pub fn backend(&self) -> BackendKind {
        match self.gpu {
            Some(_) => BackendKind::Gpu,
            None => BackendKind::Cpu,
        }
    }

    /// "gpu (device name)" or "cpu (f64 reference)".
    pub fn backend_name(&self) -> String {
        self.evaluator().name()
    }

    /// The token that stops this session's jobs; clones share it.
    pub fn cancel_token(&self) -> &CancelToken {
        &self.cancel
    }

    /// Warnings and errors the validation layer has reported on this session's device so far.
    pub fn validation_messages(&self) -> usize {
        self.gpu
            .as_ref()
            .map_or(0, |g| g.device().validation_messages())
    }

    /// [`Session::eval_pairs`] that keeps NaN, ±Inf and negative values and counts them
    /// instead of refusing them.
    pub fn eval_pairs_counting(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        pairs: &[(DVec3, DVec3)],
    ) -> Result<(Vec<[f64; 3]>, InvalidCount)> {
        let tally = std::sync::Mutex::new(InvalidCount::default());
        let f = self
            .evaluator()
            .counting_invalid(&tally)
            .eval_pairs(params, white_furnace, pairs)
            .lobe()?;
        let count = tally
            .into_inner()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        Ok((f, count))
    }

    /// f at each (ωi, ωo) pair, in 1/sr, without the cosine (0 below the horizon); refuses
    /// NaN, ±Inf and negative values ([`Error::InvalidValues`]).
    pub fn eval_pairs(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        pairs: &[(DVec3, DVec3)],
    ) -> Result<Vec<[f64; 3]>> {
        self.evaluator()
            .eval_pairs(params, white_furnace, pairs)
            .lobe()
    }

    /// The lobe table on `grid` in memory: f32 RGB per cell, cells in the grid's order. Refuses
    /// tables over `max_cells` cells (a bound on memory: 12 bytes a cell), and an anisotropic set
    /// on a grid that holds only the isotropic half of the angles.
    pub fn table(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        grid: &Grid,
        max_cells: u64,
    ) -> Result<Vec<f32>> {
        let cells = grid.cells().filter(|&c| c <= max_cells).ok_or_else(|| {
            Error::Invalid(format!(
                "a table of shape {:?} has more than the {max_cells} cells allowed in memory",
                grid.shape()
            ))
        })?;
        let mut out = Vec::with_capacity(cells as usize * 3);
        let ev = self.evaluator();
        ev.eval_table(params, white_furnace, grid, &mut |_, v| {
            ev.check_cancelled()?;
            out.extend_from_slice(v);
            Ok(())
        })
        .lobe()?;
        Ok(out)
    }

    /// Writes the table set `PATH.exr`, `PATH.npy`, `PATH.json` (all or nothing), streaming
    /// chunk by chunk; `progress` gets (cells done, cells). Returns the count of invalid values
    /// (NaN, ±Inf, negative), which the table keeps; a table with any replaces an existing set
    /// only with `replace_invalid` ([`crate::table::stage_table_with`]).
    pub fn write_table(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        grid: Grid,
        exr_path: &Path,
        replace_invalid: bool,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<InvalidCount> {
        crate::table::check_request(params, &grid, exr_path).lobe()?;
        let meta = TableMeta {
            params,
            white_furnace,
            grid,
            backend: self.backend_name(),
        };
        crate::table::write_table_with(
            &self.evaluator(),
            &meta,
            exr_path,
            replace_invalid,
            progress,
        )
        .lobe()
    }

    /// Writes `params` as a MERL file at `path` ([`crate::merl::write`]); `progress` receives
    /// (bins done, bins in all).
    pub fn write_merl(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        path: &Path,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<()> {
        crate::merl::write::write(&self.evaluator(), params, white_furnace, path, progress).lobe()
    }

    /// Directional albedo E(ωo) at each (μo, φo).
    pub fn directional_albedo(
        &self,
        params: &ParamSet,
        settings: &AlbedoSettings,
        points: &[(f64, f64)],
    ) -> Result<Vec<PointAlbedo>> {
        integrate::directional(&self.evaluator(), params, settings, points).lobe()
    }

    /// Hemispherical albedo Ē and Kulla–Conty's E_avg (at azimuth `phi` for anisotropic sets).
    pub fn hemispherical_albedo(
        &self,
        params: &ParamSet,
        settings: &AlbedoSettings,
        phi: f64,
    ) -> Result<HemiAlbedo> {
        integrate::hemispherical(&self.evaluator(), params, settings, phi).lobe()
    }

    /// Directional and hemispherical albedo together, with timings, as `lobe albedo` reports.
    pub fn albedo_report(
        &self,
        params: &ParamSet,
        settings: &AlbedoSettings,
        points: &[(f64, f64)],
        phi: f64,
    ) -> Result<AlbedoReport> {
        integrate::albedo_report(&self.evaluator(), params, settings, points, phi).lobe()
    }

    /// Computes an albedo look-up table E(μ, p), E_avg(p) in memory.
    pub fn albedo_lut(
        &self,
        spec: &LutSpec,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<LutSummary> {
        crate::lut::compute(&self.evaluator(), spec, progress).lobe()
    }

    /// Computes an albedo look-up table and writes its files beside `exr_path` (all or nothing).
    pub fn write_albedo_lut(
        &self,
        spec: &LutSpec,
        exr_path: &Path,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<LutSummary> {
        crate::lut::write(&self.evaluator(), spec, exr_path, progress).lobe()
    }

    /// Renders a material preview sheet (rows of parameter sets, shaded under `scene`);
    /// `progress` gets (columns done, columns).
    pub fn preview(
        &self,
        sheet: &crate::preview::Sheet,
        scene: &crate::preview::Scene,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<crate::preview::SheetImage> {
        crate::preview::render(&self.evaluator(), sheet, scene, progress).lobe()
    }

    /// The stability sweep over `models` (every model's parameter edges × extreme directions),
    /// on the CPU reference and, where the session has one, the GPU.
    pub fn stability(
        &self,
        models: Vec<crate::model::Model>,
        progress: &mut dyn FnMut(&str),
    ) -> Result<crate::stability::Report> {
        crate::stability::sweep(crate::stability::Options {
            backend: self.evaluator(),
            models,
            progress,
        })
        .lobe()
    }

    /// Throughput of a lobe table on `grid` on this session's backend (median of `repeats`).
    pub fn bench_table(
        &self,
        params: &ParamSet,
        grid: &Grid,
        repeats: usize,
    ) -> Result<crate::bench::Throughput> {
        crate::bench::measure(&self.evaluator(), params, grid, repeats).lobe()
    }

    /// [`Session::bench_table`], optionally under the white furnace.
    pub fn bench_table_with(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        grid: &Grid,
        repeats: usize,
    ) -> Result<crate::bench::Throughput> {
        crate::bench::measure_table(&self.evaluator(), params, white_furnace, grid, repeats).lobe()
    }

    /// Throughput of directional-albedo integration on this session's backend.
    pub fn bench_albedo(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        repeats: usize,
    ) -> Result<crate::bench::Throughput> {
        crate::bench::measure_albedo(&self.evaluator(), params, white_furnace, repeats).lobe()
    }

    /// Throughput of an albedo look-up table ([`crate::bench::lut_spec`]) on this session's
    /// backend.
    pub fn bench_lut(
        &self,
        params: &ParamSet,
        white_furnace: bool,
        repeats: usize,
    ) -> Result<crate::bench::Throughput> {
        crate::bench::measure_lut(&self.evaluator(), params, white_furnace, repeats).lobe()
    }

    /// [`Session::directional_albedo`] at `points` (and, with `phi`, [`Session::hemispherical_albedo`])
    /// for each parameter set of `rows`, the same values as one set at a time; rows of one model
    /// share each direction's quadrature nodes and the GPU sums them in the same dispatches
    /// ([`integrate::albedo_rows`]).
    pub fn albedo_rows(
        &self,
        rows: &[ParamSet],
        settings: &AlbedoSettings,
        points: &[(f64, f64)],
        phi: Option<f64>,
    ) -> Result<Vec<(Vec<PointAlbedo>, Option<HemiAlbedo>)>> {
        integrate::albedo_rows(&self.evaluator(), rows, settings, points, phi).lobe()
    }

    /// f of each parameter set of `sets` at each (ωi, ωo) pair (`out[k][j]`: set k at pair j),
    /// the values [`Session::eval_pairs`] gives one set at a time. On the GPU, sets of one model
    /// go to the device together, each pair naming its set's parameter block, so a sweep of many
    /// sets costs one batch of dispatches instead of one per set. Refuses NaN, ±Inf and negative
    /// values ([`Error::InvalidValues`]).
    pub fn eval_pairs_sets(
        &self,
        sets: &[ParamSet],
        white_furnace: bool,
        pairs: &[(DVec3, DVec3)],
    ) -> Result<Vec<Vec<[f64; 3]>>> {
        let values = self
            .evaluator()
            .eval_sets_unchecked(sets, white_furnace, pairs)
            .lobe()?;
        for (p, f) in sets.iter().zip(&values) {
            let mut count = InvalidCount::default();
            count.add_pairs(0, f, pairs);
            count.refuse(p.model().name(), "evaluating f at direction pairs")?;
        }
        Ok(values)
    }

    /// Fits the free parameters of `space` to `target` ([`crate::fit::fit`]), as `lobe fit`
    /// does; `progress` gets each iteration's best loss.
    pub fn fit(
        &self,
        target: &crate::fit::Target,
        space: &crate::fit::Space,
        opts: &crate::fit::FitOptions,
        progress: &(dyn Fn(crate::fit::FitProgress) + Sync),
    ) -> Result<crate::fit::FitReport> {
        crate::fit::fit(&self.evaluator(), target, space, opts, progress).lobe()
    }

    /// Compares model `b` against the reference `a` on the bins of `opts` ([`crate::compare`]),
    /// as `lobe compare` does; `progress` gets (bins done, bins).
    pub fn compare(
        &self,
        a: &crate::compare::Side,
        b: &crate::compare::Side,
        opts: &crate::compare::Options,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<crate::compare::Comparison> {
        crate::compare::compare(&self.evaluator(), a, b, opts, progress).lobe()
    }

    /// Computes a real-time engine's look-up table (DFG, Kulla–Conty, EON) in memory, as
    /// `lobe albedo --engine` does before writing it; `progress` gets (rows done, rows).
    pub fn engine_lut(
        &self,
        spec: &crate::lut::engine::EngineSpec,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<crate::lut::engine::EngineTable> {
        crate::lut::engine::compute_engine(&self.evaluator(), spec, progress).lobe()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let f = s.eval_pairs(&p, false, &[(DVec3::Z, DVec3::Z)]).unwrap();
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
            .write_table(&p, false, grid, &path, false, &mut |_, _| {})
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
        let e = s.table(&p, false, &grid, 1 << 20).unwrap_err();
        assert!(matches!(e, Error::Cancelled(_)), "{e}");
        // Every albedo method stops too, the adaptive reference included.
        for method in crate::integrate::Method::ALL {
            let settings = AlbedoSettings {
                method,
                samples: method.default_samples(),
                white_furnace: false,
            };
            let e = s
                .directional_albedo(&p, &settings, &[(0.5, 0.0)])
                .unwrap_err();
            assert!(matches!(e, Error::Cancelled(_)), "{}: {e}", method.name());
        }
    }
}
